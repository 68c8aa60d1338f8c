#!/bin/bash
# The robustness tables (docs/QUALITY.md holds their latest output), on generated small scenes:
#   scripts/robustness.sh [--seeds "1 2 3"] [--set key=value]...
#     mean pipe-axis F1 (pipes only, before joints; like the paper's Figure 10) over surface noise
#     0, 2, 5, 10 mm and outliers 0, 5, 20 %;
#   scripts/robustness.sh --registration [--seeds "1 … 10"] [--runs 3] [--set key=value]...
#     three stations misregistered by 0, 1, 2, 5, 10 mm (piperun generate --registration-error):
#     whole-truth F1 and the joints found, each the mean over --runs pipeline seeds.
# Prints a Markdown table.
set -euo pipefail
cd "$(dirname "$0")/.."
table=noise
seeds=""
runs=3
extra=()
while [ $# -gt 0 ]; do
  case "$1" in
    --registration) table=registration; shift ;;
    --seeds) seeds=$2; shift 2 ;;
    --runs) runs=$2; shift 2 ;;
    --set) extra+=(--set "$2"); shift 2 ;;
    *) echo "robustness.sh: unknown option $1" >&2; exit 1 ;;
  esac
done

if [ "$table" = registration ]; then
  seeds=${seeds:-"1 2 3 4 5 6 7 8 9 10"}
  echo "| registration error | F1 | elbows found | tees found | spurious joints |"
  echo "| --- | --- | --- | --- | --- |"
  for error in 0 0.001 0.002 0.005 0.01; do
    out=$(scripts/evaluate.sh --seeds "$seeds" --stations 3 --registration-error "$error" --runs "$runs" \
      "${extra[@]}")
    # Over several runs: "mean of N runs: elbows=88.7/98 tees=23.0/23 spurious_joints=7.7/120 f1=0.967";
    # over one, the "joints:" and "mean:" lines hold the same fields.
    if [ "$runs" -gt 1 ]; then
      line=$(grep "^mean of $runs runs:" <<<"$out")
    else
      line="$(grep '^joints:' <<<"$out") $(grep '^mean:' <<<"$out")"
    fi
    value() { sed -E "s/.* $1=([^ ]+).*/\1/" <<<"$line"; }
    echo "| $(awk -v e="$error" 'BEGIN { printf "%g mm", e * 1000 }') | $(value f1) | $(value elbows) |" \
      "$(value tees) | $(value spurious_joints) |"
  done
  exit 0
fi

seeds=${seeds:-"1 2 3"}
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
