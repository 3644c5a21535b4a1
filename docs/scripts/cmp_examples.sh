#!/usr/bin/env bash
# docs/scripts/cmp_examples.sh OLD_BIN NEW_BIN REPO OUT_DIR [THREADS]: runs every example for 40 steps with both binaries
# and compares diagnostics.csv and bodies.csv byte for byte (wall-time columns are not in them).
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
    "$bin" run "$case" --out "$out/$name.$which" --quiet --threads "$threads" --set time.max_steps=40 --set output.charts=false --set output.interval=0 >/dev/null 2>"$out/$name.$which.err" || echo "$name $which: exit $?"
  done
  for f in diagnostics.csv bodies.csv; do
    if [ -f "$out/$name.old/$f" ] || [ -f "$out/$name.new/$f" ]; then
      if cmp -s "$out/$name.old/$f" "$out/$name.new/$f"; then echo "same  $name/$f"; else echo "DIFF  $name/$f"; fail=1; fi
    fi
  done
done
exit $fail
