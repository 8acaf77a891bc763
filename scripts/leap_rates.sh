#!/usr/bin/env bash
# The network against raw on free-air motion at any input rate (docs/STGAE.md "Streaming at
# any rate"): the Leap tuning subject's first takes (../shared/data/leap/guinevere/s03_*-1.csv,
# 23 gestures), each resampled to RATE on a jittering clock (`handsteady resample --jitter
# 0.2 --seed 3`), corrupted (`handsteady corrupt --seed 5`, the preset `tracker` unless
# corrupt options are given after --), filtered by the shipped Multi-STGAE (or
# HANDSTEADY_MODEL) and scored against the resampled clean take (`handsteady eval`). Prints
# per rate the mean MPJPE (mm) over the takes of raw and of the network, and their ratio
# (network / raw: under 1 the network helps). About 1 min per rate on the 2-core machine.
# Usage: scripts/leap_rates.sh HANDSTEADY_BINARY SHARED_DATA_DIR OUT_DIR RATE... [-- CORRUPT_OPTIONS...]
set -euo pipefail
hs=$1; data=$2; out=$3; shift 3
rates=()
while [ $# -gt 0 ] && [ "$1" != "--" ]; do rates+=("$1"); shift; done
[ $# -gt 0 ] && shift
corrupt=("$@")
[ ${#corrupt[@]} -gt 0 ] || corrupt=(--preset tracker)
[ ${#rates[@]} -gt 0 ] || { echo "usage: $0 HANDSTEADY_BINARY SHARED_DATA_DIR OUT_DIR RATE... [-- CORRUPT_OPTIONS...]" >&2; exit 2; }
takes=("$data"/leap/guinevere/s03_*-1.csv)
[ -f "${takes[0]}" ] || { echo "no Leap takes under $data/leap/guinevere" >&2; exit 1; }
model=()
if [ -n "${HANDSTEADY_MODEL:-}" ]; then model=(--model "$HANDSTEADY_MODEL"); fi
mkdir -p "$out"
mpjpe() {  # truth estimate
  "$hs" eval --truth "$1" --in "$2" --json | python3 -c 'import json, sys; print(json.load(sys.stdin)["mpjpe_mm"])'
}
echo "| rate Hz | takes | raw MPJPE | network MPJPE | network / raw |"
echo "|---:|---:|---:|---:|---:|"
for rate in "${rates[@]}"; do
  sum_raw=0; sum_net=0; n=0
  for f in "${takes[@]}"; do
    b=$out/$(basename "$f" .csv)-$rate
    "$hs" resample --in "$f" --out "$b-clean.csv" --rate "$rate" --jitter 0.2 --seed 3 >/dev/null
    "$hs" corrupt --in "$b-clean.csv" --out "$b-noisy.csv" "${corrupt[@]}" --seed 5 >/dev/null
    "$hs" filter --in "$b-noisy.csv" --out "$b-net.csv" --method stgae "${model[@]}" >/dev/null
    sum_raw=$(python3 -c "print($sum_raw + $(mpjpe "$b-clean.csv" "$b-noisy.csv"))")
    sum_net=$(python3 -c "print($sum_net + $(mpjpe "$b-clean.csv" "$b-net.csv"))")
    n=$((n + 1))
  done
  python3 -c "print('| $rate | $n | %.3f | %.3f | %.3f |' % ($sum_raw / $n, $sum_net / $n, $sum_net / $sum_raw))"
done
