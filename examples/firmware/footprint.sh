#!/usr/bin/env bash
# Footprint of the firmware example against the GUIDE bar (Cortex-M7, -Os,
# core + compensation + port for one machine): flash <= 48 KiB, static RAM
# <= 4 KiB, worst-case stack <= 4 KiB, no heap symbol. The same measurement as
# scripts/firmware-footprint.sh (which covers the core-only images), on
# kincal_fw_example: MinSizeRel (-Os -DNDEBUG), the example's own table
# (examples/firmware/calibration_table.hpp: the identified hybrid model),
# run under qemu on examples/firmware/poses.csv for the measured stack.
# Also prints the instructions per compensated point (examples/firmware/icount.sh).
# Results: docs/benchmarks.md "Firmware example (Cortex-M7)".
#
# Usage: examples/firmware/footprint.sh [build-dir]   (default build/m7-example-footprint)
set -euo pipefail
cd "$(dirname "$0")/../.."
build=${1:-build/m7-example-footprint}
export LC_ALL=C
flash_bar=$((48 * 1024)); ram_bar=$((4 * 1024)); stack_bar=$((4 * 1024))

mkdir -p "$build"
cmake -S . -B "$build" -G Ninja -DCMAKE_TOOLCHAIN_FILE=toolchains/cortex-m7.cmake -DCMAKE_BUILD_TYPE=MinSizeRel \
  -DKINCAL_BUILD_TESTS=OFF > "$build/example-footprint.configure.log" 2>&1 \
  || { cat "$build/example-footprint.configure.log"; exit 1; }
cmake --build "$build" --target kincal_fw_example kincal_fw_example_icount > "$build/example-footprint.build.log" 2>&1 \
  || { cat "$build/example-footprint.build.log"; exit 1; }
line=$(python3 -c 'import json, sys
print(next(c["command"] for c in json.load(open(sys.argv[1])) if "kincal_fw_example.dir/main.cpp" in c["command"]))' \
       "$build/compile_commands.json")
last_opt=$(grep -oE -- ' -O[0-3sz]( |$)' <<< "$line" | tail -1 | tr -d ' ')
if [ "$last_opt" != "-Os" ] || ! grep -q -- ' -DNDEBUG' <<< "$line"; then
  echo "kincal_fw_example is not compiled with -Os -DNDEBUG (last -O: $last_opt)" >&2; exit 1
fi

elf=$build/examples/firmware/kincal_fw_example.elf
awk_hex='function hex(s,  i, n) { s = tolower(s); sub(/^0x/, "", s); n = 0
  for (i = 1; i <= length(s); i++) n = n * 16 + index("0123456789abcdef", substr(s, i, 1)) - 1
  return n }'
arm-none-eabi-size -A "$elf" | awk '$2 ~ /^[0-9]+$/ && $1 !~ /^\.(debug|comment|ARM\.attributes)/'
read -r flash ram < <(arm-none-eabi-objdump -h "$elf" | awk -v ram_base=536870912 "$awk_hex"'
  /^ +[0-9]+ / { name = $2; size = hex($3); vma = hex($4); lma = hex($5); next }
  /ALLOC/ && name != "" {
    if (/LOAD/ && lma < ram_base) flash += size
    if (vma >= ram_base && name != ".stack") ram += size
    name = "" }
  END { printf "%d %d\n", flash, ram }')
heap_re='^(__wrap_)?(malloc|free|calloc|realloc|memalign|aligned_alloc|posix_memalign|_(malloc|free|calloc|realloc|memalign)_r|_?sbrk|_sbrk_r|__malloc_.*|_Zna[jm].*|_Znw[jm].*|end|_end|__end__|__heap_.*|_heap_.*)$'
heap=$(arm-none-eabi-nm "$elf" | awk '{print $NF}' | grep -E "$heap_re" | sort -u | tr '\n' ' ' || true)

work=$(mktemp -d); trap 'rm -rf "$work"' EXIT
cp examples/firmware/poses.csv "$work/poses.csv"
elf_abs=$(realpath "$elf")
set +e
(cd "$work" && qemu-system-arm -M mps2-an500 -cpu cortex-m7 -nographic -monitor none -serial none \
   -semihosting-config enable=on,target=native -kernel "$elf_abs" -append "poses.csv joints.csv") \
   > "$build/example-footprint.qemu.log" 2>&1
rc=$?
set -e
sed 's/^/  qemu: /' "$build/example-footprint.qemu.log"
hwm=$(sed -nE 's/.*stack used ([0-9]+) of.*/\1/p' "$build/example-footprint.qemu.log")
python3 scripts/stack_usage.py "$elf" --ci "$build/examples/firmware/CMakeFiles/kincal_fw_example.dir" \
  --su "$build/port/baremetal" --runtime-log "$build/example-footprint.qemu.log" \
  | tee "$build/example-footprint.stack.txt" || true
stack=$(sed -nE 's/^RESULT worst_case_stack=(.*)/\1/p' "$build/example-footprint.stack.txt")

echo "  top 15 flash symbols (bytes):"
arm-none-eabi-nm --size-sort -r -S -C "$elf" | awk '$3 ~ /^[TtWwRrVv]$/ && n++ < 15' \
  | while read -r _ size _ name; do printf "    %6d  %.110s\n" "$((16#$size))" "$name"; done
echo "  static RAM symbols (bytes):"
arm-none-eabi-nm --size-sort -r -S -C "$elf" | awk '$3 ~ /^[BbDd]$/' \
  | while read -r _ size _ name; do printf "    %6d  %.110s\n" "$((16#$size))" "$name"; done

icount=$(examples/firmware/icount.sh compensate "$build/examples/firmware/kincal_fw_example_icount.elf" 49)
echo "  $icount"

ok() { [ "$1" = unbounded ] && { echo FAIL; return; }; [ "$1" -le "$2" ] && echo pass || echo FAIL; }
r_flash=$(ok "$flash" $flash_bar); r_ram=$(ok "$ram" $ram_bar); r_stack=$(ok "${stack:-unbounded}" $stack_bar)
r_heap=$([ -z "$heap" ] && echo pass || echo "FAIL ($heap)")
r_run=$([ "$rc" -eq 0 ] && echo pass || echo "FAIL (exit $rc)")
echo "=================== kincal_fw_example (bytes; bars: GUIDE, Cortex-M7 -Os one machine)"
printf 'flash %6d / %d %s | static RAM %5d / %d %s | stack %s / %d %s (measured %s) | heap %s | run %s\n' \
  "$flash" $flash_bar "$r_flash" "$ram" $ram_bar "$r_ram" "${stack:-?}" $stack_bar "$r_stack" "${hwm:-?}" "$r_heap" "$r_run"
for r in "$r_flash" "$r_ram" "$r_stack" "$r_heap" "$r_run"; do [ "$r" = pass ] || exit 1; done
echo "all bars met"
