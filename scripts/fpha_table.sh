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
# HS_FPHA_TREMOR=1 adds `stgae-tremor`: the network behind the palm fit and the tremor
# canceller (opt-in; docs/FILTERS.md "Tremor canceller").
# HS_FPHA_NOBONEFIT=1 adds `stgae-nobonefit`: the network without the bone fit behind it
# (docs/FILTERS.md "Bone fit"; these were the `stgae` rows before 2026-12-03).
# HS_FPHA_NOGUARD=1 adds `stgae-noguard`: the network without its oscillation guard
# (docs/STGAE.md "Oscillation guard").
# HS_FPHA_NET=dgn runs the network rows with `--method dgn` (label `dgn`, the extra rows
# `dgn-unbounded` and so on) and the shipped DGN model unless HANDSTEADY_MODEL names another.
# Usage: scripts/fpha_table.sh HANDSTEADY_BINARY SHARED_DATA_DIR OUT_DIR
set -euo pipefail
hs=$1; data=$2; out=$3
mkdir -p "$out"
$hs import --format fpha --in "$data/fpha/Subject_5" --out "$out/clean.csv" >/dev/null
methods=(raw oneeuro desp kalman)
net=${HS_FPHA_NET:-stgae}
case "$net" in stgae|dgn) ;; *) echo "fpha_table.sh: HS_FPHA_NET must be stgae or dgn, got '$net'" >&2; exit 2 ;; esac
# The CLI finds the shipped model itself; HANDSTEADY_MODEL names another for every network row.
model=()
if [ -n "${HANDSTEADY_MODEL:-}" ]; then model=(--model "$HANDSTEADY_MODEL"); fi
has_net=0
if probe=$($hs filter --method "$net" "${model[@]}" --in "$out/clean.csv" --out "$out/probe.csv" 2>&1 >/dev/null); then
  methods+=("$net"); has_net=1
elif [ ${#model[@]} -gt 0 ]; then
  echo "fpha_table.sh: HANDSTEADY_MODEL=$HANDSTEADY_MODEL cannot be run: $probe" >&2
  exit 2
else
  echo "(no $net model found: its rows are left out)"
fi
# extra NAME OPTION...: a network row ($net) with these `handsteady filter` options (the
# model among them).
extra() {
  local m=$1; shift
  $hs filter --in "$d/noisy.csv" --out "$d/$m.csv" --method "$net" "$@" >/dev/null
  $hs filter --in "$d/noisy.csv" --out "$d/${m}_h50.csv" --method "$net" "$@" --horizon-ms 50 >/dev/null
  den+=(--in "$m=$d/$m.csv"); pre+=(--in "$m=$d/${m}_h50.csv")
}
for preset in tracker paper tremor; do
  d="$out/$preset"
  mkdir -p "$d"
  $hs corrupt --in "$out/clean.csv" --out "$d/noisy.csv" --preset "$preset" --seed 1 >/dev/null
  den=(); pre=()
  for m in "${methods[@]}"; do
    opt=(); if [ "$m" = "$net" ]; then opt=("${model[@]}"); fi
    $hs filter --in "$d/noisy.csv" --out "$d/$m.csv" --method "$m" "${opt[@]}" >/dev/null
    $hs filter --in "$d/noisy.csv" --out "$d/${m}_h50.csv" --method "$m" "${opt[@]}" --horizon-ms 50 >/dev/null
    den+=(--in "$m=$d/$m.csv"); pre+=(--in "$m=$d/${m}_h50.csv")
  done
  [ "${HS_FPHA_UNBOUNDED:-0}" = 1 ] && [ $has_net = 1 ] && extra "$net-unbounded" "${model[@]}" --unbounded
  [ "${HS_FPHA_NOPALMFIT:-0}" = 1 ] && [ $has_net = 1 ] && extra "$net-nopalmfit" "${model[@]}" --no-palm-fit
  [ "${HS_FPHA_SMOOTHED:-0}" = 1 ] && [ $has_net = 1 ] && extra "$net-smoothed" "${model[@]}" --smooth-predictions
  [ "${HS_FPHA_NOGUARD:-0}" = 1 ] && [ $has_net = 1 ] && extra "$net-noguard" "${model[@]}" --no-guard
  [ "${HS_FPHA_NOBONEFIT:-0}" = 1 ] && [ $has_net = 1 ] && extra "$net-nobonefit" "${model[@]}" --no-bone-fit
  [ "${HS_FPHA_TREMOR:-0}" = 1 ] && [ $has_net = 1 ] && extra "$net-tremor" "${model[@]}" --tremor-cancel
  [ -n "${HS_CENTRED_MODEL:-}" ] && extra "$net-centred-window" --offline --model "$HS_CENTRED_MODEL"
  echo "#### \`$preset\` preset: denoising (H = 0)"
  $hs compare --truth "$out/clean.csv" "${den[@]}"
  echo
  echo "#### \`$preset\` preset: prediction (H = 50 ms)"
  $hs compare --truth "$out/clean.csv" --horizon-ms 50 "${pre[@]}"
  echo
done
