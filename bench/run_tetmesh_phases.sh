#!/usr/bin/env bash
# Where `idas tetmesh` spends its optimization, per operation, at each thread count: seconds
# (serial set-up and tail included), lost lock races, entries stolen from another part and
# entries sent to the final serial pass, with the rounds, the tets and the total time.
#   usage: bench/run_tetmesh_phases.sh [INPUT...]   (default: bunny.obj)
#   THREADS (default "1 2"), REPEATS (default 1), IDAS and DATA as in bench/run_tetmesh.sh.
set -euo pipefail
IDAS=${IDAS:-build/release/examples/idas}
DATA=${DATA:-data}
TMP=$(mktemp -d)
trap 'rm -rf "$TMP"' EXIT
[ $# -gt 0 ] || set -- bunny.obj
for f in "$@"; do
    for t in ${THREADS:-1 2}; do
        for _ in $(seq "${REPEATS:-1}"); do
            "$IDAS" tetmesh "$DATA/$f" "$TMP/out.msh" --threads "$t" --json >"$TMP/j.json"
            python3 - "$TMP/j.json" "$f" "$t" <<'PY'
import json, sys
d = json.load(open(sys.argv[1])); o = d['optimization']
print('%-14s %2s threads: %6d tets, %2d rounds, optimization %6.2f s, total %6.2f s' % (
      sys.argv[2], sys.argv[3], d['tets'], o['iterations'], d['seconds']['optimization'],
      d['seconds']['total']))
for k, p in o['phases'].items():
    print('    %-8s %6.2f s  lost races %9d  stolen %8d  to the serial pass %7d' % (
          k, p['seconds'], p['lock_failures'], p['stolen'], p['deferred_to_serial']))
PY
        done
    done
done
