#!/usr/bin/env bash
# The FPHA subject 5 comparison (README "Results"): import -> corrupt (seed 1) ->
# classical filters -> compare, denoising (H = 0) and prediction (H = 50 ms), for the
# `tracker` and `tremor` presets.
# Usage: scripts/fpha_table.sh HANDSTEADY_BINARY SHARED_DATA_DIR OUT_DIR
set -euo pipefail
hs=$1; data=$2; out=$3
mkdir -p "$out"
$hs import --format fpha --in "$data/fpha/Subject_5" --out "$out/clean.csv" >/dev/null
for preset in tracker tremor; do
  d="$out/$preset"
  mkdir -p "$d"
  $hs corrupt --in "$out/clean.csv" --out "$d/noisy.csv" --preset "$preset" --seed 1 >/dev/null
  for m in raw oneeuro desp kalman; do
    $hs filter --in "$d/noisy.csv" --out "$d/$m.csv" --method "$m" >/dev/null
    $hs filter --in "$d/noisy.csv" --out "$d/${m}_h50.csv" --method "$m" --horizon-ms 50 >/dev/null
  done
  echo "### \`$preset\` preset: denoising (H = 0)"
  $hs compare --truth "$out/clean.csv" --in raw="$d/raw.csv" --in oneeuro="$d/oneeuro.csv" \
    --in desp="$d/desp.csv" --in kalman="$d/kalman.csv"
  echo
  echo "### \`$preset\` preset: prediction (H = 50 ms)"
  $hs compare --truth "$out/clean.csv" --horizon-ms 50 --in raw="$d/raw_h50.csv" \
    --in oneeuro="$d/oneeuro_h50.csv" --in desp="$d/desp_h50.csv" --in kalman="$d/kalman_h50.csv"
  echo
done
