#!/bin/bash
# The cost of a link against a REF link: each round runs BIN once on `random 10000` and the
# models, and per model prints the median mass-steps/s and the median (min-max) of the
# within-run ratio REF / model (docs/BENCHMARKS.md, "Comparing two engines"; needs python3).
#
#   scripts/cost.sh ROUNDS BIN "MODEL WORDS"
#
# WORK sets CORDIS_BENCH_WORK (default 1e8).
set -eu
R=$1; B=$2; M=$3
for i in $(seq "$R"); do
  # shellcheck disable=SC2086
  CORDIS_BENCH_WORK=${WORK:-1e8} "$B" random 10000 $M 2>&1 | grep -E '^random' | awk '{printf "%s=%s ", $1, $4} END {print ""}'
done | python3 -c '
import sys, statistics as st, collections
v = collections.defaultdict(list); c = collections.defaultdict(list)
for l in sys.stdin:
    d = dict(x.split("=") for x in l.split())
    ref = float(d["random_N10000"])
    for m, x in d.items():
        v[m].append(float(x)); c[m].append(ref / float(x))
for m in v:
    print(f"{m:26s} {st.median(v[m]):.3e}  cost {st.median(c[m]):.3f} ({min(c[m]):.3f}-{max(c[m]):.3f}) n {len(c[m])}")
'
