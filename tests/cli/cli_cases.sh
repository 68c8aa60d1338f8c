#!/bin/bash
# Command-line tests of `piperun`: cli_cases.sh CASE PIPERUN REAL_DATA_DIR DOCS_DIR
# Each case runs the tool as a user would and checks its output and exit code.
set -u
CASE=$1
PIPERUN=$2
DATA=$3
DOCS=$4
WORK=$(mktemp -d)
trap 'rm -rf "$WORK"' EXIT

fail() { echo "FAIL [$CASE]: $*" >&2; exit 1; }

# run EXPECTED_EXIT ARGS...: runs piperun, keeps stdout/stderr in $OUT/$ERR.
run() {
  local expected=$1
  shift
  "$PIPERUN" "$@" >"$WORK/out" 2>"$WORK/err"
  local code=$?
  OUT=$(cat "$WORK/out")
  ERR=$(cat "$WORK/err")
  if [ "$code" -ne "$expected" ]; then
    fail "piperun $* exited $code, expected $expected; stdout: $OUT; stderr: $ERR"
  fi
}

expect_out() { grep -qE -- "$1" <<<"$OUT" || fail "stdout lacks /$1/: $OUT"; }
expect_err() { grep -qE -- "$1" <<<"$ERR" || fail "stderr lacks /$1/: $ERR"; }
# The error is one line, naming the file.
expect_one_line_error() {
  [ "$(wc -l <<<"$ERR")" -eq 1 ] || fail "error is not one line: $ERR"
  expect_err "^piperun: error: "
  expect_err "$1"
}

