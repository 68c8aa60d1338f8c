#!/bin/sh
# The main job on a generated example: installs what is missing, builds, generates a small plant
# scene with its ground truth, reads it back and prints its summary, then evaluates.
set -eu
cd "$(dirname "$0")/.."
./scripts/build.sh
mkdir -p example
echo "== generate a small scanned plant scene (seed 1)"
./build/app/piperun generate --preset small --seed 1 -o example/scene.ply --truth example/truth.json
echo "== read it back"
./build/app/piperun info example/scene.ply
./build/app/piperun info example/truth.json
echo "== evaluate the ground truth against itself (the metric's sanity check: F1 = 1)"
./build/app/piperun eval example/truth.json example/truth.json
