#!/usr/bin/env bash
# Instructions per call of the core kinematics, by callgrind.
#
#   host_tests/bench/icount.sh <path/to/kincal_core_kinematics_icount> [N] [operation...]
#
# Builds nothing. For each operation (default: all, from `--list`) it runs the
# harness under `valgrind --tool=callgrind` twice, with N calls (default 1000)
# and with 0 calls; the start-up and set-up cost is the same in both runs, so
#   instructions/call = (Ir(N) − Ir(0)) / N.
# Callgrind counts are deterministic for a given binary and input, which makes
# them the stable measure on a shared, noisy machine (docs/benchmarks.md).
set -euo pipefail

if [[ $# -lt 1 || ! -x "$1" ]]; then
  echo "usage: $0 <path/to/kincal_core_kinematics_icount> [N] [operation...]" >&2
  exit 2
fi
exe=$1
n=${2:-1000}
shift $(( $# >= 2 ? 2 : 1 ))
if [[ $# -gt 0 ]]; then
  ops=("$@")
else
  mapfile -t ops < <("$exe" --list)
fi
command -v valgrind >/dev/null || { echo "$0: valgrind not found" >&2; exit 2; }

work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT

# Total instructions (Ir) of one run: the "summary:" line of the callgrind output.
total_ir() {
  local op=$1 count=$2 out="$work/$1.$2.out"
  if ! valgrind --tool=callgrind --callgrind-out-file="$out" "$exe" "$op" "$count" \
      >"$work/$op.$count.stdout" 2>"$work/$op.$count.stderr"; then
    echo "$0: '$exe $op $count' failed under valgrind:" >&2
    cat "$work/$op.$count.stdout" "$work/$op.$count.stderr" >&2
    exit 1
  fi
  awk '/^summary:/ { print $2; exit }' "$out"
}

printf '%-18s %14s %14s %12s  %s\n' operation "Ir(N=$n)" "Ir(N=0)" "Ir/call" "harness report"
for op in "${ops[@]}"; do
  ir_n=$(total_ir "$op" "$n")
  ir_0=$(total_ir "$op" 0)
  per_call=$(awk -v a="$ir_n" -v b="$ir_0" -v n="$n" 'BEGIN { if (n > 0) printf "%.0f", (a - b) / n; else print "-" }')
  report=$(head -n1 "$work/$op.$n.stdout")
  printf '%-18s %14s %14s %12s  %s\n' "$op" "$ir_n" "$ir_0" "$per_call" "$report"
done
