#!/usr/bin/env bash
# Project files through piperun-render: a review script ends in `save`; reopening the project
# restores it exactly (re-saving gives the same bytes), its statuses and its undo history; a changed
# scan and a newer autosave are reported and the project still opens; `recover` takes the autosave.
# Usage: project_roundtrip_test.sh PIPERUN_RENDER SCENE WORK_DIR
set -euo pipefail
render=$1 scene=$2 work=$3
rm -rf "$work"
mkdir -p "$work"
cp "$scene" "$work/scene.ply"  # The project records this copy, which the test then changes.
cd "$work"
run() { env -u DISPLAY "$render" "$@" -o shot.png --size 320x200 --view scene; }

# Statuses in the project's "network" section (top-level keys are indented by one space).
network_of() { awk '/^ "network":/ { inside = 1 } /^ "base":/ { inside = 0 } inside' "$1"; }
count_status() { network_of "$1" | grep -c "\"status\": \"$2\"" || true; }

cat >edits.txt <<'SCRIPT'
# More joints to review: accept only the most confident ones.
rerun joints accept_confidence=0.99
save before.piperun
review next
review reject
review reject
review accept
select pipe 3
review delete
undo
redo
save review.piperun
SCRIPT
run scene.ply --script edits.txt
proposed_before=$(count_status before.piperun proposed)
echo "proposed joints before the review: $proposed_before"
[[ $(count_status review.piperun rejected) -eq 2 ]] || { echo "expected 2 rejected joints" >&2; exit 1; }
[[ $(count_status review.piperun deleted) -eq 1 ]] || { echo "expected 1 deleted pipe" >&2; exit 1; }
[[ $(count_status review.piperun proposed) -eq $((proposed_before - 3)) ]] || { echo "expected 3 joints decided" >&2; exit 1; }

# Reopened and saved again: the same project, byte for byte (network, statuses, parameters,
# fresh stages, history).
printf 'save resaved.piperun\n' >resave.txt
run review.piperun --script resave.txt
cmp review.piperun resaved.piperun || { echo "reopening changed the project" >&2; exit 1; }

# The history came back too: four undos return to the network before the review.
printf 'undo\nundo\nundo\nundo\nsave undone.piperun\n' >undo.txt
run review.piperun --script undo.txt
cmp <(network_of before.piperun) <(network_of undone.piperun) || { echo "undo after reopening did not restore the network" >&2; exit 1; }

# piperun-render never autosaves, however many edits a script makes without saving.
printf 'undo\nundo\nundo\nundo\nredo\nredo\n' >unsaved.txt
run review.piperun --script unsaved.txt
[[ ! -e review.piperun.autosave ]] || { echo "piperun-render autosaved" >&2; exit 1; }

# A changed scan and a newer autosave are reported; the project opens all the same.
printf '\x01' | dd of=scene.ply bs=1 seek=$(($(stat -c %s scene.ply) - 1)) conv=notrunc status=none
cp before.piperun review.piperun.autosave
touch -d "@$(($(stat -c %Y review.piperun) + 60))" review.piperun.autosave
printf 'review on\n' >reopen.txt  # No save: saving would make the autosave obsolete.
run review.piperun --script reopen.txt 2>warnings.txt
cat warnings.txt
grep -q "changed since the project was saved" warnings.txt || { echo "no warning for the changed scan" >&2; exit 1; }
grep -q "review.piperun.autosave is newer than the project" warnings.txt || { echo "no warning for the autosave" >&2; exit 1; }

# `recover` opens the autosave in the project's place, its network as saved whatever the scan;
# `save` without a path writes the project.
printf 'recover\nsave\n' >recover.txt
run review.piperun --script recover.txt 2>/dev/null
cmp <(network_of before.piperun) <(network_of review.piperun) || { echo "recovering did not save the autosave's network" >&2; exit 1; }
[[ ! -e review.piperun.autosave ]] || { echo "saving left the autosave behind" >&2; exit 1; }
echo "project round trip ok"
