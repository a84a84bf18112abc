#!/usr/bin/env bash
# Tetrahedral meshing part 1 (exact insertion with inside/outside): seconds per stage
# of `idas tetmesh --json` on the tet-meshing inputs, at 1 and 2 threads, and fTetWild's
# log on the same inputs when its binary is given (FTETWILD=path/to/FloatTetwild_bin,
# built by ../shared/peers/build_ftetwild.sh).
#   usage: bench/run_tetmesh_insertion.sh [IDAS_BINARY]   (default build/release/examples/idas)
# Prints one line per run; copy the table into bench/RESULTS.md by hand.
set -euo pipefail
IDAS=${1:-build/release/examples/idas}
DATA=${DATA:-data}
TMP=$(mktemp -d)
trap 'rm -rf "$TMP"' EXIT
printf '%-16s %3s %8s %9s %9s %8s %8s %8s %8s %9s %8s\n' input thr tris inserted tets inside delaunay insertion rounding winding total
for f in ${INPUTS:-bunny.obj 100071_sf.obj 37989_sf.obj blub.obj sphere.obj x.stl hour_glass.off}; do
    for t in 1 2; do
        "$IDAS" tetmesh "$DATA/$f" "$TMP/out.msh" --stage insertion --threads "$t" --json >"$TMP/j.json"
        python3 - "$TMP/j.json" "$f" "$t" <<'PY'
import json, sys
d = json.load(open(sys.argv[1])); s = d['seconds']
print('%-16s %3s %8d %9d %9d %8d %8.2f %8.2f %8.2f %9.2f %8.2f' % (sys.argv[2], sys.argv[3], d['triangles'], d['inserted_triangles'], d['tets'], d['inside_tets'], s['delaunay'], s['insertion'], s['rounding'], s['winding_number'], s['total']))
PY
    done
    if [ -n "${FTETWILD:-}" ]; then
        /usr/bin/time -f "fTetWild $f: %e s wall" "$FTETWILD" -i "$DATA/$f" -o "$TMP/ftw" --max-threads 1 --level 3 \
            >"$TMP/ftw.log" 2>&1 || echo "fTetWild $f: failed"
        grep -iE "time|elapsed" "$TMP/ftw.log" | head -20
    fi
done
