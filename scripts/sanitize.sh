#!/bin/sh
# Builds the core tests and the command-line tool with AddressSanitizer and UndefinedBehaviorSanitizer
# into ./build-sanitize and runs them: the core tests, then `piperun reconstruct` and every export on
# the real scans (../shared/data/real). Any report fails the run. Not part of the test suite (the
# build and run take about 20 minutes on two cores); run it after changes to memory handling.
set -eu
cd "$(dirname "$0")/.."
./scripts/install-deps.sh
flags="-fsanitize=address,undefined -fno-sanitize-recover=undefined -fno-omit-frame-pointer"
cmake -S . -B build-sanitize -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo -DCMAKE_CXX_FLAGS="$flags" \
  -DCMAKE_EXE_LINKER_FLAGS="$flags" >/dev/null
cmake --build build-sanitize --parallel "$(nproc)" --target core_tests piperun
export ASAN_OPTIONS=detect_leaks=1 UBSAN_OPTIONS=print_stacktrace=1
build-sanitize/tests/core_tests --gtest_brief=1
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
data=../shared/data/real
for scan in "$data/pumpAVisualReferenceImage.e57" "$data/table_scene_mug_stereo_textured.pcd"; do
  build-sanitize/app/piperun -q reconstruct "$scan" -o "$work/net.json" --export obj:"$work/net.obj" \
    --export ply:"$work/net.ply" --export csv:"$work/net.csv" --export dxf:"$work/net.dxf" --export pcf:"$work/net.pcf" \
    --export ifc:"$work/net.ifc"
  build-sanitize/app/piperun info "$work/net.json" --runs >/dev/null
done
echo "sanitize: clean"
