#!/usr/bin/env bash
# Commands' messages and refusals, as a script's last line reports them. The points' clip: chosen by
# itself under a roof (and Z, `clip toggle`, shows the roof again), none without one; its heights
# and box. The points' size (1 pixel at start on a scan of over 4 million points), their strays, their
# budget (the scene's title counts the points drawn when a layer is over it). Selecting a tile:
# its first direction, the next and previous tile (wrapping round); fly with nothing selected goes there.
# The up axis set in a script: the ceiling looked for along it. A selected pipe's heights and slope,
# and two selected pipes' distance.
# Usage: script_messages_test.sh PIPERUN_RENDER PIPERUN SCENE ROOFED_SCENE NETWORK WORK_DIR ROOFED_Y_UP_SCENE
set -uo pipefail
render=$1 piperun=$2 scene=$3 roofed=$4 network=$5 work=$6 roofed_y_up=$7
mkdir -p "$work"
failures=0

expect() {  # CODE PATTERN INPUT SCRIPT_LINES [OPTIONS...]: the last message (or the error) matches PATTERN
  local code=$1 pattern=$2 input=$3 lines=$4
  shift 4
  printf '%b\n' "$lines" >"$work/script.txt"
  local output
  output=$(env -u DISPLAY "$render" "$input" --script "$work/script.txt" --size "${size:-160x100}" -o "$work/out.png" "$@" 2>&1)
  local actual=$?
  if [[ $actual -ne $code || ! "$output" =~ $pattern ]]; then
    echo "FAIL: $input with '$lines' -> exit $actual: $output (expected exit $code matching '$pattern')" >&2
    failures=$((failures + 1))
  fi
}

# Under the roof the first view hides the points above the network; toggling shows them, and back.
expect 0 "^points not clipped" "$roofed" "clip toggle"
expect 0 "^points above 3\.[0-9][0-9] m hidden" "$roofed" "clip toggle\nclip toggle"
# Without a roof nothing is hidden, and toggling has no ceiling to go to.
expect 2 "script\.txt:1: no ceiling over the network to clip: give a height" "$scene" "clip toggle"
expect 0 "^points above 1\.50 m hidden" "$scene" "clip 1.5" --no-run
expect 0 "^points shown from 0\.50 m to 1\.50 m" "$scene" "clip 0.5 1.5" --no-run
expect 0 "^points not clipped" "$scene" "clip 1.5\nclip off" --no-run
expect 0 "^points above 1\.50 m hidden" "$scene" "clip 1.5\nclip off\nclip toggle" --no-run
expect 0 "^points outside the box from -1\.000 -2\.000 0\.500 to 1\.000 2\.000 1\.500 hidden" "$scene" \
  "box show -1 -2 0.5 1 2 1.5\nclip box" --no-run
expect 2 "script\.txt:1: no box shown \(box show, or B\)" "$scene" "clip box" --no-run
expect 2 "script\.txt:1: Z_MIN must be below Z_MAX" "$scene" "clip 1.5 0.5" --no-run
expect 2 "script\.txt:1: heights must be finite numbers \(metres\)" "$scene" "clip inf" --no-run
expect 2 "script\.txt:1: expected Z_MAX as a number, got 'high'" "$scene" "clip high" --no-run
expect 2 "script\.txt:1: no points: this document is a network" "$network" "clip 1.5"
# Under the roof with y up, taken as z up there is no ceiling (the roof is a wall); set up=y stands
# the cameras on y and finds the roof along it, and after the run as well.
expect 2 "script\.txt:1: no ceiling over the network to clip" "$roofed_y_up" "clip toggle"
expect 0 "^parameters set; the cameras stand on y" "$roofed_y_up" "set up=y"
expect 0 "^points above 3\.[0-9][0-9] m hidden" "$roofed_y_up" "set up=y\nclip toggle\nclip toggle"
expect 0 "^points above 3\.[0-9][0-9] m hidden" "$roofed_y_up" "rerun joints up=y\nclip toggle\nclip toggle"
expect 0 "^points above 3\.[0-9][0-9] m hidden" "$roofed_y_up" "clip toggle\nclip toggle" --up y

# The scene's point size.
expect 0 "^scene points drawn at 3 px" "$scene" "points size larger" --no-run
expect 0 "^scene points drawn at 1 px" "$scene" "points size 1" --no-run
expect 2 "script\.txt:2: points are drawn 1 to 10 pixels wide" "$scene" "points size 1\npoints size smaller" --no-run
expect 2 "script\.txt:1: usage: points size PX\|larger\|smaller" "$scene" "points 3" --no-run
expect 0 "^[0-9]+ stray points hidden \([0-9.]+ % of the scan\)" "$scene" "points strays hide" --no-run
expect 0 "^stray points shown" "$scene" "points strays toggle\npoints strays toggle" --no-run
expect 2 "script\.txt:1: no points: this document is a network" "$network" "points strays hide"
"$piperun" generate --preset medium --seed 1 --density 2.2 -o "$work/dense.ply" >/dev/null  # 4.4 million points
expect 0 "^scene points drawn at 2 px" "$work/dense.ply" "points size larger" --no-run

