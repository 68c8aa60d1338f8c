#!/bin/sh
# Installs what is missing, builds, and runs the whole test suite through ctest.
set -eu
cd "$(dirname "$0")/.."
./scripts/build.sh
cd build
ctest --output-on-failure --parallel "$(nproc)" --timeout 900
