#!/usr/bin/env bash
# The 16-core runs of issues 18 and 20 in one call (bench/RESULTS.md, "16 cores, session 26"):
# `idas tetmesh` on bunny, 100071_sf and 37989_sf at 16 threads (and bunny at 8), fTetWild
# at 16 threads where FloatTetwild_bin is in BIN, then the scaling cases of
# bench/run_scaling.sh (armadillo x16; 1M Gaussian points) at 16 threads, each one process.
#   usage: bench/run_device_16.sh BIN [OUT]
# BIN holds idas, bench_inputs, bench_harmonic (release build without -march=native),
# optionally FloatTetwild_bin, and lib/ with the shared libraries `ldd` lists (for a machine
# where nothing can be installed). One JSON line per run goes to OUT/tetmesh.jsonl and
# OUT/scaling.jsonl (the tool's --json, plus input, threads asked and load), fTetWild's
# wall time and stage lines to OUT/ftetwild.txt.
set -u
D=$(cd "$1" && pwd)
O=${2:-${OUT:-/tmp/idas_device_out}}
mkdir -p "$O"
export LD_LIBRARY_PATH=$D/lib${LD_LIBRARY_PATH:+:$LD_LIBRARY_PATH}
W=$(mktemp -d)
trap 'rm -rf "$W"' EXIT
T0=$SECONDS
{ nproc; grep -m1 'model name' /proc/cpuinfo; cat /proc/loadavg; date -u; } >"$O/machine.txt"
log() { echo "[$((SECONDS - T0)) s] $*" | tee -a "$O/log.txt"; }
load() { cut -d' ' -f1 /proc/loadavg; }
tet() { # input threads
    local s=$SECONDS
    timeout 120 "$D/idas" tetmesh "data/$1" "$W/t.msh" --threads "$2" --json 2>>"$O/log.txt" |
        tr -d '\n' >"$W/j"
    echo "{\"input\":\"$1\",\"threads_asked\":$2,\"load\":\"$(load)\",\"r\":$(cat "$W/j")}" >>"$O/tetmesh.jsonl"
    log "idas tetmesh $1 $2 threads: $((SECONDS - s)) s"
}
ftw() { # input threads
    local a b
    a=$(date +%s.%N)
    timeout 100 "$D/FloatTetwild_bin" -i "data/$1" -o "$W/ftw" --max-threads "$2" --level 2 >"$W/ftw.log" 2>&1
    local rc=$?
    b=$(date +%s.%N)
    echo "== fTetWild $1 $2 threads rc $rc wall $(python3 -c "print(round($b - $a, 2))" 2>/dev/null || echo "$a $b")" >>"$O/ftetwild.txt"
    grep -iE "time|#t = |#v = " "$W/ftw.log" | tail -25 >>"$O/ftetwild.txt"
    log "fTetWild $1 $2 threads: rc $rc"
}
sc() { # case threads command...
    local name=$1 t=$2 s=$SECONDS line
    shift 2
    line="$(timeout 150 "$@" 2>>"$O/log.txt" | tr -d '\n')"
    echo "${line%\}},\"case\":\"$name\",\"threads_asked\":$t,\"load\":\"$(load)\"}" >>"$O/scaling.jsonl"
    log "$name $t threads: $((SECONDS - s)) s"
}
for f in bunny.obj 100071_sf.obj 37989_sf.obj; do tet $f 16; done
if [ -x "$D/FloatTetwild_bin" ]; then for f in bunny.obj 100071_sf.obj 37989_sf.obj; do ftw $f 16; done; fi
"$D/bench_inputs" data/armadillo.obj "$W/x16.obj" --levels 2 >>"$O/log.txt" 2>&1
x16=$W/x16.obj
sc remesh 16 "$D/idas" remesh "$x16" "$W/r.ply" --edge-length 0.002 --iterations 5 --threads 16 --json
sc decimate-qslim 16 "$D/idas" decimate "$x16" "$W/q.ply" --algorithm qslim --ratio 0.1 --threads 16 --json
sc decimate-sec 16 "$D/idas" decimate "$x16" "$W/s.ply" --algorithm shortest-edge --ratio 0.01 --threads 16 --json
sc harmonic-reduced 16 "$D/idas" harmonic "$W/h.msh" --gaussian 1000000 --mode reduced --threads 16 --json
sc harmonic-complete 16 "$D/idas" harmonic "$W/h.msh" --gaussian 1000000 --mode complete --threads 16 --json
sc cgal-delaunay 16 "$D/bench_harmonic" --cgal-only --points 1000000 --threads 16
tet bunny.obj 8
sc remesh 8 "$D/idas" remesh "$x16" "$W/r.ply" --edge-length 0.002 --iterations 5 --threads 8 --json
log "end"
