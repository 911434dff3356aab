#!/usr/bin/env bash
# Runs the libFuzzer targets of fuzz/ (docs/reliability.md "Fuzzing").
#
#   fuzz/run.sh BUILD_DIR SECONDS [TARGET ...]
#
# BUILD_DIR: a build configured with clang and -DKINCAL_BUILD_FUZZERS=ON whose
# target kincal_fuzzers is built: build/sanitize after scripts/test-all.sh fuzz
# (which does both; the sanitize stage's tests share that build).
# SECONDS: the time each target runs. TARGET: pose_table, parameters, robot,
# model, effect_spec, formula_effect, port_csv_stream (default: all). Each target starts from
# its checked-in seed corpus (fuzz/corpus/TARGET, copied: the checked-in one is
# never changed) and writes what it finds to BUILD_DIR/fuzz-work/TARGET;
# a crash, a broken contract or a hang is saved there as crash-* / timeout-*
# and makes this script exit 1. Reproduce one with: BUILD_DIR/fuzz/fuzz_TARGET FILE
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
build=$(cd "${1:?usage: fuzz/run.sh BUILD_DIR SECONDS [TARGET ...]}" && pwd)
seconds=${2:?usage: fuzz/run.sh BUILD_DIR SECONDS [TARGET ...]}
shift 2
targets=("$@")
[ ${#targets[@]} -gt 0 ] || targets=(pose_table parameters robot model effect_spec formula_effect port_csv_stream)

dict_of() {
  case $1 in
    pose_table|parameters|port_csv_stream) echo "-dict=$here/dict/csv.dict" ;;
    robot|model) echo "-dict=$here/dict/json.dict" ;;
    formula_effect) echo "-dict=$here/dict/json.dict" ;;
    *) echo "" ;;
  esac
}

# GiNaC's and CLN's own leaks (every target linking identify/ has CLN's
# 26 bytes from start-up; GiNaC's parser leaks per syntax error) are not
# findings: host_tests/lsan.supp. Ours still are.
export LSAN_OPTIONS="suppressions=$here/../host_tests/lsan.supp:print_suppressions=0${LSAN_OPTIONS:+:$LSAN_OPTIONS}"

failed=0
for t in "${targets[@]}"; do
  bin=$build/fuzz/fuzz_$t
  [ "$t" = port_csv_stream ] && bin=$build/fuzz/fuzz_port_csv
  [ -x "$bin" ] || { echo "fuzz/run.sh: no $bin (build the target kincal_fuzzers)" >&2; exit 2; }
  work=$build/fuzz-work/$t
  mkdir -p "$work/corpus"
  cp -n "$here/corpus/$t"/* "$work/corpus/" 2>/dev/null || true
  # -timeout: one input may take at most 10 s (a hang is a finding);
  # -rss_limit_mb: a reader may not grow without bound.
  if ! (cd "$work" && "$bin" $(dict_of "$t") -max_total_time="$seconds" -timeout=10 -rss_limit_mb=2048 \
          -print_final_stats=1 -artifact_prefix="$work/" corpus > "$work/log.txt" 2>&1); then
    echo "fuzz $t: FAILED (see $work/log.txt)"
    tail -30 "$work/log.txt"
    failed=1
    continue
  fi
  runs=$(grep -o 'stat::number_of_executed_units: *[0-9]*' "$work/log.txt" | grep -o '[0-9]*$' || echo "?")
  cov=$(grep -oE 'cov: [0-9]+ ft: [0-9]+' "$work/log.txt" | tail -1 || true)
  echo "fuzz $t: ${seconds} s, $runs executions, $cov, no finding"
done
exit $failed
