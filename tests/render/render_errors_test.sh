#!/usr/bin/env bash
# piperun-render's failures: exit code and a one-line message naming the file and the place.
# Usage: render_errors_test.sh PIPERUN_RENDER SCENE WORK_DIR
set -uo pipefail
render=$1 scene=$2 work=$3
mkdir -p "$work"
failures=0

expect() {  # CODE PATTERN COMMAND...: the command exits with CODE and its stderr matches PATTERN
  local code=$1 pattern=$2
  shift 2
  local stderr
  stderr=$(env -u DISPLAY "$@" 2>&1 >/dev/null)
  local actual=$?
  if [[ $actual -ne $code || ! "$stderr" =~ $pattern || $(printf '%s\n' "$stderr" | grep -c .) -ne 1 ]]; then
    echo "FAIL: $* -> exit $actual, stderr: $stderr (expected exit $code matching '$pattern')" >&2
    failures=$((failures + 1))
  fi
}

printf 'view sphere\nselect pipe 999\n' >"$work/bad_pipe.txt"
printf 'explode\n' >"$work/unknown.txt"
printf 'merge\n' >"$work/merge_one.txt"
printf 'pick split 10 10\n' >"$work/split_nothing.txt"
printf 'box fit\n' >"$work/no_box.txt"
printf 'handle drop 1 2 3\n' >"$work/no_handle.txt"
expect 2 "piperun-render: error: .*missing\.ply" "$render" "$work/missing.ply" -o "$work/out.png"
expect 2 "bad_pipe\.txt:2: no pipe 999" "$render" "$scene" --no-run --script "$work/bad_pipe.txt" -o "$work/out.png"
expect 2 "unknown\.txt:1: unknown command 'explode'" "$render" "$scene" --no-run --script "$work/unknown.txt" -o "$work/out.png"
expect 2 "merge_one\.txt:1: select two pipes to merge" "$render" "$scene" --no-run --script "$work/merge_one.txt" -o "$work/out.png"
expect 2 "split_nothing\.txt:1: select a pipe to split" "$render" "$scene" --no-run --script "$work/split_nothing.txt" -o "$work/out.png"
expect 2 "no_box\.txt:1: no box shown" "$render" "$scene" --no-run --script "$work/no_box.txt" -o "$work/out.png"
expect 2 "no_handle\.txt:1: no end handle shown" "$render" "$scene" --no-run --script "$work/no_handle.txt" -o "$work/out.png"
# Outputs are checked before the scan is read and the pipeline run; a screenshot's before VTK's
# writer, which says a missing folder is a full disk, over several lines.
expect 2 "piperun-render: error: .*/no-such-dir/texts\.txt: cannot create: no folder" "$render" "$scene" \
  -o "$work/out.png" --text "$work/no-such-dir/texts.txt"
expect 2 "piperun-render: error: .*/no-such-dir/out\.png: cannot create: no folder" "$render" "$scene" \
  -o "$work/no-such-dir/out.png"
expect 2 "piperun-render: error: .*/out\.png: cannot create: no folder" "$render" "$work/missing.ply" \
  -o "$work/no-such-dir/out.png"
printf 'screenshot %s\n' "$work/no-such-dir/shot.png" >"$work/shot.txt"
expect 2 "shot\.txt:1: .*/no-such-dir/shot\.png: cannot create: no folder" "$render" "$scene" --no-run \
  --script "$work/shot.txt" -o "$work/out.png"
expect 1 "--size: expected WIDTHxHEIGHT" "$render" "$scene" --size 12 -o "$work/out.png"
expect 1 "--point-budget: expected at least 1 point" "$render" "$scene" --point-budget 0 -o "$work/out.png"
expect 1 "INPUT and -o OUT.png are required" "$render" "$scene"
expect 1 "^piperun-render: error: --view: bogus not in \\{all,scene,sphere,plane\\} \\(see piperun-render --help\\)$" "$render" "$scene" --view bogus -o "$work/out.png"
expect 1 "--units: furlong not in \\{m,cm,mm,in,ft,us-ft\\}" "$render" "$scene" --units furlong -o "$work/out.png"
exit $((failures > 0))
