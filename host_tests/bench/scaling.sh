#!/usr/bin/env bash
# How `kincal identify` and `kincal diagnose` scale with the number of
# measured nodes (issue #13; docs/benchmarks.md "Scaling"): whole-process CPU
# time (user + system, process start and file parsing included) and peak
# resident memory, by /usr/bin/time, on both reference machines at 10^2, 10^3
# and 10^4 nodes. A study, not a test: it takes a few minutes.
#
#   host_tests/bench/scaling.sh [KINCAL] [SIZES...]
#
# KINCAL: the tool (default build/host/apps/kincal). SIZES: node counts
# (default 100 1000 10000). The poses are random, drawn here (python3): the
# 6-UPS over seed 001's working box (x, y +-35 mm, z 180-220 mm, tilts +-5 deg,
# yaw +-8 deg), the hybrid over seed 000's 500 x 500 x 120 mm task cuboid
# (pure translation); every third pose held out. The machines carry the
# examples' hidden errors (examples/*/errors.csv) and, for the diagnosis, a
# scale error of the actuators the base model lacks; noise 1 um / 5 urad
# (6-UPS pose) and 5 um (hybrid gauge), given to the diagnosis as known.
set -euo pipefail
root=$(cd "$(dirname "$0")/../.." && pwd)
kincal=${1:-$root/build/host/apps/kincal}
shift || true
sizes=("$@")
[ ${#sizes[@]} -gt 0 ] || sizes=(100 1000 10000)
[ -x "$kincal" ] || { echo "scaling.sh: no $kincal (build the target kincal)" >&2; exit 2; }
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT

poses() {  # machine count seed -> poses CSV on stdout
  python3 - "$@" <<'EOF'
import math, random, sys
machine, count, seed = sys.argv[1], int(sys.argv[2]), int(sys.argv[3])
rng = random.Random(seed)
u = lambda a: rng.uniform(-a, a)
deg = math.pi / 180
print("id,role,x,y,z,rx,ry,rz")
for i in range(count):
    role = "test" if i % 3 == 2 else "cal"
    if machine == "stewart":
        p = (u(35), u(35), 200 + u(20), u(5 * deg), u(5 * deg), u(8 * deg))
    else:
        p = (u(250), u(250), u(60), 0.0, 0.0, 0.0)
    print(f"P{i + 1},{role}," + ",".join(f"{v:.6f}" for v in p))
EOF
}

# CPU seconds (user + sys) per run and peak RSS (MiB) of a command run
# $reps times in a row (/usr/bin/time counts in hundredths of a second: small
# runs are repeated).
measure() {
  /usr/bin/time -f "%U %S %M" -o "$work/time" \
    bash -c 'for ((i = 0; i < $0; ++i)); do "$@" || exit 1; done' "$reps" "$@" > "$work/log" 2>&1 \
    || { cat "$work/log" >&2; return 1; }
  read -r user sys rss < "$work/time"
  awk -v u="$user" -v s="$sys" -v m="$rss" -v r="$reps" 'BEGIN { printf "%.3f s, %.0f MiB", (u + s) / r, m / 1024 }'
}

echo "| machine | nodes (cal + test) | identify: CPU, peak RSS | diagnose: CPU, peak RSS |"
echo "|---|---:|---|---|"
for machine in stewart hybrid; do
  if [ $machine = stewart ]; then
    robot=stewart-seed001 errors=$root/examples/seed001/errors.csv noise=(--noise-mm 0.001 --noise-rad 5e-6)
    known=(--noise-um 1 --noise-urad 5)
    effect=(--effect scale:s1=2e-4 --effect scale:s4=-2e-4)
  else
    robot=hybrid-seed000 errors=$root/examples/hybrid-seed000/errors.csv noise=(--noise-mm 0.005)
    known=(--noise-um 5)
    effect=(--effect scale:s1=5e-4 --effect scale:s2=-5e-4)
  fi
  for n in "${sizes[@]}"; do
    poses $machine "$n" 7 > "$work/poses.csv"
    "$kincal" simulate --robot $robot --poses "$work/poses.csv" --errors "$errors" "${noise[@]}" --seed 3 \
      --out "$work/base.csv" > /dev/null 2>&1
    "$kincal" simulate --robot $robot --poses "$work/poses.csv" --errors "$errors" "${effect[@]}" "${noise[@]}" \
      --seed 3 --out "$work/effect.csv" > /dev/null 2>&1
    nodes=$(grep -c -v '^#\|^id' "$work/base.csv")
    reps=$(( n <= 100 ? 20 : n <= 1000 ? 3 : 1 ))
    id=$(measure "$kincal" identify --robot $robot --data "$work/base.csv" --out "$work/model.json")
    dg=$(measure "$kincal" diagnose --robot $robot --data "$work/effect.csv" --json "$work/diag.json" "${known[@]}")
    accepted=$(python3 -c "import json,sys; print(','.join(json.load(open(sys.argv[1]))['accepted']) or 'none')" "$work/diag.json")
    echo "| $robot | $nodes | $id | $dg (accepted: $accepted) |"
  done
done
