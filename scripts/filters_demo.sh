#!/usr/bin/env bash
# The classical pipeline on a synthetic track (the main job before the handwriting demo):
# installs missing Debian packages, builds, and runs
# synthesise/import -> corrupt -> filter -> eval, leaving everything in out/filters_demo/.
# With ../shared/data present it also runs the FPHA subject 5 comparison table.
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
cd "$root"
scripts/deps.sh build
cmake -S . -B build/release -DCMAKE_BUILD_TYPE=Release -DHS_BUILD_TESTS=OFF >/dev/null
cmake --build build/release -j"$(nproc)" --target handsteady
hs=build/release/cli/handsteady
out=${HS_DEMO_OUT:-out/filters_demo}
mkdir -p "$out"
$hs synth --out "$out/clean.csv" --seconds 30 --seed 1
$hs corrupt --in "$out/clean.csv" --out "$out/noisy.csv" --preset tracker --seed 1
cmp=()
for m in raw oneeuro desp kalman stgae; do  # stgae: the shipped model in models/
  $hs filter --in "$out/noisy.csv" --out "$out/$m.csv" --method "$m"
  echo "== $m (denoise) =="
  $hs eval --truth "$out/clean.csv" --in "$out/$m.csv"
  cmp+=(--in "$m=$out/$m.csv")
done
echo "== synthetic track, tracker preset: all methods =="
$hs compare --truth "$out/clean.csv" "${cmp[@]}" | tee "$out/summary.md"
data=${HS_SHARED_DATA:-$root/../shared/data}
if [ -d "$data/fpha/Subject_5" ]; then
  scripts/fpha_table.sh "$hs" "$data" "$out/fpha"
else
  echo "demo: $data/fpha/Subject_5 not found; skipping the FPHA table"
fi
echo "demo: outputs in $out"
