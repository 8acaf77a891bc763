#!/usr/bin/env bash
# Runs all tests: installs missing Debian packages, configures and builds with
# warnings as errors, runs CTest; then the same in an AddressSanitizer +
# UndefinedBehaviorSanitizer build, and the concurrency tests under ThreadSanitizer.
# Usage: scripts/test.sh [--quick]   (--quick: the normal build only)
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
cd "$root"
scripts/deps.sh test
jobs=$(nproc)
run() {  # build-dir, extra cmake args..., ctest label filter via HS_CTEST_ARGS
  local dir=$1; shift
  cmake -S . -B "$dir" -DHS_WERROR=ON "$@" >/dev/null
  cmake --build "$dir" -j"$jobs"
  (cd "$dir" && ctest --output-on-failure -j"$jobs" ${HS_CTEST_ARGS:-})
}
run build/test -DCMAKE_BUILD_TYPE=RelWithDebInfo
if [ "${1:-}" != "--quick" ]; then
  export ASAN_OPTIONS=detect_leaks=1:abort_on_error=1 UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1
  export LSAN_OPTIONS=suppressions=$root/tests/lsan.supp
  run build/asan -DCMAKE_BUILD_TYPE=Debug -DHS_SANITIZE=address,undefined
  if [ -n "$(find tests -name '*.tsan' -print -quit 2>/dev/null)" ]; then
    HS_CTEST_ARGS="-L tsan" run build/tsan -DCMAKE_BUILD_TYPE=Debug -DHS_SANITIZE=thread
  fi
fi
echo "handsteady: all tests passed"
