#!/usr/bin/env bash
# Instructions per NC point on the target, from qemu's execution trace
# (docs/benchmarks.md "Firmware example (Cortex-M7)"). qemu models no cycle
# counter (DWT), so: run the image twice, with -singlestep -d exec,nochain
# (one "Trace" line per executed guest instruction), and divide the difference
# of the two counts by the difference in points. Start-up, table check and
# exit are the same in both runs and cancel out.
#
#   examples/firmware/icount.sh compensate ICOUNT.elf [N]
#       kincal_fw_example_icount: Compensator::compensate (+ the pose from
#       x..rz) for N points (default 147) against 0 points
#   examples/firmware/icount.sh loop EXAMPLE.elf POSES.csv
#       kincal_fw_example: the whole controller period (read and parse a CSV
#       row, compensate, format and write the command) for every row of
#       POSES.csv against its first row only
# Prints one line: "<what>: <instructions> instructions per point (<runs>)".
set -euo pipefail
machine=(-M mps2-an500 -cpu cortex-m7)
count() {  # count ELF APPEND [DIR]: executed guest instructions of one run
  (cd "${3:-.}" && qemu-system-arm "${machine[@]}" -nographic -monitor none -serial none \
     -semihosting-config enable=on,target=native -kernel "$1" -append "$2" \
     -singlestep -d exec,nochain -D /dev/stdout 2>/dev/null | grep -c '^Trace')
}
case ${1:-} in
  compensate)
    elf=$(realpath "$2"); n=${3:-147}
    c0=$(count "$elf" "0"); cn=$(count "$elf" "$n")
    echo "compensate: $(( (cn - c0) / n )) instructions per point (N = $n: $cn, N = 0: $c0 instructions)"
    ;;
  loop)
    elf=$(realpath "$2"); poses=$(realpath "$3")
    work=$(mktemp -d); trap 'rm -rf "$work"' EXIT
    grep -v '^#' "$poses" > "$work/all.csv"
    head -2 "$work/all.csv" > "$work/one.csv"
    n=$(( $(wc -l < "$work/all.csv") - 2 ))
    c1=$(count "$elf" "one.csv j1.csv" "$work"); cn=$(count "$elf" "all.csv jn.csv" "$work")
    echo "loop: $(( (cn - c1) / n )) instructions per point ($((n + 1)) rows: $cn, 1 row: $c1 instructions)"
    ;;
  *) echo "usage: $0 compensate ICOUNT.elf [N] | loop EXAMPLE.elf POSES.csv" >&2; exit 2 ;;
esac
