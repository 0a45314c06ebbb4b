#!/usr/bin/env python3
"""Where a crate's compile time goes: LLVM's optimisation time per function, from the trace that
`-Z llvm-time-trace` (nightly rustc) writes (docs/ARCHITECTURE.md, "Build times").

    CARGO_TARGET_DIR=/tmp/trace cargo +nightly rustc -p cordis-core --lib -- -Z llvm-time-trace
    scripts/llvm-time.py /tmp/trace/debug/deps/cordis_core-*.llvm_timings.json [TOP]

Prints the total optimisation time (summed over LLVM's threads), the TOP (default 15) functions
that took longest, and the time of the functions grouped by the step they belong to (needs
binutils' c++filt, which demangles Rust's symbols).
"""
import collections
import json
import re
import subprocess
import sys

# The groups, first match wins: a function of the pull step, of the grid step, a copy of the
# gather/compact step inlined into a block loop or a thread's share, and the rest.
GROUPS = [
    ("pull step (per pair of curves)", ["pull"]),
    ("grid step", ["grid"]),
    ("block loop (process, process_observed)", ["Block", "process_observed", "observed_block"]),
    ("threads' shares", ["Share", "Job", "process_parallel"]),
    ("blow-up replay (check_block)", ["check_block"]),
    ("restore_link_forces", ["restore_link_forces"]),
]


def demangle(symbols):
    """The symbols demangled by binutils' `c++filt` (which reads Rust's v0 mangling), crate
    hashes taken out."""
    out = subprocess.run(
        ["c++filt"], input="\n".join(symbols), capture_output=True, text=True, check=True
    ).stdout.split("\n")
    return {s: re.sub(r"\[[0-9a-f]+\]", "", d) for s, d in zip(symbols, out)}


def main():
    if len(sys.argv) < 2:
        sys.exit(__doc__)
    path = sys.argv[1]
    top = int(sys.argv[2]) if len(sys.argv) > 2 else 15
    with open(path) as f:
        events = json.load(f)["traceEvents"]
    per = collections.defaultdict(float)
    for e in events:
        if e.get("ph") == "X" and e["name"] == "OptFunction":
            per[e.get("args", {}).get("detail", "?")] += e["dur"] / 1e6
    total = sum(per.values())
    name = demangle(list(per))
    print(f"optimisation, all functions: {total:.1f} s ({len(per)} functions)")
    print(f"\nthe {top} longest:")
    for sym, t in sorted(per.items(), key=lambda kv: -kv[1])[:top]:
        print(f"{t:8.1f} s  {name[sym][:150]}")
    groups = collections.defaultdict(float)
    for sym, t in per.items():
        words = set(re.findall(r"\w+", name[sym]))
        group = next((g for g, keys in GROUPS if words & set(keys)), "other")
        groups[group] += t
    print("\nby group:")
    for g, t in sorted(groups.items(), key=lambda kv: -kv[1]):
        print(f"{t:8.1f} s  {100 * t / total:5.1f} %  {g}")


if __name__ == "__main__":
    main()
