#!/usr/bin/env bash
# End-to-end tests of the idas command-line tool.
#   usage: cli_test.sh IDAS_BINARY DATA_DIR TMP_DIR
# Prints one line per failure and ends with "cli: N passed, M failed"; exits non-zero on
# any failure.
set -u

if [ $# -ne 3 ]; then
    echo "usage: $0 IDAS_BINARY DATA_DIR TMP_DIR" >&2
    exit 2
fi
IDAS=$1
DATA=$2
TMP=$3
rm -rf "$TMP"
mkdir -p "$TMP" || exit 1

passed=0
failed=0
ok() { passed=$((passed + 1)); }
fail() {
    failed=$((failed + 1))
    echo "FAIL: $*"
}

# run ARGS...: runs the tool, leaving stdout in $TMP/out, stderr in $TMP/err, status in $rc.
run() {
    "$IDAS" "$@" >"$TMP/out" 2>"$TMP/err"
    rc=$?
}

# One Python process answers every question about a JSON output: starting python3 costs
# 0.3 s on a small VM and the script asks over 250 of them. A request is "FILE<TAB>EXPR",
# the answer one line: EXPR over the JSON object `d` read from FILE (newlines as \n), or
# empty if FILE is not JSON or EXPR fails; EXPR "one-object" answers whether d is a dict.
coproc JSON_ORACLE {
    python3 -u -c 'import json, sys
for request in sys.stdin:
    path, expr = request.rstrip("\n").split("\t", 1)
    try:
        d = json.load(open(path))
        answer = str(isinstance(d, dict)) if expr == "one-object" else str(eval(expr))
    except Exception:
        answer = ""
    print(answer.replace("\n", "\\n"), flush=True)' 2>/dev/null
}
# ask FILE EXPR: prints the oracle's answer.
ask() {
    local answer
    printf '%s\t%s\n' "$1" "$2" >&"${JSON_ORACLE[1]}"
    IFS= read -r answer <&"${JSON_ORACLE[0]}"
    printf '%s\n' "$answer"
}

# field EXPR: evaluates a Python expression over the JSON object `d` read from $TMP/out.
field() { ask "$TMP/out" "$1"; }

# expect_field NAME EXPR VALUE: the JSON in $TMP/out has EXPR == VALUE.
expect_field() {
    local got
    got=$(field "$2")
    if [ "$got" = "$3" ]; then ok; else fail "$1: $2 is '$got', expected '$3'"; fi
}

# expect_rc NAME CODE: the last run exited with CODE.
expect_rc() {
    if [ "$rc" -eq "$2" ]; then ok; else fail "$1: exit code $rc, expected $2 (stderr: $(head -c 300 "$TMP/err"))"; fi
}

# expect_error NAME CODE [PATTERN]: failed with CODE, stderr starts with "idas: error: ",
# stdout is empty, and stderr matches PATTERN if given.
expect_error() {
    expect_rc "$1" "$2"
    if head -n 1 "$TMP/err" | grep -q '^idas: error: '; then ok; else fail "$1: stderr does not start with 'idas: error: ': $(head -c 300 "$TMP/err")"; fi
    if [ ! -s "$TMP/out" ]; then ok; else fail "$1: stdout is not empty"; fi
    if [ $# -ge 3 ]; then
        if grep -q -- "$3" "$TMP/err"; then ok; else fail "$1: stderr does not mention '$3': $(head -c 300 "$TMP/err")"; fi
    fi
}

# expect_one_json NAME: stdout is exactly one JSON object.
expect_one_json() {
    if [ "$(ask "$TMP/out" one-object)" = True ]; then ok; else fail "$1: stdout is not one JSON object"; fi
}

# ---- info ------------------------------------------------------------------------------------

run info "$DATA/bunny.obj" --json
expect_rc "info bunny.obj" 0
expect_one_json "info bunny.obj"
expect_field "info bunny.obj" 'd["vertices"]' 35947
expect_field "info bunny.obj" 'd["faces"]' 69451
expect_field "info bunny.obj" 'd["euler_characteristic"]' -3
expect_field "info bunny.obj" 'd["boundary_loops"]' 5
expect_field "info bunny.obj" 'd["boundary_edges"]' 223
expect_field "info bunny.obj" 'd["manifold"]' True
expect_field "info bunny.obj" 'd["components"]' 1

run info "$DATA/bunny.obj"
expect_rc "info bunny.obj (text)" 0
if grep -q '35947' "$TMP/out" && grep -q '69451' "$TMP/out"; then ok; else fail "info bunny.obj (text): counts missing"; fi

run info "$DATA/hour_glass.off" --json
expect_rc "info hour_glass.off" 0
expect_one_json "info hour_glass.off"
expect_field "info hour_glass.off" 'd["nonmanifold_vertices"]' 1
expect_field "info hour_glass.off" 'd["manifold"]' False

run info "$DATA/edge_with_four_triangles.off" --json
expect_rc "info edge_with_four_triangles.off" 0
expect_field "info edge_with_four_triangles.off" 'd["nonmanifold_edges"]' 1

run info "$DATA/37989_sf.obj" --json
expect_rc "info 37989_sf.obj" 0
expect_field "info 37989_sf.obj" 'd["nonmanifold_edges"]' 232
expect_field "info 37989_sf.obj" 'd["vertices"]' 5233
expect_field "info 37989_sf.obj" 'd["faces"]' 11210

# --reference: a triangle and its copy a quarter above are a quarter apart both ways.
printf 'v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n' >"$TMP/tri.obj"
printf 'v 0 0 0.25\nv 1 0 0.25\nv 0 1 0.25\nf 1 2 3\n' >"$TMP/tri_up.obj"
run info "$TMP/tri_up.obj" --json --reference "$TMP/tri.obj"
expect_rc "info --reference on a surface" 0
expect_field "info --reference: surface to reference" "abs(d['reference']['surface_to_reference']['max'] - 0.25) < 1e-15" True
expect_field "info --reference: reference to surface" "abs(d['reference']['reference_to_surface']['max'] - 0.25) < 1e-15" True
expect_field "info --reference: relative to the reference's diagonal" "abs(d['reference']['reference_to_surface']['relative'] - 0.25 / 2 ** 0.5) < 1e-15" True
run info "$DATA/bunny.off" --json --reference "$DATA/bunny.off"
expect_field "info --reference on itself" "d['reference']['surface_to_reference']['max'] < 1e-12 and d['reference']['reference_to_surface']['max'] < 1e-12" True
run info "$TMP/tri_up.obj" --reference "$TMP/tri.obj"
if grep -q 'reference -> surface' "$TMP/out"; then ok; else fail "info --reference (text): no distance line"; fi
run info "$TMP/tri_up.obj" --json --reference "$TMP/tri.obj" --samples -1
expect_error "info --samples -1" 2 "samples"
run info "$TMP/tri_up.obj" --json --reference "$TMP/tri.obj" --samples 100000
expect_error "info --samples 100000" 2 "samples"
run info "$TMP/tri_up.obj" --samples 4
expect_error "info --samples without --reference" 2 "reference"
run info "$TMP/tri_up.obj" --reference "$TMP/no_such_reference.obj"
expect_error "info --reference missing file" 2 "no_such_reference.obj"
run info "$DATA/37989_sf.obj"
expect_rc "info 37989_sf.obj (text)" 0
if grep -q 'non-manifold edge (' "$TMP/out"; then ok; else fail "info 37989_sf.obj (text): problems not listed"; fi

# ---- demo ------------------------------------------------------------------------------------

run demo "$DATA/37989_sf.obj" "$TMP/refused.obj"
expect_error "demo 37989_sf.obj" 2 'non-manifold'
if [ ! -e "$TMP/refused.obj" ]; then ok; else fail "demo 37989_sf.obj: wrote an output file"; fi

run demo "$DATA/bunny.off" "$TMP/demo.obj" --json --ops 1000 --seed 3
expect_rc "demo bunny.off" 0
expect_one_json "demo bunny.off"
expect_field "demo bunny.off" 'sum(o["attempted"] for o in d["operations"].values())' 1000
expect_field "demo bunny.off" 'all(o["attempted"] == o["accepted"] + o["rejected"] for o in d["operations"].values())' True
expect_field "demo bunny.off" 'd["operations"]["split"]["accepted"] > 0' True
if [ -s "$TMP/demo.obj" ]; then ok; else fail "demo bunny.off: no output file"; fi
demo_faces=$(field 'd["output_stats"]["faces"]')

run info "$TMP/demo.obj" --json
expect_rc "info demo output" 0
expect_field "info demo output" 'd["manifold"]' True
expect_field "info demo output" 'd["oriented"]' True
expect_field "info demo output" 'd["closed"]' True
expect_field "info demo output" 'd["euler_characteristic"]' 2
expect_field "info demo output" 'd["faces"]' "$demo_faces"

# Same seed, same result.
run demo "$DATA/bunny.off" "$TMP/demo2.obj" --json --ops 1000 --seed 3
if cmp -s "$TMP/demo.obj" "$TMP/demo2.obj"; then ok; else fail "demo bunny.off: not deterministic for a fixed seed"; fi

run demo "$DATA/bunny.off" "$TMP/demo_text.ply" --ops 200
expect_rc "demo bunny.off (text)" 0
if grep -q 'split' "$TMP/out"; then ok; else fail "demo bunny.off (text): no summary"; fi

# ---- convert ---------------------------------------------------------------------------------

run convert "$DATA/bunny.obj" "$TMP/bunny.ply"
expect_rc "convert obj->ply" 0
run convert "$TMP/bunny.ply" "$TMP/bunny_back.obj"
expect_rc "convert ply->obj" 0
run info "$TMP/bunny_back.obj" --json
expect_field "round trip obj->ply->obj" 'd["vertices"]' 35947
expect_field "round trip obj->ply->obj" 'd["faces"]' 69451
expect_field "round trip obj->ply->obj" 'd["euler_characteristic"]' -3

run convert "$DATA/bunny.off" "$TMP/bunny_ascii.stl" --ascii
expect_rc "convert off->ascii stl" 0
if head -c 5 "$TMP/bunny_ascii.stl" 2>/dev/null | grep -q 'solid'; then ok; else fail "convert --ascii: STL is not text"; fi
run info "$TMP/bunny_ascii.stl" --json
expect_field "round trip off->stl" 'd["vertices"]' 3485
expect_field "round trip off->stl" 'd["faces"]' 6966

# ---- errors ----------------------------------------------------------------------------------

: >"$TMP/empty.obj"
printf 'this is not a mesh\n\001\002\003 garbage\n' >"$TMP/garbage.off"
printf 'v 0 0 0\nv 1 0 nan\nv 0 1 0\nf 1 2 3\n' >"$TMP/nan.obj"

run info "$TMP/does_not_exist.obj"
expect_error "info nonexistent" 2 'does_not_exist.obj'
run info "$TMP/empty.obj"
expect_error "info empty file" 2 'empty.obj'
run info "$TMP/garbage.off"
expect_error "info garbage" 2 'garbage.off'
run info "$TMP/nan.obj"
expect_error "info NaN" 2 'nan.obj'
run demo "$TMP/nan.obj" "$TMP/nan_out.obj"
expect_error "demo NaN" 2 'nan.obj'
run info "$TMP/garbage.off" --json
expect_error "info garbage --json" 2
run frobnicate "$DATA/bunny.off"
expect_error "unknown subcommand" 2 'frobnicate'
run info
expect_error "missing argument" 2
run convert "$DATA/bunny.off"
expect_error "convert missing OUT" 2
run
expect_error "no subcommand" 2
run info "$DATA/bunny.off" --no-such-option
expect_error "unknown option" 2
run demo "$DATA/bunny.off" "$TMP/neg.obj" --ops -1
expect_error "negative --ops" 2

run convert "$TMP/garbage.off" "$TMP/never.obj"
expect_error "convert garbage" 2
if [ ! -e "$TMP/never.obj" ]; then ok; else fail "convert garbage: output file exists"; fi
run convert "$TMP/does_not_exist.obj" "$TMP/never2.ply"
expect_error "convert nonexistent" 2
if [ ! -e "$TMP/never2.ply" ]; then ok; else fail "convert nonexistent: output file exists"; fi

# A failed convert leaves an existing output untouched.
cp "$DATA/edge_with_four_triangles.off" "$TMP/keep.off"
run convert "$TMP/garbage.off" "$TMP/keep.off"
expect_error "convert over existing" 2
if cmp -s "$DATA/edge_with_four_triangles.off" "$TMP/keep.off"; then ok; else fail "convert over existing: output changed"; fi

run convert "$DATA/bunny.off" "$TMP/out.xyz"
expect_error "unknown output extension" 2 'xyz'

# ---- decimate --------------------------------------------------------------------------------

for alg in qslim shortest-edge; do
    for t in 1 2; do
        run decimate "$DATA/bunny.obj" "$TMP/dec_${alg}_$t.ply" --algorithm "$alg" --ratio 0.1 --threads "$t" --json
        expect_rc "decimate $alg t=$t" 0
        expect_one_json "decimate $alg t=$t"
        expect_field "decimate $alg t=$t" "d['input_faces']" 69451
        expect_field "decimate $alg t=$t" "d['threads']" "$t"
        expect_field "decimate $alg t=$t" "abs(d['output_faces'] - 6945) <= 69" True
        expect_field "decimate $alg t=$t" "d['seconds_algorithm'] <= d['seconds_total']" True
        expect_field "decimate $alg t=$t phases" "list(d['phases'])" \
            "['read', 'build', 'attributes', 'self_intersection_index', 'decimation_setup', 'decimation', 'decimation_serial_tail', 'export', 'check', 'write', 'total']"
        expect_field "decimate $alg t=$t phases" \
            "min(d['phases'].values()) >= 0 and sum(v for k, v in d['phases'].items() if k != 'total') <= d['phases']['total'] + 1e-6" True
        run info "$TMP/dec_${alg}_$t.ply" --json
        expect_field "decimated $alg t=$t" "d['euler_characteristic']" -3
        expect_field "decimated $alg t=$t" "d['boundary_loops']" 5
        expect_field "decimated $alg t=$t" "d['nonmanifold_edges'] + d['nonmanifold_vertices']" 0
    done
done
# Serial runs are deterministic, and --faces hits the target exactly.
run decimate "$DATA/bunny.off" "$TMP/det1.obj" --faces 1000
run decimate "$DATA/bunny.off" "$TMP/det2.obj" --faces 1000
if cmp -s "$TMP/det1.obj" "$TMP/det2.obj"; then ok; else fail "decimate: serial output not deterministic"; fi
run info "$TMP/det1.obj" --json
expect_field "decimate --faces" "d['faces']" 1000
run decimate "$DATA/37989_sf.obj" "$TMP/nm.obj" --ratio 0.5
expect_error "decimate non-manifold" 2 'non-manifold'
if [ ! -e "$TMP/nm.obj" ]; then ok; else fail "decimate non-manifold: output written"; fi
run decimate "$DATA/bunny.off" "$TMP/x.obj"
expect_error "decimate without target" 2
run decimate "$DATA/bunny.off" "$TMP/x.obj" --ratio 0.5 --faces 10
expect_error "decimate with both targets" 2
run decimate "$DATA/bunny.off" "$TMP/x.obj" --ratio 1.5
expect_error "decimate ratio out of range" 2 'ratio'
run decimate "$DATA/bunny.off" "$TMP/x.obj" --ratio 0.5 --algorithm magic
expect_error "decimate unknown algorithm" 2
run decimate "$DATA/bunny.off" "$TMP/x.obj" --ratio 0.5 --threads 0
expect_error "decimate zero threads" 2

# ---- backends --------------------------------------------------------------------------------

# Both connectivity backends run demo and decimate; the result is a valid mesh either way.
run decimate "$DATA/bunny.obj" "$TMP/dec_ct.ply" --ratio 0.1 --backend corner-table --json
expect_rc "decimate --backend corner-table" 0
expect_one_json "decimate --backend corner-table"
expect_field "decimate --backend corner-table" "d['backend']" corner-table
expect_field "decimate --backend corner-table" "abs(d['output_faces'] - 6945) <= 1" True
run info "$TMP/dec_ct.ply" --json
expect_field "decimated corner-table" "d['euler_characteristic']" -3
expect_field "decimated corner-table" "d['boundary_loops']" 5
expect_field "decimated corner-table" "d['nonmanifold_edges'] + d['nonmanifold_vertices']" 0
run decimate "$DATA/bunny.obj" "$TMP/dec_ct2.ply" --ratio 0.1 --backend corner-table --threads 2 --algorithm shortest-edge --json
expect_rc "decimate --backend corner-table --threads 2" 0
expect_field "decimate --backend corner-table --threads 2" "abs(d['output_faces'] - 6945) <= 69" True
run decimate "$DATA/bunny.off" "$TMP/det_ct.obj" --faces 1000 --backend corner-table
run info "$TMP/det_ct.obj" --json
expect_field "decimate --faces --backend corner-table" "d['faces']" 1000
run decimate "$DATA/bunny.obj" "$TMP/dec_idx.ply" --ratio 0.1 --backend indexed --json
expect_field "decimate --backend indexed" "d['backend']" indexed

run demo "$DATA/bunny.off" "$TMP/demo_ct.obj" --json --ops 1000 --seed 3 --backend corner-table
expect_rc "demo --backend corner-table" 0
expect_field "demo --backend corner-table" 'd["backend"]' corner-table
expect_field "demo --backend corner-table" 'sum(o["attempted"] for o in d["operations"].values())' 1000
run info "$TMP/demo_ct.obj" --json
expect_field "demo corner-table output" 'd["manifold"]' True
expect_field "demo corner-table output" 'd["closed"]' True
expect_field "demo corner-table output" 'd["euler_characteristic"]' 2
run demo "$DATA/bunny.off" "$TMP/demo_ct2.obj" --json --ops 1000 --seed 3 --backend corner-table
if cmp -s "$TMP/demo_ct.obj" "$TMP/demo_ct2.obj"; then ok; else fail "demo --backend corner-table: not deterministic for a fixed seed"; fi

run demo "$DATA/bunny.off" "$TMP/x.obj" --backend linked-list
expect_error "demo unknown backend" 2 'backend'
run decimate "$DATA/bunny.off" "$TMP/x.obj" --ratio 0.5 --backend linked-list
expect_error "decimate unknown backend" 2 'backend'

# --deterministic: the same file at 1 and 3 threads (3 on fewer cores), the target exact.
# bunny.obj (69,451 faces) runs in groups of shards; blub (14,208) is under the serial tail
# (16,384 faces) and gets the serial executor's file.
run decimate "$DATA/bunny.obj" "$TMP/detb1.ply" --ratio 0.1 --deterministic --json
expect_rc "decimate --deterministic bunny.obj" 0
expect_field "decimate --deterministic bunny.obj" "d['deterministic'] and d['grouped'] > 1000" True
expect_field "decimate --deterministic bunny.obj" "d['output_faces'] in (d['target_faces'], d['target_faces'] - 1)" True
run decimate "$DATA/bunny.obj" "$TMP/detb3.ply" --ratio 0.1 --deterministic --threads 3
if cmp -s "$TMP/detb1.ply" "$TMP/detb3.ply"; then ok; else fail "decimate --deterministic bunny.obj: files differ at 1 and 3 threads"; fi
run decimate "$DATA/blub.obj" "$TMP/det1.ply" --ratio 0.1 --deterministic --json
expect_rc "decimate --deterministic" 0
expect_field "decimate --deterministic" "d['deterministic'] and d['grouped'] == 0" True
expect_field "decimate --deterministic" "d['output_faces'] in (d['target_faces'], d['target_faces'] - 1)" True
run decimate "$DATA/blub.obj" "$TMP/det3.ply" --ratio 0.1 --deterministic --threads 3 --json
expect_rc "decimate --deterministic 3 threads" 0
if cmp -s "$TMP/det1.ply" "$TMP/det3.ply"; then ok; else fail "decimate --deterministic: files differ at 1 and 3 threads"; fi
run decimate "$DATA/blub.obj" "$TMP/det_serial.ply" --ratio 0.1 --threads 1
if cmp -s "$TMP/det1.ply" "$TMP/det_serial.ply"; then ok; else fail "decimate --deterministic: blub differs from the serial run"; fi
run decimate "$DATA/blub.obj" "$TMP/det3s.ply" --ratio 0.1 --algorithm shortest-edge --deterministic --threads 3
run decimate "$DATA/blub.obj" "$TMP/det1s.ply" --ratio 0.1 --algorithm shortest-edge --deterministic
if cmp -s "$TMP/det1s.ply" "$TMP/det3s.ply"; then ok; else fail "decimate shortest-edge --deterministic: files differ"; fi
run remesh "$DATA/bunny.off" "$TMP/rdet1.ply" --edge-length 0.02 --iterations 2 --deterministic --json
expect_rc "remesh --deterministic" 0
expect_field "remesh --deterministic" "d['deterministic']" True
run remesh "$DATA/bunny.off" "$TMP/rdet3.ply" --edge-length 0.02 --iterations 2 --deterministic --threads 3
if cmp -s "$TMP/rdet1.ply" "$TMP/rdet3.ply"; then ok; else fail "remesh --deterministic: files differ at 1 and 3 threads"; fi

# ---- remesh ----------------------------------------------------------------------------------

run remesh "$DATA/bunny.off" "$TMP/rem.ply" --edge-length 0.02 --iterations 3 --threads 2 --json
expect_field "remesh phases" "[k for k in d['phases'] if k.startswith('remeshing')]" \
    "['remeshing_setup', 'remeshing', 'remeshing_serial_tail']"
expect_field "remesh phases" "abs(d['phases']['remeshing_setup'] + d['phases']['remeshing'] + d['phases']['remeshing_serial_tail'] - d['seconds_algorithm']) < 0.05" True
expect_field "remesh phases per kind" "sorted(d['remeshing_phases'])" "['collapse', 'smooth', 'split', 'swap']"
expect_field "remesh phases per kind" "sum(p['succeeded'] for p in d['remeshing_phases'].values()) == d['splits'] + d['collapses'] + d['swaps'] + d['smooths']" True
expect_rc "remesh" 0
expect_one_json "remesh"
expect_field "remesh" "d['threads']" 2
expect_field "remesh" "d['output_stats']['valence']['interior_valence6_fraction'] > 0.6" True
expect_field "remesh" "abs(d['output_stats']['edge_length']['mean'] / d['target_edge_length'] - 1) < 0.1" True
run info "$TMP/rem.ply" --json
expect_field "remeshed" "d['euler_characteristic']" 2
# --trace: the quality after every phase, the last one that of the file written.
run remesh "$DATA/bunny.off" "$TMP/rem_trace.ply" --edge-length 0.02 --iterations 2 --threads 2 --trace --json
expect_rc "remesh --trace" 0
expect_field "remesh --trace" "[(q['iteration'], q['phase']) for q in d['trace']]" \
    "[(1, 'split'), (1, 'collapse'), (1, 'swap'), (1, 'smooth'), (2, 'split'), (2, 'collapse'), (2, 'swap'), (2, 'smooth')]"
expect_field "remesh --trace" "d['trace'][-1]['faces'] == d['output_faces']" True
expect_field "remesh --trace" "abs(d['trace'][-1]['min_angle_deg'] - d['output_stats']['angles']['min_deg']) < 1e-6" True
expect_field "remesh --trace" "d['trace'][-1]['valence'] == [d['output_stats']['valence']['min'], d['output_stats']['valence']['max']]" True
run remesh "$DATA/bunny.off" "$TMP/rem_ct.ply" --edge-length 0.02 --iterations 3 --threads 2 --backend corner-table --json
expect_rc "remesh --backend corner-table" 0
expect_field "remesh --backend corner-table" "d['backend']" corner-table
expect_field "remesh --backend corner-table" "d['output_stats']['valence']['interior_valence6_fraction'] > 0.6" True
run info "$TMP/rem_ct.ply" --json
expect_field "remeshed corner-table" "d['euler_characteristic']" 2
run remesh "$DATA/bunny.off" "$TMP/x.obj" --backend linked-list
expect_error "remesh unknown backend" 2 'backend'
run remesh "$DATA/37989_sf.obj" "$TMP/rem_nm.obj"
expect_error "remesh non-manifold" 2 'non-manifold'
run remesh "$DATA/bunny.off" "$TMP/x.obj" --edge-length 0
expect_error "remesh zero length" 2 'edge-length'

# ---- tetrahedral meshes (.msh in and out, .vtu out) -------------------------------------------

TETS="$(cd "$(dirname "$0")" && pwd)/data" # Gmsh spheres: 205 nodes, 679 tets, 320 triangles, 12 other elements
for v in 22_ascii 22_binary 41_ascii 41_binary; do
    run info "$TETS/gmsh_sphere_$v.msh" --json
    expect_rc "info sphere $v" 0
    expect_one_json "info sphere $v"
    expect_field "info sphere $v" 'd["kind"]' tetrahedral
    expect_field "info sphere $v" 'd["tets"]' 679
    expect_field "info sphere $v" 'd["vertices"]' 205
    expect_field "info sphere $v" 'd["skipped_elements"]' 12 # points and lines; the 320 triangles are kept
    expect_field "info sphere $v" 'd["inverted_tets"]' 0
    expect_field "info sphere $v" 'd["euler_characteristic"]' 1
    expect_field "info sphere $v" 'd["faces"] == d["boundary_faces"] + d["interior_faces"]' True
    expect_field "info sphere $v" '4 * d["tets"] == d["boundary_faces"] + 2 * d["interior_faces"]' True
    expect_field "info sphere $v" 'd["boundary"]["closed_2_manifold"]' True
    expect_field "info sphere $v" 'd["boundary"]["genus"]' 0
    expect_field "info sphere $v" 'd["editable"]' True
    expect_field "info sphere $v" '0 < d["dihedral_angle_deg"]["min"] < 70.53 < d["dihedral_angle_deg"]["max"] < 180' True
    expect_field "info sphere $v" '3 <= d["amips"]["min"] <= d["amips"]["mean"] <= d["amips"]["max"]' True
    expect_field "info sphere $v" 'd["amips"]["finite_tets"]' 679
done
run info "$TETS/gmsh_sphere_41_ascii.msh"
expect_rc "info sphere (text)" 0
if grep -q 'closed 2-manifold' "$TMP/out" && grep -q 'AMIPS' "$TMP/out" && grep -q '679' "$TMP/out"; then ok; else fail "info sphere (text): summary missing"; fi

# Round trips through every MSH variant keep the mesh (binary ones bit for bit).
run info "$TETS/gmsh_sphere_41_binary.msh" --json
ref_amips=$(field 'd["amips"]["mean"]')
ref_dihedral=$(field 'd["dihedral_angle_deg"]["min"]')
cp "$TETS/gmsh_sphere_41_binary.msh" "$TMP/tet_0.msh"
i=0
for opts in "--msh-version 2.2" "--msh-version 2.2 --ascii" "--ascii" ""; do
    # shellcheck disable=SC2086
    run convert "$TMP/tet_$i.msh" "$TMP/tet_$((i + 1)).msh" $opts
    expect_rc "convert msh ($opts)" 0
    i=$((i + 1))
done
run info "$TMP/tet_4.msh" --json
expect_field "msh round trip" 'd["tets"]' 679
expect_field "msh round trip" 'd["skipped_elements"]' 0
expect_field "msh round trip" 'd["boundary"]["closed_2_manifold"]' True
expect_field "msh round trip" 'd["amips"]["mean"]' "$ref_amips"
expect_field "msh round trip" 'd["dihedral_angle_deg"]["min"]' "$ref_dihedral"
run convert "$TMP/tet_4.msh" "$TMP/tet_5.msh"
if cmp -s "$TMP/tet_4.msh" "$TMP/tet_5.msh"; then ok; else fail "msh round trip: binary 4.1 is not reproduced exactly"; fi
if head -n 2 "$TMP/tet_2.msh" | grep -q '^2.2 0 8'; then ok; else fail "convert --msh-version 2.2 --ascii: header is not '2.2 0 8'"; fi

for enc in "" "--ascii"; do
    # shellcheck disable=SC2086
    run convert "$TETS/gmsh_sphere_22_ascii.msh" "$TMP/tet$enc.vtu" $enc
    expect_rc "convert msh->vtu $enc" 0
    if grep -q 'NumberOfPoints="205" NumberOfCells="679"' "$TMP/tet$enc.vtu"; then ok; else fail "convert msh->vtu $enc: wrong counts"; fi
done
if grep -q 'format="ascii"' "$TMP/tet--ascii.vtu"; then ok; else fail "convert msh->vtu --ascii: not ascii"; fi

# A tet mesh to a surface format writes its boundary, outward.
run convert "$TETS/gmsh_sphere_22_binary.msh" "$TMP/tet_boundary.obj"
expect_rc "convert msh->obj" 0
run info "$TMP/tet_boundary.obj" --json
expect_field "msh boundary" 'd["faces"]' 320
expect_field "msh boundary" 'd["vertices"]' 162
expect_field "msh boundary" 'd["closed"] and d["manifold"] and d["oriented"]' True
expect_field "msh boundary" 'd["euler_characteristic"]' 2

# Hand-made meshes: one tet, and one tet stored inverted with a second one beside it.
one_tet='$MeshFormat\n2.2 0 8\n$EndMeshFormat\n$Nodes\n5\n1 0 0 0\n2 1 0 0\n3 0 1 0\n4 0 0 1\n5 1 1 1\n$EndNodes\n'
printf "${one_tet}"'$Elements\n1\n1 4 0 1 2 3 4\n$EndElements\n' >"$TMP/one.msh"
run info "$TMP/one.msh" --json
expect_rc "info one tet" 0
expect_field "info one tet" 'd["tets"], d["referenced_vertices"], d["boundary_faces"], d["edges"]' "(1, 4, 4, 6)"
expect_field "info one tet" 'd["boundary"]["closed_2_manifold"]' True
expect_field "info one tet" 'abs(d["dihedral_angle_deg"]["max"] - 90) < 1e-9' True
expect_field "info one tet" 'abs(d["amips"]["min"] - 4.5 / 2 ** (1 / 3)) < 1e-9' True
printf "${one_tet}"'$Elements\n2\n1 4 0 1 3 2 4\n2 4 0 2 3 4 5\n$EndElements\n' >"$TMP/inverted.msh"
run info "$TMP/inverted.msh" --json
expect_rc "info inverted" 0
expect_field "info inverted" 'd["inverted_tets"]' 1
expect_field "info inverted" 'd["editable"]' False
expect_field "info inverted" '"inverted" in d["problem"]' True
expect_field "info inverted" 'd["amips"]["finite_tets"]' 1
run info "$TMP/inverted.msh"
expect_rc "info inverted (text)" 0
if grep -q 'inverted tets *1' "$TMP/out"; then ok; else fail "info inverted (text): count missing"; fi
# Files are data: an inverted tet is still converted as stored.
run convert "$TMP/inverted.msh" "$TMP/inverted_copy.msh"
expect_rc "convert inverted" 0

# Bad tet input: exit 2, the file named, no output left behind.
head -c 20000 "$TETS/gmsh_sphere_41_binary.msh" >"$TMP/truncated.msh"
head -c 9000 "$TETS/gmsh_sphere_22_ascii.msh" >"$TMP/truncated_ascii.msh"
printf '$MeshFormat\n2.2 0 8\n$EndMeshFormat\n\001\002garbage\377\n' >"$TMP/garbage.msh"
printf "${one_tet}"'$Elements\n1\n1 4 0 1 2 3 9\n$EndElements\n' >"$TMP/out_of_range.msh"
printf '$MeshFormat\n2.2 0 8\n$EndMeshFormat\n$Nodes\n999999999\n1 0 0 0\n$EndNodes\n' >"$TMP/lying.msh"
printf "${one_tet}"'$Elements\n5\n1 4 0 1 2 3 4\n$EndElements\n' >"$TMP/lying_elements.msh"
printf "${one_tet}"'$Elements\n1\n1 2 0 1 2 3\n$EndElements\n' >"$TMP/no_tets.msh"
for bad in truncated truncated_ascii garbage out_of_range lying lying_elements no_tets; do
    run info "$TMP/$bad.msh"
    expect_error "info $bad.msh" 2 "$bad.msh"
    run info "$TMP/$bad.msh" --json
    expect_error "info $bad.msh --json" 2
    for ext in msh vtu obj; do
        run convert "$TMP/$bad.msh" "$TMP/never_$bad.$ext"
        expect_error "convert $bad.msh -> $ext" 2 "$bad.msh"
        if [ ! -e "$TMP/never_$bad.$ext" ]; then ok; else fail "convert $bad.msh -> $ext: output file exists"; fi
    done
done
if ls "$TMP" | grep -q '\.tmp'; then fail "tet convert: temporary files left behind"; else ok; fi
cp "$TMP/one.msh" "$TMP/keep.msh"
run convert "$TMP/garbage.msh" "$TMP/keep.msh"
expect_error "convert over existing msh" 2
if cmp -s "$TMP/one.msh" "$TMP/keep.msh"; then ok; else fail "convert over existing msh: output changed"; fi

run info "$TMP/tet.vtu"
expect_error "info vtu" 2 'tet.vtu'
run convert "$DATA/bunny.off" "$TMP/never_tets.msh"
expect_error "convert surface -> msh" 2 'bunny.off'
if [ ! -e "$TMP/never_tets.msh" ]; then ok; else fail "convert surface -> msh: output file exists"; fi
run convert "$TMP/one.msh" "$TMP/never.xyz"
expect_error "convert msh -> unknown extension" 2 'never.xyz'
run convert "$TMP/one.msh" "$TMP/never.msh" --msh-version 3.0
expect_error "convert --msh-version 3.0" 2
run convert "$TMP/one.msh" "$TMP/never.vtu" --msh-version 2.2
expect_error "convert --msh-version to vtu" 2 'msh-version'
if [ ! -e "$TMP/never.msh" ] && [ ! -e "$TMP/never.vtu" ]; then ok; else fail "convert bad options: output file exists"; fi

# ---- harmonic --------------------------------------------------------------------------------

run harmonic "$TMP/h.msh" --gaussian 2000 --seed 3 --json
expect_rc "harmonic gaussian" 0
expect_field "harmonic gaussian" "d['points']" 2000
expect_field "harmonic gaussian" "d['mode']" complete
expect_field "harmonic gaussian" "d['mean_harmonic_index_after'] < d['mean_harmonic_index_before']" True
expect_field "harmonic gaussian" "d['max_energy_after'] <= d['max_energy_before']" True
expect_field "harmonic gaussian" "d['flips'] > 0 and d['smoothed'] > 0" True
expect_field "harmonic phases" "[k for k in d['phases'] if k in ('generate', 'delaunay', 'build', 'flipping', 'check', 'write')]" \
    "['generate', 'delaunay', 'build', 'flipping', 'check', 'write']"
if [ -s "$TMP/h.msh" ]; then ok; else fail "harmonic gaussian: no output"; fi
run info "$TMP/h.msh" --json
expect_rc "harmonic output reads back" 0
run harmonic "$TMP/h2.msh" --gaussian 2000 --seed 3 --json
if cmp -s "$TMP/h.msh" "$TMP/h2.msh"; then ok; else fail "harmonic: serial output not deterministic"; fi
run harmonic "$TMP/hd1.msh" --gaussian 2000 --seed 3 --deterministic
run harmonic "$TMP/hd3.msh" --gaussian 2000 --seed 3 --deterministic --threads 3 --json
expect_field "harmonic --deterministic" "d['deterministic']" True
if cmp -s "$TMP/hd1.msh" "$TMP/hd3.msh"; then ok; else fail "harmonic --deterministic: files differ at 1 and 3 threads"; fi
run harmonic "$TMP/h.vtu" --gaussian 2000 --seed 3 --mode reduced --threads 2 --json
expect_rc "harmonic reduced vtu 2 threads" 0
expect_field "harmonic reduced" "d['smoothed']" 0
expect_field "harmonic reduced" "d['tets_after'] == d['tets_before'] - d['flips']" True
# The adjacency tet backend: the same serial reduced run flips the same faces.
run harmonic "$TMP/hi.msh" --gaussian 2000 --seed 3 --mode reduced --json
indexed_result=$(field "[d['flips'], d['tets_after'], round(d['mean_harmonic_index_after'], 12)]")
run harmonic "$TMP/ha.msh" --gaussian 2000 --seed 3 --mode reduced --backend adjacency --json
expect_rc "harmonic adjacency backend" 0
expect_field "harmonic adjacency backend" "d['backend']" adjacency
expect_field "harmonic adjacency backend" "[d['flips'], d['tets_after'], round(d['mean_harmonic_index_after'], 12)]" "$indexed_result"
run info "$TMP/ha.msh" --json
expect_rc "harmonic adjacency output reads back" 0
run harmonic "$TMP/never_h.msh" --gaussian 100 --backend corner
expect_rc "harmonic unknown backend" 2
printf '# four points and a duplicate\n0 0 0\n1 0 0\n0 1 0\n0 0 1\n1 0 0\n0.3 0.3 0.3\n' >"$TMP/pts.xyz"
run harmonic "$TMP/pts.msh" --points "$TMP/pts.xyz" --json
expect_rc "harmonic xyz" 0
expect_field "harmonic xyz" "d['duplicate_points']" 1
run harmonic "$TMP/g.msh" --points "$DATA/gaussian_points_100k.ply" --mode reduced
expect_rc "harmonic ply 100k" 0
printf '0 0 0\n1 0 0\n0 1 0\n1 1 0\n' >"$TMP/flat.xyz"
run harmonic "$TMP/never_h.msh" --points "$TMP/flat.xyz"
expect_error "harmonic coplanar points" 2 'flat.xyz'
printf '0 0 0\n1 zero 0\n' >"$TMP/bad.xyz"
run harmonic "$TMP/never_h.msh" --points "$TMP/bad.xyz"
expect_error "harmonic bad xyz" 2 'bad.xyz'
run harmonic "$TMP/never_h.msh" --points "$TMP/missing.ply"
expect_error "harmonic missing input" 2 'missing.ply'
run harmonic "$TMP/never_h.obj" --gaussian 100
expect_error "harmonic bad output extension" 2 'never_h.obj'
run harmonic "$TMP/never_h.msh"
expect_error "harmonic without input" 2
run harmonic "$TMP/never_h.msh" --gaussian 100 --points "$TMP/pts.xyz"
expect_error "harmonic with two inputs" 2
run harmonic "$TMP/never_h.msh" --gaussian 100 --mode fancy
expect_error "harmonic bad mode" 2
run harmonic "$TMP/never_h.msh" --gaussian 3
expect_error "harmonic too few points" 2
if ls "$TMP" | grep -q 'never_h'; then fail "harmonic: output written on bad input"; else ok; fi

# ---- reliability (issue 16) -------------------------------------------------------------------

# Geometry ranges: coordinates whose lengths or areas over- or underflow in double precision
# are refused by every command, naming the file (mesh/geometry_range.hpp: |x| <= 1e50,
# bounding box at least 1e-50 wide).
# scale_off IN OUT M: writes the OFF file IN scaled so its largest coordinate magnitude is M.
scale_off() {
    python3 - "$1" "$2" "$3" <<'PY'
import sys
lines = open(sys.argv[1]).read().split('\n')
nv = int(lines[1].split()[0])
largest = max(abs(float(x)) for i in range(2, 2 + nv) for x in lines[i].split())
target = float(sys.argv[3])
for i in range(2, 2 + nv):
    lines[i] = ' '.join(repr(float(x) / largest * target) for x in lines[i].split())
open(sys.argv[2], 'w').write('\n'.join(lines))
PY
}
scale_off "$DATA/bunny.off" "$TMP/bunny_huge.off" 9e307
scale_off "$DATA/bunny.off" "$TMP/bunny_e310.off" 1e-310
scale_off "$DATA/bunny.off" "$TMP/bunny_e318.off" 1e-318
tet_obj() { printf 'v 0 0 0\nv %s 0 0\nv 0 %s 0\nv 0 0 %s\nf 1 3 2\nf 1 2 4\nf 2 3 4\nf 1 4 3\n' "$1" "$1" "$1"; }
tet_obj 1e-320 >"$TMP/tet_tiny.obj"
tet_obj 1e308 >"$TMP/tet_huge.obj"
tet_obj 1e-60 >"$TMP/tet_small.obj"
for bad in bunny_huge.off bunny_e310.off bunny_e318.off tet_tiny.obj tet_huge.obj tet_small.obj; do
    run info "$TMP/$bad"
    expect_error "info $bad" 2 "$TMP/$bad: "
    run info "$TMP/$bad" --json
    expect_error "info $bad --json" 2 'supported'
    run convert "$TMP/$bad" "$TMP/never_range.obj"
    expect_error "convert $bad" 2 "$bad"
    run decimate "$TMP/$bad" "$TMP/never_range.obj" --ratio 0.5
    expect_error "decimate $bad" 2 "$bad"
    for b in indexed corner-table; do
        run remesh "$TMP/$bad" "$TMP/never_range.obj" --backend "$b"
        expect_error "remesh $bad --backend $b" 2 "$bad"
    done
    run demo "$TMP/$bad" "$TMP/never_range.obj"
    expect_error "demo $bad" 2 "$bad"
done
run info "$TMP/bunny_huge.off"
expect_error "info bunny_huge.off says why" 2 'beyond the supported range'
run info "$TMP/tet_tiny.obj"
expect_error "info tet_tiny.obj says why" 2 'below the supported minimum'
if [ ! -e "$TMP/never_range.obj" ]; then ok; else fail "geometry range: an output was written"; fi
printf '0 0 0\n1e300 0 0\n0 1e300 0\n0 0 1e300\n' >"$TMP/huge.xyz"
run harmonic "$TMP/never_h.msh" --points "$TMP/huge.xyz"
expect_error "harmonic huge points" 2 'huge.xyz'
printf '0 0 0\n1e-320 0 0\n0 1e-320 0\n0 0 1e-320\n' >"$TMP/tiny.xyz"
run harmonic "$TMP/never_h.msh" --points "$TMP/tiny.xyz"
expect_error "harmonic tiny points" 2 'tiny.xyz'
printf '$MeshFormat\n2.2 0 8\n$EndMeshFormat\n$Nodes\n4\n1 0 0 0\n2 1e200 0 0\n3 0 1e200 0\n4 0 0 1e200\n$EndNodes\n$Elements\n1\n1 4 0 1 2 3 4\n$EndElements\n' >"$TMP/huge.msh"
run info "$TMP/huge.msh"
expect_error "info huge.msh" 2 'huge.msh'
run convert "$TMP/huge.msh" "$TMP/never_range.vtu"
expect_error "convert huge.msh" 2 'huge.msh'

# Two triangles on the same three vertices, oppositely oriented: a closed sphere that no
# operation may turn into a non-manifold (alone, and as a component of bunny.off).
printf 'v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\nf 1 3 2\n' >"$TMP/pair.obj"
python3 - "$DATA/bunny.off" "$TMP/bunny_pair.off" <<'PY'
import sys
lines = [l for l in open(sys.argv[1]).read().split('\n') if l.strip()]
nv, nf, _ = map(int, lines[1].split())
verts, faces = lines[2:2 + nv], lines[2 + nv:2 + nv + nf]
verts += ['0.2 0 0', '0.25 0 0', '0.2 0.05 0']
faces += ['3 %d %d %d' % (nv, nv + 1, nv + 2), '3 %d %d %d' % (nv, nv + 2, nv + 1)]
open(sys.argv[2], 'w').write('OFF\n%d %d 0\n' % (nv + 3, nf + 2) + '\n'.join(verts + faces) + '\n')
PY
for b in indexed corner-table; do
    run remesh "$TMP/pair.obj" "$TMP/pair_$b.obj" --backend "$b" --json
    expect_rc "remesh pair --backend $b" 0
    run info "$TMP/pair_$b.obj" --json
    expect_field "remeshed pair ($b)" 'd["manifold"], d["oriented"], d["closed"], d["euler_characteristic"]' "(True, True, True, 2)"
    run remesh "$TMP/bunny_pair.off" "$TMP/bunny_pair_$b.obj" --edge-length 0.02 --iterations 2 --backend "$b" --json
    expect_rc "remesh bunny+pair --backend $b" 0
    expect_field "remesh bunny+pair --backend $b" "d['seconds_check'] >= 0" True
    run info "$TMP/bunny_pair_$b.obj" --json
    expect_field "remeshed bunny+pair ($b)" 'd["manifold"], d["oriented"], d["components"], d["euler_characteristic"]' "(True, True, 2, 4)"
done
run decimate "$TMP/bunny_pair.off" "$TMP/bunny_pair_dec.obj" --ratio 0.2 --json
expect_rc "decimate bunny+pair" 0
expect_field "decimate bunny+pair" "d['seconds_check'] >= 0" True
run info "$TMP/bunny_pair_dec.obj" --json
expect_field "decimated bunny+pair" 'd["manifold"], d["oriented"], d["euler_characteristic"]' "(True, True, 4)"
run remesh "$DATA/bunny.off" "$TMP/rem_text.obj" --edge-length 0.05 --iterations 1
if grep -q 'result check' "$TMP/out"; then ok; else fail "remesh (text): result check time missing"; fi
run harmonic "$TMP/hc.msh" --gaussian 200 --json
expect_field "harmonic result check" "d['seconds_check'] >= 0" True

# --threads is capped (32767 threads aborted the process).
for t in 1025 32767 4294967295; do
    run decimate "$DATA/bunny.off" "$TMP/never_t.obj" --ratio 0.5 --threads "$t"
    expect_error "decimate --threads $t" 2 'threads'
    run remesh "$DATA/bunny.off" "$TMP/never_t.obj" --threads "$t"
    expect_error "remesh --threads $t" 2 'threads'
    run harmonic "$TMP/never_t.msh" --gaussian 100 --threads "$t"
    expect_error "harmonic --threads $t" 2 'threads'
done
if ls "$TMP" | grep -q 'never_t'; then fail "--threads: output written"; else ok; fi

# An STL that convert wrote reads back, even with a face whose distinct vertices share a
# position (the reader welds them and drops the face, saying so).
printf 'v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 0\nv 0 0 1\nf 1 2 3\nf 1 4 5\n' >"$TMP/shared.obj"
for enc in "" "--ascii"; do
    # shellcheck disable=SC2086
    run convert "$TMP/shared.obj" "$TMP/shared$enc.stl" $enc
    expect_rc "convert shared-position face to stl $enc" 0
    run info "$TMP/shared$enc.stl" --json
    expect_rc "info shared-position stl $enc" 0
    expect_field "info shared-position stl $enc" 'd["faces"], d["vertices"]' "(1, 3)"
    if grep -q 'dropped 1 face' "$TMP/err"; then ok; else fail "info shared-position stl $enc: no warning about the dropped face"; fi
done

# Absurd options: exit 2, naming the option.
for v in 0 -1 nan inf; do
    run remesh "$DATA/bunny.off" "$TMP/never_o.obj" --envelope "$v"
    expect_error "remesh --envelope $v" 2 'envelope'
done
for v in -1 nan 500; do
    run remesh "$DATA/bunny.off" "$TMP/never_o.obj" --feature-angle "$v"
    expect_error "remesh --feature-angle $v" 2 'feature-angle'
done
for v in -1 nan 0; do
    run decimate "$DATA/bunny.off" "$TMP/never_o.obj" --ratio "$v"
    expect_error "decimate --ratio $v" 2 'ratio'
done
run decimate "$DATA/bunny.off" "$TMP/never_o.obj" --faces -5
expect_error "decimate --faces -5" 2 'faces'
run harmonic "$TMP/never_o.msh" --gaussian 18446744073709551615
expect_error "harmonic --gaussian 2^64-1" 2 'gaussian'
run remesh "$DATA/bunny.off" "$TMP/never_o.obj" --edge-length 1e-5
expect_error "remesh --edge-length 1e-5" 2 'edge-length'
run remesh "$DATA/bunny.off" "$TMP/never_o.obj" --edge-length 0.02 --max-faces 1000
expect_error "remesh --max-faces 1000" 2 'max-faces'
tet_obj 1e40 >"$TMP/tet_1e40.obj"
run remesh "$TMP/tet_1e40.obj" "$TMP/never_o.obj" --edge-length 1e300
expect_error "remesh --edge-length 1e300" 2 'edge-length'
if ls "$TMP" | grep -q 'never_o'; then fail "absurd options: output written"; else ok; fi
run remesh "$DATA/bunny.off" "$TMP/rem_feat.obj" --edge-length 0.05 --iterations 1 --feature-angle 0
expect_rc "remesh --feature-angle 0" 0

# SIGTERM during the write removes the temporary file; the output never appears. The
# output is large (a grid written as ASCII STL) so the write lasts long enough to be caught.
mkdir -p "$TMP/sig"
python3 - "$TMP/sig/grid.obj" <<'PY'
import sys
n = 400
out = ['v %d %d 0' % (x, y) for y in range(n) for x in range(n)]
for y in range(n - 1):
    for x in range(n - 1):
        a = y * n + x + 1
        out.append('f %d %d %d' % (a, a + 1, a + n + 1))
        out.append('f %d %d %d' % (a, a + n + 1, a + n))
open(sys.argv[1], 'w').write('\n'.join(out) + '\n')
PY
caught=0
for attempt in 1 2 3 4 5; do
    "$IDAS" convert "$TMP/sig/grid.obj" "$TMP/sig/out.stl" --ascii >/dev/null 2>&1 &
    pid=$!
    seen=0
    while kill -0 "$pid" 2>/dev/null; do
        if compgen -G "$TMP/sig/out.stl.tmp.*" >/dev/null; then
            kill -TERM "$pid"
            seen=1
            break
        fi
        sleep 0.002
    done
    wait "$pid"
    status=$?
    # The write may finish between seeing its temporary file and the signal: then the
    # run ended well (exit 0, output complete) and the signal came too late; try again.
    if [ "$seen" -eq 1 ] && [ "$status" -eq 0 ]; then seen=0; fi
    if [ "$seen" -eq 1 ]; then
        caught=1
        if [ "$status" -eq 143 ]; then ok; else fail "SIGTERM: exit status $status, expected 143"; fi
        if compgen -G "$TMP/sig/out.stl.tmp.*" >/dev/null; then fail "SIGTERM: temporary file left behind"; else ok; fi
        if [ ! -e "$TMP/sig/out.stl" ]; then ok; else fail "SIGTERM: output exists"; fi
        break
    fi
    rm -f "$TMP/sig/out.stl"
done
if [ "$caught" -eq 1 ]; then ok; else fail "SIGTERM: the write was never caught in progress"; fi

# ---- tetmesh ---------------------------------------------------------------------------------

run tetmesh "$DATA/hour_glass.off" "$TMP/hg.msh" --stage insertion --json
expect_rc "tetmesh hour_glass" 0
expect_one_json "tetmesh hour_glass"
expect_field "tetmesh hour_glass" "d['inserted_triangles'] == d['triangles'] == 512" True
expect_field "tetmesh hour_glass" "d['inverted_tets']" 0
expect_field "tetmesh hour_glass" "0 < d['inside_tets'] < d['tets']" True
run info "$TMP/hg.msh" --json
expect_rc "tetmesh output reads back" 0
run tetmesh "$DATA/hour_glass.off" "$TMP/hg_ascii.msh" --stage insertion --ascii --json
expect_rc "tetmesh ascii" 0
tags=$(awk '/\$Elements/{e=1;next} /\$EndElements/{e=0} e && NF==9 {print $4}' "$TMP/hg_ascii.msh" | sort -u | tr '\n' ' ')
if [ "$tags" = "1 2 " ]; then ok; else fail "tetmesh: MSH physical tags are '$tags', expected '1 2 '"; fi
run tetmesh "$DATA/hour_glass.off" "$TMP/hg2.msh" --stage insertion --json --threads 2
if cmp -s "$TMP/hg.msh" "$TMP/hg2.msh"; then ok; else fail "tetmesh: 1 and 2 threads give different files"; fi
run tetmesh "$DATA/x.stl" "$TMP/x.msh" --stage insertion --json
expect_rc "tetmesh x.stl soup" 0
expect_field "tetmesh x.stl" "d['inserted_triangles'] == d['triangles']" True
printf 'v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n' >"$TMP/flat.obj"
run tetmesh "$TMP/flat.obj" "$TMP/flat.msh"
expect_error "tetmesh flat input" 2 "encloses no volume"
if [ ! -e "$TMP/flat.msh" ]; then ok; else fail "tetmesh flat input: wrote an output"; fi
printf 'v 0 0 0\nv 1 0 0\nv nan 1 0\nv 0 0 1\nf 1 2 3\nf 1 2 4\n' >"$TMP/nan.obj"
run tetmesh "$TMP/nan.obj" "$TMP/nan.msh"
expect_error "tetmesh NaN coordinate" 2
printf 'v 0 0 0\nv 1e308 0 0\nv 0 1 0\nv 0 0 1\nf 1 2 3\nf 1 2 4\n' >"$TMP/huge.obj"
run tetmesh "$TMP/huge.obj" "$TMP/huge.msh"
expect_error "tetmesh 1e308 coordinate" 2
printf 'v 0 0 0\nv 1 0 0\nv 2 0 0\nf 1 2 3\n' >"$TMP/degenerate.obj"
run tetmesh "$TMP/degenerate.obj" "$TMP/degenerate.msh"
expect_error "tetmesh only degenerate faces" 2 "degenerate"
# Seeded soups (bench/make_soups.py) whose triangle pairs share an edge whose line crosses a
# background tet's edge where a third plane crosses it too: that cut point was made twice,
# and the cone of its cell made a flat tet ("a cone made a flat tet", exit 1).
python3 "$(dirname "$0")/../bench/make_soups.py" "$TMP/soups" --seeds 5 >/dev/null
for soup in open_boxes_5 spheres_5; do
    run tetmesh "$TMP/soups/$soup.obj" "$TMP/$soup.msh" --stage insertion --no-simplify --json
    expect_rc "tetmesh $soup insertion" 0
    expect_field "tetmesh $soup insertion" "d['inserted_triangles'] == d['triangles'] and d['inverted_tets'] == 0" True
done
# The full run: insertion and optimization.
run tetmesh "$DATA/hour_glass.off" "$TMP/hgq.msh" --json
expect_rc "tetmesh optimize hour_glass" 0
expect_field "tetmesh optimize" "d['optimization']['stopped']" energy_reached
expect_field "tetmesh optimize" "d['amips']['max'] <= 10 and d['flat_or_inverted_tets'] == 0" True
expect_field "tetmesh optimize" "d['boundary']['closed_2_manifold']" True
expect_field "tetmesh optimize simplifies" "d['inserted_triangles'] == d['simplified_triangles'] < d['triangles']" True
if [ -s "$TMP/err" ]; then fail "tetmesh optimize: a run that met its stop energy wrote to stderr: $(head -c 300 "$TMP/err")"; else ok; fi
# A run that stops above its stop energy writes its output and says so on stderr.
run tetmesh "$DATA/hour_glass.off" "$TMP/hg_short.msh" --stop-energy 3 --max-iterations 1 --stall-rounds 0 --json
expect_rc "tetmesh stopped early" 0
expect_field "tetmesh stopped early" "d['optimization']['stopped']" iteration_limit
if grep -q "^idas: warning: .*hg_short.msh: the largest AMIPS energy .* is above the stop energy 3 (stopped: iteration_limit)" "$TMP/err"; then ok; else fail "tetmesh stopped early: no warning on stderr: $(head -c 300 "$TMP/err")"; fi
if [ -s "$TMP/hg_short.msh" ]; then ok; else fail "tetmesh stopped early: no output"; fi
run info "$TMP/hgq.msh" --json
expect_rc "tetmesh optimized output reads back" 0
expect_field "info's AMIPS histogram counts every finite tet" "sum(d['amips']['histogram']['counts']) == d['amips']['finite_tets'] == d['tets']" True
expect_field "info's AMIPS histogram: none above the stop energy" "sum(c for b, c in zip(d['amips']['histogram']['bounds'], d['amips']['histogram']['counts']) if b >= 10)" 0
# The boundary lies within the envelope (epsilon: 1e-3 of the input's diagonal), measured
# apart from the envelope the run used.
run info "$TMP/hgq.msh" --json --reference "$DATA/hour_glass.off" --samples 25
expect_rc "info --reference" 0
expect_field "tetmesh boundary within epsilon of the input" "0 <= d['reference']['surface_to_reference']['relative'] <= 1e-3 * (1 + 1e-9)" True
expect_field "the input near the tetmesh boundary" "0 <= d['reference']['reference_to_surface']['relative'] < 0.05" True
expect_field "info --reference samples" "d['reference']['samples_per_face']" 25
run info "$DATA/hour_glass.off" --reference "$TMP/hgq.msh"
expect_error "info --reference a tet mesh" 2 "triangle surface"
# x.stl's second round leaves a few tets above the stop energy (one thread): collapses,
# swaps and smoothing clear them, and no third round runs.
run tetmesh "$DATA/x.stl" "$TMP/xq.msh" --json
expect_field "tetmesh touch-up" "d['optimization']['touch_ups'] >= 1 and d['optimization']['stopped'] == 'energy_reached'" True
expect_field "tetmesh per-round counts" "len(d['optimization']['tets_above_stop_per_round']) == d['optimization']['iterations'] and d['optimization']['tets_above_stop_per_round'][-1] == 0" True
run tetmesh "$DATA/hour_glass.off" "$TMP/hgq2.msh" --json
if cmp -s "$TMP/hgq.msh" "$TMP/hgq2.msh"; then ok; else fail "tetmesh: two runs on one thread give different files"; fi
run tetmesh "$DATA/hour_glass.off" "$TMP/hgd1.msh" --deterministic --json
expect_rc "tetmesh --deterministic" 0
expect_field "tetmesh --deterministic" "d['deterministic'] and d['amips']['max'] <= 10 and d['flat_or_inverted_tets'] == 0" True
run tetmesh "$DATA/hour_glass.off" "$TMP/hgd3.msh" --deterministic --threads 3 --json
if cmp -s "$TMP/hgd1.msh" "$TMP/hgd3.msh"; then ok; else fail "tetmesh --deterministic: 1 and 3 threads give different files"; fi
run tetmesh "$DATA/hour_glass.off" "$TMP/hgq_all.msh" --keep-outside --ascii --threads 2 --json
expect_rc "tetmesh optimize --keep-outside on 2 threads" 0
expect_field "tetmesh --keep-outside" "d['tets'] > d['inside_tets'] > 0" True
run tetmesh "$DATA/hour_glass.off" "$TMP/hg_ns.msh" --no-simplify --json
expect_rc "tetmesh --no-simplify" 0
expect_field "tetmesh --no-simplify" "d['inserted_triangles'] == d['simplified_triangles'] == d['triangles'] == 512 and d['amips']['max'] <= 10" True
run tetmesh "$DATA/hour_glass.off" "$TMP/hg3.msh" --stop-energy 2
expect_error "tetmesh stop energy below 3" 2 "stop-energy"
# A stop energy no mesh reaches (3: every tet regular): the run ends when a round improves
# on neither the best largest energy nor the best count above it, not after 80 rounds.
run tetmesh "$DATA/hour_glass.off" "$TMP/hg_stall.msh" --stop-energy 3 --stall-rounds 1 --json
expect_rc "tetmesh --stall-rounds" 0
expect_field "tetmesh stops when stalled" "d['optimization']['stopped'] == 'stalled' and 2 <= d['optimization']['iterations'] < 80" True
run tetmesh "$DATA/hour_glass.off" "$TMP/hg_stall.msh" --stall-rounds 1000000
expect_error "tetmesh --stall-rounds too large" 2 "stall-rounds"
run tetmesh "$DATA/hour_glass.off" "$TMP/hg.xyz"
expect_error "tetmesh wrong extension" 2 ".msh or .vtu"
# VTU output with its cell fields, MSH 4.1 with both tags, and the boundary surface.
run tetmesh "$DATA/hour_glass.off" "$TMP/hgq.vtu" --boundary "$TMP/hgq_boundary.obj" --json
expect_rc "tetmesh .vtu --boundary" 0
if grep -q 'Name="region"' "$TMP/hgq.vtu" && grep -q 'Name="amips"' "$TMP/hgq.vtu"; then ok; else fail "tetmesh .vtu: no region or amips cell field"; fi
run info "$TMP/hgq_boundary.obj" --json
expect_rc "tetmesh --boundary reads back" 0
expect_field "tetmesh --boundary is closed" "d['closed'] and d['manifold'] and d['oriented']" True
run tetmesh "$DATA/hour_glass.off" "$TMP/hgq41.msh" --msh-version 4.1 --keep-outside --json
expect_rc "tetmesh --msh-version 4.1" 0
tets41=$(field "d['tets']")
run info "$TMP/hgq41.msh" --json
expect_field "tetmesh 4.1 output reads back" "d['tets']" "$tets41"
if python3 - "$TMP/hgq41.msh" <<'PY'
import sys
data = open(sys.argv[1], 'rb').read()
sys.exit(0 if data.startswith(b'$MeshFormat\n4.1 1 8') and b'$Entities' in data else 1)
PY
then ok; else fail "tetmesh --msh-version 4.1: not a 4.1 file with entities"; fi
run tetmesh "$DATA/hour_glass.off" "$TMP/hgq.msh" --boundary "$TMP/b.xyz"
expect_error "tetmesh --boundary unknown extension" 2 "boundary"
# Sizing: a constant coarser than the default gives fewer tets; a sizing mesh whose
# lengths are four times smaller on the low-x half gives shorter edges there.
run tetmesh "$DATA/hour_glass.off" "$TMP/hg_default.msh" --json
default_tets=$(field "d['tets']")
run tetmesh "$DATA/hour_glass.off" "$TMP/hg_coarse.msh" --sizing 0.1 --json
expect_rc "tetmesh --sizing constant" 0
expect_field "tetmesh --sizing 0.1 coarser than the default" "d['tets'] < $default_tets" True
python3 - "$TMP/hgq_all.msh" "$TMP/sizing_bg.msh" "$TMP/sizing_bg_nodata.msh" <<'PY'
import sys
# The optimized hour_glass with its outside (MSH 2.2 ASCII) as the background mesh.
lines = open(sys.argv[1]).read().split('\n')
i = lines.index('$Nodes'); n = int(lines[i + 1]); nodes = lines[i + 2:i + 2 + n]
xs = [float(l.split()[1]) for l in nodes]
ys = [float(l.split()[2]) for l in nodes]; zs = [float(l.split()[3]) for l in nodes]
lo, hi = min(xs), max(xs)
diag = ((hi - lo) ** 2 + (max(ys) - min(ys)) ** 2 + (max(zs) - min(zs)) ** 2) ** 0.5
mid = (lo + hi) / 2
values = ['%s %r' % (l.split()[0], diag / 40 if float(l.split()[1]) < mid else diag / 10) for l in nodes]
body = '\n'.join(lines).rstrip('\n')
open(sys.argv[3], 'w').write(body + '\n')
open(sys.argv[2], 'w').write(body + '\n$NodeData\n1\n"length"\n1\n0\n3\n0\n1\n%d\n%s\n$EndNodeData\n' % (n, '\n'.join(values)))
PY
run tetmesh "$DATA/hour_glass.off" "$TMP/hg_sized.msh" --sizing "$TMP/sizing_bg.msh" --ascii --json
expect_rc "tetmesh --sizing FILE.msh" 0
expect_field "tetmesh --sizing FILE.msh meets the stop energy" "d['amips']['max'] <= 10 and d['boundary']['closed_2_manifold']" True
if python3 - "$TMP/hg_sized.msh" <<'PY'
import sys, math
lines = open(sys.argv[1]).read().split('\n')
i = lines.index('$Nodes'); n = int(lines[i + 1])
P = {int(l.split()[0]): tuple(map(float, l.split()[1:4])) for l in lines[i + 2:i + 2 + n]}
j = lines.index('$Elements'); m = int(lines[j + 1])
lo = min(p[0] for p in P.values()); hi = max(p[0] for p in P.values())
acc = {0: [0, 0], 1: [0, 0]}
for l in lines[j + 2:j + 2 + m]:
    v = [P[int(x)] for x in l.split()[5:9]]
    cx = sum(p[0] for p in v) / 4
    side = 0 if cx < lo + 0.3 * (hi - lo) else 1 if cx > hi - 0.3 * (hi - lo) else None
    if side is None: continue
    for a in range(4):
        for b in range(a + 1, 4):
            acc[side][0] += math.dist(v[a], v[b]); acc[side][1] += 1
fine, coarse = acc[0][0] / acc[0][1], acc[1][0] / acc[1][1]
print('fine %.4g coarse %.4g' % (fine, coarse))
sys.exit(0 if fine < 0.7 * coarse else 1)
PY
then ok; else fail "tetmesh --sizing FILE.msh: edges on the fine side are not shorter"; fi
run tetmesh "$DATA/hour_glass.off" "$TMP/hg3.msh" --sizing "$TMP/sizing_bg_nodata.msh"
expect_error "tetmesh --sizing mesh without \$NodeData" 2 "NodeData"
run tetmesh "$DATA/hour_glass.off" "$TMP/hg3.msh" --sizing "$TMP/missing_sizing.msh"
expect_error "tetmesh --sizing missing file" 2 "missing_sizing.msh"
run tetmesh "$DATA/hour_glass.off" "$TMP/hg3.msh" --sizing banana
expect_error "tetmesh --sizing garbage" 2 "sizing"
run tetmesh "$DATA/hour_glass.off" "$TMP/hg3.msh" --sizing 0
expect_error "tetmesh --sizing 0" 2 "sizing"
run tetmesh "$DATA/hour_glass.off" "$TMP/hg3.msh" --sizing 0.1 --stage insertion
expect_error "tetmesh --sizing with --stage insertion" 2 "sizing"
run tetmesh "$DATA/hour_glass.off" "$TMP/hg3.msh" --edge-length 1e-5
expect_error "tetmesh --edge-length far too small" 2 "1/1000"
if [ ! -e "$TMP/hg3.msh" ]; then ok; else fail "tetmesh: a refused run left an output"; fi
run tetmesh "$DATA/hour_glass.off" "$TMP/hg3.msh" --edge-length -1
expect_error "tetmesh negative edge length" 2 "edge-length"
run tetmesh "$DATA/hour_glass.off" "$TMP/hg3.msh" --epsilon nan
expect_error "tetmesh NaN epsilon" 2

# ---- attributes (issue 21) --------------------------------------------------------------------

run info "$DATA/blub.obj"
expect_rc "info blub.obj" 0
if grep -q 'attributes: uv (corner, float64 x2)' "$TMP/out"; then ok; else fail "info blub.obj: uv not listed: $(grep attributes "$TMP/out")"; fi
run info "$DATA/blub.obj" --json
expect_field "info --json attributes" "[(a['name'], a['domain'], a['width']) for a in d['attributes']]" "[('uv', 'corner', 2)]"
run convert "$DATA/blub.obj" "$TMP/blub_copy.obj"
expect_rc "convert blub.obj keeps texture" 0
if [ "$(grep -c '^vt ' "$TMP/blub_copy.obj")" -gt 7000 ] && grep -q '^mtllib ./blub.mtl' "$TMP/blub_copy.obj" && grep -q '^f [0-9]*/[0-9]* ' "$TMP/blub_copy.obj"; then ok; else fail "convert blub.obj: vt, mtllib or f v/vt lost"; fi
run convert "$DATA/blub.obj" "$TMP/blub_bare.obj" --drop-attributes
expect_rc "convert --drop-attributes" 0
if ! grep -q '^vt ' "$TMP/blub_bare.obj"; then ok; else fail "convert --drop-attributes: vt written"; fi
run convert "$DATA/blub.obj" "$TMP/blub.off"
expect_rc "convert textured OBJ to OFF" 0
if grep -q "warning: .*blub.off cannot store these attributes, not written: uv (corner)" "$TMP/err"; then ok; else fail "convert to OFF: no warning about the lost uv: $(head -c 300 "$TMP/err")"; fi
# A coloured OFF keeps its colours through PLY; PLY lists idas cannot hold are named.
printf 'COFF\n3 1\n0 0 0 255 0 0\n1 0 0 0 255 0\n0 1 0 0 0 255\n3 0 1 2\n' > "$TMP/coloured.off"
run convert "$TMP/coloured.off" "$TMP/coloured.ply" --ascii
expect_rc "convert COFF to PLY" 0
if grep -q '^property uchar red$' "$TMP/coloured.ply" && grep -q '^0 0 0 255 0 0$' "$TMP/coloured.ply"; then ok; else fail "convert COFF to PLY: colours lost: $(head -c 300 "$TMP/coloured.ply")"; fi
printf 'ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\nelement face 1\nproperty list uchar int vertex_indices\nproperty list uchar int flags\nend_header\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2 1 7\n' > "$TMP/lists.ply"
run convert "$TMP/lists.ply" "$TMP/lists_out.ply"
expect_rc "convert PLY with a list property" 0
if grep -q "warning: .*lists.ply: not kept (idas cannot hold them): flags (face list property)" "$TMP/err"; then ok; else fail "convert PLY: no warning about the skipped list: $(head -c 300 "$TMP/err")"; fi
run decimate "$DATA/blub.obj" "$TMP/blub_dec.obj" --ratio 0.1 --json
expect_rc "decimate textured" 0
expect_field "decimate textured: uv carried" "[a['name'] for a in d['attributes']]" "['uv']"
expect_field "decimate textured: seam vertices kept" "d['constrained_vertices'] > 100" True
if [ "$(grep -c '^f [0-9]*/[0-9]* [0-9]*/[0-9]* [0-9]*/[0-9]*$' "$TMP/blub_dec.obj")" = "$(field "d['output_faces']")" ]; then ok; else fail "decimate textured: faces without texture coordinates"; fi
run decimate "$DATA/blub.obj" "$TMP/blub_dec_bare.obj" --ratio 0.1 --drop-attributes --json
expect_field "decimate --drop-attributes" "d['attributes']" "[]"
if ! grep -q '^vt ' "$TMP/blub_dec_bare.obj"; then ok; else fail "decimate --drop-attributes: vt written"; fi
run decimate "$DATA/blub.obj" "$TMP/blub_det1.obj" --ratio 0.1 --deterministic
run decimate "$DATA/blub.obj" "$TMP/blub_det3.obj" --ratio 0.1 --deterministic --threads 3
if cmp -s "$TMP/blub_det1.obj" "$TMP/blub_det3.obj"; then ok; else fail "decimate --deterministic with texture: 1 and 3 threads differ"; fi
run decimate "$DATA/bunny.obj" "$TMP/bunny_kb.ply" --ratio 0.1 --keep-boundary --json
expect_rc "decimate --keep-boundary" 0
expect_field "decimate --keep-boundary" "d['constrained_vertices']" "223"
run decimate "$DATA/bunny.obj" "$TMP/bunny_fa.ply" --ratio 0.1 --feature-angle 200
expect_error "decimate --feature-angle 200" 2 "feature-angle"
run remesh "$DATA/blub.obj" "$TMP/blub_rem.obj" --edge-length 0.02 --iterations 2 --json
expect_rc "remesh textured" 0
expect_field "remesh textured: uv carried" "[a['name'] for a in d['attributes']]" "['uv']"
if [ "$(grep -c '^vt ' "$TMP/blub_rem.obj")" -gt 100 ]; then ok; else fail "remesh textured: no vt written"; fi
run --version
expect_rc "--version" 0
if grep -q '^idas [0-9]*\.[0-9]*\.[0-9]*$' "$TMP/out"; then ok; else fail "--version: $(cat "$TMP/out")"; fi

# ---- attribute weight (issue 21 item 2) -------------------------------------------------------

run decimate "$DATA/blub.obj" "$TMP/blub_w_default.obj" --ratio 0.1 --json
expect_field "decimate: default attribute weight" "d['attribute_weight']" "0.2"
run decimate "$DATA/blub.obj" "$TMP/blub_w0.obj" --ratio 0.1 --attribute-weight 0 --json
expect_rc "decimate --attribute-weight 0" 0
expect_field "decimate --attribute-weight 0" "d['attribute_weight']" "0.0"
if ! cmp -s "$TMP/blub_w0.obj" "$TMP/blub_w_default.obj"; then ok; else fail "decimate --attribute-weight 0: same output as the default weight"; fi
for w in -1 nan inf; do
    run decimate "$DATA/blub.obj" "$TMP/blub_w_bad.obj" --ratio 0.1 --attribute-weight=$w
    expect_error "decimate --attribute-weight $w" 2 "attribute-weight must be a finite number >= 0"
done
run decimate "$DATA/blub.obj" "$TMP/blub_w_sec.obj" --ratio 0.1 --algorithm shortest-edge --attribute-weight 1
expect_error "decimate --attribute-weight with shortest-edge" 2 "qslim only"
run decimate "$DATA/blub.obj" "$TMP/blub_w_drop.obj" --ratio 0.1 --drop-attributes --attribute-weight 1
expect_error "decimate --attribute-weight with --drop-attributes" 2 "drop-attributes"

# ---- self-intersections (issue 16 item 5 b) --------------------------------------------------
# A thin bumpy plate (tests/test_support.hpp's noisy_thin_plate): two nearly touching sheets,
# where QSlim to 10% without the invariant folds one through the other.
python3 - "$TMP/plate.obj" <<'PY'
import sys
n, thickness, noise = 32, 0.02, 0.5
ids, verts, faces = {}, [], []
def at(c):
    if c not in ids:
        ids[c] = len(verts)
        x, y, z = (v / n for v in c)
        bump = 0.0
        if c[2] in (0, n) and 0 < c[0] < n and 0 < c[1] < n:
            h = ((c[0] * 73856093) ^ (c[1] * 19349663) ^ (c[2] * 83492791)) & 0xffffffff
            h = (h * 2654435761) & 0xffffffff
            bump = noise * (((h >> 8) % 1000) / 1000.0 - 0.5)
        verts.append((x, y, thickness * (z + bump)))
    return ids[c]
for axis in range(3):
    for side in range(2):
        for i in range(n):
            for j in range(n):
                def p(u, w):
                    c = [0, 0, 0]
                    c[axis], c[(axis + 1) % 3], c[(axis + 2) % 3] = side * n, u, w
                    return at(tuple(c))
                a, b, c, d = p(i, j), p(i + 1, j), p(i + 1, j + 1), p(i, j + 1)
                faces += [(a, b, c), (a, c, d)] if side else [(a, c, b), (a, d, c)]
with open(sys.argv[1], "w") as f:
    f.writelines("v %.17g %.17g %.17g\n" % v for v in verts)
    f.writelines("f %d %d %d\n" % (a + 1, b + 1, c + 1) for a, b, c in faces)
PY
# crossings FILE: the exact count of face pairs of FILE that meet (idas info).
crossings() {
    run info "$1" --self-intersections --json
    field "d['self_intersections']"
}
expect_value() {
    if [ "$2" = "$3" ]; then ok; else fail "$1: got '$2', expected '$3'"; fi
}
expect_value "info --self-intersections: the plate" "$(crossings "$TMP/plate.obj")" 0
run info "$TMP/plate.obj" --self-intersections
if grep -q '^self-intersecting face pairs: 0$' "$TMP/out"; then ok; else fail "info --self-intersections: text line missing"; fi
run info "$TMP/plate.obj" --json
expect_field "info without --self-intersections" "'self_intersections' in d" "False"
run decimate "$TMP/plate.obj" "$TMP/plate_free.obj" --ratio 0.1 --algorithm qslim --allow-self-intersections --json
expect_field "decimate --allow-self-intersections" "d['self_intersections_refused']" "False"
if [ "$(crossings "$TMP/plate_free.obj")" -gt 0 ]; then ok; else fail "decimate --allow-self-intersections: the plate did not fold (the test below would prove nothing)"; fi
for threads in 1 2 8; do
    for algorithm in qslim shortest-edge; do
        run decimate "$TMP/plate.obj" "$TMP/plate_dec.obj" --ratio 0.1 --algorithm $algorithm --threads $threads --json
        expect_rc "decimate $algorithm $threads threads: plate" 0
        expect_field "decimate $algorithm $threads threads: refuses crossings" "d['self_intersections_refused']" "True"
        expect_field "decimate $algorithm $threads threads: target" "d['output_faces'] <= 1229" "True"
        expect_value "decimate $algorithm $threads threads: no crossings" "$(crossings "$TMP/plate_dec.obj")" 0
    done
done
run decimate "$TMP/plate.obj" "$TMP/plate_det1.obj" --ratio 0.1 --deterministic
run decimate "$TMP/plate.obj" "$TMP/plate_det3.obj" --ratio 0.1 --deterministic --threads 3
if cmp -s "$TMP/plate_det1.obj" "$TMP/plate_det3.obj"; then ok; else fail "decimate --deterministic with the invariant: 1 and 3 threads differ"; fi
expect_value "decimate --deterministic: no crossings" "$(crossings "$TMP/plate_det3.obj")" 0
for threads in 1 2; do
    run remesh "$TMP/plate.obj" "$TMP/plate_rem.obj" --edge-length 0.04 --iterations 3 --threads $threads --json
    expect_rc "remesh $threads threads: plate" 0
    expect_field "remesh $threads threads: refuses crossings" "d['self_intersections_refused']" "True"
    expect_value "remesh $threads threads: no crossings" "$(crossings "$TMP/plate_rem.obj")" 0
done
run remesh "$DATA/bunny.obj" "$TMP/bunny_free.ply" --edge-length 0.02 --iterations 1 --allow-self-intersections --json
expect_field "remesh --allow-self-intersections" "d['self_intersections_refused']" "False"

# ---- help ------------------------------------------------------------------------------------

run --help
expect_rc "--help" 0
if grep -q 'info' "$TMP/out" && grep -q 'demo' "$TMP/out"; then ok; else fail "--help: subcommands not listed"; fi
run demo --help
expect_rc "demo --help" 0
if grep -q -- '--seed' "$TMP/out"; then ok; else fail "demo --help: --seed not listed"; fi

echo "cli: $passed passed, $failed failed"
[ "$failed" -eq 0 ]
