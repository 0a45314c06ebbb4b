#!/bin/bash
# Times `cordis render` of one model file with several builds of the CLI, alternating them round by
# round so that a noisy machine's drift falls on all alike, and checks that their outputs are the
# same bytes (docs/BENCHMARKS.md, "Comparing two engines"; needs python3).
#
#   scripts/render-ab.sh ROUNDS MODEL CLI [CLI...]
#
# Each CLI is a copy of target/release/cordis (cargo build --release -p cordis-cli), one per
# commit, under distinct file names. Prints, per build, the median, least and most wall-clock
# seconds of its renders (parsing and writing the WAV file included), then the MD5 sum of each
# build's last output, and exits with 1 if the outputs differ (or a render fails: its messages).
#
# FLAGS adds words to every render, each `%` in them the build's own output path without its
# extension, so that files they write are compared too: FLAGS='--events %.events.csv'.
set -euo pipefail
R=$1; M=$2; shift 2
OUT=${OUT:-$(mktemp -d)}
FLAGS=${FLAGS:-}
for i in $(seq "$R"); do for b in "$@"; do
  s=$(date +%s.%N)
  stem="$OUT/$(basename "$b")"
  # shellcheck disable=SC2086 # (FLAGS is words)
  if ! "$b" render "$M" -o "$stem.wav" ${FLAGS//%/$stem} > "$OUT/log" 2>&1; then
    cat "$OUT/log" >&2; exit 1
  fi
  e=$(date +%s.%N)
  echo "$(basename "$b") $s $e"
done; done | python3 -c '
import sys, statistics as st, collections
d = collections.defaultdict(list)
for l in sys.stdin:
    b, s, e = l.split()
    d[b].append(float(e) - float(s))
for b, v in d.items():
    print(f"{b:24s} median {st.median(v):.3f} s  min {min(v):.3f}  max {max(v):.3f}  n {len(v)}")
'
exts=(.wav)
for w in $FLAGS; do [[ $w == *%* ]] && exts+=("${w#*%}"); done
for ext in "${exts[@]}"; do
  sums=$(for b in "$@"; do md5sum "$OUT/$(basename "$b")$ext"; done)
  echo "$sums"
  if [ "$(echo "$sums" | awk '{print $1}' | sort -u | wc -l)" -ne 1 ]; then
    echo "the outputs differ ($ext)" >&2; exit 1
  fi
done
echo "the outputs are the same bytes"
