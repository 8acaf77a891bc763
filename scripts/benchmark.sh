#!/usr/bin/env bash
# The project's quality benchmark (docs/BENCHMARK.md): builds the CLI and the plotter in
# build/release (Release), scores raw, One Euro (default and tuned per noise cell on the
# tuning split), DESP, Kalman and the shipped model (plus every --model LABEL=FILE.hsm
# given) on the fixed, seeded grid over ../shared/data, and writes out/benchmark/
# benchmark.md, benchmark.json, curve.csv and PNG plots.
# Usage: scripts/benchmark.sh [--quick] [--model LABEL=FILE.hsm ...] [other `handsteady benchmark` options]
# Environment: HS_BENCHMARK_OUT (default out/benchmark), HS_DATA (default ../shared/data).
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
cd "$root"
scripts/deps.sh build
build=build/release
out=${HS_BENCHMARK_OUT:-out/benchmark}
cmake -S . -B "$build" -DCMAKE_BUILD_TYPE=Release -DHS_BUILD_TESTS=OFF -DHS_BUILD_TRAINING=OFF >/dev/null
cmake --build "$build" -j"$(nproc)" --target handsteady handsteady_benchmark_plot
"$build/cli/handsteady" benchmark --data "${HS_DATA:-../shared/data}" --out "$out" "$@"
"$build/sample_app/benchmark_plot/handsteady_benchmark_plot" --in "$out/benchmark.json"
echo "benchmark: $out/benchmark.md"
