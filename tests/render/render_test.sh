#!/usr/bin/env bash
# One render test: piperun-render draws INPUT after SCRIPT with no X display; the image is compared
# with tests/baselines/NAME.png. With PIPERUN_UPDATE_BASELINES=1 the output replaces the baseline.
# Usage: render_test.sh RENDER COMPARE NAME INPUT SCRIPT VIEW SIZE THRESHOLD BASELINE_DIR OUTPUT_DIR
set -euo pipefail
render=$1 compare=$2 name=$3 input=$4 script=$5 view=$6 size=$7 threshold=$8 baselines=$9 outputs=${10}

mkdir -p "$outputs"
output="$outputs/$name.png"
diff="$outputs/$name.diff.png"
rm -f "$output" "$diff"
env -u DISPLAY -u WAYLAND_DISPLAY "$render" "$input" --script "$script" --view "$view" --size "$size" -o "$output"

baseline="$baselines/$name.png"
if [[ "${PIPERUN_UPDATE_BASELINES:-0}" == 1 ]]; then
  cp "$output" "$baseline"
  echo "updated $baseline"
  exit 0
fi
if [[ ! -f "$baseline" ]]; then
  echo "no baseline $baseline: look at $output and run scripts/update-baselines.sh $name" >&2
  exit 1
fi
"$compare" "$output" "$baseline" "$diff" "$threshold"
