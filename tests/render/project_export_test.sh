#!/usr/bin/env bash
# The end of a review: the studio's `export` command writes the reviewed network, and
# `piperun export`, `info` and `eval` read a saved project's reviewed network (same bytes).
# Usage: project_export_test.sh PIPERUN_RENDER PIPERUN SCENE WORK_DIR
set -euo pipefail
render=$1 piperun=$2 scene=$3 work=$4
rm -rf "$work"
mkdir -p "$work"
cd "$work"
fail() { echo "project export: $*" >&2; exit 1; }

cat >review.txt <<'SCRIPT'
review next
review reject
select pipe 3
review delete
save review.piperun
export studio.csv
export studio.pcf
export studio.ifc
SCRIPT
env -u DISPLAY "$render" "$scene" --script review.txt -o shot.png --size 320x200 --view scene
[[ -s studio.csv && -s studio.pcf && -s studio.ifc ]] || fail "the studio wrote no export"
grep -q "^3,pipe," studio.csv && fail "the deleted pipe 3 was exported"
[[ $(grep -c "^[0-9]*,pipe," studio.csv) -gt 0 ]] || fail "no pipe exported"

"$piperun" export review.piperun -o cli.csv
cmp studio.csv cli.csv || fail "piperun export of the project differs from the studio's export"
"$piperun" export review.piperun -o cli.pcf
cmp studio.pcf cli.pcf || fail "the PCF exports differ"
"$piperun" export review.piperun -o cli.ifc
# An IFC file's header names the file and the time of export.
cmp <(grep -v "^FILE_NAME(" studio.ifc) <(grep -v "^FILE_NAME(" cli.ifc) || fail "the IFC exports differ"
grep -q "'pipe-3'" studio.ifc && fail "the deleted pipe 3 was exported to IFC"
"$piperun" info review.piperun >info.txt
grep -q "^format: piperun-project version 1" info.txt || fail "info does not name the project format"
grep -q "^metadata: project = reviewed network, 2 edits" info.txt || fail "info does not count the edits"
# Against itself: everything it keeps lies on itself (the deleted pipe and rejected joint still
# count as truth, so recall is below 1).
"$piperun" eval review.piperun review.piperun | tail -1 | grep -q "^precision=1.000 " || fail "eval does not read the project"

# A bad export names the file; the studio script stops there.
printf 'export studio.stl\n' >bad.txt
if env -u DISPLAY "$render" review.piperun --script bad.txt -o shot.png --size 320x200 2>err.txt; then
  fail "export to .stl succeeded"
fi
grep -q "cannot tell the export format from \"studio.stl\"" err.txt || fail "unclear error: $(cat err.txt)"
echo "project export ok"
