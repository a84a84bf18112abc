#!/usr/bin/env bash
# Issue 17's insertion stage against fTetWild's, one thread each, one tool after the other
# per input: idas's background Delaunay + insertion + rounding + labels (from
# `idas tetmesh IN OUT --threads 1 --json`) against fTetWild's tetrahedralizing + cutting
# + winding number (from its log, `--max-threads 1 --level 2`). Also the insertion alone
# (without labels) and both tools' totals. Neither side counts building the input's
# distance tree, which the background's grid uses: fTetWild builds it before its first
# timer (src/main.cpp, `AABBWrapper tree(sf_mesh)`), idas with the cleaning (since
# session 32; bunny's tree takes about 0.03 s).
#   usage: FTETWILD=path/to/FloatTetwild_bin bench/run_insertion_stage.sh [INPUT...]
#   (default inputs: 37989_sf.obj blub.obj 100071_sf.obj bunny.obj; IDAS and DATA as in
#   bench/run_tetmesh.sh)
set -euo pipefail
IDAS=${IDAS:-build/release/examples/idas}
DATA=${DATA:-data}
: "${FTETWILD:?set FTETWILD to the FloatTetwild_bin of ../shared/peers/build_ftetwild.sh}"
TMP=$(mktemp -d)
trap 'rm -rf "$TMP"' EXIT
[ $# -gt 0 ] || set -- 37989_sf.obj blub.obj 100071_sf.obj bunny.obj
for f in "$@"; do
    "$IDAS" tetmesh "$DATA/$f" "$TMP/i.msh" --threads 1 --json >"$TMP/i.json"
    "$FTETWILD" -i "$DATA/$f" -o "$TMP/f.msh" --max-threads 1 --level 2 >"$TMP/f.log" 2>&1
    python3 - "$f" "$TMP" <<'PY'
import json, re, sys
name, tmp = sys.argv[1], sys.argv[2]
s = json.load(open(tmp + '/i.json'))['seconds']
log = open(tmp + '/f.log').read()
def stage(label):
    return float(re.search(r'\] ' + label + r' ([0-9.e-]+)s', log).group(1))
ft = stage('tetrahedralizing'), stage('cutting'), stage('winding number')
# The labels alone (fTetWild's stage 5 is its winding number and the removal of the outside),
# and with the rest of idas's output assembly (boundary repair, quality summary) as before.
labels = s.get('winding_number', s['winding_number_and_output'])
ii = s['delaunay'], s['insertion'], s['rounding'], labels
with_output = sum(ii[:3]) + s['winding_number_and_output']
print('%-14s idas %.3f + %.3f + %.3f + %.3f = %.2f s | fTetWild %.3f + %.3f + %.3f = %.2f s | '
      'ratio %.2f | with output assembly %.2f | without labels %.2f | totals %.1f / %.1f s' % (
      name, *ii, sum(ii), *ft, sum(ft), sum(ii) / sum(ft), with_output / sum(ft),
      sum(ii[:3]) / sum(ft[:2]), s['total'],
      stage('preprocessing') + sum(ft) + stage('mesh optimization')))
PY
done
