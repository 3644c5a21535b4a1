#!/bin/bash
# The wet-collision tables of docs/validation.md ("Wet collisions"): a disk launched at a wall
# (the scene wet.ron, the test's), St 20..640 and 10^4 at 8 and 16 cells per diameter.
# usage: [BIN=multifield] [OUT=runs] [MAXDT=2e-3] sweep.sh TAG RHO_S COLLISION_TIME LUBRICATION
#   e.g. MAXDT=1e-3 ./sweep.sh lub8 8 0.02 true && python3 measure.py runs/lub8 8 0
M=${BIN:-multifield}
cd "$(dirname "$0")"
TAG=$1; RHO=$2; TC=$3; LUB=$4; CA=${5:-0.0}
for st in 20 40 80 160 320 640 10000; do
  mu=$(python3 -c "print($RHO*1.0*0.25/(9*$st))")
  for c in 8 16; do
    $M run wet.ron -o ${OUT:-runs}/$TAG/st${st}_c$c -j 1 -q --set fields.disk.density=$RHO --set contact.params.lubrication=$LUB \
      --set contact.params.collision_time=$TC --set time.max_dt=${MAXDT:-2e-3} --set fields.fluid.stress.0.params.viscosity=$mu \
      --set "domain.cells=($((6*c)), $((4*c)))" > /dev/null 2>&1 || echo "fail $st $c"
  done
done
