#!/usr/bin/env bash
# The points drawn while the camera moves, in a real X window (Xvfb): on a scan of 2 million points
# zoomed in with the mouse wheel, a drag draws the subsample of what the camera sees, the near
# points densest, not an even subsample of the whole scan (which kept about 6 % of what the still
# view shows here; the view's subsample keeps about 27 %).
# Usage: studio_moving_points_xvfb_test.sh PIPERUN_STUDIO PIPERUN WORK_DIR
set -euo pipefail
studio=$1 piperun=$2 work=$3
rm -rf "$work"
mkdir -p "$work"
"$piperun" -q generate --preset medium --seed 1 -o "$work/scene.ply" >/dev/null

source "$(dirname "$0")/xvfb_session.sh"
start_xvfb "$work"

# Only the points: the pipes and joints would cover them.
cat >"$work/setup.txt" <<'SCRIPT'
layer network/pipes off
layer network/joints off
layer network/rejected-joints off
view scene
SCRIPT
open_studio "$studio" "$work/scene.ply" "$work/setup.txt" "$work/studio.log"

centre_x=$((X + WIDTH / 2)) centre_y=$((Y + (HEIGHT - 54) / 2))
xdotool mousemove "$centre_x" "$centre_y"
for _ in $(seq 10); do  # Ten wheel steps towards the middle of the scan.
  xdotool click 4
  sleep 0.3
done
sleep 3
import -window root "$work/still.png"
xdotool mousedown 1
for step in 1 2 3 4; do
  xdotool mousemove "$((centre_x + 3 * step))" "$((centre_y + 2 * step))"
  sleep 0.3
done
import -window root "$work/moving.png"
xdotool mouseup 1

# Share of coloured pixels (the points; the background is grey) in the middle of the view.
crop="$((WIDTH / 2))x$((HEIGHT / 2))+$((X + WIDTH / 4))+$((Y + HEIGHT / 5))"
coloured() { convert "$1" -crop "$crop" +repage -fx "max(r,max(g,b))-min(r,min(g,b)) > 0.3" -format "%[fx:mean]" info:; }
still=$(coloured "$work/still.png")
moving=$(coloured "$work/moving.png")
echo "coloured pixels: still $still, moving $moving"
awk -v s="$still" -v m="$moving" 'BEGIN { exit !(s > 0.05 && m > 0.15 * s) }' || {
  echo "FAIL: while moving the zoomed view keeps under 15 % of the coloured pixels it shows still" >&2
  exit 1
}
