#!/usr/bin/env bash
# A scan in millimetres in the studio: read as metres it is warned of, in a notice wrapped to the
# view; read with --units mm it reconstructs, and its saved project reopens in millimetres.
# Usage: units_test.sh PIPERUN_RENDER PIPERUN WORK_DIR
set -uo pipefail
render=$1 piperun=$2 work=$3
rm -rf "$work" && mkdir -p "$work"
fail() { echo "FAIL: $*" >&2; exit 1; }

"$piperun" -q generate --preset small --seed 3 --density 0.3 -o "$work/scene.ply" >/dev/null || fail "generate"
"$piperun" -q convert "$work/scene.ply" "$work/m.xyz" --no-colors --no-intensity --no-labels >/dev/null || fail "convert"
awk '{ printf "%.9g %.9g %.9g\n", $1 * 1000, $2 * 1000, $3 * 1000 }' "$work/m.xyz" >"$work/mm.xyz"

# Read as metres: the warning on stderr and in the notice, whose lines fit the 640 pixel view.
stderr=$(env -u DISPLAY "$render" "$work/mm.xyz" --no-run --size 640x400 -o "$work/metres.png" --text "$work/metres.txt" 2>&1 >/dev/null) ||
  fail "render as metres: $stderr"
[[ $stderr =~ "far too sparse to show pipes".*"--units (cm, mm, in, ft, us-ft)" ]] || fail "no warning: $stderr"
notice=$(sed -n '/^\[notice\]$/,/^\[/p' "$work/metres.txt" | sed '1d;$d')
[ "$(grep -c . <<<"$notice")" -ge 3 ] || fail "the notice is not wrapped: $notice"
awk 'length > 70 { exit 1 }' <<<"$notice" || fail "a notice line is wider than the view: $notice"
grep -q -- "--units" <<<"$notice" || fail "the notice lacks the option: $notice"

# Read in millimetres: no warning, pipes found; the saved project keeps the unit.
printf 'save %s\n' "$work/mm.piperun" >"$work/save.txt"
stderr=$(env -u DISPLAY "$render" "$work/mm.xyz" --units mm --script "$work/save.txt" --size 640x400 -o "$work/mm.png" \
  --text "$work/mm.txt" 2>&1 >/dev/null) || fail "render in millimetres: $stderr"
[ -z "$stderr" ] || fail "warned of a scan read in its unit: $stderr"
grep -qE "^[1-9][0-9]* pipes " "$work/mm.txt" || fail "no pipes from the scan in millimetres: $(cat "$work/mm.txt")"
grep -q "^mm.xyz  [0-9]* points (read in mm)$" "$work/mm.txt" || fail "the status does not say the unit: $(cat "$work/mm.txt")"
grep -q " points (read in" "$work/metres.txt" && fail "a scan read as metres names its unit: $(cat "$work/metres.txt")"
grep -q '"units": "mm"' "$work/mm.piperun" || fail "the project does not record the unit"
stderr=$(env -u DISPLAY "$render" "$work/mm.piperun" --no-run --size 640x400 -o "$work/project.png" --text "$work/project.txt" 2>&1 >/dev/null) ||
  fail "render the project: $stderr"
[ -z "$stderr" ] || fail "the project's scan was not read in millimetres: $stderr"
grep -q "^\[notice\]" "$work/project.txt" && fail "a notice on reopening: $(cat "$work/project.txt")"
exit 0
