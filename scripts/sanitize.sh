#!/usr/bin/env bash
# Sanitizer and fuzzing checks, in one build tree, build-sanitize:
# clang, every target (plugins and tests included) compiled and linked with AddressSanitizer
# and UBSan (-fno-sanitize-recover) plus libFuzzer's coverage instrumentation
# (-DFRICHB_FUZZ=ON), line tables only (-g1) to keep the build short.
#  1. the ctest suites except the long, install and fuzz ones, and except the eight heaviest
#     numerical tests, which take 3 to 15 s in Release and 2 to 10 min each here (the
#     sanitizers and the fuzzer's comparison tracing slow floating-point loops 40-80 times):
#     the bladed-disk harmonic convergence, five stress scenes that trace thousands of
#     points or integrate in time, and the comparison of the iterative linear solvers with the
#     dense LU on a whole folding curve (over 600 s here; the iterative solvers run under the
#     sanitizers in test_linear_solver and the Jacobian-operator stress tests). Their code
#     paths run in the other tests at smaller sizes;
#     the remaining stress scenes (extreme stiffness, preload, gap, harmonics, aliasing) run;
#     and the FE pipeline check (a 4422-DOF sector's eigen-solution, 3 s in Release), whose
#     provider code runs under the sanitizers in the fe_sector tests; and the FE patch check
#     (three response curves on the test-case blade, 18-36 s in Release, over 300 s here), whose
#     patch code runs under the sanitizers in test_contact_patch; and the 50 Hz - 20 kHz sweep
#     of the 2-DOF damper (3000 + 14 020 points, 2 s in Release), whose code paths every run takes;
#  2. fuzz_scene_bounded: libFuzzer on scene parsing and validation for FRICHB_FUZZ_SECONDS
#     (default 60) from the shipped scenes; then fuzz_import_*_bounded: libFuzzer on each
#     `frichb import` reader (four matrix formats, node coordinates, equation maps) for
#     FRICHB_FUZZ_IMPORT_SECONDS each (default 18) from tests/fuzz/import_seeds/.
# Warnings are errors in the main GCC build (scripts/test.sh), not here.
# Jobs default to the core count (FRICHB_JOBS overrides it).
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/setup.sh
jobs=${FRICHB_JOBS:-$(nproc 2>/dev/null || echo 2)}
seconds=${FRICHB_FUZZ_SECONDS:-60}
import_seconds=${FRICHB_FUZZ_IMPORT_SECONDS:-18}
start=$(date +%s)
stamp() { echo "sanitize: $1 ($(($(date +%s) - start)) s)"; }

cmake -S . -B build-sanitize -DCMAKE_C_COMPILER=clang -DCMAKE_CXX_COMPILER=clang++ \
  -DCMAKE_BUILD_TYPE=RelWithDebInfo -DCMAKE_CXX_FLAGS_RELWITHDEBINFO="-O2 -g1 -DNDEBUG" \
  -DCMAKE_C_FLAGS_RELWITHDEBINFO="-O2 -g1 -DNDEBUG" -DFRICHB_FUZZ=ON \
  -DFRICHB_FUZZ_SECONDS="$seconds" -DFRICHB_FUZZ_IMPORT_SECONDS="$import_seconds" >/dev/null
cmake --build build-sanitize -j"$jobs"
stamp "build-sanitize built"
# libgomp (CHOLMOD's OpenMP runtime, loaded with the fe_sector plugin) is preloaded so that it
# stays loaded when the plugin is unloaded: unloaded with it, its 8-byte thread-pool allocation
# is reported by LeakSanitizer as a leak from an unknown module.
export LD_PRELOAD=libgomp.so.1
ASAN_OPTIONS=detect_leaks=1:abort_on_error=1 \
  UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1 \
  ctest --test-dir build-sanitize --output-on-failure -j"$jobs" -LE "long|install|fuzz" \
  -E "^(fe_pipeline_matches_calculix_cyclic|fe_blade_nonlinear_mode_limits|Cli\.AWideWindowIsTracedOrStopsWithTheRemedyThatWorks|Coupled3d\.SlowlyContractingSliderStateBecomesPeriodicWithNewtonSteps|fe_patch_scene_matches_hand_written_contact|large_case_folds_are_physical|Cyclic\.BladedDiskPeakConvergesWithTheNumberOfHarmonics|FloquetMultipliers\.(HertzGapUpperBranchIsUnstableAsShootingFinds|HertzGapCurveNamesItsBifurcations|DuffingConvergesInHarmonicsToShooting|GapClosingCurveChangesStabilityAtItsFoldsAlone)|StudyRun\.OverlayDashesEachRunsUnstableBranches|NonlinearModes\.(TheVerbsBackboneOfTheJenkinsOscillatorEqualsTheDescribingFunction|AnUndampedOscillatorsBackboneEqualsTheDescribingFunction|SynthesisedPeaksOfTheDamperEqualFullRunsAtLightFrictionDamping)|PeakTracking\.(TracedPeaksEqualThePeaksOfFullCurves|TheDamperStudysTracedPeaksEqualFullCurves|AStalledBranchJumpsToTheRunsPeakAndGoesOn|NormalisedOptimaOfThreeExcitationLevelsCollapse)|Stress\.(StiffContactSlippingReachesTheEndAndItsPeakAgrees|HertzAtZeroPreloadConvergesToTimeIntegration|SeveralResonancesInOneSweep|GapFoldsEndRightOrSayWhy|FineControlLocatesTheFoldsOfAClosingGap|IterativePathsAndDenseLuSolveTheSameCurve)|Mistuning\.(RunGivesEveryBladesPeakAndTheAmplificationOverTheTunedDisk|StudyOverSeedsGivesEachPatternsAmplificationAndTheirStatistics|LinearAmplificationStaysUnderTheWhiteheadBoundAndRisesThenFalls))$"
stamp "ASan/UBSan tests passed"
ctest --test-dir build-sanitize -L fuzz --output-on-failure
grep -h "^stat::" build-sanitize/fuzz-scene/fuzz.log build-sanitize/fuzz-import-*/fuzz.log || true
stamp "fuzzing passed"
