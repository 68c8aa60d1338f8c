#!/bin/bash
# Reconstructs generated scenes over several seeds and prints the accuracy of each and the mean.
#   scripts/evaluate.sh [--preset small] [--seeds "1 2 3"] [--noise M] [--outliers F]
#                       [--stations K] [--registration-error M] [--mixed-pixels F] [--up AXIS] [--roof] [--pipes-only]
#                       [--until merge|joints] [--set key=value]... [--joints] [--runs N]
# --up AXIS generates the scenes turned so that AXIS (x, y, -z, ...) is up and tells the pipeline so;
# add --set up=z to reconstruct them as if z were up. --roof closes the scenes' rooms with a roof.
# --pipes-only compares only straight pipes (the pipe-axis figures before joints); --until merge
# stops the reconstruction before the joints stage (the same pipes, no joints); --joints also lists,
# seed by seed, every truth elbow and tee missed and every spurious joint (piperun eval --joints).
# --runs N reconstructs each scene N times, with the pipeline seeds seed, seed + 100, … (the random
# draws of directions and placement change, the scene does not): the figures then move by a few
# joints from run to run (docs/QUALITY.md), and each run's totals are printed with their mean.
# Needs a build (scripts/build.sh). Prints one line per seed, then
#   mean: precision=… recall=… f1=… radius_err_mm=… (median of the seeds' medians)
#   observable: share=… recall_observable=… (the share of the truth the scan shows, and the recall
#               over that part; the scenes are generated with labels for it, see docs/EVALUATION.md)
# and, without --pipes-only, the joint totals: over all the truth, over the observable joints, and
# over the joints whose pipes the scan shows near their corners, then the missed joints by cause
# (not seen at the corner, a pipe not found there, or both found and not joined; docs/EVALUATION.md).
set -euo pipefail
cd "$(dirname "$0")/.."
PIPERUN=${PIPERUN:-build/app/piperun}
preset=small
seeds="1 2 3 4 5 6 7 8 9 10"
noise=0.002
outliers=0.01
stations=0
registration_error=0
mixed_pixels=0
up=z
roof=()
sets=()
eval_flags=()
list_joints=0
runs=1
while [ $# -gt 0 ]; do
  case "$1" in
    --preset) preset=$2; shift 2 ;;
    --seeds) seeds=$2; shift 2 ;;
    --noise) noise=$2; shift 2 ;;
    --outliers) outliers=$2; shift 2 ;;
    --stations) stations=$2; shift 2 ;;
    --registration-error) registration_error=$2; shift 2 ;;
    --mixed-pixels) mixed_pixels=$2; shift 2 ;;
    --up) up=$2; shift 2 ;;
    --roof) roof=(--roof); shift ;;
    --set) sets+=(--set "$2"); shift 2 ;;
    --until) sets+=(--until "$2"); shift 2 ;;
    --pipes-only) eval_flags+=(--pipes-only); shift ;;
    --joints) list_joints=1; shift ;;
    --runs) runs=$2; shift 2 ;;
    *) echo "evaluate.sh: unknown option $1" >&2; exit 1 ;;
  esac
done

work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
results="$work/results.txt"
: >"$results"
case "$runs" in '' | *[!0-9]* | 0) echo "evaluate.sh: --runs needs a positive count" >&2; exit 1 ;; esac
for seed in $seeds; do
  "$PIPERUN" -q generate --preset "$preset" --seed "$seed" --noise "$noise" --outliers "$outliers" \
    --stations "$stations" --registration-error "$registration_error" \
    --mixed-pixels "$mixed_pixels" --up "$up" "${roof[@]}" --labels -o "$work/scene.ply" --truth "$work/truth.json" >/dev/null
  for ((run = 0; run < runs; ++run)); do
    pipeline_seed=$((seed + 100 * run))
    label="seed=$seed"
    [ "$runs" -gt 1 ] && label="$label run=$run pipeline_seed=$pipeline_seed"
    start=$(date +%s.%N)
    # The scene's up axis goes first, so that a --set up=… given after it tells the pipeline otherwise.
    "$PIPERUN" -q reconstruct "$work/scene.ply" -o "$work/net.json" --seed "$pipeline_seed" --set "up=$up" \
      "${sets[@]}" >/dev/null
    end=$(date +%s.%N)
    "$PIPERUN" eval "${eval_flags[@]}" --joints --scan "$work/scene.ply" "$work/truth.json" "$work/net.json" >"$work/eval.txt"
    line=$(tail -1 "$work/eval.txt")
    if [ "$list_joints" -eq 1 ]; then
      grep -E '^(joint .* missed|spurious )' "$work/eval.txt" | sed "s/^/$label /" || true
    fi
    seconds=$(awk -v a="$start" -v b="$end" 'BEGIN { printf "%.2f", b - a }')
    echo "$label $line seconds=$seconds"
    echo "run=$run $line seconds=$seconds" >>"$results"
  done
