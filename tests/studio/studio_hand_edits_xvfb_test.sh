#!/usr/bin/env bash
# The hand edits in a real X window (Xvfb): Shift+S with the mouse on the selected pipe splits it
# there, dragging the end handle moves that end, Shift+click adds a second pipe to the selection
# (drawn magenta), a command typed on the command line (':') sets a radius, and Ctrl+S saves the
# edits in the project's history.
# Usage: studio_hand_edits_xvfb_test.sh PIPERUN_STUDIO SCENE WORK_DIR
set -euo pipefail
studio=$1 scene=$2 work=$3
rm -rf "$work"
mkdir -p "$work"
cp "$scene" "$work/scene.ply"  # Ctrl+S saves the project beside the scan.
scene="$work/scene.ply"

source "$(dirname "$0")/xvfb_session.sh"
start_xvfb "$work"

# The 3-D view alone, pipe 3 (21 mm, 3.2 m) across it with the end handle (yellow) on its start.
cat >"$work/setup.txt" <<'SCRIPT'
view scene
widgets off
layer input/points off
color pipes plain
select pipe 3
fly
handle on
SCRIPT
open_studio "$studio" "$scene" "$work/setup.txt" "$work/studio.log"

centre_of() {  # IMAGE CROP FX-CONDITION: "x y width" (screen) of the matching pixels' bounding box centre
  local crop_x=${2#*+} box
  local crop_y=${crop_x#*+}
  crop_x=${crop_x%+*}
  box=$(convert "$1" -crop "$2" +repage -fx "$3" -format "%@" info:)  # WxH+X+Y
  [[ $box =~ ^([0-9]+)x([0-9]+)\+([0-9]+)\+([0-9]+)$ ]] || { echo "0 0 0"; return; }
  echo "$((crop_x + BASH_REMATCH[3] + BASH_REMATCH[1] / 2)) $((crop_y + BASH_REMATCH[4] + BASH_REMATCH[2] / 2)) ${BASH_REMATCH[1]}"
}
import -window root "$work/start.png"
# The handle (lit yellow) in the left half of the view, pipe 3 (magenta) in the middle band.
read -r handle_x handle_y handle_width <<<"$(centre_of "$work/start.png" "$((WIDTH / 2))x$((HEIGHT / 2))+$X+$((Y + HEIGHT / 4))" \
  "r > 0.94 && g > 0.94 && b > 0.31 && b < 0.51")"
read -r pipe_x pipe_y pipe_width <<<"$(centre_of "$work/start.png" "${WIDTH}x$((HEIGHT / 4))+$X+$((Y + HEIGHT * 3 / 8))" \
  "r > 0.6 && b > 0.6 && g < 0.3")"
echo "handle at ($handle_x, $handle_y), $handle_width pixels wide; pipe 3 centred at ($pipe_x, $pipe_y), $pipe_width wide"
[[ $handle_width -gt 10 && $pipe_width -gt 300 ]] || { echo "no end handle or no pipe 3 drawn" >&2; exit 1; }

# Shift+S with the mouse on pipe 3, a third of the way from its start to its middle: a split there.
split_x=$(((2 * handle_x + pipe_x) / 3)) split_y=$(((2 * handle_y + pipe_y) / 3))
xdotool mousemove "$split_x" "$split_y" sleep 0.2 key --window "$window" shift+s sleep 0.5

# Drag the handle 120 pixels right and 90 up.
xdotool mousemove "$handle_x" "$handle_y" sleep 0.2 mousedown 1
for step in 1 2 3 4; do xdotool mousemove "$((handle_x + 30 * step))" "$((handle_y - 22 * step))" sleep 0.1; done
xdotool mouseup 1 sleep 0.5

# Shift+click on pipe 5, which runs below pipe 3 (at its middle, 85 pixels below in this view).
xdotool mousemove "$pipe_x" "$((pipe_y + 85))" sleep 0.2 keydown shift click 1 keyup shift sleep 0.5
import -window root "$work/two.png"
along_pipe_5() {
  convert "$1" -crop "200x30+$((pipe_x - 100))+$((pipe_y + 70))" +repage -fx "r > 0.6 && b > 0.6 && g < 0.3" \
    -format "%[fx:mean]" info:
}
first=$(along_pipe_5 "$work/start.png") second=$(along_pipe_5 "$work/two.png")
echo "magenta share along pipe 5: $first before the Shift+click, $second after"
awk -v b="$first" -v a="$second" 'BEGIN { exit !(b < 0.01 && a > 0.05) }' || { echo "Shift+click did not add pipe 5" >&2; exit 1; }

# The command line: ':' opens it, the typed command runs on Return.
xdotool type --delay 30 ":pipe 1 radius 0.05"
sleep 0.5
xdotool key Return
sleep 0.5

xdotool key --window "$window" ctrl+s
for _ in $(seq 50); do [[ -f "$work/scene.piperun" ]] && break; sleep 0.1; done
commands=$(grep '"command":' "$work/scene.piperun" | cut -d'"' -f4)
echo "$commands"
grep -q "^pipe 3 split " <<<"$commands" || { echo "Shift+S did not split pipe 3" >&2; exit 1; }
grep -q "^pipe 3 move-end start " <<<"$commands" || { echo "the handle did not move pipe 3's start" >&2; exit 1; }
grep -q "^pipe 1 radius 0.05$" <<<"$commands" || { echo "the typed command line did not set pipe 1's radius" >&2; exit 1; }
