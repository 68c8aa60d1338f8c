#!/usr/bin/env bash
# The render tests' small scene under a roof: a flat slab of points every 2 cm over its whole
# footprint, 30 cm above its highest point (the generator makes no roofs). With `y`, the scene is
# then turned so that y is up, (x, y, z) -> (x, z, -y), as `piperun generate --up y` turns.
# Usage: roofed_scene.sh PIPERUN OUT.xyz [y]
set -euo pipefail
piperun=$1 out=$2 up=${3:-z}
"$piperun" generate --preset small --seed 1 -o "$out" >/dev/null
awk 'NR == 1 { next }
     NR == 2 || $1 < x0 { x0 = $1 } NR == 2 || $1 > x1 { x1 = $1 }
     NR == 2 || $2 < y0 { y0 = $2 } NR == 2 || $2 > y1 { y1 = $2 }
     NR == 2 || $3 > z1 { z1 = $3 }
     END { for (x = x0; x <= x1; x += 0.02) for (y = y0; y <= y1; y += 0.02) printf "%.4f %.4f %.4f 0.5\n", x, y, z1 + 0.3 }' \
  "$out" >"$out.roof"
cat "$out.roof" >>"$out"
rm "$out.roof"
if [[ "$up" == y ]]; then
  # -y by its sign alone, so that every digit stays.
  awk 'NR == 1 { print; next } { y = substr($2, 1, 1) == "-" ? substr($2, 2) : "-" $2; print $1, $3, y, $4 }' \
    "$out" >"$out.turned"
  mv "$out.turned" "$out"
fi
