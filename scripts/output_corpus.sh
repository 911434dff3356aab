#!/usr/bin/env bash
# The safety net of a refactor that must keep behaviour (issue #12: "the same
# numbers to the printed digits"): runs the tool on a fixed corpus — both
# families, identify (default, --estimator ridge / liu, --json, --effects)
# and diagnose (noise given and estimated, --report), on data this script
# simulates with hidden effects — and writes every output (stdout, stderr,
# MODEL.json, SUMMARY.json, DIAG.json, REPORT.html) into one folder. Run it
# with the tool before and after a change, then compare:
#
#   scripts/output_corpus.sh build/host/apps/kincal /tmp/before   # before the change
#   scripts/output_corpus.sh build/host/apps/kincal /tmp/after    # after it
#   scripts/output_corpus.sh --compare /tmp/before /tmp/after      # no output: identical
#   scripts/output_corpus.sh --compare-numbers /tmp/before /tmp/after
#
# --compare-numbers is for a change that may move the last digits (a product
# rounded another way): per differing file, "same words" and the largest
# relative difference of its numbers, or "words differ" where anything but a
# number changed (a count, a name, a verdict, a line more or fewer). Needs
# python3.
#
# Timings ("diagnosis in … s", "seconds") and the folder's own name are left
# out of the comparison. About 15 s.
set -euo pipefail
cd "$(dirname "$0")/.."

strip() {  # file dir: the file with the corpus folder's name and timings taken out
  sed -E -e "s|$2|CORPUS|g" -e 's/diagnosis in [0-9.e+-]+ s/diagnosis in T s/' -e 's/"seconds": [0-9.e+-]+/"seconds": T/' \
    -e 's/swaps\), [0-9.]+ s/swaps), T s/' "$1"
}

