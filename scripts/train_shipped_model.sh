#!/usr/bin/env bash
# Trains a shipped model from scratch, the three steps models/MODEL.md describes:
#  causal (models/handsteady_xr26_causal.hsm, Multi-STGAE, about 70 min on a 2-core machine):
#   1. the base model on FPHA subjects 1-4, the full schedule (models/configs/causal_xr26.json;
#      until 2026-11-29 the shortened models/configs/shipped_causal_xr26.json);
#   2. its fine-tune on all recorded training data, BatchNorm statistics kept, taught the
#      base model's answers and motion ahead on FPHA, the newest frame weighted
#      (models/configs/finetune_distill_motion_newest_xr26.json; until 2026-11-30
#      models/configs/finetune_distill_motion_xr26.json, without loss.newest and loss.distill);
#  stgae (models/handsteady_xr26_stgae.hsm, denoise only, about 70 min):
#   1. the base model on the full schedule (models/configs/stgae_causal_long_xr26.json; until
#      2026-11-30 the shortened models/configs/stgae_causal_xr26.json);
#   2. its fine-tune on all recorded training data, BatchNorm statistics kept
#      (models/configs/stgae_finetune_fixed_norm_xr26.json);
#  dgn (models/handsteady_xr26_dgn.hsm, about 20 min):
#   1. the base model (models/configs/dgn_causal_xr26.json);
#   2. as for causal (models/configs/dgn_finetune_distill_motion_xr26.json);
#  3. the blend 0.3 x base + 0.7 x fine-tune (`handsteady blend`, docs/TRAINING.md).
# Step 2 starts from (and, for causal and dgn, is taught by) this run's base. Builds the CLI with
# training in build/release first.
# Usage: scripts/train_shipped_model.sh causal|stgae|dgn [OUT_DIR]   (default out/shipped_NAME;
#        the model is OUT_DIR/handsteady_xr26_NAME.hsm, beside base.hsm, finetune.hsm and their logs)
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
cd "$root"
name=${1:-}
case "$name" in
  causal|stgae|dgn) ;;
  *) echo "usage: $0 causal|stgae|dgn [OUT_DIR]" >&2; exit 2 ;;
esac
out=${2:-out/shipped_$name}
mkdir -p "$out"
out=$(cd "$out" && pwd)
# Inside the checkout, files are named from its root (the script runs there): the models'
# meta records the paths it is given, and a path of this machine would travel with them.
out=$(realpath --relative-base="$root" "$out")
ft_base=$(realpath --relative-to="$out" "$root/models/configs")
ft_train="\"init\": \"$out/base.hsm\", \"teacher\": \"$out/base.hsm\""
case "$name" in
  causal) base_cfg=causal_xr26.json; ft_cfg=finetune_distill_motion_newest_xr26.json ;;
  dgn) base_cfg=dgn_causal_xr26.json; ft_cfg=dgn_finetune_distill_motion_xr26.json ;;
  stgae) base_cfg=stgae_causal_long_xr26.json; ft_cfg=stgae_finetune_fixed_norm_xr26.json
         ft_train="\"init\": \"$out/base.hsm\"" ;;
esac
scripts/deps.sh all
cmake -S . -B build/release -DCMAKE_BUILD_TYPE=Release -DHS_BUILD_TRAINING=ON >/dev/null
cmake --build build/release -j"$(nproc)" --target handsteady
hs=build/release/cli/handsteady
$hs train --config "models/configs/$base_cfg" --out "$out/base.hsm" --threads 1 --quiet | tee "$out/base.log"
printf '{\n  "base": "%s",\n  "train": {%s}\n}\n' "$ft_base/$ft_cfg" "$ft_train" > "$out/finetune.json"
$hs train --config "$out/finetune.json" --out "$out/finetune.hsm" --threads 1 --quiet | tee "$out/finetune.log"
$hs blend --from "$out/base.hsm" --to "$out/finetune.hsm" --alpha 0.7 --out "$out/handsteady_xr26_$name.hsm"
echo "train_shipped_model: $out/handsteady_xr26_$name.hsm"
