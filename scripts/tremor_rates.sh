#!/usr/bin/env bash
# Which tremor a model at the tracker's own rate handles (models/MODEL.md "What keeps the
# 90 Hz model from the demo"): synthetic handwriting (the demo's text, hand pose from the
# HoloLens 2 recording when ../shared/data has it) at 90 Hz with Parkinsonian (4-6 Hz),
# physiological (8-12 Hz) or no tremor under the tracker preset, and the same Parkinsonian
# hand written at 60 Hz and resampled to 90 Hz (a runtime interpolating a slower tracker).
# Each is filtered by the shipped model alone and paired with each rate model given
# (`handsteady filter --rate-model`), then scored against the clean hand (`handsteady eval`:
# MPJPE mm, jitter = RMS second difference mm/frame^2, lag ms). Seeded; seconds to run.
# Usage: scripts/tremor_rates.sh HANDSTEADY_BINARY OUT_DIR [RATE_MODEL.hsm ...]
set -euo pipefail
hs=$1; out=$2; shift 2
mkdir -p "$out"
data=${HS_SHARED_DATA:-$(cd "$(dirname "$0")/.." && pwd)/../shared/data}
pose=()
hl2=$data/hololens2/20240216_202836897.csv
if [ -f "$hl2" ]; then
  $hs import --format mrtk --in "$hl2" --out "$out/pose_source.csv" >/dev/null
  pose=(--pose-from "$out/pose_source.csv")
fi
write() {  # name tremor rate
  $hs synth-handwriting --text ISMAR --tremor "$2" --seed 1 --rate "$3" --out "$out/$1.csv" "${pose[@]}" >/dev/null
}
write parkinson parkinson 90
write physiological physiological 90
write none none 90
write parkinson60 parkinson 60
$hs resample --in "$out/parkinson60.csv" --out "$out/parkinson60to90.csv" --rate 90 >/dev/null
$hs resample --in "$out/parkinson60_clean.csv" --out "$out/parkinson60to90_clean.csv" --rate 90 >/dev/null
score() {  # label input truth
  $hs eval --truth "$3" --in "$2" | awk -v l="$1" '/^MPJPE/{m=$2} /^jitter/{j=$2} /^lag/{g=$2} END{printf "| %s | %s | %s | %s |\n", l, m, j, g}'
}
echo "| input, filter | MPJPE mm | jitter mm/frame² | lag ms |"
echo "|---|---:|---:|---:|"
for set in parkinson parkinson60to90 physiological none; do
  truth=$out/${set}_clean.csv
  score "$set, raw" "$out/$set.csv" "$truth"
  $hs filter --method stgae --in "$out/$set.csv" --out "$out/${set}_shipped.csv"
  score "$set, shipped" "$out/${set}_shipped.csv" "$truth"
  for m in "$@"; do
    name=$(basename "$m" .hsm)
    $hs filter --method stgae --rate-model "$m" --in "$out/$set.csv" --out "$out/${set}_$name.csv"
    score "$set, + $name" "$out/${set}_$name.csv" "$truth"
  done
done
