#!/usr/bin/env bash
# The firmware example in one command (docs/firmware.md "The firmware example"):
#   scripts/firmware-example.sh MODEL.json POSES.csv JOINTS.csv
# 1. builds the host kincal tool if needed (build/host, Release);
# 2. configures a Cortex-M7 firmware build with that MODEL.json
#    (build/firmware-example, -Os -DNDEBUG): `kincal table` generates the
#    parameter table header, which the firmware compiles in (regenerated
#    whenever the model changes);
# 3. runs the firmware under qemu (mps2-an500) on POSES.csv: it checks its
#    table, writes and verifies the encoder offsets, compensates every pose and
#    writes JOINTS.csv (id, x..rz, q1..q6, status, seq, flags), the same
#    numbers `kincal compensate` writes on the host.
# Exit status: the firmware's (0 ok; 1 a file failed; 3 the controller was not
# ready: table or register fault, every point held) or the build's.
# Environment: KINCAL_HOST_BUILD, KINCAL_FIRMWARE_BUILD (build directories),
# KINCAL_JOBS (parallel jobs).
set -euo pipefail
if [ $# -ne 3 ]; then
  echo "usage: $0 MODEL.json POSES.csv JOINTS.csv" >&2
  exit 2
fi
model=$(realpath "$1")
poses=$(realpath "$2")
out=$(realpath -m "$3")
for f in "$model" "$poses"; do
  [ -f "$f" ] || { echo "$0: $f: no such file" >&2; exit 2; }
done
mkdir -p "$(dirname "$out")"
cd "$(dirname "$0")/.."
root=$PWD
scripts/install-deps.sh > /dev/null
jobs=${KINCAL_JOBS:-$(nproc)}
host=${KINCAL_HOST_BUILD:-$root/build/host}
fw=${KINCAL_FIRMWARE_BUILD:-$root/build/firmware-example}

log=$(mktemp)
trap 'rm -f "$log"' EXIT
step() {  # step "what" command...: quiet unless it fails
  echo "== $1"
  shift
  "$@" > "$log" 2>&1 || { cat "$log"; exit 1; }
}

[ -f "$host/CMakeCache.txt" ] ||
  step "configure the host tool ($host)" cmake -S . -B "$host" -G Ninja -DCMAKE_BUILD_TYPE=Release
step "build the host tool" cmake --build "$host" -j "$jobs" --target kincal
step "configure the Cortex-M7 firmware with $model ($fw)" \
  cmake -S . -B "$fw" -G Ninja -DCMAKE_TOOLCHAIN_FILE=toolchains/cortex-m7.cmake -DCMAKE_BUILD_TYPE=MinSizeRel \
  -DKINCAL_BUILD_TESTS=OFF -DKINCAL_CALIBRATION_MODEL="$model" -DKINCAL_HOST_TOOL="$host/apps/kincal"
step "generate the table and build the firmware" cmake --build "$fw" -j "$jobs" --target kincal_fw_example
elf=$fw/examples/firmware/kincal_fw_example.elf
arm-none-eabi-size "$elf" | sed 's/^/   /'

# qemu's semihosting reads file names relative to its working directory and
# from a space-separated command line: run it in a scratch directory with
# plain names, whatever the user's paths look like.
work=$(mktemp -d)
trap 'rm -f "$log"; rm -rf "$work"' EXIT
cp "$poses" "$work/poses.csv"
echo "== run under qemu (mps2-an500, Cortex-M7)"
set +e
(cd "$work" && qemu-system-arm -M mps2-an500 -cpu cortex-m7 -nographic -monitor none -serial none \
   -semihosting-config enable=on,target=native -kernel "$elf" -append "poses.csv joints.csv")
rc=$?
set -e
[ -f "$work/joints.csv" ] && cp "$work/joints.csv" "$out"
[ $rc -eq 0 ] && echo "== wrote $out" || echo "== firmware exit status $rc (see above); output: $out" >&2
exit $rc