# The points drawn when still: at most the budget, of the points in view.
expect 0 "^scene layers draw at most 30000 points when still" "$scene" "points budget 30000" --no-run
expect 0 "^scene layers draw every point when still" "$scene" "points budget 30000\npoints budget all" --no-run
expect 2 "script\.txt:1: the point budget is at least 1 point" "$scene" "points budget 0" --no-run
expect 2 "script\.txt:1: expected the most points drawn as an integer, got 'many'" "$scene" "points budget many" --no-run
expect 0 "^camera zoom 2" "$work/dense.ply" "points budget 1000000\ncamera zoom 2" --no-run --text "$work/dense.txt"
if ! grep -Eq "points drawn: (9[0-9]{5}|1000000) of 4[0-9]{6}$" "$work/dense.txt"; then
  echo "FAIL: the dense scan's title does not count the points drawn: $(head -2 "$work/dense.txt")" >&2
  failures=$((failures + 1))
fi
# The shown layers share the budget: the scan's 299,897 points and the plane points together are
# over 300,000 (the title counts both layers), the scan alone is not (every point, no count).
expect 0 "^preprocess/planes on" "$scene" "points budget 300000\nlayer preprocess/planes on" --text "$work/shared.txt"
drawn=$(sed -nE 's/.*points drawn: ([0-9]+) of ([0-9]+)$/\1 \2/p' "$work/shared.txt")
if ! awk -v counts="$drawn" 'BEGIN { split(counts, c, " "); exit !(c[1] <= 300000 && c[1] > 290000 && c[2] > 299897) }'; then
  echo "FAIL: two shown layers do not share the budget: $(head -2 "$work/shared.txt")" >&2
  failures=$((failures + 1))
fi
expect 0 "^preprocess/planes off" "$scene" "points budget 300000\nlayer preprocess/planes on\nlayer preprocess/planes off" \
  --text "$work/alone.txt"
if grep -q "points drawn" "$work/alone.txt"; then
  echo "FAIL: the scan alone within the budget still counts its points drawn: $(head -2 "$work/alone.txt")" >&2
  failures=$((failures + 1))
fi

# The generated scene has four tiles, whose first directions are 0, 7, 14 and 20 (26 is the last).
expect 0 "^selected direction 26 \(tile 3\)" "$scene" "select direction 26"
expect 0 "^selected direction 14 \(tile 2\)" "$scene" "select tile 2"
expect 0 "^selected direction 0 \(tile 0\)" "$scene" "select direction 26\nselect tile next"
expect 0 "^selected direction 20 \(tile 3\)" "$scene" "select tile previous"
expect 0 "^selected direction 0 \(tile 0\)" "$scene" "select tile 1\nselect tile previous"
expect 0 "^camera on tile 2" "$scene" "select tile 2\nfly"
expect 2 "script\.txt:1: no tile 9 \(there are 4\)" "$scene" "select tile 9"
expect 2 "script\.txt:1: no directions yet: run the directions stage" "$scene" "select tile next" --no-run
# What the selection says of a pipe's lie and of two pipes' distance: a level 8" pipe at 3 m and a
# 4" one falling 0.2 m over 4 m (5 %) beside it, 0.4 m between the axes at the nearest.
cat >"$work/two_pipes.json" <<'JSON'
{"format": "piperun-network", "version": 1, "pipes": [
  {"id": 1, "radius": 0.1, "axis": [[0, 0, 3], [6, 0, 3]]},
  {"id": 2, "radius": 0.05, "axis": [[1, 0.4, 3.2], [5, 0.4, 3.0]]}]}
JSON
expect_info() {  # SCRIPT_LINES LINE: the info text drawn after the script (in a window wide enough) holds LINE
  size=1280x800 expect 0 "^selected" "$work/two_pipes.json" "$1" --text "$work/info.txt"
  if ! grep -qxF -- "$2" "$work/info.txt"; then
    echo "FAIL: after '$1' the info lacks '$2': $(sed -n '/^\[info\]/,$p' "$work/info.txt")" >&2
    failures=$((failures + 1))
  fi
}
expect_info "select pipe 1" "height 3.000 m, slope 0.0° (0.0 %); bottom of pipe 2.900 m, top 3.100 m"
expect_info "select pipe 2" "height 3.000 to 3.200 m, slope 2.9° (5.0 %); bottom of pipe 3.050 m, top 3.150 m"
expect_info "select pipe 1 2" "apart: axes 0.400 m, surfaces 0.250 m, axes at 2.9°"
# In a narrow window the info's lines are broken to its width, between fields where they fit.
size=480x300 expect 0 "^selected" "$work/two_pipes.json" "select pipe 1 2" --text "$work/narrow.txt"
if [[ "$(sed -n '/^\[info\]/,$p' "$work/narrow.txt" | sed -n '7,8p')" != $'and pipe 2  radius 50 mm (3-1/2" DN 90)  length 4 m\n(Shift+M merges it into pipe 1, Shift+J joins them)' ]]; then
  echo "FAIL: the narrow window's info is not broken between fields: $(cat "$work/narrow.txt")" >&2
  failures=$((failures + 1))
fi
exit $((failures > 0))
