#!/usr/bin/env bash
# Session 29, second device run: remeshing with the smoothing angle rule at 1, 8 and 16
# threads; tet meshing and fTetWild on bunny at 16 threads once more.
set -u
D=$PWD/device-bin
export LD_LIBRARY_PATH=$D/lib
O=${OUT:-/tmp/out}; mkdir -p "$O"
W=/tmp/w; mkdir -p $W
T0=$SECONDS
{ nproc; grep -m1 'model name' /proc/cpuinfo; cat /proc/loadavg; date -u; } > $O/machine.txt
log() { echo "[$((SECONDS - T0)) s] $*" | tee -a $O/log.txt; }
load() { cut -d' ' -f1 /proc/loadavg; }
tet() {
    local s=$SECONDS
    timeout 120 $D/idas tetmesh data/$1 $W/t.msh --threads $2 --json 2>>$O/log.txt | tr -d '\n' > $W/j
    echo "{\"input\":\"$1\",\"threads_asked\":$2,\"load\":\"$(load)\",\"r\":$(cat $W/j)}" >> $O/tetmesh.jsonl
    log "idas tetmesh $1 $2 threads: $((SECONDS - s)) s"
}
sc() {
    local name=$1 t=$2; shift 2
    local s=$SECONDS
    local line="$(timeout 150 "$@" 2>>$O/log.txt | tr -d '\n')"
    echo "${line%\}},\"case\":\"$name\",\"threads_asked\":$t,\"load\":\"$(load)\"}" >> $O/scaling.jsonl
    log "$name $t threads: $((SECONDS - s)) s"
}
log "start on $(nproc) cores"
$D/bench_inputs data/armadillo.obj $W/x16.obj --levels 2 >>$O/log.txt 2>&1; log "x16 written"
R="remesh $W/x16.obj $W/r.ply --edge-length 0.002 --iterations 5 --json"
for i in 1 2 3 4; do sc remesh 16 $D/idas $R --threads 16; done
for i in 1 2; do sc remesh 8 $D/idas $R --threads 8; done
sc remesh 1 $D/idas $R --threads 1
tet bunny.obj 16; tet bunny.obj 16; tet 100071_sf.obj 16
a=$(date +%s.%N); timeout 100 $D/FloatTetwild_bin -i data/bunny.obj -o $W/ftw --max-threads 16 --level 2 > $W/ftw.log 2>&1
b=$(date +%s.%N); echo "== fTetWild bunny 16 threads rc $? wall $(python3 -c "print(round($b - $a, 2))")" >> $O/ftetwild.txt
grep -E "#t = " $W/ftw.log | tail -1 >> $O/ftetwild.txt; log "fTetWild bunny"
sc remesh 16 $D/idas $R --threads 16
log "end"
