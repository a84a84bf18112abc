#!/usr/bin/env bash
# Tetrahedral meshing side by side, one run: idas tetmesh, fTetWild and TetGen on the real
# meshes and on seeded triangle soups (bench/make_soups.py), every output measured the same
# way by `idas info OUT.msh --json --reference IN` (tets, vertices, AMIPS and its histogram,
# smallest dihedral angle, inverted tets by exact orientation, whether the boundary is a
# closed 2-manifold, and the farthest sample of the boundary from the input and of the input
# from the boundary, relative to the input's diagonal).
#
#   bench/run_tetmesh.sh [IDAS_BINARY]   (default build/release/examples/idas)
#
# Environment:
#   INPUTS            files in DATA (default: every surface in data/; "none": soups only)
#   SOUPS             seeds of the generated soups (default "1 2"; empty: none)
#   SOUP_KINDS        which soups of each seed (default "spheres open_boxes shards")
#   THREADS           idas's thread counts (default "1 2")
#   FTETWILD          path to FloatTetwild_bin (built by ../shared/peers/build_ftetwild.sh);
#                     unset: no fTetWild runs
#   FTETWILD_THREADS  fTetWild's thread counts (default "1 2")
#   TETGEN            path to tetgen (default: tetgen on PATH, Debian's package; "none": no
#                     TetGen runs); run as `tetgen -pq1.2`, on one thread (it has no other)
#   EDGE              edge length for idas and fTetWild (relative to the diagonal, both
#                     tools' default 1/20 if unset); epsilon is both tools' default (1e-3)
#   LIMIT             seconds allowed per run (default 900)
#   RESULTS           JSON lines written here (default bench/tetmesh_results.jsonl)
# Then: bench/plot_tetmesh.py --results RESULTS (the table and the plots of RESULTS.md).
set -euo pipefail
IDAS=${1:-build/release/examples/idas}
DATA=${DATA:-data}
LIMIT=${LIMIT:-900}
RESULTS=${RESULTS:-bench/tetmesh_results.jsonl}
TETGEN=${TETGEN:-$(command -v tetgen || echo none)}
HERE=$(cd "$(dirname "$0")" && pwd)
TMP=$(mktemp -d)
trap 'rm -rf "$TMP"' EXIT
IDAS_EDGE=()
FTW_EDGE=()
if [ -n "${EDGE:-}" ]; then IDAS_EDGE=(--edge-length "$EDGE"); FTW_EDGE=(-l "$EDGE"); fi

inputs=()
[ "${INPUTS:-}" = none ] && INPUTS=" "
for f in ${INPUTS:-sphere.obj hour_glass.off x.stl bunny.off blub.obj 100071_sf.obj 37989_sf.obj \
    bunny.obj armadillo.obj edge_with_four_triangles.off}; do
    inputs+=("$DATA/$f")
done
if [ -n "${SOUPS-1 2}" ]; then
    python3 "$HERE/make_soups.py" "$TMP/soups" --seeds ${SOUPS-1 2} >/dev/null
    for kind in ${SOUP_KINDS:-spheres open_boxes shards}; do
        for f in "$TMP"/soups/"$kind"_*.obj; do inputs+=("$f"); done
    done
fi

: >"$RESULTS"
# record INPUT TOOL THREADS STATUS SECONDS_JSON [MSH]: measures MSH against INPUT, appends a line.
record() {
    local input=$1 tool=$2 threads=$3 status=$4 seconds=$5 msh=${6:-}
    local info=null
    if [ "$status" = ok ]; then
        if "$IDAS" info "$msh" --json --reference "$input" >"$TMP/info.json" 2>"$TMP/info.err"; then
            info=$(cat "$TMP/info.json")
        else
            status="unreadable: $(head -c 300 "$TMP/info.err" | tr '\n"' ' ')"
        fi
    fi
    python3 - "$input" "$tool" "$threads" "$status" "$seconds" "$info" >>"$RESULTS" <<'PY'
import json, os, sys
inp, tool, threads, status, seconds, info = sys.argv[1:]
print(json.dumps({"input": os.path.basename(inp), "tool": tool, "threads": int(threads),
                  "status": status, "seconds": json.loads(seconds), "info": json.loads(info)}))
PY
}
now() { date +%s.%N; }
since() { printf '%.3f' "$(echo "$(now) - $1" | bc)"; }

