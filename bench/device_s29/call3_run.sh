#!/usr/bin/env bash
# Session 29, third device run: bunny at 16 threads, the set-aside entries dealt out in
# disjoint sets (idas_ind) against the build before it (idas), alternating.
set -u
D=$PWD/device-bin
export LD_LIBRARY_PATH=$D/lib
O=${OUT:-/tmp/out}; mkdir -p "$O"
W=/tmp/w; mkdir -p $W
T0=$SECONDS
{ nproc; grep -m1 'model name' /proc/cpuinfo; cat /proc/loadavg; date -u; } > $O/machine.txt
tet() { # binary input threads
    local s=$SECONDS
    timeout 120 $D/$1 tetmesh data/$2 $W/t.msh --threads $3 --json 2>>$O/log.txt | tr -d '\n' > $W/j
    echo "{\"bin\":\"$1\",\"input\":\"$2\",\"threads_asked\":$3,\"load\":\"$(cut -d' ' -f1 /proc/loadavg)\",\"r\":$(cat $W/j)}" >> $O/tetmesh.jsonl
    echo "[$((SECONDS - T0)) s] $1 $2 $3: $((SECONDS - s)) s" | tee -a $O/log.txt
}
for i in 1 2; do tet idas_ind bunny.obj 16; tet idas bunny.obj 16; done
tet idas_ind bunny.obj 16
tet idas_ind 100071_sf.obj 16; tet idas 100071_sf.obj 16
