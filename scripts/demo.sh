#!/bin/sh
# The main job on a generated example: installs what is missing, builds, generates a small plant
# scan with its ground truth, reads it back, reconstructs its pipe network, exports it and
# evaluates it.
set -eu
cd "$(dirname "$0")/.."
./scripts/build.sh
mkdir -p example
echo "== generate a small scanned plant scene (seed 1) with its ground truth"
./build/app/piperun generate --preset small --seed 1 -o example/scene.ply --truth example/truth.json
echo "== read it back"
./build/app/piperun info example/scene.ply
echo "== reconstruct its pipe network (pipes, elbows, tees, runs), export it and evaluate it against the truth"
./build/app/piperun reconstruct example/scene.ply -o example/network.json --truth example/truth.json \
  --export obj:example/network.obj --export pcf:example/network.pcf --export ifc:example/network.ifc
echo "== the metric's sanity check: the truth against itself (F1 = 1)"
./build/app/piperun eval example/truth.json example/truth.json
echo "== outputs: example/scene.ply, example/truth.json, example/network.json, example/network.obj, example/network.pcf, example/network.ifc"
if [ -n "${DISPLAY:-}" ] && xdpyinfo >/dev/null 2>&1; then
  echo "== PipeRun Studio on the example (H lists the keys; docs/STUDIO.md)"
  ./build/app/piperun-studio example/scene.ply
else
  echo "== no display: PipeRun Studio's window drawn headless"
  ./build/app/piperun-render example/scene.ply -o example/studio.png
  echo "== screenshot: example/studio.png (piperun-studio example/scene.ply opens the window on a display)"
fi
