#!/bin/bash
# Compares two builds of the engine benchmark, alternating runs so that a noisy machine's drift
# falls on both alike (docs/BENCHMARKS.md, "Comparing two engines"; needs python3).
#
#   scripts/ab.sh ROUNDS "MODEL WORDS" BIN_A BIN_B
#
# BIN_A and BIN_B are copies of target/release/deps/engine-* (cargo bench -p cordis-core --bench
# engine --no-run), one per commit. Each round runs A then B once on the models; per model it
# prints the medians of A and B and the median (min-max) of the rounds' ratios B/A.
# WORK sets CORDIS_BENCH_WORK (default 1e8); RAW the file of raw figures.
set -eu
R=$1; M=$2; A=$3; B=$4
RAW=${RAW:-/tmp/ab-raw.txt}; : > "$RAW"
for i in $(seq "$R"); do for b in A B; do
  bin=$A; [ $b = B ] && bin=$B
  # (word splitting of $M is wanted: the models' words)
  # shellcheck disable=SC2086
  CORDIS_BENCH_WORK=${WORK:-1e8} "$bin" $M 2>&1 | grep -E '^[a-z]+_' | awk -v b=$b -v i="$i" '{print i, b, $1, $4}' >> "$RAW"
done; done
python3 "$(dirname "$0")/ab.py" < "$RAW"
