"""Summarises scripts/ab.sh's raw figures: lines `ROUND A|B MODEL MASS-STEPS/S` on stdin."""
import collections
import statistics as st
import sys

v = collections.defaultdict(lambda: collections.defaultdict(dict))
for line in sys.stdin:
    i, b, m, x = line.split()
    v[m][b][i] = float(x)
for m, d in v.items():
    r = [d["B"][i] / d["A"][i] for i in d["A"] if i in d["B"]]
    a, b = st.median(d["A"].values()), st.median(d["B"].values())
    print("%-28s A %.3e B %.3e B/A %.3f (%.2f-%.2f) n %d"
          % (m, a, b, st.median(r), min(r), max(r), len(r)))
