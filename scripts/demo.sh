#!/usr/bin/env bash
# The main job: the AR handwriting demo, headless, end to end. Installs missing Debian
# packages, builds, then:
#   handsteady synth-handwriting  (text "ISMAR", Parkinsonian tremor + tracker noise)
#   -> replay runtime (XR_RUNTIME_JSON) -> Khronos loader -> HandSteady layer
#   -> handsteady_demo (OpenXR app; OSMesa offscreen, or a window with --window)
# once with the shipped Multi-STGAE model (the layer's default) and once with One Euro,
# leaving composite PNGs, frames, trajectory plots and a metrics summary in out/demo/.
# With ../shared/data present the hand pose comes from a real HoloLens 2 recording and
# the FPHA subject 5 table is computed too (HS_DEMO_FPHA=0 skips it). HS_DEMO_MODEL=FILE.hsm
# runs the layer, the app's prediction line and the FPHA table with that model instead of the shipped one.
# HS_DEMO_SEED=N draws the tremor and tracker noise with seed N instead of 1 (the spread of
# the demo's measures over noise draws).
# HS_DEMO_NET=dgn runs the network panel (and the FPHA table's network rows) with the layer's
# `dgn` method, the shipped DGN model, instead of Multi-STGAE (`stgae`).
# Usage: scripts/demo.sh [extra handsteady_demo options, e.g. --window]
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
cd "$root"
scripts/deps.sh build
cmake -S . -B build/release -DCMAKE_BUILD_TYPE=Release -DHS_BUILD_TESTS=OFF -DHS_BUILD_TRAINING=OFF >/dev/null
cmake --build build/release -j"$(nproc)" --target handsteady XrApiLayer_handsteady handsteady_replay_runtime handsteady_demo
b=build/release
hs=$b/cli/handsteady
out=$(realpath -m "${HS_DEMO_OUT:-out/demo}")  # absolute: the runtime and app get paths
rm -rf "$out" && mkdir -p "$out"
data=${HS_SHARED_DATA:-$root/../shared/data}

# 1. The writing hand: clean, noisy (tremor then tracker noise) and the font strokes.
pose=()
hl2=$data/hololens2/20240216_202836897.csv
if [ -f "$hl2" ]; then
  $hs import --format mrtk --in "$hl2" --out "$out/hl2_pose_source.csv" >/dev/null
  pose=(--pose-from "$out/hl2_pose_source.csv")
else
  echo "demo: $hl2 not found; the parametric hand writes"
fi
$hs synth-handwriting --text "ISMAR" --tremor parkinson --seed "${HS_DEMO_SEED:-1}" --out "$out/handwriting.csv" "${pose[@]}"

# 2. The OpenXR app through the real loader, the layer (its raw side channel gives the
#    raw panel) and the replay runtime at 90 Hz, answering the newest sample (no
#    runtime-side prediction), like a tracker without extrapolation.
export XR_RUNTIME_JSON=$root/$b/runtime_shim/handsteady_replay_runtime.json
# The build tree keeps the layer where an install does, <libdir>/handsteady (plugin/).
libdir=$(sed -n 's/^CMAKE_INSTALL_LIBDIR:PATH=//p' "$b/CMakeCache.txt")
export XR_API_LAYER_PATH=$root/$b/$libdir/handsteady
export HANDSTEADY_SHIM_TRACK=$out/handwriting.csv HANDSTEADY_SHIM_CLOCK=sim:11.111111 HANDSTEADY_SHIM_FUTURE=hold
# The simulated clock runs faster than real time: the layer's worker answers in lockstep,
# as it does in real time when it keeps up (docs/OPENXR_LAYER.md "Worker").
export HANDSTEADY_WORKER=${HANDSTEADY_WORKER:-lockstep}
unset XR_ENABLE_API_LAYERS HANDSTEADY_CONFIG HANDSTEADY_MODEL
if [ -n "${HS_DEMO_MODEL:-}" ]; then export HANDSTEADY_MODEL; HANDSTEADY_MODEL=$(realpath "$HS_DEMO_MODEL"); fi
# A frame PNG every second; with ffmpeg installed every 3rd frame, made into a 30 fps video.
every=90
if command -v ffmpeg >/dev/null; then every=3; fi
net=${HS_DEMO_NET:-stgae}
case "$net" in stgae|dgn) ;; *) echo "demo.sh: HS_DEMO_NET must be stgae or dgn, got '$net'" >&2; exit 2 ;; esac
for method in "$net" oneeuro; do
  echo "== handsteady_demo, layer method $method (denoise) =="
  HANDSTEADY_MODE=denoise HANDSTEADY_METHOD=$method $b/sample_app/app/handsteady_demo --out "$out/$method" \
    --strokes "$out/handwriting_strokes.csv" --truth "$out/handwriting_clean.csv" --frames-every $every "$@"
  if [ $every = 3 ]; then
    ffmpeg -loglevel error -y -framerate 30 -pattern_type glob -i "$out/$method/frames/frame_*.png" \
      -vf "pad=ceil(iw/2)*2:ceil(ih/2)*2,format=yuv420p" "$out/$method/demo.mp4" || echo "demo: ffmpeg failed; no video"
  fi
done
{
  echo "# Handwriting demo: \"ISMAR\", Parkinsonian tremor + tracker noise, replayed at 90 Hz"
  echo
  for method in "$net" oneeuro; do
    echo "## HandSteady layer with \`$method\` (denoise)"
    echo
    cat "$out/$method/summary.md"
    echo
  done
} > "$out/summary.md"

if [ -d "$data/fpha/Subject_5" ] && [ "${HS_DEMO_FPHA:-1}" != 0 ]; then
  echo "== FPHA subject 5 table (README) =="
  HS_FPHA_NET=$net scripts/fpha_table.sh "$hs" "$data" "$out/fpha" | tee "$out/fpha_table.md"
fi
echo "demo: outputs in $out: summary.md, {$net,oneeuro}/composite.png, {$net,oneeuro}/index_tip_plot.png, frames"