done
field() { sed -E "s/.*[[:space:]]$1=([-0-9.]+).*/\1/;s/^$1=([-0-9.]+).*/\1/" "$results"; }
mean() { field "$1" | awk '{ sum += $1 } END { printf "%.3f", sum / NR }'; }
# Median of the seeds' median radius errors (mawk has no sort, so sort(1) orders them).
median_radius=$(field radius_err_mm | sort -n | awk '{ v[NR] = $1 } END { printf "%.1f", NR % 2 ? v[(NR + 1) / 2] : (v[NR / 2] + v[NR / 2 + 1]) / 2 }')
echo "mean: precision=$(mean precision) recall=$(mean recall) f1=$(mean f1) radius_err_mm=$median_radius seconds=$(mean seconds) seeds=$(( $(wc -l <"$results") / runs ))$([ "$runs" -gt 1 ] && echo " runs=$runs")"
echo "observable: share=$(mean observable) recall_observable=$(mean recall_observable)"
# How often the nominal size a PCF export writes is the truth's (over the matched truth samples).
ratio() { sed -E "s/.*[[:space:]]$1=([0-9]+)\/([0-9]+).*/\1 \2/" "$results" | awk '{ a += $1; b += $2 } END { if (b == 0) print "n/a"; else printf "%.3f", a / b }'; }
echo "nominal size right: $(ratio nominal_size_right)"
# Joint totals over the seeds ("found/truth"), and the median of the seeds' bend-radius errors
# (seeds without a matched elbow left out).
total() { sed -E "s/.*[[:space:]]$1=([0-9]+)\/([0-9]+).*/\1 \2/" "$results" | awk '{ a += $1; b += $2 } END { printf "%d/%d", a, b }'; }
median_bend=$(paste -d' ' <(field bend_radius_err) <(sed -E 's/.*elbows=([0-9]+)\/.*/\1/' "$results") |
  awk '$2 > 0 { print $1 }' | sort -n | awk '{ v[NR] = $1 } END { if (NR == 0) print "n/a"; else printf "%.3f", NR % 2 ? v[(NR + 1) / 2] : (v[NR / 2] + v[NR / 2 + 1]) / 2 }')
if [ ${#eval_flags[@]} -eq 0 ]; then
  echo "joints: elbows=$(total elbows) tees=$(total tees) spurious_joints=$(total spurious_joints) bend_radius_err=$median_bend"
  echo "observable joints: elbows=$(total observable_elbows) tees=$(total observable_tees)"
  echo "corner-seen joints: elbows=$(total corner_seen_elbows) tees=$(total corner_seen_tees)"
  count() { sed -E "s/.*[[:space:]]$1=([0-9]+).*/\1/" "$results" | awk '{ a += $1 } END { printf "%d", a }'; }
  misses() { echo "unseen=$(count "missed_$1_unseen") pipe_not_found=$(count "missed_$1_pipe_not_found") not_joined=$(count "missed_$1_not_joined")"; }
  echo "missed joints by cause: elbows $(misses elbows), tees $(misses tees)"
  # What keeping the accepted elements and reviewing the proposed ones gives: the share of each
  # status's axis samples on the truth (precision by status) and its spurious joints.
  echo "by review status: accepted precision=$(ratio accepted_matched) spurious_joints=$(total spurious_accepted), proposed precision=$(ratio proposed_matched) spurious_joints=$(total spurious_proposed)"
  if [ "$runs" -gt 1 ]; then
    # Each run's totals over the scenes, then their mean per run (the spread is the pipeline's
    # sensitivity to its random draws).
    all="$results"
    for ((run = 0; run < runs; ++run)); do
      results="$work/run$run.txt"
      grep "^run=$run " "$all" >"$results"
      echo "run $run: elbows=$(total elbows) tees=$(total tees) spurious_joints=$(total spurious_joints) f1=$(mean f1)"
    done
    results="$all"
    per_run() { sed -E "s/.*[[:space:]]$1=([0-9]+)\/([0-9]+).*/\1 \2/" "$results" | awk -v runs="$runs" '{ a += $1; b += $2 } END { printf "%.1f/%d", a / runs, b / runs }'; }
    echo "mean of $runs runs: elbows=$(per_run elbows) tees=$(per_run tees) spurious_joints=$(per_run spurious_joints) f1=$(mean f1)"
  fi
fi
