#!/usr/bin/env bash
# Firmware footprint against the GUIDE bar (Cortex-M7, -Os, one machine):
#   flash <= 48 KiB, static RAM <= 4 KiB, worst-case stack <= 4 KiB, no heap symbol.
# Builds the two footprint images (host_tests/firmware/footprint.cpp: core
# kinematics of stewart-seed001 / hybrid-seed000 in double) as MinSizeRel, i.e.
# -Os -DNDEBUG (the default build type keeps assert/eigen_assert, ~10 KiB of
# strings, which a product image does not carry), runs them under qemu, and
# prints per image: sections, the no-heap check, the largest flash symbols and
# contributors, static worst-case stack (scripts/stack_usage.py) and the
# measured stack high-water mark. Exits 1 if a bar is exceeded or an image fails.
# Results and their reading: docs/benchmarks.md "Firmware footprint (Cortex-M7)".
#
# Usage: scripts/firmware-footprint.sh [build-dir]     (default build/m7-footprint)
set -euo pipefail
cd "$(dirname "$0")/.."
build=${1:-build/m7-footprint}
export LC_ALL=C  # deterministic sort order and number formats

flash_bar=$((48 * 1024))
ram_bar=$((4 * 1024))
stack_bar=$((4 * 1024))
machines=(stewart hybrid)

# Own build directory: the size bars are for MinSizeRel, while the test builds
# (build/m7) keep assertions on.
mkdir -p "$build"
cmake -S . -B "$build" -G Ninja -DCMAKE_TOOLCHAIN_FILE=toolchains/cortex-m7.cmake \
  -DCMAKE_BUILD_TYPE=MinSizeRel -DKINCAL_BUILD_TESTS=ON > "$build/footprint.configure.log" 2>&1 \
  || { cat "$build/footprint.configure.log"; exit 1; }
cmake --build "$build" --target "${machines[@]/#/kincal_fw_footprint_}" > "$build/footprint.build.log" 2>&1 \
  || { cat "$build/footprint.build.log"; exit 1; }

# The measurement is only valid at -Os with NDEBUG: check the real compile line
# (the toolchain puts -Os first, and a build type's flags come after it).
for m in "${machines[@]}"; do
  line=$(grep -o "\"command\": \"[^\"]*footprint.cpp[^\"]*\"" "$build/compile_commands.json" \
         | grep "kincal_fw_footprint_$m.dir")
  last_opt=$(grep -oE -- ' -O[0-3sz]( |$)' <<< "$line" | tail -1 | tr -d ' ')
  if [ "$last_opt" != "-Os" ] || ! grep -q -- ' -DNDEBUG' <<< "$line"; then
    echo "kincal_fw_footprint_$m is not compiled with -Os -DNDEBUG (last -O: $last_opt)" >&2
    exit 1
  fi
done

# qemu exactly as ctest runs the firmware tests (docs/firmware.md).
qemu=(qemu-system-arm -M mps2-an500 -cpu cortex-m7 -nographic -monitor none -serial none
      -semihosting-config enable=on,target=native -kernel)
# awk helper (mawk has no strtonum): "0x1f" or "1f" -> 31.
awk_hex='function hex(s,  i, n) { s = tolower(s); sub(/^0x/, "", s); n = 0
  for (i = 1; i <= length(s); i++) n = n * 16 + index("0123456789abcdef", substr(s, i, 1)) - 1
  return n }'
# Heap entry points (the --wrap list of port/baremetal plus sbrk/heap-region names).
# operator delete is not on the list: port/baremetal defines a trapping one.
heap_re='^(__wrap_)?(malloc|free|calloc|realloc|memalign|aligned_alloc|posix_memalign|_(malloc|free|calloc|realloc|memalign)_r|_?sbrk|_sbrk_r|__malloc_.*|_Zna[jm].*|_Znw[jm].*|end|_end|__end__|__heap_.*|_heap_.*)$'

