#!/usr/bin/env bash
# Rewrites the render-test baselines (tests/baselines/*.png and *.txt) from the current build.
# Usage: scripts/update-baselines.sh [NAME-REGEX]   e.g. scripts/update-baselines.sh sphere
# Look at every changed PNG and text before committing them (git diff --stat tests/baselines).
set -euo pipefail
cd "$(dirname "$0")/.."
build=${BUILD_DIR:-build}
ninja -C "$build" -j2 piperun piperun-render compare-images
PIPERUN_UPDATE_BASELINES=1 ctest --test-dir "$build" -L render -R "render\.(generate-scene|${1:-.*})" --output-on-failure
git status --short tests/baselines
