#!/bin/bash
# The robustness table (like the paper's Figure 10): mean pipe-axis F1 (pipes only, before
# joints) on generated small scenes
# over surface noise 0, 2, 5, 10 mm and outliers 0, 5, 20 %.
#   scripts/robustness.sh [--seeds "1 2 3"] [--set key=value]...
# Prints a Markdown table (docs/QUALITY.md holds its latest output).
set -euo pipefail
cd "$(dirname "$0")/.."
seeds="1 2 3"
extra=()
while [ $# -gt 0 ]; do
  case "$1" in
    --seeds) seeds=$2; shift 2 ;;
    --set) extra+=(--set "$2"); shift 2 ;;
    *) echo "robustness.sh: unknown option $1" >&2; exit 1 ;;
  esac
done
outliers_list="0 0.05 0.2"
echo "| noise \\ outliers | 0 % | 5 % | 20 % |"
echo "| --- | --- | --- | --- |"
for noise in 0 0.002 0.005 0.01; do
  row="| $(awk -v n="$noise" 'BEGIN { printf "%g mm", n * 1000 }') |"
  for outliers in $outliers_list; do
    f1=$(scripts/evaluate.sh --pipes-only --seeds "$seeds" --noise "$noise" --outliers "$outliers" "${extra[@]}" |
      grep '^mean:' | sed -E 's/.* f1=([0-9.]+).*/\1/')
    row="$row $f1 |"
  done
  echo "$row"
done