for input in "${inputs[@]}"; do
    name=$(basename "$input")
    for t in ${THREADS:-1 2}; do
        start=$(now)
        if timeout "$LIMIT" "$IDAS" tetmesh "$input" "$TMP/idas.msh" --threads "$t" "${IDAS_EDGE[@]}" \
            --json >"$TMP/j.json" 2>"$TMP/err"; then
            wall=$(since "$start")
            seconds=$(python3 -c 'import json,sys; d=json.load(open(sys.argv[1]))["seconds"]; d["wall"]=float(sys.argv[2]); print(json.dumps(d))' "$TMP/j.json" "$wall")
            record "$input" idas "$t" ok "$seconds" "$TMP/idas.msh"
        else
            record "$input" idas "$t" "failed: $(head -c 300 "$TMP/err" | tr '\n"' ' ')" null
        fi
    done
    if [ -n "${FTETWILD:-}" ]; then
        for t in ${FTETWILD_THREADS:-1 2}; do
            rm -f "$TMP"/ftw*
            start=$(now)
            if timeout "$LIMIT" "$FTETWILD" -i "$input" -o "$TMP/ftw" --max-threads "$t" --level 2 \
                "${FTW_EDGE[@]}" >"$TMP/ftw.log" 2>&1 && [ -s "$TMP/ftw_.msh" ]; then
                wall=$(since "$start")
                # fTetWild's own stage times (its OUT_.csv: stage id, seconds, ...).
                seconds=$(python3 - "$TMP/ftw_.csv" "$wall" <<'PY'
import json, sys
names = {1: "preprocessing", 2: "delaunay", 3: "insertion", 4: "optimization", 5: "winding_number", -1: "total"}
d = {}
for line in open(sys.argv[1]):
    p = [x.strip() for x in line.split(",")]
    if len(p) > 1 and int(p[0]) in names:
        d[names[int(p[0])]] = d.get(names[int(p[0])], 0) + float(p[1])
d["wall"] = float(sys.argv[2])
print(json.dumps(d))
PY
)
                record "$input" fTetWild "$t" ok "$seconds" "$TMP/ftw_.msh"
            else
                record "$input" fTetWild "$t" "failed: $(tail -c 300 "$TMP/ftw.log" | tr '\n"' ' ')" null
            fi
        done
    fi
    if [ "$TETGEN" != none ]; then
        # TetGen reads OFF, PLY and STL, not OBJ; its -p needs a surface without
        # self-intersections (it stops on one: that run counts as failed).
        base="$TMP/tg"
        rm -f "$base".*
        case "$name" in
        *.obj) python3 "$HERE/tetmesh_io.py" obj-to-off "$input" "$base.off"; src="$base.off" ;;
        *) cp "$input" "$base.${name##*.}"; src="$base.${name##*.}" ;;
        esac
        start=$(now)
        if timeout "$LIMIT" "$TETGEN" -pq1.2 -Q "$src" >"$TMP/tg.log" 2>&1 && [ -s "$base.1.ele" ]; then
            wall=$(since "$start")
            python3 "$HERE/tetmesh_io.py" tetgen-to-msh "$base.1" "$TMP/tg.msh"
            record "$input" TetGen 1 ok "{\"wall\": $wall}" "$TMP/tg.msh"
        else
            record "$input" TetGen 1 "failed: $(tail -c 300 "$TMP/tg.log" | tr '\n"' ' ')" null
        fi
    fi
    echo "$name done" >&2
done
python3 "$HERE/plot_tetmesh.py" --results "$RESULTS" --table
