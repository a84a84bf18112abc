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

# field EXPR: evaluates a Python expression over the JSON object `d` read from $TMP/out.
field() {
    python3 -c 'import json, sys
d = json.load(open(sys.argv[1]))
print(eval(sys.argv[2]))' "$TMP/out" "$1" 2>/dev/null
}

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
    if python3 -c 'import json, sys; d = json.load(open(sys.argv[1])); assert isinstance(d, dict)' "$TMP/out" 2>/dev/null; then ok; else fail "$1: stdout is not one JSON object"; fi
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

# ---- remesh ----------------------------------------------------------------------------------

run remesh "$DATA/bunny.off" "$TMP/rem.ply" --edge-length 0.02 --iterations 3 --threads 2 --json
expect_rc "remesh" 0
expect_one_json "remesh"
expect_field "remesh" "d['threads']" 2
expect_field "remesh" "d['output_stats']['valence']['interior_valence6_fraction'] > 0.6" True
expect_field "remesh" "abs(d['output_stats']['edge_length']['mean'] / d['target_edge_length'] - 1) < 0.1" True
run info "$TMP/rem.ply" --json
expect_field "remeshed" "d['euler_characteristic']" 2
run remesh "$DATA/37989_sf.obj" "$TMP/rem_nm.obj"
expect_error "remesh non-manifold" 2 'non-manifold'
run remesh "$DATA/bunny.off" "$TMP/x.obj" --edge-length 0
expect_error "remesh zero length" 2 'edge-length'

# ---- help ------------------------------------------------------------------------------------

run --help
expect_rc "--help" 0
if grep -q 'info' "$TMP/out" && grep -q 'demo' "$TMP/out"; then ok; else fail "--help: subcommands not listed"; fi
run demo --help
expect_rc "demo --help" 0
if grep -q -- '--seed' "$TMP/out"; then ok; else fail "demo --help: --seed not listed"; fi

echo "cli: $passed passed, $failed failed"
[ "$failed" -eq 0 ]
