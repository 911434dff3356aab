#!/usr/bin/env bash
# Installs everything kincal needs on a fresh Debian 12 machine, from Debian's
# packages only. Safe to run again: it installs only what is missing.
set -euo pipefail

packages=(
  cmake ninja-build g++ make                       # host build
  libeigen3-dev                                    # core/ (and everything)
  nlohmann-json3-dev libcli11-dev                  # identify/, apps/
  libginac-dev pkg-config                          # identify/: formula effects (parse, differentiate, print C++); found by pkg-config
  libgtest-dev libgmock-dev libbenchmark-dev       # tests, benchmarks
  gcc-arm-none-eabi libnewlib-arm-none-eabi libstdc++-arm-none-eabi-newlib  # firmware
  qemu-system-arm                                  # firmware tests
  clang libclang-rt-14-dev                         # libFuzzer targets (fuzz/): clang 14 ships libFuzzer there
  valgrind                                         # instruction counts
  python3                                          # small helpers in scripts/
)

# `scripts/install-deps.sh linuxcnc` adds LinuxCNC 2.9 (Debian 12's
# linuxcnc-uspace, its non-realtime POSIX build) for the linuxcnc stage of
# test-all.sh, which runs `kincal export linuxcnc`'s files inside LinuxCNC
# (host_tests/linuxcnc/). Without recommends: no GUI toolkits it does not need.
for group in "$@"; do
  case $group in
    linuxcnc) packages+=(linuxcnc-uspace linuxcnc-uspace-dev) ;;
    *) echo "install-deps: unknown group '$group' (linuxcnc)" >&2; exit 2 ;;
  esac
done

missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ ${#missing[@]} -eq 0 ]; then
  echo "install-deps: all ${#packages[@]} packages present"
  exit 0
fi

sudo_cmd=()
if [ "$(id -u)" -ne 0 ]; then sudo_cmd=(sudo); fi
echo "install-deps: installing ${missing[*]}"
export DEBIAN_FRONTEND=noninteractive
"${sudo_cmd[@]}" apt-get update -q
"${sudo_cmd[@]}" apt-get install -y -q --no-install-recommends "${missing[@]}"
