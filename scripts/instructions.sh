#!/bin/bash
# Instructions two builds of the engine benchmark run in the pull step's loops, counted by
# callgrind: the same count whatever else the machine is doing, so a change too small for
# `ab.sh` to time on a noisy machine still shows (docs/BENCHMARKS.md, "Comparing two engines";
# needs valgrind).
#
#   scripts/instructions.sh "MODEL SIZE [MODEL SIZE...]" BIN_A [BIN_B]
#
# valgrind has no AVX-512: under it the engine takes its AVX2 steps, so these are the AVX2 pull
# step's counts (`COLLECT`, a callgrind function pattern, picks other functions). Each model
# runs the bench's five timed runs of `WORK` mass-steps (default 2e6). Prints, per model, each
# build's count and their ratio B/A.
set -eu
M=$1; A=$2; B=${3:-}
COLLECT=${COLLECT:-'*groups_avx2_with*'}
count() {
  local out; out=$(mktemp)
  CORDIS_BENCH_WORK=${WORK:-2e6} valgrind --tool=callgrind --callgrind-out-file="$out" \
    --toggle-collect="$COLLECT" "$1" "$2" "$3" 2>&1 | awk '/Collected/ {print $4}'
  rm -f "$out"
}
# (word splitting of $M is wanted: the models' words, two at a time)
# shellcheck disable=SC2086
set -- $M
while [ $# -ge 2 ]; do
  a=$(count "$A" "$1" "$2")
  if [ -n "$B" ]; then
    b=$(count "$B" "$1" "$2")
    echo "$1 $2: A $a B $b B/A $(python3 -c "print(f'{$b / $a:.6f}')")"
  else
    echo "$1 $2: $a"
  fi
  shift 2
done
