#!/usr/bin/env bash
# The FPHA subject 5 comparison (README "Results"): import -> corrupt (tracker, seed 1)
# -> classical filters -> compare, denoising (H = 0) and prediction (H = 50 ms).
# Usage: scripts/fpha_table.sh HANDSTEADY_BINARY SHARED_DATA_DIR OUT_DIR
set -euo pipefail
hs=$1; data=$2; out=$3
mkdir -p "$out"
$hs import --format fpha --in "$data/fpha/Subject_5" --out "$out/clean.csv"
$hs corrupt --in "$out/clean.csv" --out "$out/noisy.csv" --preset tracker --seed 1
for m in raw oneeuro desp kalman; do
  $hs filter --in "$out/noisy.csv" --out "$out/$m.csv" --method "$m"
  $hs filter --in "$out/noisy.csv" --out "$out/${m}_h50.csv" --method "$m" --horizon-ms 50
done
echo "### Denoising (H = 0)"
$hs compare --truth "$out/clean.csv" --in raw="$out/raw.csv" --in oneeuro="$out/oneeuro.csv" \
  --in desp="$out/desp.csv" --in kalman="$out/kalman.csv"
echo
echo "### Prediction (H = 50 ms)"
$hs compare --truth "$out/clean.csv" --horizon-ms 50 --in raw="$out/raw_h50.csv" \
  --in oneeuro="$out/oneeuro_h50.csv" --in desp="$out/desp_h50.csv" --in kalman="$out/kalman_h50.csv"
