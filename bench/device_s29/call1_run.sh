#!/usr/bin/env bash
# Session 29 device run: tet meshing and fTetWild at 16 threads, remeshing's quality traced
# per phase at 16 and 8 threads, the scaling cases at 1 and 16 threads.
set -u
D=$PWD/device-bin
export LD_LIBRARY_PATH=$D/lib
O=${OUT:-/tmp/out}; mkdir -p "$O"
W=/tmp/w; mkdir -p $W
T0=$SECONDS
{ nproc; grep -m1 'model name' /proc/cpuinfo; cat /proc/loadavg; date -u; } > $O/machine.txt
log() { echo "[$((SECONDS - T0)) s] $*" | tee -a $O/log.txt; }
load() { cut -d' ' -f1 /proc/loadavg; }
tet() { # input threads
    local s=$SECONDS
    timeout 120 $D/idas tetmesh data/$1 $W/t.msh --threads $2 --json 2>>$O/log.txt | tr -d '\n' > $W/j
    echo "{\"input\":\"$1\",\"threads_asked\":$2,\"load\":\"$(load)\",\"r\":$(cat $W/j)}" >> $O/tetmesh.jsonl
    log "idas tetmesh $1 $2 threads: $((SECONDS - s)) s"
}
ftw() { # input threads
    local a b
    a=$(date +%s.%N)
    timeout 100 $D/FloatTetwild_bin -i data/$1 -o $W/ftw --max-threads $2 --level 2 > $W/ftw.log 2>&1
    local rc=$?
    b=$(date +%s.%N)
    echo "== fTetWild $1 $2 threads rc $rc wall $(python3 -c "print(round($b - $a, 2))" 2>/dev/null || echo "$a $b")" >> $O/ftetwild.txt
    grep -iE "time|#t = |#v = " $W/ftw.log | tail -25 >> $O/ftetwild.txt
    log "fTetWild $1 $2 threads: rc $rc"
}
sc() { # case threads command...
    local name=$1 t=$2; shift 2
    local s=$SECONDS
    local line="$(timeout 150 "$@" 2>>$O/log.txt | tr -d '\n')"
    echo "${line%\}},\"case\":\"$name\",\"threads_asked\":$t,\"load\":\"$(load)\"}" >> $O/scaling.jsonl
    log "$name $t threads: $((SECONDS - s)) s"
}
log "start on $(nproc) cores"
tet bunny.obj 16; tet 100071_sf.obj 16; tet 37989_sf.obj 16
$D/bench_inputs data/armadillo.obj $W/x16.obj --levels 2 >>$O/log.txt 2>&1; log "x16 written"
in=$W/x16.obj
R="remesh $in $W/r.ply --edge-length 0.002 --iterations 5 --json"
sc remesh-trace 16 $D/idas $R --threads 16 --trace
cp $W/r.ply $O/r16_trace.ply
sc remesh-trace 16 $D/idas $R --threads 16 --trace
sc remesh-trace 8 $D/idas $R --threads 8 --trace
sc remesh 16 $D/idas $R --threads 16
for f in bunny.obj 100071_sf.obj 37989_sf.obj; do ftw $f 16; done
sc remesh 16 $D/idas $R --threads 16
sc remesh 1 $D/idas $R --threads 1
sc decimate-qslim 16 $D/idas decimate $in $W/q.ply --algorithm qslim --ratio 0.1 --threads 16 --json
sc decimate-sec 16 $D/idas decimate $in $W/s.ply --algorithm shortest-edge --ratio 0.01 --threads 16 --json
sc harmonic-reduced 16 $D/idas harmonic $W/h.msh --gaussian 1000000 --mode reduced --threads 16 --json
sc harmonic-complete 16 $D/idas harmonic $W/h.msh --gaussian 1000000 --mode complete --threads 16 --json
sc cgal-delaunay 16 $D/bench_harmonic --cgal-only --points 1000000 --threads 16
tet bunny.obj 16; tet 100071_sf.obj 16
sc decimate-qslim 1 $D/idas decimate $in $W/q.ply --algorithm qslim --ratio 0.1 --threads 1 --json
sc decimate-sec 1 $D/idas decimate $in $W/s.ply --algorithm shortest-edge --ratio 0.01 --threads 1 --json
tet bunny.obj 16
sc remesh-trace 16 $D/idas $R --threads 16 --trace
log "end"
