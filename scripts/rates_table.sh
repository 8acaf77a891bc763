#!/usr/bin/env bash
# The streaming adapter at rates the benchmark grid lacks (docs/STGAE.md "Irregular
# times"): ManipNet mug3 and FPHA subject 5, each replayed on a jittering clock (times
# (k + u) / rate, u uniform in +-20 % of a period, seed 5: `handsteady resample --jitter`),
# `tracker` noise (seed 2), the shipped Multi-STGAE (or HANDSTEADY_MODEL) at H = 0 and
# 50 ms. Prints MPJPE (mm) and jitter (second difference per row, mm) per set and rate,
# and raw's MPJPE.
# Usage: scripts/rates_table.sh HANDSTEADY_BINARY SHARED_DATA_DIR OUT_DIR [RATE ...]
# (rates default: 30 44 45 60 75)
set -euo pipefail
hs=$1; data=$2; out=$3; shift 3
rates=("$@")
[ ${#rates[@]} -gt 0 ] || rates=(30 44 45 60 75)
mkdir -p "$out"
model=()
if [ -n "${HANDSTEADY_MODEL:-}" ]; then model=(--model "$HANDSTEADY_MODEL"); fi
"$hs" import --format bvh --in "$data/manipnet/mug3_rightHand.bvh" --out "$out/manipnet.csv" >/dev/null
"$hs" import --format fpha --in "$data/fpha/Subject_5" --out "$out/fpha.csv" >/dev/null
metric() {  # truth estimate horizon_ms -> "MPJPE jitter"
  "$hs" eval --truth "$1" --in "$2" --horizon-ms "$3" --json |
    python3 -c 'import json, sys; j = json.load(sys.stdin); print("%.2f %.2f" % (j["mpjpe_mm"], j["jitter_mm"]))'
}
echo "| set | rate Hz | raw MPJPE | H = 0 MPJPE | H = 0 jitter | 50 ms MPJPE | 50 ms jitter |"
echo "|---|---:|---:|---:|---:|---:|---:|"
for set in manipnet fpha; do
  for rate in "${rates[@]}"; do
    b=$out/$set-$rate
    "$hs" resample --in "$out/$set.csv" --out "$b-clean.csv" --rate "$rate" --jitter 0.2 --seed 5 >/dev/null
    "$hs" corrupt --in "$b-clean.csv" --out "$b-noisy.csv" --preset tracker --seed 2 >/dev/null
    for h in 0 50; do
      "$hs" filter --in "$b-noisy.csv" --out "$b-h$h.csv" --method stgae "${model[@]}" --horizon-ms "$h" >/dev/null
    done
    read -r raw _ < <(metric "$b-clean.csv" "$b-noisy.csv" 0)
    read -r m0 j0 < <(metric "$b-clean.csv" "$b-h0.csv" 0)
    read -r m50 j50 < <(metric "$b-clean.csv" "$b-h50.csv" 50)
    echo "| $set | $rate | $raw | $m0 | $j0 | $m50 | $j50 |"
  done
done
