#!/usr/bin/env bash
# The studio's hand-edit commands through piperun-render, checked in the saved projects' networks:
# a split where a pixel shows the selected pipe, a two-pipe selection by click and Shift+click then
# merge, radius snap, join on two selected pipes, a fit in the box widget, a fit around a picked
# point, the end handle dropped somewhere, and undo of that.
# Usage: hand_edits_test.sh PIPERUN_RENDER SCENE NOMINAL_SIZES_CSV WORK_DIR
set -euo pipefail
render=$1 scene=$2 sizes=$3 work=$4
rm -rf "$work"
mkdir -p "$work"
cd "$work"

# The pipes of a project's "network" section: ids, and one field of a pipe ("axis": its six numbers).
pipes_of() {
  awk '/^ "network":/ { net = 1 } /^ "base":/ { net = 0 } net && /^  "pipes":/ { pipes = 1; next }
       pipes && /^  \]/ { pipes = 0 } net && pipes' "$1"
}
pipe_ids() { pipes_of "$1" | awk '/^    "id":/ { gsub(/[^0-9]/, ""); print }' | sort -n; }
pipe_field() {
  pipes_of "$1" | awk -v id="$2" -v key="$3" '
    /^   \{/ { delete field; axis = "" }
    /^      -?[0-9]/ { value = $1; sub(/,$/, "", value); axis = axis (axis == "" ? "" : " ") value }
    /^    "[a-z_]+": [^[]/ { name = $1; gsub(/[":]/, "", name); value = $2; sub(/,$/, "", value); field[name] = value }
    /^   \}/ { field["axis"] = axis; if (field["id"] == id) print field[key] }'
}
new_pipe() { comm -13 <(pipe_ids "$1") <(pipe_ids "$2"); }
joint_between() {  # the status of the joint of pipes A and B
  awk '/^ "network":/ { net = 1 } /^ "base":/ { net = 0 } net' "$1" | tr -d ' \n' |
    grep -o "\"pipes\":\[$2,$3\][^}]*\"status\":\"[a-z]*\"" | grep -o '"status":"[a-z]*"' | cut -d'"' -f4
}
joint_id_between() {  # the id of the joint of pipes A and B
  awk '/^ "network":/ { net = 1 } /^ "base":/ { net = 0 } net' "$1" | tr -d ' \n' |
    grep -o "\"id\":[0-9]*,\"pipes\":\[$2,$3\]" | grep -o '[0-9]*' | head -1
}
close_to() { awk -v a="$1" -v b="$2" -v tolerance="$3" 'BEGIN { d = a - b; exit !(d <= tolerance && -d <= tolerance) }'; }
fail() { echo "$*" >&2; exit 1; }

# The elbow between pipes 1 and 4 (ids as the pipeline numbers them: pipes, then joints).
echo "save reconstructed.piperun" >reconstruct.txt
env -u DISPLAY "$render" "$scene" --script reconstruct.txt --view scene --size 480x360 -o reconstructed.png
elbow=$(joint_id_between reconstructed.piperun 1 4)
[[ -n "$elbow" ]] || fail "no joint between pipes 1 and 4 to reject"

cat >edits.txt <<SCRIPT
# 480x360 scene view, pixels from the bottom left: pipe 3 (21 mm, 3.2 m) runs across the middle.
layer input/points off
select pipe 3
fly
save before.piperun
pick split 240 180
save split.piperun
click 150 178
click 330 179 shift
merge
save merged.piperun
radius snap
save snapped.piperun
joint $elbow reject
select pipe 1 4
join
save joined.piperun
select pipe 1
box show
box fit
save box.piperun
layer network/pipes off
layer input/points on
select pipe 1
fly
pick fit 240 180
save point.piperun
select pipe 3
handle on
handle drop 1 2 1.11
save moved.piperun
undo
save undone.piperun
SCRIPT
env -u DISPLAY "$render" "$scene" --script edits.txt --view scene --size 480x360 -o shot.png

# Split at the pixel: one new pipe; pipe 3 and the new one share its length.
length=$(pipe_field before.piperun 3 length)
piece=$(new_pipe before.piperun split.piperun)
[[ $(wc -w <<<"$piece") -eq 1 ]] || fail "split: expected one new pipe, got '$piece'"
close_to "$(awk -v a="$(pipe_field split.piperun 3 length)" -v b="$(pipe_field split.piperun "$piece" length)" \
  'BEGIN { print a + b }')" "$length" 0.001 || fail "split: the pieces do not add up to pipe 3's $length m"
awk -v a="$(pipe_field split.piperun 3 length)" -v whole="$length" 'BEGIN { exit !(a > 0.3 * whole && a < 0.7 * whole) }' ||
  fail "split: not near the middle of pipe 3"
# Click, Shift+click, merge: the pipes of before, pipe 3 whole again.
[[ "$(pipe_ids merged.piperun)" == "$(pipe_ids before.piperun)" ]] || fail "merge: expected the pipes of before"
close_to "$(pipe_field merged.piperun 3 length)" "$length" 0.001 || fail "merge: pipe 3 is not whole again"
# Snap: the radius is half a nominal outside diameter.
snapped=$(pipe_field snapped.piperun 3 radius)
grep -v '^#' "$sizes" | tail -n +2 | cut -d, -f3 |
  awk -v r="$snapped" '{ d = r * 2000 - $1; if (d * d < 1e-6) found = 1 } END { exit !found }' ||
  fail "snap: radius $snapped is no nominal size"
# Join: pipes 1 and 4 joined again after their elbow was rejected.
[[ "$(joint_between joined.piperun 1 4 | sort | tr '\n' ' ')" == "accepted rejected " ]] ||
  fail "join: expected an accepted joint beside the rejected one between pipes 1 and 4"
# Box and point fits around pipe 1: a new pipe of its radius each.
radius=$(pipe_field joined.piperun 1 radius)
for fit in box point; do
  from=$([[ $fit == box ]] && echo joined || echo box)
  fitted=$(new_pipe $from.piperun $fit.piperun)
  [[ $(wc -w <<<"$fitted") -eq 1 ]] || fail "$fit fit: expected one new pipe, got '$fitted'"
  close_to "$(pipe_field $fit.piperun "$fitted" radius)" "$radius" 0.003 || fail "$fit fit: radius is not pipe 1's"
done
# The handle dropped at (1, 2, 1.11) moved one end of pipe 3 there; undo put it back.
grep -q '"command": "pipe 3 move-end \(start\|end\) 1 2 1.11"' moved.piperun || fail "handle: no move-end in the history"
read -r -a axis <<<"$(pipe_field moved.piperun 3 axis)"
{ close_to "${axis[0]}" 1 1e-9 && close_to "${axis[1]}" 2 1e-9 && close_to "${axis[2]}" 1.11 1e-9; } ||
  { close_to "${axis[3]}" 1 1e-9 && close_to "${axis[4]}" 2 1e-9 && close_to "${axis[5]}" 1.11 1e-9; } ||
  fail "handle: pipe 3's axis ${axis[*]} does not end at (1, 2, 1.11)"
[[ "$(pipe_field undone.piperun 3 axis)" == "$(pipe_field point.piperun 3 axis)" ]] || fail "undo: pipe 3 not back"
echo "hand edits ok: split into 3 and $piece, merged, snapped to $snapped m, joined 1 and 4, two fits, handle"
