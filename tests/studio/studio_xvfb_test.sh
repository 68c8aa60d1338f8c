#!/usr/bin/env bash
# The studio in a real X window (Xvfb): opens a generated scene, a click selects the pipe at the
# centre of the 3-D view, a click on the stale merge stage's button runs it, a key re-runs the
# placement stage, and screenshots of the X screen show the magenta selection highlight appear where the
# click was (the Gaussian-sphere view staying as it was) and the merge button turn from stale to fresh.
# Then review keys: N selects a proposed joint, R rejects it, Ctrl+S saves the project (the title
# names it), Ctrl+Z and Ctrl+S again: the saved statuses follow. Last, I (intensity colours) shows no
# hand-edit widget.
# Usage: studio_xvfb_test.sh PIPERUN_STUDIO SCENE WORK_DIR
set -euo pipefail
studio=$1 scene=$2 work=$3
mkdir -p "$work"
rm -f "$work"/*.png "$work"/studio.log "$work"/*.piperun*
cp "$scene" "$work/scene.ply"  # Ctrl+S saves the project beside the scan.
scene="$work/scene.ply"

source "$(dirname "$0")/xvfb_session.sh"
start_xvfb "$work"

# Propose the joints the pipeline is less sure of; hide the points and grey the pipes so that only
# the highlight is magenta; centre the view on pipe 1; make the merge stage stale.
cat >"$work/setup.txt" <<'SCRIPT'
rerun joints accept_confidence=0.99
layer input/points off
color pipes plain
select pipe 1
fly
select none
set merge.max_gap=0.051
SCRIPT
"$studio" "$scene" --size 1200x760 --script "$work/setup.txt" >"$work/studio.log" 2>&1 &
studio_pid=$!

wait_for_line() {  # PATTERN COUNT: waits until the log holds COUNT lines matching PATTERN
  for _ in $(seq 600); do
    [[ $(grep -c -- "$1" "$work/studio.log" || true) -ge $2 ]] && return 0
    kill -0 "$studio_pid" 2>/dev/null || { cat "$work/studio.log"; echo "the studio exited" >&2; return 1; }
    sleep 0.1
  done
  cat "$work/studio.log"
  echo "timed out waiting for '$1' x$2" >&2
  return 1
}
wait_for_line "script done" 1

window=$(xdotool search --sync --name "PipeRun Studio")
title=$(xdotool getwindowname "$window")
[[ "$title" == "PipeRun Studio - $(basename "$scene")" ]] || { echo "unexpected title '$title'" >&2; exit 1; }
eval "$(xdotool getwindowgeometry --shell "$window")"  # X Y WIDTH HEIGHT

# Centre of the 3-D view: the left 64 % of the window above the 54-pixel stage bar.
click_x=$((WIDTH * 32 / 100)) click_y=$(((HEIGHT - 54) / 2))
centre="200x200+$((X + click_x - 100))+$((Y + click_y - 100))"
sphere="300x250+$((X + WIDTH * 70 / 100))+$((Y + 40))"

highlight_share() {  # IMAGE CROP: share of magenta pixels (the highlight) in the crop
  convert "$1" -crop "$2" +repage -fx "r>0.4 && b>0.4 && g<0.3" -format "%[fx:mean]" info:
}
differing_pixels() {  # IMAGE IMAGE CROP: pixels that differ by more than 10 % in the crop
  convert "$1" -crop "$3" +repage "$work/crop1.png"
  convert "$2" -crop "$3" +repage "$work/crop2.png"
  compare -metric AE -fuzz 10% "$work/crop1.png" "$work/crop2.png" null: 2>&1 || true
}

screenshot_until() {  # FILE CONDITION...: screenshots into FILE until CONDITION holds (at most 20 s)
  local file=$1
  shift
  for _ in $(seq 40); do
    import -window root "$file"
    "$@" && return 0
    sleep 0.5
  done
  return 0  # The checks below report what the last screenshot shows.
}
highlighted() { awk -v a="$(highlight_share "$1" "$centre")" 'BEGIN { exit !(a > 0.05) }'; }
not_highlighted() { ! highlighted "$1"; }

screenshot_until "$work/before.png" not_highlighted "$work/before.png"  # The script's last frame.
xdotool mousemove "$((X + click_x))" "$((Y + click_y))" click 1
screenshot_until "$work/selected.png" highlighted "$work/selected.png"

before=$(highlight_share "$work/before.png" "$centre")
selected=$(highlight_share "$work/selected.png" "$centre")
sphere_changed=$(differing_pixels "$work/before.png" "$work/selected.png" "$sphere")
echo "highlight share at the click: before $before, after $selected; sphere pixels changed: $sphere_changed"
awk -v b="$before" -v a="$selected" 'BEGIN { exit !(b < 0.01 && a > 0.05) }' || { echo "the click did not highlight a pipe" >&2; exit 1; }
[[ "$sphere_changed" -lt 200 ]] || { echo "the sphere view changed on a click in the 3-D view" >&2; exit 1; }

# The stage bar along the bottom (54 pixels): buttons 96 wide, 6 apart; the fifth is merge.
# Sample its face left of the label: grey (90,90,96) when stale, green (40,130,70) when fresh.
merge_x=$((6 + 4 * 102 + 48)) merge_y=$((HEIGHT - 27))
face_colour() { convert "$1" -format "%[pixel:p{$((X + merge_x - 42)),$((Y + merge_y + 8))}]" info:; }
stale=$(face_colour "$work/selected.png")
xdotool mousemove "$((X + merge_x))" "$((Y + merge_y))" click 1
wait_for_line "finished:" 2
merge_fresh() { [[ $(face_colour "$1") == "srgb(40,130,70)" ]]; }
screenshot_until "$work/merged.png" merge_fresh "$work/merged.png"
fresh=$(face_colour "$work/merged.png")
echo "merge button: $stale before the click, $fresh after the run"
[[ "$stale" == "srgb(90,90,96)" && "$fresh" == "srgb(40,130,70)" ]] || { echo "the merge button did not run merge" >&2; exit 1; }

# L re-runs placement (and the stages after it) in the background; the selection survives.
xdotool key --window "$window" l
wait_for_line "finished:" 3
sleep 1  # The frame drawn from the new results.
screenshot_until "$work/rerun.png" highlighted "$work/rerun.png"
rerun=$(highlight_share "$work/rerun.png" "$centre")
echo "highlight share after the re-run: $rerun"
awk -v a="$rerun" 'BEGIN { exit !(a > 0.05) }' || { echo "the selection was lost by the re-run" >&2; exit 1; }
grep -c "finished:" "$work/studio.log"

# The project's statuses (top-level keys are indented by one space; "network" comes before "base").
rejected_joints() {
  awk '/^ "network":/ { inside = 1 } /^ "base":/ { inside = 0 } inside' "$1" | grep -c '"status": "rejected"' || true
}
saved_rejected() {  # COUNT: waits until the saved project holds COUNT rejected joints
  for _ in $(seq 100); do
    [[ -f "$work/scene.piperun" && $(rejected_joints "$work/scene.piperun") -eq $1 ]] && return 0
    sleep 0.1
  done
  echo "the saved project does not hold $1 rejected joints" >&2
  return 1
}
xdotool key --window "$window" n r ctrl+s
saved_rejected 1
title=$(xdotool getwindowname "$window")
[[ "$title" == "PipeRun Studio - scene.piperun" ]] || { echo "the title does not name the project: '$title'" >&2; exit 1; }
xdotool key --window "$window" ctrl+z ctrl+s
saved_rejected 0
echo "review keys: N R Ctrl+S saved 1 rejected joint, Ctrl+Z Ctrl+S saved none"

# I colours the points by intensity and nothing else: VTK's widgets switch themselves on with "i"
# unless told not to, and the fit box and the end handle would show (outlined in srgb(255,217,51)).
widget_pixels() {  # IMAGE: pixels of the widgets' yellow in the window
  convert "$1" -crop "${WIDTH}x${HEIGHT}+${X}+${Y}" +repage -fill black +opaque "srgb(255,217,51)" \
    -fill white -opaque "srgb(255,217,51)" -format "%[fx:round(mean*w*h)]" info:
}
xdotool mousemove "$((X + click_x))" "$((Y + click_y))" key --window "$window" Home  # The whole scene in view.
sleep 1
import -window root "$work/before_i.png"
xdotool key --window "$window" i
sleep 1.5  # No line is logged for a colour change: time for the next frames.
import -window root "$work/after_i.png"
echo "widget pixels before I: $(widget_pixels "$work/before_i.png"), after: $(widget_pixels "$work/after_i.png")"
[[ $(widget_pixels "$work/after_i.png") -le 10 ]] || { echo "the I key showed a hand-edit widget" >&2; exit 1; }
