#!/usr/bin/env bash
# One render test: piperun-render draws INPUT after SCRIPT with no X display; the image is compared
# with tests/baselines/NAME.png, and the texts drawn over the views (titles, status, info) must equal
# tests/baselines/NAME.txt (a changed word is too few pixels for the image comparison). With
# PIPERUN_UPDATE_BASELINES=1 the outputs replace the baselines.
# Usage: render_test.sh RENDER COMPARE NAME INPUT SCRIPT VIEW SIZE THRESHOLD BASELINE_DIR OUTPUT_DIR [OPTION...]
# (the options go to piperun-render).
set -euo pipefail
render=$1 compare=$2 name=$3 input=$4 script=$5 view=$6 size=$7 threshold=$8 baselines=$9 outputs=${10}
options=("${@:11}")

mkdir -p "$outputs"
output="$outputs/$name.png"
text="$outputs/$name.txt"
diff="$outputs/$name.diff.png"
rm -f "$output" "$text" "$diff"
env -u DISPLAY -u WAYLAND_DISPLAY "$render" "$input" --script "$script" --view "$view" --size "$size" -o "$output" \
  --text "$text" "${options[@]}"

baseline="$baselines/$name.png"
text_baseline="$baselines/$name.txt"
if [[ "${PIPERUN_UPDATE_BASELINES:-0}" == 1 ]]; then
  cp "$output" "$baseline"
  cp "$text" "$text_baseline"
  echo "updated $baseline and $text_baseline"
  exit 0
fi
for expected in "$baseline" "$text_baseline"; do
  if [[ ! -f "$expected" ]]; then
    echo "no baseline $expected: look at $output and $text and run scripts/update-baselines.sh $name" >&2
    exit 1
  fi
done
if ! diff -u "$text_baseline" "$text"; then
  echo "the texts over the views differ from $text_baseline" >&2
  exit 1
fi
"$compare" "$output" "$baseline" "$diff" "$threshold"
