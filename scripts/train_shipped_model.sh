#!/usr/bin/env bash
# Trains the shipped Multi-STGAE model (models/handsteady_xr26_causal.hsm) from scratch,
# the three steps models/MODEL.md describes (about 35 min on a 2-core machine):
#  1. the base model on FPHA subjects 1-4 (models/configs/shipped_causal_xr26.json);
#  2. its fine-tune on all recorded training data, BatchNorm statistics kept, taught the
#     base model's motion ahead on FPHA (models/configs/finetune_distill_motion_xr26.json,
#     here with this run's base as init and teacher);
#  3. the blend 0.3 x base + 0.7 x fine-tune (`handsteady blend`, docs/TRAINING.md).
# Builds the CLI with training in build/release first.
# Usage: scripts/train_shipped_model.sh [OUT_DIR]   (default out/shipped; the model is
#        OUT_DIR/handsteady_xr26_causal.hsm, beside base.hsm, finetune.hsm and their logs)
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
cd "$root"
out=${1:-out/shipped}
mkdir -p "$out"
out=$(cd "$out" && pwd)
scripts/deps.sh all
cmake -S . -B build/release -DCMAKE_BUILD_TYPE=Release -DHS_BUILD_TRAINING=ON >/dev/null
cmake --build build/release -j"$(nproc)" --target handsteady
hs=build/release/cli/handsteady
$hs train --config models/configs/shipped_causal_xr26.json --out "$out/base.hsm" --threads 1 --quiet | tee "$out/base.log"
cat > "$out/finetune.json" <<JSON
{
  "base": "$root/models/configs/finetune_distill_motion_xr26.json",
  "train": {"init": "$out/base.hsm", "teacher": "$out/base.hsm"}
}
JSON
$hs train --config "$out/finetune.json" --out "$out/finetune.hsm" --threads 1 --quiet | tee "$out/finetune.log"
$hs blend --from "$out/base.hsm" --to "$out/finetune.hsm" --alpha 0.7 --out "$out/handsteady_xr26_causal.hsm"
echo "train_shipped_model: $out/handsteady_xr26_causal.hsm"
