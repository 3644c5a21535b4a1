#!/usr/bin/env bash
# docs/scripts/cmp_examples.sh OLD_BIN NEW_BIN REPO OUT_DIR [THREADS]: runs every example for 40 steps with both binaries,
# with an HDF5 snapshot (face velocities included) at the end, and compares every file they write byte for byte
# (diagnostics.csv, bodies.csv, monitors, snapshots, pictures, ...) but summary.json (it holds wall times).
# Used to check that a change leaves every example's results bit-identical (docs/performance.md).
set -u
old=$1 new=$2 repo=$3 out=$4 threads=${5:-2}
mkdir -p "$out"
fail=0
for case in "$repo"/examples/*.ron; do
  name=$(basename "$case" .ron)
  for which in old new; do
    bin=$old; [ $which = new ] && bin=$new
    rm -rf "$out/$name.$which"
    "$bin" run "$case" --out "$out/$name.$which" --quiet --threads "$threads" --set time.max_steps=40 --set output.charts=false --set output.interval=0 --set 'output.snapshots=Some((at_end: true, faces: true))' >/dev/null 2>"$out/$name.$which.err" || echo "$name $which: exit $?"
  done
  files=$( (cd "$out/$name.old" && find . -type f; cd "$out/$name.new" && find . -type f) | grep -v '^./summary.json$' | sort -u)
  for f in $files; do
    f=${f#./}
    if cmp -s "$out/$name.old/$f" "$out/$name.new/$f"; then echo "same  $name/$f"; else echo "DIFF  $name/$f"; fail=1; fi
  done
done
exit $fail
