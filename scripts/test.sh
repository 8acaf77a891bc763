#!/usr/bin/env bash
# Runs all tests: installs missing Debian packages, configures and builds with
# warnings as errors, runs CTest; then the same in an AddressSanitizer +
# UndefinedBehaviorSanitizer build, the concurrency tests under ThreadSanitizer, and a
# libFuzzer run on the model loader.
# Usage: scripts/test.sh [--quick]   (--quick: the normal build only)
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
cd "$root"
scripts/deps.sh test
jobs=$(nproc)
run() {  # build-dir [cmake args...]; HS_TARGETS limits what is built, HS_CTEST_ARGS what runs
  local dir=$1; shift
  cmake -S . -B "$dir" -DHS_WERROR=ON "$@" >/dev/null
  local targets=()
  for t in ${HS_TARGETS:-}; do targets+=(--target "$t"); done
  cmake --build "$dir" -j"$jobs" "${targets[@]}"
  (cd "$dir" && ctest --output-on-failure -j"$jobs" ${HS_CTEST_ARGS:-})
}
run build/test -DCMAKE_BUILD_TYPE=RelWithDebInfo
if [ "${1:-}" != "--quick" ]; then
  export ASAN_OPTIONS=detect_leaks=1:abort_on_error=1 UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1
  export LSAN_OPTIONS=suppressions=$root/tests/lsan.supp
  # The training tests too: libtorch itself is not instrumented, our code around it is.
  run build/asan -DCMAKE_BUILD_TYPE=Debug -DHS_SANITIZE=address,undefined
  # Concurrency tests (CTest label "tsan"; their targets in tests/tsan_targets.txt).
  HS_TARGETS="$(grep -v '^#' tests/tsan_targets.txt)" HS_CTEST_ARGS="-L tsan" \
    run build/tsan -DCMAKE_BUILD_TYPE=Debug -DHS_SANITIZE=thread -DHS_BUILD_TRAINING=OFF
  # libFuzzer on the .hsm model loader (clang, ASan+UBSan): fixed seed, HS_FUZZ_SECONDS (60).
  cmake -S . -B build/fuzz -DCMAKE_CXX_COMPILER=clang++ -DCMAKE_BUILD_TYPE=RelWithDebInfo -DHS_WERROR=ON \
    -DHS_FUZZ=ON -DHS_SANITIZE=address,undefined -DHS_BUILD_TRAINING=OFF -DHS_BUILD_DEMO=OFF >/dev/null
  cmake --build build/fuzz -j"$jobs" --target fuzz_hsm_loader
  mkdir -p build/fuzz/corpus
  if ! build/fuzz/tests/fuzz/fuzz_hsm_loader -seed=1 -max_total_time="${HS_FUZZ_SECONDS:-60}" -print_final_stats=1 \
      -artifact_prefix=build/fuzz/ build/fuzz/corpus > build/fuzz/fuzz.log 2>&1; then
    tail -n 80 build/fuzz/fuzz.log >&2
    echo "fuzz_hsm_loader failed: the input is in build/fuzz/ (crash-*, leak-*, timeout-*)" >&2
    exit 1
  fi
  tail -n 8 build/fuzz/fuzz.log
fi
echo "handsteady: all tests passed"
