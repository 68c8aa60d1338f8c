#!/usr/bin/env bash
# Regenerates the screenshots in docs/STUDIO.md with the headless renderer (no display needed).
# Usage: scripts/studio-screenshots.sh   (after scripts/build.sh)
set -euo pipefail
cd "$(dirname "$0")/.."
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
render() { env -u DISPLAY build/app/piperun-render "$@"; }

build/app/piperun generate --preset small --seed 1 -o "$work/scene.ply" --truth "$work/truth.json" >/dev/null
printf 'select pipe 1\n' >"$work/window.txt"
render "$work/scene.ply" --script "$work/window.txt" --size 1280x800 -o docs/images/studio-window.png
printf 'color points qa\n' >"$work/qa.txt"
render "$work/scene.ply" --script "$work/qa.txt" --view scene --size 800x500 -o docs/images/studio-scene-qa.png
printf 'select direction 1\n' >"$work/sphere.txt"
render "$work/scene.ply" --script "$work/sphere.txt" --view sphere --size 600x500 -o docs/images/studio-sphere.png
printf 'select direction 0\n' >"$work/plane.txt"
render "$work/scene.ply" --script "$work/plane.txt" --view plane --size 600x500 -o docs/images/studio-plane.png
printf 'joint 19 reject\njoint 23 propose\njoint 26 propose\ncolor pipes plain\ncamera zoom 1.5\n' >"$work/joints.txt"
render "$work/truth.json" --script "$work/joints.txt" --view scene --size 800x500 -o docs/images/studio-joints.png

# Review: more joints proposed, two rejected (faded), one accepted, a pipe deleted (ghosted), the
# counters; then the same review saved, and reopened with a newer autosave beside it.
cat >"$work/review.txt" <<'SCRIPT'
rerun joints accept_confidence=0.9
layer input/points off
color pipes plain
review next
review reject
review reject
review accept
select pipe 3
review delete
review previous
camera reset
camera azimuth -30
camera zoom 2
SCRIPT
render "$work/scene.ply" --script "$work/review.txt" --view scene --size 800x500 -o docs/images/studio-review.png
printf 'review next\nfly\n' >"$work/fly.txt"
cat "$work/review.txt" "$work/fly.txt" >"$work/review-fly.txt"
render "$work/scene.ply" --script "$work/review-fly.txt" --view scene --size 800x500 -o docs/images/studio-review-joint.png
printf 'rerun joints accept_confidence=0.9\nreview next\nreview reject\nsave %s\n' "$work/review.piperun" >"$work/save.txt"
render "$work/scene.ply" --script "$work/save.txt" -o "$work/saved.png" >/dev/null
cp "$work/review.piperun" "$work/review.piperun.autosave"
touch -d "@$(($(stat -c %Y "$work/review.piperun") + 60))" "$work/review.piperun.autosave"
render "$work/review.piperun" --size 1280x800 -o docs/images/studio-recovery.png 2>/dev/null

# Hand edits in the window: the fit box around a selected pipe; two pipes selected with the end
# handle on the first.
printf 'color pipes plain\nselect pipe 1\nfly\ncamera zoom 0.8\nbox show\n' >"$work/box.txt"
render "$work/scene.ply" --script "$work/box.txt" --view scene --size 800x500 -o docs/images/studio-fit-box.png
printf 'layer input/points off\ncolor pipes plain\nselect pipe 3\nfly\nhandle on\nclick 400 195 shift\n' >"$work/two.txt"
render "$work/scene.ply" --script "$work/two.txt" --view scene --size 800x500 -o docs/images/studio-two-pipes.png

# A site-sized scan: the medium preset's 25 tiles, one tile's Gaussian sphere and its cube in the
# scene, the scan's points at 1 pixel.
build/app/piperun generate --preset medium --seed 1 -o "$work/medium.ply" >/dev/null
printf 'points size 1\nselect tile 16\n' >"$work/tiles.txt"
render "$work/medium.ply" --script "$work/tiles.txt" --size 1280x800 -o docs/images/studio-tiles.png
