#!/usr/bin/env bash
# Multi-STGAE benchmark (issue 3, §7; docs/STGAE.md "Benchmark"): builds hs_bench_stgae in
# build/bench (Release; needs libtorch-dev and libbenchmark-dev), runs it on one core and
# writes out/bench/stgae_bench.txt (benchmarks + summary table) and
# out/bench/stgae_bench.json (Google Benchmark JSON, every repetition).
# Arguments are passed to hs_bench_stgae, e.g. --cpu=1, --model=PATH,
# --stream_frames=N, --benchmark_repetitions=N, --benchmark_filter=eigen.
# Environment: HS_BENCH_BUILD (build dir, default build/bench), HS_BENCH_OUT (default out/bench),
# HS_BENCH_CXXFLAGS (e.g. -march=native; use a separate HS_BENCH_BUILD for it).
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
cd "$root"
scripts/deps.sh test  # libtorch-dev and libbenchmark-dev are test dependencies
build=${HS_BENCH_BUILD:-build/bench}
out=${HS_BENCH_OUT:-out/bench}
cmake -S . -B "$build" -DCMAKE_BUILD_TYPE=Release -DHS_BUILD_TESTS=OFF -DHS_BUILD_DEMO=OFF -DHS_BUILD_TRAINING=ON \
  -DCMAKE_CXX_FLAGS="${HS_BENCH_CXXFLAGS:-}" >/dev/null
cmake --build "$build" -j"$(nproc)" --target hs_bench_stgae
bin="$build/training/bench/hs_bench_stgae"
if [ ! -x "$bin" ]; then
  echo "bench: $bin was not built (libtorch-dev or libbenchmark-dev missing?)" >&2
  exit 1
fi
mkdir -p "$out"
# One thread everywhere: libtorch's intra-op pool and OpenBLAS (OpenMP build).
export OMP_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1
{
  echo "# scripts/bench.sh $*  ($(date -u +%Y-%m-%dT%H:%M:%SZ), $(git rev-parse --short HEAD 2>/dev/null || echo '?'))"
  echo "# uptime: $(uptime)"
  echo "# compiler: $(${CXX:-c++} --version | head -1); CXXFLAGS: ${HS_BENCH_CXXFLAGS:-none} (Release)"
  blas=/etc/alternatives/libblas.so.3-x86_64-linux-gnu
  [ -e "$blas" ] && echo "# BLAS (libtorch): $(readlink -f "$blas")"
  "$bin" --benchmark_repetitions=5 --benchmark_display_aggregates_only=true --benchmark_color=false \
    --benchmark_out="$out/stgae_bench.json" --benchmark_out_format=json "$@"
} 2>&1 | tee "$out/stgae_bench.txt"
echo "bench: wrote $out/stgae_bench.txt and $out/stgae_bench.json"