if [ "${1:-}" = "--compare-numbers" ]; then
  [ $# -eq 3 ] || { echo "usage: $0 --compare-numbers BEFORE AFTER" >&2; exit 2; }
  status=0
  for f in "$2"/*; do
    name=$(basename "$f")
    [ -e "$3/$name" ] || { echo "only in $2: $name"; status=1; continue; }
    diff -q <(strip "$f" "$2") <(strip "$3/$name" "$3") > /dev/null && continue
    python3 - <(strip "$f" "$2") <(strip "$3/$name" "$3") "$name" <<'PY' || status=1
import re, sys
number = re.compile(r"[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?")
a, b = open(sys.argv[1]).read(), open(sys.argv[2]).read()
if number.split(a) != number.split(b):
    print(f"{sys.argv[3]}: words differ")
    sys.exit(1)
worst = max(abs(float(x) - float(y)) / max(abs(float(x)), abs(float(y)), 1e-300)
            for x, y in zip(number.findall(a), number.findall(b)))
print(f"{sys.argv[3]}: same words, numbers within {worst:.1e} relative")
PY
  done
  exit $status
fi

if [ "${1:-}" = "--compare" ]; then
  [ $# -eq 3 ] || { echo "usage: $0 --compare BEFORE AFTER" >&2; exit 2; }
  status=0
  for f in "$2"/*; do
    name=$(basename "$f")
    if [ ! -e "$3/$name" ]; then echo "only in $2: $name"; status=1; continue; fi
    if ! diff <(strip "$f" "$2") <(strip "$3/$name" "$3") > /dev/null; then
      echo "differs: $name"
      diff <(strip "$f" "$2") <(strip "$3/$name" "$3") | head -6 || true  # on to the next file (pipefail)
      status=1
    fi
  done
  for f in "$3"/*; do [ -e "$2/$(basename "$f")" ] || { echo "only in $3: $(basename "$f")"; status=1; }; done
  exit $status
fi

[ $# -eq 2 ] || { echo "usage: $0 KINCAL OUT_DIR | $0 --compare BEFORE AFTER | $0 --compare-numbers BEFORE AFTER" >&2; exit 2; }
kincal=$1
out=$2
rm -rf "$out"
mkdir -p "$out"
run() {  # name, then the tool's arguments: stdout, stderr and the exit status kept
  local name=$1
  shift
  local rc=0
  "$kincal" "$@" > "$out/$name.out" 2> "$out/$name.err" || rc=$?
  echo "exit $rc" >> "$out/$name.out"
}

# The 6-UPS: seed 001's machine, a thermal drift hidden.
st=examples/seed001
$kincal simulate --robot stewart-seed001 --poses $st/diagnosis_poses.csv --errors $st/errors.csv \
  --effect thermal:c=1.2e-5 --noise-mm 0.001 --noise-rad 5e-6 --seed 3 --out "$out/st_measured.csv"
run st_identify identify --robot stewart-seed001 --data "$out/st_measured.csv" --out "$out/st_model.json" \
  --json "$out/st_summary.json"
run st_identify_ridge identify --robot stewart-seed001 --data "$out/st_measured.csv" --estimator ridge \
  --out "$out/st_model_ridge.json"
run st_identify_effects identify --robot stewart-seed001 --data "$out/st_measured.csv" --effects thermal \
  --out "$out/st_model_effects.json"
run st_diagnose diagnose --robot stewart-seed001 --data "$out/st_measured.csv" --noise-um 1 \
  --json "$out/st_diagnosis.json" --report "$out/st_report.html"
run st_diagnose_noise_estimated diagnose --robot stewart-seed001 --data "$out/st_measured.csv" \
  --json "$out/st_diagnosis_estimated.json"

# The hybrid: seed 000's machine and gauge, 5 um noise, clean and with
# effects (sizes of scripts/hybrid_effects_study.sh).
hy=examples/hybrid-seed000
while IFS='|' read -r name spec; do
  args=()
  for e in $spec; do args+=(--effect "$e"); done
  $kincal simulate --robot hybrid-seed000 --poses $hy/diagnosis_poses.csv --errors $hy/errors.csv "${args[@]}" \
    --noise-mm 0.005 --seed 11 --out "$out/hy_${name}_measured.csv"
  run "hy_${name}_identify" identify --robot hybrid-seed000 --data "$out/hy_${name}_measured.csv" \
    --out "$out/hy_${name}_model.json" --json "$out/hy_${name}_summary.json"
  run "hy_${name}_diagnose" diagnose --robot hybrid-seed000 --data "$out/hy_${name}_measured.csv" --noise-um 5 \
    --json "$out/hy_${name}_diagnosis.json"
done <<'EOF'
clean|
thermal|thermal:c=1.7e-5
ups_scale|scale:s1=5e-4 scale:s2=-5e-4
compliance_scale|compliance:k1=0.3 compliance:k2=-0.3 compliance:k3=0.3 scale:s4=2e-3 scale:s6=-2e-3
EOF
run hy_identify_liu identify --robot hybrid-seed000 --data "$out/hy_clean_measured.csv" --estimator liu \
  --out "$out/hy_model_liu.json"
run hy_identify_effects identify --robot hybrid-seed000 --data "$out/hy_ups_scale_measured.csv" --effects scale \
  --out "$out/hy_model_effects.json"
run hy_diagnose_report diagnose --robot hybrid-seed000 --data "$out/hy_thermal_measured.csv" \
  --json "$out/hy_diagnosis_estimated.json" --report "$out/hy_report.html"

# Laser-tracker targets (the target fit, either family): robot descriptions
# with `targets`, three in the base frame and one in the tracker's own frame.
with_targets() {  # robot, targets JSON, out: the description with `targets` added
  $kincal robot --robot "$1" --out "$3.tmp" > /dev/null
  { sed -e '$ d' "$3.tmp" | sed -e '$ s/$/,/'; echo "  \"targets\": $2"; echo "}"; } > "$3"
  rm -f "$3.tmp"
}
with_targets stewart-seed001 '[[30, 40, 10], [-35, 20, 15], [5, -45, 12]]' "$out/st_targets3.json"
with_targets stewart-seed001 '[[30, 40, 10]]' "$out/st_targets1.json"
with_targets hybrid-seed000 '[[60, 0, 20], [-30, 52, 20], [-30, -52, 20]]' "$out/hy_targets3.json"
$kincal simulate --robot "$out/st_targets3.json" --poses $st/diagnosis_poses.csv --errors $st/errors.csv \
  --targets robot --noise-mm 0.005 --seed 5 --out "$out/st_t3_measured.csv"
run st_t3_identify identify --robot "$out/st_targets3.json" --data "$out/st_t3_measured.csv" \
  --out "$out/st_t3_model.json" --json "$out/st_t3_summary.json"
run st_t3_diagnose diagnose --robot "$out/st_targets3.json" --data "$out/st_t3_measured.csv" --noise-um 5 \
  --json "$out/st_t3_diagnosis.json"
$kincal simulate --robot "$out/st_targets1.json" --poses $st/diagnosis_poses.csv --errors $st/errors.csv \
  --targets robot --instrument-frame 1500,200,300,0.1,-0.05,2.0 --noise-mm 0.005 --seed 6 \
  --out "$out/st_t1_measured.csv"
run st_t1_identify identify --robot "$out/st_targets1.json" --data "$out/st_t1_measured.csv" --instrument-frame \
  --out "$out/st_t1_model.json" --json "$out/st_t1_summary.json"
run st_t1_effects identify --robot "$out/st_targets1.json" --data "$out/st_t1_measured.csv" --instrument-frame \
  --effects compliance --out "$out/st_t1_model_effects.json"
$kincal simulate --robot "$out/hy_targets3.json" --poses $hy/diagnosis_poses.csv --errors $hy/errors.csv \
  --targets robot --instrument-frame 1800,-300,400,0.05,0.1,2.3 --noise-mm 0.005 --seed 7 \
  --out "$out/hy_t3_measured.csv"
run hy_t3_identify identify --robot "$out/hy_targets3.json" --data "$out/hy_t3_measured.csv" --instrument-frame \
  --out "$out/hy_t3_model.json" --json "$out/hy_t3_summary.json"
run hy_t3_diagnose diagnose --robot "$out/hy_targets3.json" --data "$out/hy_t3_measured.csv" --instrument-frame \
  --noise-um 5 --json "$out/hy_t3_diagnosis.json"

# Robot summaries and descriptions, and plans (the family seam's kinematics).
for r in stewart-seed001 hybrid-seed000 examples/robots/large-hexapod.json; do
  n=$(basename "$r" .json)
  run "robot_$n" robot --robot "$r"
  run "robot_${n}_params" robot --robot "$r" --params
  run "plan_$n" plan --robot "$r" --count 30 --samples 400 --test 4 --quiet --out "$out/plan_$n.csv" \
    --grid-out "$out/plan_${n}_grid.csv"
done
run plan_hybrid_pose plan --robot hybrid-seed000 --count 25 --samples 300 --measure pose --quiet \
  --out "$out/plan_hybrid_pose.csv"
run plan_hybrid_scale plan --robot hybrid-seed000 --count 30 --samples 300 --effects scale --margin 0.2 --quiet \
  --out "$out/plan_hybrid_scale.csv"
# The hybrid's targets on poses that turn the tool (the plan's; seed 000's
# layers are translations, which the target fit refuses above).
$kincal simulate --robot "$out/hy_targets3.json" --poses "$out/plan_hybrid-seed000.csv" --errors $hy/errors.csv \
  --targets robot --instrument-frame 1800,-300,400,0.05,0.1,2.3 --noise-mm 0.005 --seed 8 \
  --out "$out/hy_t3_turning_measured.csv"
run hy_t3_turning_identify identify --robot "$out/hy_targets3.json" --data "$out/hy_t3_turning_measured.csv" \
  --instrument-frame --out "$out/hy_t3_turning_model.json"
run hy_t3_turning_diagnose diagnose --robot "$out/hy_targets3.json" --data "$out/hy_t3_turning_measured.csv" \
  --instrument-frame --json "$out/hy_t3_turning_diagnosis.json"
