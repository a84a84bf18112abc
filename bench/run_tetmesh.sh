#!/usr/bin/env bash
# Tetrahedral meshing, parts 1 and 2 (insertion and quality optimization): `idas tetmesh
# --json` at 1 and 2 threads beside fTetWild at 1 thread (FTETWILD=path/to/FloatTetwild_bin,
# built by ../shared/peers/build_ftetwild.sh), same epsilon (1e-3) and edge length (1/20 of
# the diagonal, or EDGE if set: both tools get it), on the inputs in INPUTS; THREADS lists
# idas's thread counts (default "1 2"), FTETWILD_THREADS fTetWild's (default 1). The 16-core
# comparison of bench/RESULTS.md: THREADS=16 FTETWILD_THREADS=16.
#   usage: bench/run_tetmesh.sh [IDAS_BINARY]   (default build/release/examples/idas)
# Prints one line per run; copy the table into bench/RESULTS.md by hand.
set -euo pipefail
EDGE=${EDGE:-}
IDAS_EDGE=()
FTW_EDGE=()
if [ -n "$EDGE" ]; then IDAS_EDGE=(--edge-length "$EDGE"); FTW_EDGE=(-l "$EDGE"); fi
IDAS=${1:-build/release/examples/idas}
DATA=${DATA:-data}
TMP=$(mktemp -d)
trap 'rm -rf "$TMP"' EXIT
printf '%-16s %-8s %3s %8s %8s %8s %8s %8s %7s %7s %6s %9s %9s %s\n' input tool thr tets verts \
    amips_mn amips_mx mindih rounds stop closed triangles optimize total
for f in ${INPUTS:-sphere.obj hour_glass.off x.stl blub.obj 100071_sf.obj 37989_sf.obj bunny.obj}; do
    for t in ${THREADS:-1 2}; do
        if ! timeout "${LIMIT:-900}" "$IDAS" tetmesh "$DATA/$f" "$TMP/out.msh" --threads "$t" \
            "${IDAS_EDGE[@]}" --json >"$TMP/j.json"; then
            echo "$f idas $t: failed or over ${LIMIT:-900} s"
            continue
        fi
        python3 - "$TMP/j.json" "$f" "$t" <<'PY'
import json, sys
d = json.load(open(sys.argv[1])); s = d['seconds']; o = d['optimization']
print('%-16s %-8s %3s %8d %8d %8.2f %8.3g %8.2f %7d %7s %6s %9s %9.2f %.2f' % (sys.argv[2], 'idas', sys.argv[3],
      d['tets'], d['vertices'], d['amips']['mean'], d['amips']['max'], d['min_dihedral_deg'],
      o['iterations'], 'energy' if o['stopped'] == 'energy_reached' else 'limit',
      'yes' if d['boundary']['closed_2_manifold'] else 'no',
      '%d>%d' % (d['triangles'], d['simplified_triangles']), s['optimization'], s['total']))
PY
    done
    if [ -n "${FTETWILD:-}" ]; then
        for ft in ${FTETWILD_THREADS:-1}; do
            start=$(date +%s.%N)
            if timeout "${LIMIT:-900}" "$FTETWILD" -i "$DATA/$f" -o "$TMP/ftw" --max-threads "$ft" --level 2 \
                "${FTW_EDGE[@]}" >"$TMP/ftw.log" 2>&1; then
                end=$(date +%s.%N)
                opt=$(grep -i "mesh optimization" "$TMP/ftw.log" | grep -oE "[0-9]+\.[0-9]+s" | head -1)
                tets=$(grep -oE "#t = [0-9]+" "$TMP/ftw.log" | tail -1)
                printf '%-16s %-8s %3s %s optimization %s total %.2f\n' "$f" fTetWild "$ft" "$tets" "$opt" \
                    "$(echo "$end - $start" | bc)"
            else
                echo "$f fTetWild $ft: failed"
            fi
        done
    fi
done