fail=0
summary=()
for m in "${machines[@]}"; do
  elf=$build/host_tests/kincal_fw_footprint_$m.elf
  map=$build/host_tests/kincal_fw_footprint_$m.map
  log=$build/host_tests/kincal_fw_footprint_$m.qemu.log
  echo "=================== kincal_fw_footprint_$m ($(basename "$elf"))"

  # Sections. Flash = everything loaded below RAM, including .data's initial
  # image (its LMA is in flash). Static RAM = allocated sections in RAM except
  # the reserved .stack region (KINCAL_FIRMWARE_STACK_SIZE, a link-time choice:
  # the stack bar is checked against the analysed worst case instead).
  arm-none-eabi-size -A "$elf" | awk '$2 ~ /^[0-9]+$/ && $1 !~ /^\.(debug|comment|ARM\.attributes)/'
  # RAM starts at 0x20000000 on both mps2 boards (port/baremetal/mps2.ld).
  read -r flash ram stack_region < <(arm-none-eabi-objdump -h "$elf" | awk -v ram_base=536870912 "$awk_hex"'
    /^ +[0-9]+ / { name = $2; size = hex($3); vma = hex($4); lma = hex($5); next }
    /ALLOC/ && name != "" {
      if (/LOAD/ && lma < ram_base) flash += size
      if (vma >= ram_base) { if (name == ".stack") stk += size; else ram += size }
      name = "" }
    END { printf "%d %d %d\n", flash, ram, stk }')

  # No heap symbol anywhere in the image.
  heap=$(arm-none-eabi-nm "$elf" | awk '{print $NF}' | grep -E "$heap_re" | sort -u | tr '\n' ' ' || true)

  # Run it: a footprint image is also a test (non-zero status on a failed check).
  set +e
  "${qemu[@]}" "$elf" > "$log" 2>&1
  rc=$?
  set -e
  sed 's/^/  qemu: /' "$log"
  hwm=$(sed -nE 's/.*stack used ([0-9]+) of.*/\1/p' "$log")

  # Static worst-case stack.
  python3 scripts/stack_usage.py "$elf" --ci "$build/host_tests/CMakeFiles/kincal_fw_footprint_$m.dir" \
    --su "$build/port/baremetal" --runtime-log "$log" | tee "$build/host_tests/kincal_fw_footprint_$m.stack.txt" \
    || fail=1
  stack=$(sed -nE 's/^RESULT worst_case_stack=(.*)/\1/p' "$build/host_tests/kincal_fw_footprint_$m.stack.txt")

  echo "  top 15 flash symbols (bytes):"
  arm-none-eabi-nm --size-sort -r -S -C "$elf" | awk '$3 ~ /^[TtWwRr]$/ && n++ < 15' \
    | while read -r _ size _ name; do printf "    %6d  %.110s\n" "$((16#$size))" "$name"; done

  # Flash by input file (map file): which library the bytes come from.
  echo "  flash by input file (bytes):"
  awk "$awk_hex"'
    /^[.][A-Za-z]/ { out = $1 }                           # output section
    /^ [.*]/ { pending = 0
      if (NF >= 4 && $2 ~ /^0x/) { add(out, $3, $4) } else if ($1 != "*fill*" && NF == 1) pending = 1
      if ($1 == "*fill*") add(out, $3, "(alignment padding)"); next }
    pending && NF == 3 && $1 ~ /^0x/ && $2 ~ /^0x/ { add(out, $2, $3); pending = 0; next }
    { pending = 0 }
    function add(sec, size, file) {
      if (sec !~ /^\.(isr_vector|text|rodata|ARM\.ex(idx|tab)|(pre)?init_array|fini_array|data)$/) return
      if (file !~ /^\(/) { sub(/\(.*/, "", file); sub(/.*\//, "", file) }
      total[file] += hex(size) }
    END { for (f in total) if (total[f]) printf "    %6d  %s\n", total[f], f }' "$map" | sort -k1,1nr -k2

  ok() { [ "$1" = unbounded ] && { echo FAIL; return; }; [ "$1" -le "$2" ] && echo pass || echo FAIL; }
  r_flash=$(ok "$flash" $flash_bar); r_ram=$(ok "$ram" $ram_bar); r_stack=$(ok "$stack" $stack_bar)
  r_heap=$([ -z "$heap" ] && echo pass || echo "FAIL ($heap)")
  r_run=$([ "$rc" -eq 0 ] && echo pass || echo "FAIL (exit $rc)")
  summary+=("$(printf '%-8s flash %6d / %d %-5s | static RAM %5d / %d %-5s (+ %d reserved stack) | stack %s / %d %-5s (measured %s) | heap %s | run %s' \
    "$m" "$flash" $flash_bar "$r_flash" "$ram" $ram_bar "$r_ram" "$stack_region" "$stack" $stack_bar "$r_stack" "${hwm:-?}" "$r_heap" "$r_run")")
  for r in "$r_flash" "$r_ram" "$r_stack" "$r_heap" "$r_run"; do [ "$r" = pass ] || fail=1; done
done

echo "=================== summary (bytes; bars: GUIDE, Cortex-M7 -Os one machine)"
printf '%s\n' "${summary[@]}"
[ $fail -eq 0 ] && echo "all bars met" || echo "BAR EXCEEDED (see above)"
exit $fail
