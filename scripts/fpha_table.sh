#!/usr/bin/env bash
# The FPHA subject 5 comparison (README "Results"): import -> corrupt (seed 1) ->
# filters -> compare, denoising (H = 0) and prediction (H = 50 ms), for the `tracker`,
# `paper` and `tremor` presets. The Multi-STGAE rows use the shipped model
# (models/handsteady_xr26_causal.hsm, or HANDSTEADY_MODEL) and are left out without one.
# HS_CENTRED_MODEL=FILE adds a column for a centred model in window mode (`--offline`:
# denoising from each frame's centred window, which sees (T-1)/2 future frames; prediction
# from the window ending at each row, the paper's protocol).
# HS_FPHA_UNBOUNDED=1 adds `stgae-unbounded`: the network without its trust region
# (docs/STGAE.md "Trust region").
# HS_FPHA_NOPALMFIT=1 adds `stgae-nopalmfit`: the network without the palm fit in front of
# it (docs/FILTERS.md "Palm fit"; these were the `stgae` rows before 2026-11-24).
# HS_FPHA_SMOOTHED=1 adds `stgae-smoothed`: the network's predictions smoothed over time
# (opt-in; docs/STGAE.md "Prediction smoothing").
# Usage: scripts/fpha_table.sh HANDSTEADY_BINARY SHARED_DATA_DIR OUT_DIR
set -euo pipefail
hs=$1; data=$2; out=$3
mkdir -p "$out"
$hs import --format fpha --in "$data/fpha/Subject_5" --out "$out/clean.csv" >/dev/null
methods=(raw oneeuro desp kalman)
if $hs filter --method stgae --in "$out/clean.csv" --out "$out/probe.csv" >/dev/null 2>&1; then
  methods+=(stgae)
else
  echo "(no Multi-STGAE model found: its rows are left out)"
fi
for preset in tracker paper tremor; do
  d="$out/$preset"
  mkdir -p "$d"
  $hs corrupt --in "$out/clean.csv" --out "$d/noisy.csv" --preset "$preset" --seed 1 >/dev/null
  den=(); pre=()
  for m in "${methods[@]}"; do
    $hs filter --in "$d/noisy.csv" --out "$d/$m.csv" --method "$m" >/dev/null
    $hs filter --in "$d/noisy.csv" --out "$d/${m}_h50.csv" --method "$m" --horizon-ms 50 >/dev/null
    den+=(--in "$m=$d/$m.csv"); pre+=(--in "$m=$d/${m}_h50.csv")
  done
  if [ "${HS_FPHA_UNBOUNDED:-0}" = 1 ] && [[ " ${methods[*]} " == *" stgae "* ]]; then
    m=stgae-unbounded
    $hs filter --in "$d/noisy.csv" --out "$d/$m.csv" --method stgae --unbounded >/dev/null
    $hs filter --in "$d/noisy.csv" --out "$d/${m}_h50.csv" --method stgae --unbounded --horizon-ms 50 >/dev/null
    den+=(--in "$m=$d/$m.csv"); pre+=(--in "$m=$d/${m}_h50.csv")
  fi
  if [ "${HS_FPHA_NOPALMFIT:-0}" = 1 ] && [[ " ${methods[*]} " == *" stgae "* ]]; then
    m=stgae-nopalmfit
    $hs filter --in "$d/noisy.csv" --out "$d/$m.csv" --method stgae --no-palm-fit >/dev/null
    $hs filter --in "$d/noisy.csv" --out "$d/${m}_h50.csv" --method stgae --no-palm-fit --horizon-ms 50 >/dev/null
    den+=(--in "$m=$d/$m.csv"); pre+=(--in "$m=$d/${m}_h50.csv")
  fi
  if [ "${HS_FPHA_SMOOTHED:-0}" = 1 ] && [[ " ${methods[*]} " == *" stgae "* ]]; then
    m=stgae-smoothed
    $hs filter --in "$d/noisy.csv" --out "$d/$m.csv" --method stgae --smooth-predictions >/dev/null
    $hs filter --in "$d/noisy.csv" --out "$d/${m}_h50.csv" --method stgae --smooth-predictions --horizon-ms 50 >/dev/null
    den+=(--in "$m=$d/$m.csv"); pre+=(--in "$m=$d/${m}_h50.csv")
  fi
  if [ -n "${HS_CENTRED_MODEL:-}" ]; then
    m=stgae-centred-window
    $hs filter --in "$d/noisy.csv" --out "$d/$m.csv" --method stgae --offline --model "$HS_CENTRED_MODEL" >/dev/null
    $hs filter --in "$d/noisy.csv" --out "$d/${m}_h50.csv" --method stgae --offline --horizon-ms 50 \
      --model "$HS_CENTRED_MODEL" >/dev/null
    den+=(--in "$m=$d/$m.csv"); pre+=(--in "$m=$d/${m}_h50.csv")
  fi
  echo "#### \`$preset\` preset: denoising (H = 0)"
  $hs compare --truth "$out/clean.csv" "${den[@]}"
  echo
  echo "#### \`$preset\` preset: prediction (H = 50 ms)"
  $hs compare --truth "$out/clean.csv" --horizon-ms 50 "${pre[@]}"
  echo
done
