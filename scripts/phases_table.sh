#!/usr/bin/env bash
# The interleaved-streams table of docs/STGAE.md: the shipped 30 Hz model over 90 Hz
# tracks with one stream (--phases 1) and with the default (3 streams at 90 Hz).
# Tracks: `handsteady synth --rate 90` (clean, + tracker, + paper; seed 3) and the demo's
# "ISMAR" handwriting at 90 Hz (clean; Parkinsonian tremor + tracker noise, seed 1), the
# hand pose from the HoloLens 2 recording when SHARED_DATA_DIR has it.
# Usage: scripts/phases_table.sh HANDSTEADY_BINARY SHARED_DATA_DIR OUT_DIR
set -euo pipefail
hs=$1; data=$2; out=$3
mkdir -p "$out"
$hs synth --out "$out/synth.csv" --rate 90 --seconds 20 >/dev/null
$hs corrupt --in "$out/synth.csv" --out "$out/synth_tracker.csv" --preset tracker --seed 3 >/dev/null
$hs corrupt --in "$out/synth.csv" --out "$out/synth_paper.csv" --preset paper --seed 3 >/dev/null
pose=()
hl2=$data/hololens2/20240216_202836897.csv
if [ -f "$hl2" ]; then
  $hs import --format mrtk --in "$hl2" --out "$out/hl2.csv" >/dev/null
  pose=(--pose-from "$out/hl2.csv")
fi
$hs synth-handwriting --text ISMAR --tremor none --noise none --rate 90 --out "$out/hw_none.csv" "${pose[@]}" >/dev/null
$hs synth-handwriting --text ISMAR --tremor parkinson --seed 1 --rate 90 --out "$out/hw_park.csv" "${pose[@]}" >/dev/null
score() {  # truth estimate -> "MPJPE / acceleration error"
  $hs eval --truth "$1" --in "$2" --json |
    python3 -c 'import json,sys; d=json.load(sys.stdin); print("%.2f / %.2f" % (d["mpjpe_mm"], d["accel_error_mm"]))'
}
row() {  # label truth noisy
  $hs filter --in "$3" --out "$out/one.csv" --method stgae --phases 1 >/dev/null
  $hs filter --in "$3" --out "$out/three.csv" --method stgae >/dev/null
  echo "| $1 | $(score "$2" "$3") | $(score "$2" "$out/one.csv") | $(score "$2" "$out/three.csv") |"
}
echo "| track (90 Hz) | raw | 1 stream | default (3 streams) |"
echo "|---|---:|---:|---:|"
row "synthetic hand, clean" "$out/synth.csv" "$out/synth.csv"
row "synthetic hand + tracker" "$out/synth.csv" "$out/synth_tracker.csv"
row "synthetic hand + paper" "$out/synth.csv" "$out/synth_paper.csv"
row "handwriting, clean" "$out/hw_none_clean.csv" "$out/hw_none.csv"
row "handwriting + tremor + tracker" "$out/hw_park_clean.csv" "$out/hw_park.csv"
