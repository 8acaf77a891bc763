#!/usr/bin/env bash
# Runs all tests: installs missing Debian packages, configures and builds with
# warnings as errors, runs CTest; then the same in an AddressSanitizer +
# UndefinedBehaviorSanitizer build, the concurrency tests under ThreadSanitizer, and
# libFuzzer runs on the file parsers.
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
# Debug information as line tables only (-g1) in all four builds: backtraces and sanitizer
# reports still name file and line, and full -g (most of what the compiler wrote for the
# Eigen and libtorch code) made this script take 105 CPU-min and 61-65 min on 2 cores,
# against 68 and 40 (2026-11-27, the same host). The optimised builds (this one and the
# fuzzers) share their flags.
optimised="-DCMAKE_CXX_FLAGS_RELWITHDEBINFO=-O2 -g1 -DNDEBUG"
run build/test -DCMAKE_BUILD_TYPE=RelWithDebInfo "$optimised"
if [ "${1:-}" != "--quick" ]; then
  export ASAN_OPTIONS=detect_leaks=1:abort_on_error=1 UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1
  export LSAN_OPTIONS=suppressions=$root/tests/lsan.supp
  # The training tests too: libtorch itself is not instrumented, our code around it is.
  # -O1, as the AddressSanitizer documentation advises for reasonable speed: with Eigen at
  # -O0 the synthetic benchmark grid test alone took 490-780 s, at -O1 27 s.
  # The sanitizer builds leave out the layer's x86-64-v3 copy (HS_LAYER_V3: the same
  # sources again with -march=x86-64-v3, a sixth of the build) and the Google benchmarks:
  # the baseline layer runs the same code under the sanitizers.
  run build/asan -DCMAKE_BUILD_TYPE=Debug "-DCMAKE_CXX_FLAGS_DEBUG=-g1 -O1" -DHS_SANITIZE=address,undefined \
    -DHS_LAYER_V3=OFF
  # Concurrency tests (CTest label "tsan"; their targets in tests/tsan_targets.txt).
  HS_TARGETS="$(grep -v '^#' tests/tsan_targets.txt)" HS_CTEST_ARGS="-L tsan" \
    run build/tsan -DCMAKE_BUILD_TYPE=Debug -DCMAKE_CXX_FLAGS_DEBUG=-g1 -DHS_SANITIZE=thread -DHS_BUILD_TRAINING=OFF -DHS_LAYER_V3=OFF
  # libFuzzer (clang, ASan+UBSan) on every parser of user input: the .hsm model loader,
  # the track CSV reader, the FPHA/MRTK/BVH importers, the layer's JSON configuration and
  # environment, the replay runtime's environment and paths, the training config
  # (docs/FUZZING.md). Fixed seed; each from a scratch copy of its seed corpus
  # (tests/fuzz/corpus/<name>), HS_FUZZ_SECONDS each (default 60 s for the model loader,
  # 30 s for the others), $jobs at a time (a fuzzer is one process on one core): 3 min
  # on 2 cores. Reported in this order whatever order they end in.
  cmake -S . -B build/fuzz -DCMAKE_CXX_COMPILER=clang++ -DCMAKE_BUILD_TYPE=RelWithDebInfo -DHS_WERROR=ON \
    "$optimised" \
    -DHS_FUZZ=ON -DHS_SANITIZE=address,undefined -DHS_BUILD_TRAINING=OFF -DHS_BUILD_DEMO=OFF >/dev/null
  fuzzers=(hsm_loader track_csv fpha mrtk bvh layer_config layer_env replay_env replay_paths train_config)
  cmake --build build/fuzz -j"$jobs" --target "${fuzzers[@]/#/fuzz_}"
  fuzz() {  # name: runs one fuzzer, its exit status in build/fuzz/fuzz_<name>.rc
    local name=$1 corpus=build/fuzz/corpus/$1 log=build/fuzz/fuzz_$1.log seconds=30 dict=() rc=0
    if [ "$name" = hsm_loader ]; then seconds=60; fi
    rm -rf "$corpus" && mkdir -p "$corpus"
    if [ -d "tests/fuzz/corpus/$name" ]; then cp "tests/fuzz/corpus/$name"/* "$corpus"/; fi
    if [ -f "tests/fuzz/dict/$name.dict" ]; then dict=(-dict="tests/fuzz/dict/$name.dict"); fi
    "build/fuzz/tests/fuzz/fuzz_$name" -seed=1 -max_total_time="${HS_FUZZ_SECONDS:-$seconds}" -timeout=10 \
      -print_final_stats=1 -artifact_prefix="build/fuzz/$name-" "${dict[@]}" "$corpus" > "$log" 2>&1 || rc=$?
    echo "$rc" > "build/fuzz/fuzz_$name.rc"
  }
  for name in "${fuzzers[@]}"; do
    rm -f "build/fuzz/fuzz_$name.rc"
    while [ "$(jobs -rp | wc -l)" -ge "$jobs" ]; do wait -n || true; done
    fuzz "$name" &
  done
  wait
  for name in "${fuzzers[@]}"; do
    log=build/fuzz/fuzz_$name.log
    if [ "$(cat "build/fuzz/fuzz_$name.rc" 2>/dev/null)" != 0 ]; then
      tail -n 80 "$log" >&2
      echo "fuzz_$name failed; the input: $(sed -n 's/.*Test unit written to //p' "$log")" >&2
      exit 1
    fi
    echo "fuzz_$name: $(grep -E '^#[0-9]+[[:space:]]+DONE' "$log")"
  done
fi
echo "handsteady: all tests passed"
