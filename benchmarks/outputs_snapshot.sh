#!/usr/bin/env bash
# Every report tracecheck writes on the sample traces and the paper's traces, in every format,
# with one checkout: for a change that must not change outputs (a refactoring), snapshot the
# old and the new checkout and compare them with compare_outputs.sh.
#
#   benchmarks/outputs_snapshot.sh TREE OUTDIR      (TREE: a checkout; ../shared beside it)
#
# Run with the Python environment in $TRACECHECK (default: this checkout's .venv/bin/tracecheck);
# PYTHONPATH makes it run TREE's code. The sample traces are copied to one place both
# snapshots read them from ($SNAPSHOT_DATA), so that file names in the outputs agree.
set -u
TREE=$(cd "$1" && pwd); OUT=$2; rm -rf "$OUT"; mkdir -p "$OUT"; OUT=$(cd "$OUT" && pwd)
echo "$TREE" > "$OUT/.tree"
export PYTHONPATH=$TREE COLUMNS=100
TC=${TRACECHECK:-$(dirname "$0")/../.venv/bin/tracecheck}
S=${SNAPSHOT_DATA:-/tmp/tracecheck-snapshot-data}
[ -d "$S" ] || { mkdir -p "$S" && cp "$TREE"/sample_traces/*.mcap "$S"/; }
SHARED=$(cd "$TREE/../shared" && pwd -P)  # one spelling in both snapshots
P=$SHARED/data/paper-traces; M=$SHARED/data/paper-models
cd "$TREE"
run() { # name, args...
  local name=$1; shift
  ( $TC "$@" > "$OUT/$name.out" 2> "$OUT/$name.err"; echo "rc=$?" > "$OUT/$name.rc" )
}
for f in text md csv json; do
  run check-paper-$f check-model paper --format $f
  run check-strict-$f check-model strict --format $f
  run guards-$f guards paper --state models/examples/state_approaching.json --format $f
  run info-$f info $S/base_none.mcap $S/base_paper.mcap --format $f
  run replay-none-paper-$f replay $S/base_none.mcap --shield paper --format $f
  run replay-none-strict-$f replay $S/base_none.mcap --shield strict --format $f --all
  run replay-paper-paper-$f replay $S/base_paper.mcap --shield paper --format $f
  run replay-ltl-$f replay $S/base_none.mcap --shield paper --ltl 'G {crashed = FALSE}' --ltl 'F [FASTER]' --format $f
  run diff-$f diff $S/base_none.mcap --shield strict --against paper --format $f
  run diff-sym-$f diff --symbolic --shield strict --against paper --format $f
  run prove-paper-$f prove paper --deadlock-free --well-defined --format $f
  run prove-strict-$f prove strict --deadlock-free --format $f
  run stats-$f stats $S/base_none.mcap $S/base_paper.mcap --format $f
done
run resim-json replay $S/base_none.mcap --shield paper --resimulate --format json
for m in $(find $M -name '*.mch' | sort); do
  b=$(basename $(dirname $m))_$(basename $m .mch); run model-$b check-model $m --format json
done
run import-simb-base import simb $P/simb/base -o $OUT/simb_base.mcap
run import-simb-shield import simb $P/simb/base_shield -o $OUT/simb_shield.mcap
run import-p2t import prob2trace $P/prob2trace/*.prob2trace -o $OUT/p2t.mcap
for x in simb_base simb_shield p2t; do
  for f in text json; do
    run info-$x-$f info $OUT/$x.mcap --format $f
    run replay-$x-$f replay $OUT/$x.mcap --shield paper --format $f
    run stats-$x-$f stats $OUT/$x.mcap --format $f
  done
done
run stats-simb-pair-json stats $OUT/simb_base.mcap $OUT/simb_shield.mcap --format json
run render render $S/base_none.mcap --episode 3 --shield paper -o $OUT/episode3.html
run report report $S/base_none.mcap $S/base_paper.mcap --shield paper -o $OUT/report.html
run export-simb export simb $S/base_none.mcap -o $OUT/exp_simb
run export-p2t export prob2trace $S/base_none.mcap --episode 3 -o $OUT/exp_p2t
run export-fox export foxglove $S/base_none.mcap -o $OUT/exp_fox.mcap
run record record --agent models/agents/base.zip --shield paper --episodes 3 --seed 0 -o $OUT/rec.mcap

for x in rec exp_fox; do
  run info-$x-json info $OUT/$x.mcap --format json
  run replay-$x-json replay $OUT/$x.mcap --shield paper --format json
done
