#!/usr/bin/env bash
# Compare two snapshots of outputs_snapshot.sh: every output byte-identical apart from what
# each run differs in by nature — timings and rates, the creation times written into files
# (created, savedAt), matplotlib's SVG ids and dates, the two snapshots' and checkouts' own
# paths, and the padding of table columns that hold those paths. MCAP files are compared
# through what info and replay read from them (their JSON, in the snapshot).
#
#   benchmarks/compare_outputs.sh BEFORE AFTER      (exit 1 if any output differs)
A=$(cd "$1" && pwd); B=$(cd "$2" && pwd); bad=0; same=0; mc=0
TA=$(cat "$A/.tree"); TB=$(cat "$B/.tree")
norm() { sed -E "s#$A#/SNAP#g; s#$B#/SNAP#g; s#$TA/#/TREE/#g; s#$TB/#/TREE/#g" "$1" | sed -E '
  s#/tmp/tracecheck-snapshot-data#/DATA#g;
  s/"(created|savedAt)": "[^"]*"/"\1": <TIME>/g;
  s/(id|href|clip-path)="[^"]*"/\1=<ID>/g; s/url\(#[^)]*\)/url(<ID>)/g; s#<dc:date>[^<]*</dc:date>#<DATE>#g;
  s/"(seconds|elapsed_s|time_s|wall_s|duration_s|steps_per_s|elapsed|statistics_s)": [0-9.e+-]+/"\1": <T>/g;
  s/\([0-9][0-9,]* ?$/(<R>/; s/ +/ /g; s/[0-9][0-9,]*(\.[0-9]+)? ?(s|ms|µs)\b/<T>/g;
  s/[0-9][0-9,]*(\.[0-9]+)? steps\/s/<R> steps\/s/g'; }
cmpfile() { # relpath
  local f=$1
  if [ ! -e "$B/$f" ]; then echo "MISSING $f"; bad=$((bad+1)); return; fi
  case $f in *.mcap) mc=$((mc+1)); return;; esac
  if cmp -s "$A/$f" "$B/$f" || diff -q <(norm "$A/$f") <(norm "$B/$f") >/dev/null; then
    same=$((same+1)); else echo "DIFFER $f"; bad=$((bad+1)); fi
}
for f in $(cd "$A" && find . -type f ! -name .tree | sort); do cmpfile "${f#./}"; done
extra=$(comm -13 <(cd "$A" && find . -type f ! -name .tree | sort) \
                 <(cd "$B" && find . -type f ! -name .tree | sort))
[ -n "$extra" ] && { echo "ONLY AFTER: $extra"; bad=$((bad+1)); }
echo "identical: $same files, different: $bad (MCAP files compared through their info/replay JSON: $mc)"
[ "$bad" -eq 0 ]
