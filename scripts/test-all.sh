#!/usr/bin/env bash
# Sets everything up and runs every test: host (Release), host under
# AddressSanitizer + UndefinedBehaviorSanitizer, every reader under libFuzzer
# for a bounded time (about a minute in all; fuzz/run.sh runs them longer) --
# the last two from one clang build, build/sanitize, so that identify/ is
# compiled with the sanitizers once -- and
# the firmware core checks under qemu for the Cortex-M7 (double FPU) and the
# Cortex-M4F (float), and `kincal export linuxcnc` checked inside LinuxCNC 2.9
# itself (host_tests/linuxcnc/check_export.py: its genhexkins, compensation
# tables and homing, headless).
# Usage: scripts/test-all.sh [host|sanitize|fuzz|m7|m4f|linuxcnc ...]   (default: all six)
set -euo pipefail
cd "$(dirname "$0")/.."

jobs=${KINCAL_JOBS:-$(nproc)}
stages=("$@")
[ ${#stages[@]} -gt 0 ] || stages=(host sanitize fuzz m7 m4f linuxcnc)
groups=()
for stage in "${stages[@]}"; do [ "$stage" != linuxcnc ] || groups+=(linuxcnc); done
scripts/install-deps.sh "${groups[@]}"

run_stage() {
  local name=$1; shift
  local dir=build/$name
  echo "=== $name: configure"
  cmake -S . -B "$dir" -G Ninja "$@" > "$dir.configure.log" 2>&1 || { cat "$dir.configure.log"; return 1; }
  echo "=== $name: build"
  cmake --build "$dir" -j "$jobs"
  echo "=== $name: test"
  (cd "$dir" && ctest --output-on-failure -j "$jobs" "${ctest_args[@]}")
}
ctest_args=()

# The firmware stages' end-to-end test (examples/firmware) runs the host
# kincal tool (simulate, identify, table, compensate): build/host's, built
# here if the host stage has not done it already.
host_tool() {
  if [ ! -f build/host/CMakeCache.txt ]; then
    cmake -S . -B build/host -G Ninja -DCMAKE_BUILD_TYPE=Release > build/host.configure.log 2>&1 \
      || { cat build/host.configure.log; return 1; }
  fi
  echo "=== host tool for the firmware end-to-end test: build/host/apps/kincal"
  cmake --build build/host -j "$jobs" --target kincal > build/host.tool.log 2>&1 \
    || { tail -50 build/host.tool.log; return 1; }
}

# The sanitizer build: clang, AddressSanitizer + UndefinedBehaviorSanitizer at
# -O1 with assertions on (Debug), and libFuzzer's instrumentation so that the
# fuzz stage's targets come from the same objects (top-level CMakeLists.txt).
sanitizer_build=(-DCMAKE_BUILD_TYPE=Debug -DCMAKE_C_COMPILER=clang -DCMAKE_CXX_COMPILER=clang++
                 -DKINCAL_SANITIZE=ON -DKINCAL_BUILD_FUZZERS=ON -DKINCAL_BUILD_BENCHMARKS=OFF)

# Under the sanitizers the hybrid's identification with effects (backward
# elimination, each pass a nonlinear base fit) runs ~70x slower than in
# Release: these nine tests took 1-15 s there and 3.5 to over 10 minutes
# here. They run in the host stage; their code paths run under the
# sanitizers in the shorter hybrid tests (BothMachines/HiddenEffect.*/hybrid_*
# for compliance, backlash, cyclic and thermal, identifyBlunder.*).
# HybridAcrossMachines repeats the single-machine tracker and full-pose tests
# (HybridTracker.*, HybridFullPose.*, which run here) on 24 more machines.
sanitize_skip_tests=(
  'HybridDefaultBaseCompensatesAtLeastAsWellAsOls'
  'ComplianceAndScaleTogetherFitLikeComplianceAlone'
  'HiddenEffect.IsNamedFirstAcceptedAndCompensated/hybrid_scale'
  'IdentifyWithEffectsHoldsWhatTheDataCannotTellAndMakesATable'
  'HoldsParametersTheDataCannotTellFromTheBase'
  'HybridUpsActuatorScaleIsFittedFromAFarStart'
  'HybridPairsAreNamedAndCompensatedNearTheFloor'
  'HybridEliminationRoundsKeepTheMinimum'
  'HybridRivalEffectsAreChosenByMallowsCp'
  'HybridTrackerEffect'
  'HybridAcrossMachines'
# The loops on independently simulated machines (identify_independent_*_test)
# run the kincal tool 30-50 times each: numerical evidence, in the host
# stage; the identify / diagnose / compensate paths they drive run under the
# sanitizers in the tests above.
  'EachPhysicalGroupIsAbsorbedAndCompensated'
  'IndependentDiagnosis'
  'IndependentHybrid.MillimetreErrorsAreAbsorbedByTheExactModel'
  'HeldOutAgainstCalRatioIsCalibratedOnACompleteModel'
  'IndependentEffects.StewartClearance'
  'IndependentRus6.EachEffectIsNamedAndCompensatedNearTheFloorWithNoise'
  'IndependentRus6.OneTrackerTargetEachEffectIsNamedAndCompensated'
# The slowest of the rest (20-150 s each under the sanitizers, at most 4 s in
# Release; CI's budget, docs/benchmarks.md "Build time (CI)"), each with a
# shorter test of the same path that stays here:
# - the 6-RUS workspace box (a dense grid of IKs): CoreRus6.ClosedFormIk*,
#   RoundTrip*, FkFromPreviousPoseTracksAPath;
# - the controller's random-table property: PortController.* (bad streams,
#   corrupt tables) and the fuzz stage's fuzz_port_csv (reader + compensator);
# - diagnosis on a misfit outside the library: NoiseEstimateDiagnosis.TooFew*
#   and .Collinear*, and BothMachines/Outside.*/"stewart";
# - hybrid backlash from full poses: BothMachines/HiddenEffect.*/hybrid_backlash;
# - the loops through the tool: appKincal.IdentifyThenCompensateTheHybrid,
#   appKincal.OneTrackerTargetInItsOwnFrameThroughTheTool,
#   FormulaEffectLoop.TheHybridsUpsLegs*, UserEffect.*;
# - planning on every machine: Plan.PosesAreReachable*.
  'CoreRus6.WorkspaceBoxReachableInsideLimits'
  'PortControllerProperty'
  'NoiseEstimateDiagnosis.OutsideMisfitNeverExplained'
  'Outside.SaysUnexplainedWithTheJointAndStrokeAsHotspot/"hybrid"'
  'HybridFullPose.HiddenBacklashIsNamedFittedAndCompensated'
  'appKincal.TheHybridFromFullPosesThroughTheTool'
  'appKincal.TheHybridLoopFallsAtEveryStep'
  'FormulaEffectLoop.SixUpsEffectsOutsideTheLibrary'
  'Plan.BeatsTheGridOnEveryMachineAndMeasurement'
)
sanitize_skip=$(IFS='|'; echo "${sanitize_skip_tests[*]}")

# The sanitizer builds (sanitize, fuzz) report leaks, but not GiNaC's and
# CLN's own (host_tests/lsan.supp): ours still are. print_suppressions=0:
# the statistics LeakSanitizer prints at exit would be extra lines on the
# tool's stderr, which the tests read.
export LSAN_OPTIONS="suppressions=$PWD/host_tests/lsan.supp:print_suppressions=0${LSAN_OPTIONS:+:$LSAN_OPTIONS}"

mkdir -p build
# Each stage's wall time, printed at the end (CI's budget: docs/benchmarks.md "Build time (CI)").
timings=()
for stage in "${stages[@]}"; do
  stage_start=$SECONDS
  case $stage in
    host)     run_stage host -DCMAKE_BUILD_TYPE=Release ;;
    sanitize) ctest_args=(-E "$sanitize_skip")
              run_stage sanitize "${sanitizer_build[@]}"
              ctest_args=() ;;
    fuzz)     echo "=== fuzz: configure (build/sanitize, shared with the sanitize stage)"
              cmake -S . -B build/sanitize -G Ninja "${sanitizer_build[@]}" > build/sanitize.configure.log 2>&1 \
                || { cat build/sanitize.configure.log; exit 1; }
              echo "=== fuzz: build"
              cmake --build build/sanitize -j "$jobs" --target kincal_fuzzers
              echo "=== fuzz: run (8 s per target)"
              fuzz/run.sh build/sanitize 8 ;;
    m7)       host_tool
              run_stage m7 -DCMAKE_TOOLCHAIN_FILE=toolchains/cortex-m7.cmake -DKINCAL_HOST_TOOL="$PWD/build/host/apps/kincal" ;;
    m4f)      host_tool
              run_stage m4f -DCMAKE_TOOLCHAIN_FILE=toolchains/cortex-m4f.cmake -DKINCAL_HOST_TOOL="$PWD/build/host/apps/kincal" ;;
    linuxcnc) host_tool
              echo "=== linuxcnc: kincal export linuxcnc inside LinuxCNC 2.9 (build/linuxcnc/RESULTS.md)"
              python3 host_tests/linuxcnc/check_export.py --kincal build/host/apps/kincal --work build/linuxcnc ;;
    *) echo "unknown stage '$stage' (host, sanitize, fuzz, m7, m4f, linuxcnc)" >&2; exit 2 ;;
  esac
  timings+=("$stage $((SECONDS - stage_start)) s")
  echo "=== $stage: done in $((SECONDS - stage_start)) s"
done
echo "=== all stages passed: ${stages[*]} (${SECONDS} s: $(IFS=,; echo "${timings[*]}" | sed 's/,/, /g'))"