case "$CASE" in
  version)
    run 0 --version
    expect_out "^piperun [0-9]+\.[0-9]+\.[0-9]+$"
    for sub in info generate eval convert reconstruct params export; do
      run 0 "$sub" --version
      expect_out "^piperun [0-9]+\.[0-9]+\.[0-9]+$"
    done
    ;;
  help)
    run 0 --help
    for sub in info generate eval convert reconstruct params export; do expect_out "$sub"; done
    expect_out "Exit codes"
    run 0 generate --help
    expect_out "--preset"
    expect_out "--seed"
    ;;
  usage-errors)
    run 1
    expect_one_line_error "subcommand"
    run 1 frobnicate
    run 1 generate --preset huge -o "$WORK/a.ply"
    run 1 generate
    expect_one_line_error "output"
    run 1 eval only-one.json
    ;;
  info-e57)
    run 0 info "$DATA/pumpAVisualReferenceImage.e57"
    expect_out "^points: 155201$"
    expect_out "^format: E57"
    expect_out "colors"
    expect_out "intensity"
    expect_out "^size: 4\.6[0-9]* x 4\.5[0-9]* x 3\.7[0-9]* m$"
    expect_out "^spacing: [0-9]"
    ;;
  info-pcd)
    run 0 info "$DATA/pumpA_pump_station.pcd"
    expect_out "^points: 155201$"
    run 0 info --json "$DATA/table_scene_mug_stereo_textured.pcd"
    expect_out '"points": 209280'
    expect_out '"non_finite_dropped": 97920'
    ;;
  bad-input)
    run 2 info "$WORK/absent.ply"
    expect_one_line_error "absent.ply: no such file"
    printf 'ply\nformat ascii 1.0\nelement vertex 5\nproperty float x\nproperty float y\nproperty float z\nend_header\n1 2 3\n4 5\n' >"$WORK/short.ply"
    run 2 info "$WORK/short.ply"
    expect_one_line_error "short.ply: line"
    printf 'LASF' >"$WORK/scan.laz"
    run 2 info "$WORK/scan.laz"
    expect_one_line_error "decompress"
    head -c 5000 "$DATA/pumpAVisualReferenceImage.e57" >"$WORK/cut.e57"
    run 2 info "$WORK/cut.e57"
    expect_one_line_error "cut.e57: "
    printf '{"format":"piperun-network","version":9,"pipes":[]}' >"$WORK/future.json"
    run 2 eval "$WORK/future.json" "$WORK/future.json"
    expect_one_line_error "version 9"
    ;;
  convert)
    run 0 convert "$DATA/pumpAVisualReferenceImage.e57" "$WORK/pump.ply"
    expect_out "points=155201 "
    run 0 info "$WORK/pump.ply"
    expect_out "^points: 155201$"
    expect_out "colors, intensity"
    run 0 convert --no-colors "$WORK/pump.ply" "$WORK/pump.xyz"
    run 0 info "$WORK/pump.xyz"
    expect_out "^points: 155201$"
    expect_out "^attributes: intensity$"
    ;;
  units)
    # The pump room in millimetres: warned of as far too sparse when read as metres; read with
    # --units mm it is the scan in metres, and gives the same network.
    run 0 convert --no-colors --no-intensity "$DATA/pumpA_pump_station.pcd" "$WORK/m.xyz"
    awk '{ printf "%.9g %.9g %.9g\n", $1 * 1000, $2 * 1000, $3 * 1000 }' "$WORK/m.xyz" >"$WORK/mm.xyz"
    run 0 info "$WORK/mm.xyz"
    expect_out "^units: m$"
    expect_err "^piperun: warning: .*mm.xyz: the scan's points lie 4\.[0-9]+ m apart .*--units \(cm, mm, in, ft, us-ft\)$"
    run 0 info --units mm "$WORK/mm.xyz"
    [ -z "$ERR" ] || fail "warned of a scan read in its unit: $ERR"
    expect_out "^size: 4\.6[0-9]* x 4\.5[0-9]* x 3\.7[0-9]* m$"
    expect_out "^spacing: 4\.[0-9] mm"
    expect_out "^units: mm \(--units\), read as metres$"
    run 0 reconstruct "$WORK/mm.xyz" --units mm -o "$WORK/mm.json"
    expect_out "^units: mm \(--units\), read as metres$"
    run 0 reconstruct "$WORK/m.xyz" -o "$WORK/m.json"
    expect_out "pipes=[1-9][0-9]* joints=[1-9]"
    grep -q '"source_units": "mm"' "$WORK/mm.json" || fail "the network does not record the unit read"
    grep -q '"source_units": "m"' "$WORK/m.json" || fail "the network does not record metres"
    cmp -s <(grep -v '"source' "$WORK/m.json") <(grep -v '"source' "$WORK/mm.json") ||
      fail "the scan in millimetres gave another network than in metres"
    run 0 reconstruct "$WORK/mm.xyz" -o "$WORK/wrong.json"
    expect_err "far too sparse to show pipes"
    expect_out "pipes=0 "
    run 0 convert --units mm "$WORK/mm.xyz" "$WORK/back.ply"
    expect_out "^units: mm \(--units\), written in metres$"
    run 0 info "$WORK/back.ply"
    expect_out "^size: 4\.6[0-9]* x 4\.5[0-9]* x 3\.7[0-9]* m$"
    run 1 reconstruct "$WORK/mm.xyz" --units furlong -o "$WORK/f.json"
    expect_one_line_error "--units: furlong not in \{m,cm,mm,in,ft,us-ft\}"
    run 0 reconstruct --help
    expect_out "--units"
    ;;
  generate-eval)
    run 0 generate --preset small --seed 3 --density 0.25 -o "$WORK/scene.ply" --truth "$WORK/truth.json"
    expect_out "^points=[0-9]+ pipes=[0-9]+ elbows=[0-9]+ tees=[0-9]+ runs=[0-9]+"
    run 0 info "$WORK/scene.ply"
    expect_out "^points: [0-9]+$"
    run 0 info "$WORK/truth.json"
    expect_out "^pipes: [0-9]+"
    # A bill of materials by nominal size: every pipe and joint counted under one size.
    expect_out '^size [0-9/-]+" \(DN [0-9]+\): pipes [0-9]+ \([0-9.]+ m\), elbows [0-9]+( \([^)]*\))?, tees [0-9]+, boundary [0-9]+, proposed 0$'
    # The elbows by fitting (the generator bends mostly by 90°, a few gently), every one listed once.
    expect_out '^size .*, elbows [1-9][0-9]* \([1-9][0-9]* at 90°'
    grep -q "^size .*, elbows 0 (" <<<"$OUT" && fail "a size without elbows lists their fittings"
    elbows=$(sed -nE 's/^joints: [0-9]+ \(elbows ([0-9]+),.*/\1/p' <<<"$OUT")
    fittings=$(sed -nE 's/^size .*, elbows [0-9]+ \(([^)]*)\), tees.*/\1/p' <<<"$OUT" | grep -oE "[0-9]+ (at 90°|at 45°|other)" |
      awk '{ n += $1 } END { print n + 0 }')
    [ "$fittings" -eq "$elbows" ] || fail "the fittings listed ($fittings) are not the $elbows elbows"
    pipes=$(sed -nE 's/^pipes: ([0-9]+) .*/\1/p' <<<"$OUT")
    [ "$(sed -nE 's/^size .*: pipes ([0-9]+) .*/\1/p' <<<"$OUT" | awk '{ n += $1 } END { print n }')" -eq "$pipes" ] ||
      fail "the sizes do not add up to the $pipes pipes"
    # With --runs, one line per run.
    runs=$(sed -nE 's/^runs: ([0-9]+)$/\1/p' <<<"$OUT")
    run 0 info --runs "$WORK/truth.json"
    expect_out '^run [0-9]+: [0-9.]+ m, [0-9/-]+" \(DN [0-9]+\), pipes [1-9][0-9]*, elbows [0-9]+, tees [0-9]+, proposed 0$'
    [ "$(grep -c '^run [0-9]*:' <<<"$OUT")" -eq "$runs" ] || fail "info --runs does not list the $runs runs"
    run 0 info --json "$WORK/truth.json"
    expect_out '"sizes": \['
    expect_out '"elbows_90": [0-9]+'
    run 0 eval "$WORK/truth.json" "$WORK/truth.json"
    expect_out "precision=1.000 recall=1.000 f1=1.000 radius_err_mm=0.0"
    expect_out " accepted_matched=([0-9]+)/\1 proposed_matched=0/0 spurious_accepted=0/[1-9][0-9]* spurious_proposed=0/0"
    run 0 eval --json "$WORK/truth.json" "$WORK/truth.json"
    expect_out '"f1": 1.0'
    # By review status: the truth's first joint proposed is a proposed joint on the truth.
    sed '0,/"status": "accepted"/s//"status": "proposed"/' "$WORK/truth.json" >"$WORK/one_proposed.json"
    run 0 eval "$WORK/truth.json" "$WORK/one_proposed.json"
    expect_out " accepted_matched=([0-9]+)/\1 proposed_matched=([1-9][0-9]*)/\2 spurious_accepted=0/[1-9][0-9]* spurious_proposed=0/1"
    run 0 eval --json "$WORK/truth.json" "$WORK/one_proposed.json"
    expect_out '"proposed": \{'
    # With the labelled scan, recall is also measured over the truth the scan shows.
    run 0 generate --preset small --seed 3 --density 0.25 --labels -o "$WORK/labelled.ply"
    run 0 eval --scan "$WORK/labelled.ply" "$WORK/truth.json" "$WORK/truth.json"
    expect_out " observable=0\.[0-9]+ recall_observable=1\.000 observable_elbows=([0-9]+)/\1 observable_tees=([0-9]+)/\2 corner_seen_elbows=([0-9]+)/\3 corner_seen_tees=([0-9]+)/\4 missed_elbows_unseen=0 missed_elbows_pipe_not_found=0 missed_elbows_not_joined=0 missed_tees_unseen=0 missed_tees_pipe_not_found=0 missed_tees_not_joined=0$"
    # Joint by joint: every truth elbow and tee found (by itself), with the points on its pipes.
    run 0 eval --joints --scan "$WORK/labelled.ply" "$WORK/truth.json" "$WORK/truth.json"
    expect_out "^joint elbow ([0-9]+) found as \1, 0\.000 m off, R ([0-9.]+) -> \2 m, at \(.*\), pipes [0-9]+ \([0-9]+ points, [0-9]+ within [0-9.]+ m\) [0-9]+ \([0-9]+ points, [0-9]+ within [0-9.]+ m\), [0-9]+ points on it$"
    expect_out "^joint tee ([0-9]+) found as \1, 0\.000 m off, at "
    run 0 eval --json --joints "$WORK/truth.json" "$WORK/truth.json"
    expect_out '"spurious": \[\]'
    expect_out '"found": true'
    # The truth's first joint rejected: missed, with every pipe found, so unseen or not joined.
    sed '0,/"status": "accepted"/s//"status": "rejected"/' "$WORK/truth.json" >"$WORK/one_rejected.json"
    run 0 eval --joints --scan "$WORK/labelled.ply" "$WORK/truth.json" "$WORK/one_rejected.json"
    expect_out "^joint (elbow|tee) [0-9]+ missed, .*; (unseen|not_joined) \(found near the corner: 100 % 100 %\)$"
    expect_out " missed_elbows_unseen=[0-9]+ missed_elbows_pipe_not_found=0 missed_elbows_not_joined=[0-9]+ missed_tees_unseen=[0-9]+ missed_tees_pipe_not_found=0 missed_tees_not_joined=[0-9]+$"
    run 0 eval --json --joints --scan "$WORK/labelled.ply" "$WORK/truth.json" "$WORK/one_rejected.json"
    expect_out '"miss_cause": "(unseen|not_joined)"'
    expect_out '"missed_elbows": \{'
    run 1 eval --scan "$WORK/scene.ply" "$WORK/truth.json" "$WORK/truth.json"
    expect_one_line_error "the scan has no labels"
    ;;
  generate-deterministic)
    run 0 generate --preset small --seed 5 --density 0.2 -o "$WORK/a.ply" --truth "$WORK/a.json"
    run 0 generate --preset small --seed 5 --density 0.2 -o "$WORK/b.ply" --truth "$WORK/b.json"
    cmp -s "$WORK/a.ply" "$WORK/b.ply" || fail "same seed gave different points"
    cmp -s "$WORK/a.json" "$WORK/b.json" || fail "same seed gave different truth"
    run 0 generate --preset small --seed 6 --density 0.2 -o "$WORK/c.ply"
    cmp -s "$WORK/a.ply" "$WORK/c.ply" && fail "different seeds gave the same points"
    # Misregistered stations: the first station's points stay, the truth records the error.
    run 0 generate --preset small --seed 5 --density 0.2 --stations 2 -o "$WORK/d.ply"
    run 0 generate --preset small --seed 5 --density 0.2 --stations 2 --registration-error 0.004 \
      -o "$WORK/e.ply" --truth "$WORK/e.json"
    [ "$(stat -c %s "$WORK/d.ply")" -eq "$(stat -c %s "$WORK/e.ply")" ] || fail "misregistration changed the point count"
    cmp -s "$WORK/d.ply" "$WORK/e.ply" && fail "misregistered stations gave the same points"
    grep -q '"registration_error_m": "0.004' "$WORK/e.json" || fail "truth lacks registration_error_m"
    grep -q registration_error "$WORK/a.json" && fail "a registered scene's truth names a registration error"
    run 1 generate --registration-error -1 -o "$WORK/f.ply"
    # Mixed pixels take their rays' places: the same point count, counted on the points line.
    run 0 generate --preset small --seed 5 --density 0.2 --stations 2 --mixed-pixels 1 -o "$WORK/g.ply" --truth "$WORK/g.json"
    expect_out "outliers, [0-9]+ mixed pixels\)"
    [ "$(stat -c %s "$WORK/d.ply")" -eq "$(stat -c %s "$WORK/g.ply")" ] || fail "mixed pixels changed the point count"
    grep -q '"mixed_pixel_share": "1.0' "$WORK/g.json" || fail "truth lacks mixed_pixel_share"
    run 1 generate --mixed-pixels 2 -o "$WORK/f.ply"
    # A roof adds points and is recorded; the scene without one records none.
    run 0 generate --preset small --seed 5 --density 0.2 --stations 2 --roof -o "$WORK/h.ply" --truth "$WORK/h.json"
    [ "$(stat -c %s "$WORK/h.ply")" -gt "$(stat -c %s "$WORK/d.ply")" ] || fail "a roof added no points"
    grep -q '"roof": "true"' "$WORK/h.json" || fail "truth lacks roof"
    grep -q '"roof"' "$WORK/a.json" && fail "a scene without a roof records one"
    ;;
  up)
    # generate --up y turns the z-up scene, (x, y, z) -> (x, z, -y), every digit kept; the truth
    # records the axis.
    run 0 generate --preset small --seed 5 --density 0.2 -o "$WORK/z.xyz" --truth "$WORK/z.json"
    run 0 generate --preset small --seed 5 --density 0.2 --up y -o "$WORK/y.xyz" --truth "$WORK/y.json"
    awk 'NR == 1 { print; next } { y = substr($2, 1, 1) == "-" ? substr($2, 2) : "-" $2; print $1, $3, y, $4 }' \
      "$WORK/z.xyz" >"$WORK/z-turned.xyz"
    cmp -s "$WORK/z-turned.xyz" "$WORK/y.xyz" || fail "generate --up y is not the z-up scene turned"
    grep -q '"up": "y"' "$WORK/y.json" || fail "the turned truth does not record its up axis"
    grep -q '"up"' "$WORK/z.json" && fail "a z-up truth records an up axis"
    # reconstruct --up: said, and recorded in the network (the studio stands its camera on it).
    run 0 reconstruct "$WORK/y.xyz" -o "$WORK/net.json" --up y
    expect_out "^up: y$"
    grep -q '"up": "y"' "$WORK/net.json" || fail "the network does not record its up axis"
    run 0 reconstruct "$WORK/y.xyz" -o "$WORK/net-z.json" --set up=y --up z
    grep -q '^up:' <<<"$OUT" && fail "--up z did not override --set up=y"
    run 0 reconstruct "$WORK/y.xyz" -o "$WORK/net-set.json" --set up=-x
    expect_out "^up: -x$"
    run 1 reconstruct "$WORK/y.xyz" -o "$WORK/net.json" --up w
    expect_one_line_error "--up"
    run 1 reconstruct "$WORK/y.xyz" -o "$WORK/net.json" --set up=north
    expect_one_line_error "parameter up: 'north' is not one of"
    run 1 generate --up sideways -o "$WORK/a.ply"
    # export: a PCF is written with the recorded up axis as z (East, North, Up), so the turned
    # truth's is the z-up truth's; --up overrides the record.
    run 0 export "$WORK/z.json" -o "$WORK/z.pcf"
    run 0 export "$WORK/y.json" -o "$WORK/y.pcf"
    cmp -s "$WORK/z.pcf" "$WORK/y.pcf" || fail "the y-up truth's PCF is not the z-up truth's"
    run 0 export "$WORK/y.json" -o "$WORK/y-as-z.pcf" --up z
    cmp -s "$WORK/z.pcf" "$WORK/y-as-z.pcf" && fail "export --up z did not override the recorded axis"
    run 1 export "$WORK/y.json" -o "$WORK/y.pcf" --up w
    # So is an IFC model, which stands on z (the header's FILE_NAME, with the time, left out).
    run 0 export "$WORK/z.json" -o "$WORK/z.ifc"
    run 0 export "$WORK/y.json" -o "$WORK/y.ifc"
    cmp -s <(grep -v "^FILE_NAME(" "$WORK/z.ifc") <(grep -v "^FILE_NAME(" "$WORK/y.ifc") ||
      fail "the y-up truth's IFC is not the z-up truth's"
    ;;
  params)
    run 0 params
    expect_out "^placement.max_radius = "
    expect_out "^placement.center_bandwidth = 0.01 .*\[m\]  \(> 0\)$"
    expect_out "^directions.min_support = 0.02 .*  \(in \[0, 1\]\)$"
    run 0 params --json
    echo "$OUT" >"$WORK/defaults.json"
    run 0 params --markdown
    # docs/PARAMETERS.md carries the same table as the code: keep them in step.
    diff <(echo "$OUT") <(grep '^|' "$DOCS/PARAMETERS.md") >"$WORK/diff" ||
      fail "docs/PARAMETERS.md differs from 'piperun params --markdown': $(cat "$WORK/diff")"
    printf '{"placement": {"max_radios": 1}}' >"$WORK/bad.json"
    run 2 reconstruct "$DATA/pumpA_pump_station.pcd" -o "$WORK/n.json" --params "$WORK/bad.json"
    expect_one_line_error "/placement/max_radios: unknown parameter"
    run 1 reconstruct "$DATA/pumpA_pump_station.pcd" -o "$WORK/n.json" --set placement.nothing=3
    expect_one_line_error "unknown parameter"
    # Values outside a parameter's range, alone or against another, are refused before any work.
    run 1 reconstruct "$DATA/pumpA_pump_station.pcd" -o "$WORK/n.json" --set placement.center_bandwidth=0
    expect_one_line_error "placement.center_bandwidth must be > 0 m, not 0"
    run 1 reconstruct "$DATA/pumpA_pump_station.pcd" -o "$WORK/n.json" --set placement.max_radius=0.01
    expect_one_line_error "placement.min_radius \(0.012\) must be below placement.max_radius \(0.01\)"
    printf '{"preprocess": {"tile_size": 0.01}}' >"$WORK/small-tiles.json"
    run 2 reconstruct "$DATA/pumpA_pump_station.pcd" -o "$WORK/n.json" --params "$WORK/small-tiles.json"
    expect_one_line_error "/preprocess/tile_size: must be >= 0.5 m, not 0.01"
    [ -e "$WORK/n.json" ] && fail "a refused parameter still wrote a network"
    ;;
  reconstruct)
    run 0 generate --preset small --seed 2 --density 0.5 -o "$WORK/scene.ply" --truth "$WORK/truth.json"
    run 0 reconstruct "$WORK/scene.ply" -o "$WORK/net.json" --threads 2 --dump-stages "$WORK/stages" \
      --truth "$WORK/truth.json"
    expect_out "^preprocess: "
    expect_out "^directions: "
    expect_out "^merge: [0-9]+ pipes"
    expect_out "^joints: [0-9]+ elbows?, [0-9]+ tees?, [0-9]+ boundary joints? \([0-9]+ accepted, [0-9]+ proposed\), [1-9][0-9]* runs?  \[[0-9.]+ s\]$"
    # Under it, what the stage added and left out, each named only when it happened.
    expect_out "^  found: [1-9][0-9]* "
    grep -q " 0 " <<<"$(grep -E "^  (found|merged|left out): " <<<"$OUT")" && fail "a step that did nothing is named: $OUT"
    expect_out "^points=[0-9]+ kept=[0-9]+ directions=[0-9]+ pipes=[1-9][0-9]* joints=[1-9][0-9]* runs=[1-9][0-9]* seconds=[0-9.]+ peak_mb=[1-9][0-9]*$"
    grep -q '"type": "elbow"' "$WORK/net.json" || fail "no elbow in the network"
    grep -q '"runs": \[' "$WORK/net.json" || fail "no runs in the network"
    [ -s "$WORK/stages/preprocessed.ply" ] || fail "no preprocessed.ply"
    [ -s "$WORK/stages/pipes.ply" ] || fail "no pipes.ply"
    [ -s "$WORK/stages/joints.ply" ] || fail "no joints.ply"
    ls "$WORK"/stages/tile_*/round_0/sphere_samples.ply >/dev/null || fail "no sphere samples"
    ls "$WORK"/stages/tile_*/round_0/candidates_0.ply >/dev/null || fail "no circle candidates"
    run 0 info "$WORK/stages/pipes.ply"
    expect_out "labels"
    run 0 eval "$WORK/truth.json" "$WORK/net.json"
    expect_out "elbows=[1-9][0-9]*/[0-9]+ tees=[0-9]+/[0-9]+ spurious_joints="
    f1=$(sed -E 's/.* f1=([0-9.]+).*/\1/' <<<"$(tail -1 <<<"$OUT")")
    awk -v f="$f1" 'BEGIN { exit !(f > 0.6) }' || fail "F1 $f1 too low"
    # A labelled scan is kept past the preprocessing for the recall over what it shows.
    run 0 generate --preset small --seed 2 --density 0.3 --labels -o "$WORK/labelled.ply"
    run 0 reconstruct "$WORK/labelled.ply" -o "$WORK/labelled.json" --truth "$WORK/truth.json"
    expect_out "^evaluation against .* recall_observable=[0-9.]+ "
    expect_out "^points=[1-9][0-9]* kept="
    run 0 reconstruct "$WORK/scene.ply" -o "$WORK/net1.json" --threads 1
    run 0 reconstruct "$WORK/scene.ply" -o "$WORK/net2.json" --threads 2
    cmp -s "$WORK/net1.json" "$WORK/net2.json" || fail "1 and 2 threads gave different networks"
    # Every file the run writes or reads at its end is checked before the scan is read: with a
    # scan that is no point cloud, the error names the output.
    run 2 reconstruct "$WORK/truth.json" -o "$WORK/missing/n.json"
    expect_one_line_error "missing/n.json: cannot create: no folder .*missing$"
    run 2 reconstruct "$WORK/truth.json" -o "$WORK"
    expect_one_line_error "cannot create: it is a folder"
    run 2 reconstruct "$WORK/truth.json" -o "$WORK/n.json" --export obj:"$WORK/missing/n.obj"
    expect_one_line_error "missing/n.obj: cannot create: no folder"
    run 2 reconstruct "$WORK/truth.json" -o "$WORK/n.json" --dump-stages "$WORK/scene.ply/stages"
    expect_one_line_error "scene.ply/stages: cannot create the folder"
    run 2 reconstruct "$WORK/truth.json" -o "$WORK/n.json" --truth "$WORK/absent.json"
    expect_one_line_error "absent.json: no such file"
    [ -e "$WORK/n.json" ] && fail "a failed check left a network"
    ls "$WORK" | grep -q "tmp-" && fail "a check left its probe file"
    run 2 generate --preset small --seed 2 --density 0.1 -o "$WORK/g.ply" --truth "$WORK/missing/g.json"
    expect_one_line_error "missing/g.json: cannot create: no folder"
    [ -e "$WORK/g.ply" ] && fail "generate wrote its scene though it could not write the truth"
    # What is left to review: the pump room's short casings that take no joint are proposed pipes.
    run 0 reconstruct "$DATA/pumpA_pump_station.pcd" -o "$WORK/n.json"
    expect_out "^review: 0 joints and [1-9][0-9]* pipes proposed \(piperun-studio $WORK/n.json, then N steps through them\)$"
    ;;
  export)
    run 0 generate --preset small --seed 1 --density 0.1 -o "$WORK/scene.ply" --truth "$WORK/truth.json"
    elements=$(tail -1 <<<"$OUT" | sed -E 's/.*pipes=([0-9]+) elbows=([0-9]+) tees=([0-9]+).*/\1 + \2 + \3/')
    elements=$((elements))
    for format in obj ply csv dxf pcf ifc; do
      run 0 export "$WORK/truth.json" -o "$WORK/net.$format"
      expect_out "^exported: .*truth.json -> .*net.$format \($format\)$"
      expect_out "^pipes=[1-9][0-9]* elbows=[1-9][0-9]* tees=[1-9][0-9]* boundary=0 left_out=0$"
      [ -s "$WORK/net.$format" ] || fail "net.$format is empty"
    done
    [ "$(grep -c '^o ' "$WORK/net.obj")" -eq "$elements" ] || fail "net.obj lacks one object per element"
    [ "$(wc -l <"$WORK/net.csv")" -eq $((elements + 1)) ] || fail "net.csv lacks one row per element"
    head -c 4 "$WORK/net.ply" | grep -q "^ply" || fail "net.ply is not PLY"
    grep -q "^AC1009" "$WORK/net.dxf" || fail "net.dxf is not DXF R12"
    grep -qx "FILE_SCHEMA(('IFC4'));" "$WORK/net.ifc" || fail "net.ifc is not IFC4"
    [ "$(grep -cE '^#[0-9]+=IFCPIPE(SEGMENT|FITTING)\(' "$WORK/net.ifc")" -eq "$elements" ] ||
      fail "net.ifc lacks one product per element"
    # Read by a DXF library of CAD scripting (Debian's python3-ezdxf): a clean audit, every element's
    # centre line and extended data as in the network.
    ezdxf_reads() {
      /usr/bin/python3 "$(dirname "$0")/dxf_reads_in_ezdxf.py" "$1" "$2" >"$WORK/ezdxf" 2>&1 || fail "ezdxf: $(cat "$WORK/ezdxf")"
    }
    ezdxf_reads "$WORK/truth.json" "$WORK/net.dxf"
    grep -q "^PIPELINE-REFERENCE RUN-" "$WORK/net.pcf" || fail "net.pcf has no pipeline"
    run 0 export "$WORK/truth.json" --format PCF -o "$WORK/iso.txt"
    grep -q "^UNITS-BORE MM" "$WORK/iso.txt" || fail "--format pcf did not write PCF"
    # PCF bores: nominal sizes (DN, whole millimetres) by default, the fitted diameters on request.
    grep -qE "^    END-POINT .* [0-9]+\.0"$'\r'"$" "$WORK/net.pcf" || fail "net.pcf has no nominal bore"
    grep -qE "^    END-POINT .* [0-9]+\.[1-9]"$'\r'"$" "$WORK/net.pcf" && fail "net.pcf has a bore that is no DN"
    run 0 export "$WORK/truth.json" --pcf-bore outside -o "$WORK/od.pcf"
    grep -qE "^    END-POINT .* [0-9]+\.[1-9]"$'\r'"$" "$WORK/od.pcf" || fail "od.pcf has no fitted outside diameter"
    run 1 export "$WORK/truth.json" --pcf-bore od -o "$WORK/x.pcf"
    run 1 export "$WORK/truth.json" -o "$WORK/net.stl"
    expect_one_line_error "cannot tell the export format from .*net.stl"
    run 1 export "$WORK/truth.json" --format stl -o "$WORK/x.obj"
    run 2 export "$WORK/absent.json" -o "$WORK/x.obj"
    expect_one_line_error "absent.json: no such file"
    run 2 export "$WORK/truth.json" -o "$WORK/missing/x.obj"
    expect_one_line_error "missing/x.obj: cannot create"
    # Batch exports from reconstruct: a bad target fails before any work, a good one writes what
    # `export` writes from the saved network.
    run 1 reconstruct "$WORK/scene.ply" -o "$WORK/n.json" --export stl:"$WORK/n.stl"
    expect_one_line_error "FORMAT:FILE"
    [ -e "$WORK/n.json" ] && fail "reconstruct ran despite a bad --export"
    run 0 reconstruct "$WORK/scene.ply" -o "$WORK/n.json" --threads 2 --export obj:"$WORK/r.obj" --export pcf:"$WORK/r.pcf" \
      --pcf-bore outside
    expect_out "^export: .*r.obj \(obj\)$"
    expect_out "^export: .*r.pcf \(pcf\)$"
    run 0 export "$WORK/n.json" -o "$WORK/n.obj"
    run 0 export "$WORK/n.json" -o "$WORK/n.dxf"
    ezdxf_reads "$WORK/n.json" "$WORK/n.dxf"
    # Only what is accepted: a proposed joint is left out, the network file is whole.
    sed '0,/"status": "accepted"/s//"status": "proposed"/' "$WORK/truth.json" >"$WORK/one_proposed.json"
    run 0 export "$WORK/one_proposed.json" --accepted-only -o "$WORK/accepted.csv"
    expect_out "^exported: .*one_proposed.json -> .*accepted.csv \(csv, accepted only\)$"
    expect_out "^pipes=[1-9][0-9]* elbows=[0-9]+ tees=[0-9]+ boundary=0 left_out=1$"
    [ "$(wc -l <"$WORK/accepted.csv")" -eq "$elements" ] || fail "accepted.csv does not leave the proposed joint out"
    grep -q ",proposed," "$WORK/accepted.csv" && fail "accepted.csv holds a proposed element"
    run 0 reconstruct "$WORK/scene.ply" -o "$WORK/a.json" --threads 2 --accepted-only --export csv:"$WORK/a.csv"
    expect_out "^export: .*a.csv \(csv, accepted only\)$"
    cmp -s "$WORK/a.json" "$WORK/n.json" || fail "--accepted-only changed the network written"
    run 0 export "$WORK/a.json" --accepted-only -o "$WORK/a2.csv"
    cmp -s "$WORK/a.csv" "$WORK/a2.csv" || fail "reconstruct --accepted-only differs from export --accepted-only"
    cmp -s "$WORK/r.obj" "$WORK/n.obj" || fail "reconstruct --export differs from export of the saved network"
    run 0 export "$WORK/n.json" --pcf-bore outside -o "$WORK/n.pcf"
    cmp -s "$WORK/r.pcf" "$WORK/n.pcf" || fail "reconstruct --pcf-bore differs from export --pcf-bore"
    ;;
  evaluate-runs)
    # scripts/evaluate.sh --runs: each scene under several pipeline seeds, each run's totals and their mean.
    script="$DOCS/../scripts/evaluate.sh"
    OUT=$(PIPERUN="$PIPERUN" bash "$script" --seeds 4 --runs 2 2>&1) || fail "evaluate.sh --runs 2 failed: $OUT"
    expect_out "^seed=4 run=0 pipeline_seed=4 precision="
    expect_out "^seed=4 run=1 pipeline_seed=104 precision="
    expect_out "^mean: .* seeds=1 runs=2$"
    expect_out "^run 0: elbows=[0-9]+/[0-9]+ tees=[0-9]+/[0-9]+ spurious_joints=[0-9]+/[0-9]+ f1=[0-9.]+$"
    expect_out "^run 1: elbows=[0-9]+/[0-9]+ "
    expect_out "^mean of 2 runs: elbows=[0-9]+\.[0-9]/[0-9]+ tees=[0-9]+\.[0-9]/[0-9]+ spurious_joints=[0-9]+\.[0-9]/[0-9]+ f1=[0-9.]+$"
    expect_out "^by review status: accepted precision=[0-9.]+ spurious_joints=[0-9]+/[0-9]+, proposed precision=([0-9.]+|n/a) spurious_joints=[0-9]+/[0-9]+$"
    OUT=$(PIPERUN="$PIPERUN" bash "$script" --seeds 4 --runs 0 2>&1) && fail "evaluate.sh took --runs 0: $OUT"
    expect_out "needs a positive count"
    ;;
  robustness-registration)
    # scripts/robustness.sh --registration: a row a registration error, with F1 and the joint totals.
    script="$DOCS/../scripts/robustness.sh"
    OUT=$(PIPERUN="$PIPERUN" bash "$script" --registration --seeds 4 --runs 1 2>&1) ||
      fail "robustness.sh --registration failed: $OUT"
    expect_out "^\| registration error \| F1 \| elbows found \| tees found \| spurious joints \|$"
    for error in "0 mm" "1 mm" "2 mm" "5 mm" "10 mm"; do
      expect_out "^\| $error \| [0-9.]+ \| [0-9]+/[0-9]+ \| [0-9]+/[0-9]+ \| [0-9]+/[0-9]+ \|$"
    done
    OUT=$(PIPERUN="$PIPERUN" bash "$script" --bogus 2>&1) && fail "robustness.sh took --bogus: $OUT"
    expect_out "unknown option --bogus"
    ;;
  *)
    fail "unknown case"
    ;;
esac
echo "ok [$CASE]"
