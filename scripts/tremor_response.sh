#!/usr/bin/env bash
# How a filter answers an oscillation of one frequency (models/MODEL.md "What the networks do
# to an oscillation of the whole hand"): a clean hand (FPHA subject 5 when ../shared/data has
# it, else `handsteady synth`, 120 s) gets a 3 mm oscillation at f ± 0.2 Hz (the `tremor`
# preset's oscillator, `handsteady corrupt`), either of the whole hand (every joint moved
# together: nothing in one row tells it from motion) or of the fingers alone (the hand still,
# each finger its own), at the model's 30 Hz and at 90 Hz. Each filter's MPJPE (mm) against
# the clean hand, and in brackets its ratio to raw's: above 1 the filter made the oscillation
# larger. Columns: raw, the shipped Multi-STGAE, then each LABEL=MODEL.hsm given
# (`handsteady filter --method stgae --model`; METHOD=dgn for DGN models). Seeded; the
# filters of one input run side by side: about 3 min per model on the 2-core machine with
# the FPHA hand, seconds with the synthetic one. HS_TREMOR_NOGUARD=1 adds a column
# `shipped-noguard`: the shipped model without its oscillation guard (`--no-guard`; docs/STGAE.md
# "Oscillation guard").
# Usage: scripts/tremor_response.sh HANDSTEADY_BINARY OUT_DIR [LABEL=MODEL.hsm ...]
set -euo pipefail
hs=$1; out=$2; shift 2
method=${METHOD:-stgae}
mkdir -p "$out"
data=${HS_SHARED_DATA:-$(cd "$(dirname "$0")/.." && pwd)/../shared/data}
if [ -d "$data/fpha/Subject_5" ]; then
  $hs import --format fpha --in "$data/fpha/Subject_5" --out "$out/clean30.csv" >/dev/null
  hand="FPHA subject 5"
else
  $hs synth --out "$out/clean30.csv" --seconds 120 --rate 30 --seed 1 >/dev/null
  hand="synthetic hand (no ../shared/data)"
fi
$hs resample --in "$out/clean30.csv" --out "$out/clean90.csv" --rate 90 >/dev/null
freqs=(2 3 4 5 6 8 10 12)
labels=("raw" "shipped")
noguard=${HS_TREMOR_NOGUARD:-0}
[ "$noguard" = 1 ] && labels+=("shipped-noguard")
for m in "$@"; do labels+=("${m%%=*}"); done
mpjpe() {  # truth estimate
  $hs eval --truth "$1" --in "$2" | awk '/^MPJPE/{print $2}'
}
echo "Hand: $hand. MPJPE mm (× raw's) against the hand without the oscillation."
for kind in hand fingers; do
  if [ $kind = hand ]; then amps=(--tremor-hand-mm 3 --tremor-finger-mm 0); else amps=(--tremor-hand-mm 0 --tremor-finger-mm 3); fi
  for rate in 30 90; do
    echo
    echo "**3 mm oscillation of the $kind, $rate Hz**"
    echo
    printf "| Hz |"; for l in "${labels[@]}"; do printf " %s |" "$l"; done; echo
    printf "|---:|"; for l in "${labels[@]}"; do printf -- "---:|"; done; echo
    for f in "${freqs[@]}"; do
      lo=$(awk -v f="$f" 'BEGIN{print f - 0.2}'); hi=$(awk -v f="$f" 'BEGIN{print f + 0.2}')
      noisy=$out/${kind}_${rate}_$f.csv
      $hs corrupt --in "$out/clean$rate.csv" --out "$noisy" --preset tremor --tremor-min-hz "$lo" \
        --tremor-max-hz "$hi" "${amps[@]}" --seed 3 >/dev/null
      # The filters run side by side (one thread each); a failed one stops the script.
      $hs filter --method "$method" --in "$noisy" --out "$out/shipped.csv" >/dev/null &
      pids=($!)
      outs=("$out/shipped.csv")
      if [ "$noguard" = 1 ]; then
        $hs filter --method "$method" --no-guard --in "$noisy" --out "$out/noguard.csv" >/dev/null &
        pids+=($!)
        outs+=("$out/noguard.csv")
      fi
      i=0
      for m in "$@"; do
        $hs filter --method "$method" --model "${m#*=}" --in "$noisy" --out "$out/m$i.csv" >/dev/null &
        pids+=($!)
        outs+=("$out/m$i.csv"); i=$((i + 1))
      done
      for p in "${pids[@]}"; do wait "$p"; done
      raw=$(mpjpe "$out/clean$rate.csv" "$noisy")
      printf "| %s | %.2f (1.00) |" "$f" "$raw"
      for o in "${outs[@]}"; do
        v=$(mpjpe "$out/clean$rate.csv" "$o")
        printf " %.2f (%.2f) |" "$v" "$(awk -v a="$v" -v b="$raw" 'BEGIN{print a / b}')"
      done
      echo
    done
  done
done
