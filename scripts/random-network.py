#!/usr/bin/env python3
"""Writes a random network in the model language, as the engine bench's `random N` (docs/BENCHMARKS.md):
N masses, each end 1 of two REF links to other masses drawn at random (4 links per mass on
average), one ground tied to mass 0, mass N/4 struck, the position of mass N/2 recorded.

    scripts/random-network.py N [DURATION] > random.cordis
"""
import random
import sys

n = int(sys.argv[1])
duration = sys.argv[2] if len(sys.argv) > 2 else "1s"
rng = random.Random(20261206)
out = [f"# a random network of {n} masses (scripts/random-network.py {n} {duration})",
       "rate 44100", f"duration {duration}", "sol g X0=0"]
out += [f"mas m{i} M=1 X0=0" + (" V0=1" if i == n // 4 else "") for i in range(n)]
out.append("ref rg g m0 K=0.1 Z=0.0001")
for i in range(n):
    for t in range(2):
        j = (i + 1 + rng.randrange(n - 1)) % n  # any mass but i
        out.append(f"ref r{i}_{t} m{i} m{j} K=0.1 Z=0.0001")
out.append(f"sox out m{n // 2}")
print("\n".join(out))
