#!/usr/bin/env python3
"""analyse.py: small measurements on cordis renders (python3 standard library only).

Every number in docs/INSTRUMENTARIUM.md comes from one of these subcommands:

  events   EVENTS.csv                     connections / disconnections of the sticking springs
  score    EVENTS.csv [--gap 0.5]         the symbolic score: each event, the configuration after
                                          it, and the groups of events (separated by > gap s)
  summary  EVENTS.csv --duration 24       one line of counts (for the parameter sweeps)
  peaks    OUT.csv --from A --to B        spectral peaks of channel 0 between A and B seconds
  partials OUT.csv --fmax F               the partials of the first 0.5 s, and their level in
                                          the last 0.5 s (who is still audible)
  configs  EVENTS.csv OUT.csv             for each configuration that lasts, the predicted lowest
                                          mode of every closed string and the measured peaks
  level    OUT.csv --from A --to B        largest |sample| between A and B s, in dB re the file's peak
  energy   ENERGY.csv --step N [--rows 3] energy rows around step N

EVENTS.csv is what `cordis render --events` writes (step,time_s,link,state); only the sticking
springs (links named NAME.L or NAME.S1.L / NAME.S2.L) count as connections; BUTs and tracked LNLs
are listed separately by `events`. OUT.csv is a CSV render (`cordis render M.cordis -o out.csv`).
"""

import argparse
import signal
import cmath
import csv
import math
import sys

FS = 44100.0

# ---------------------------------------------------------------------------------------------
# event logs


def read_events(path):
    rows = []
    with open(path, newline="") as f:
        for r in csv.DictReader(f):
            rows.append((int(r["step"]), float(r["time_s"]), r["link"], int(r["state"])))
    return rows


def is_spring(link):
    return link.endswith(".L")


def pair_name(link):
    """`L1R3.L` -> `L1R3`, `dev1.S1.L` -> `dev1.S1`."""
    return link[: -len(".L")]


def spring_events(rows):
    return [r for r in rows if is_spring(r[2])]


def link_intervals(rows, end_time):
    """(pair, t_on, t_off or end_time, closed?) for every connection."""
    open_at = {}
    out = []
    for step, t, link, state in spring_events(rows):
        p = pair_name(link)
        if state == 1:
            open_at[p] = t
        elif p in open_at:
            out.append((p, open_at.pop(p), t, True))
    for p, t0 in open_at.items():
        out.append((p, t0, end_time, False))
    out.sort(key=lambda x: x[1])
    return out


def cmd_events(a):
    rows = read_events(a.events)
    kinds = {}
    for _, _, link, state in rows:
        k = "sticking spring" if is_spring(link) else ("BUT" if ".B" in link else "tracked LNL")
        kinds.setdefault(k, [0, 0])[0 if state else 1] += 1
    print("events by kind (became active / became inactive):")
    for k, (on, off) in sorted(kinds.items()):
        print(f"  {k:16s} {on:6d} / {off:6d}")
    print("sticking springs:")
    for step, t, link, state in spring_events(rows):
        print(f"  step {step:8d}  t = {t:9.4f} s  {link:12s} {'connects' if state else 'lets go'}")


def groups_of(ev, gap):
    groups = []
    for e in ev:
        if groups and e[1] - groups[-1][-1][1] <= gap:
            groups[-1].append(e)
        else:
            groups.append([e])
    return groups


def cmd_score(a):
    ev = spring_events(read_events(a.events))
    active = set()
    print("   time (s)  event     configuration after it")
    for step, t, link, state in ev:
        p = pair_name(link)
        if state:
            active.add(p)
        else:
            active.discard(p)
        conf = " ".join(sorted(active)) or "(all free)"
        print(f"  {t:9.4f}  {'+' if state else '-'}{p:8s} {conf}")
    print(f"groups (events closer than {a.gap} s):")
    for g in groups_of(ev, a.gap):
        seq = " ".join(("+" if s else "-") + pair_name(l) for _, _, l, s in g)
        print(f"  {g[0][1]:7.3f} .. {g[-1][1]:7.3f} s  {len(g):3d} events: {seq}")


def cmd_summary(a):
    rows = read_events(a.events)
    ev = spring_events(rows)
    on = sum(1 for e in ev if e[3] == 1)
    off = len(ev) - on
    iv = link_intervals(rows, a.duration)
    closed = sorted(t1 - t0 for _, t0, t1, c in iv if c)
    pairs = sorted({p for p, *_ in iv})
    short = sum(1 for d in closed if d < 0.010)
    groups = groups_of(ev, a.gap)
    times = [0.0] + [e[1] for e in ev] + [a.duration]
    silence = max(t1 - t0 for t0, t1 in zip(times, times[1:]))
    med = closed[len(closed) // 2] if closed else float("nan")
    # configurations visited, and the time spent with every string free
    active, confs, free_time, last = set(), {frozenset()}, 0.0, 0.0
    for _, t, link, state in ev:
        if not active:
            free_time += t - last
        (active.add if state else active.discard)(pair_name(link))
        confs.add(frozenset(active))
        last = t
    if not active:
        free_time += a.duration - last
    def median_ms(ds):
        ds = sorted(ds)
        return f"{ds[len(ds) // 2] * 1000:.0f}" if ds else "-"

    same = [t1 - t0 for p, t0, t1, c in iv if c and p[1] == p[3]]
    cross = [t1 - t0 for p, t0, t1, c in iv if c and p[1] != p[3]]
    print(
        f"connections {on}, disconnections {off}, pairs used {len(pairs)}/9 "
        f"({' '.join(pairs)}), configurations {len(confs)}, groups {len(groups)}, "
        f"links < 10 ms {short}, median link {med * 1000:.0f} ms "
        f"(same row {median_ms(same)}, across rows {median_ms(cross)}), "
        f"longest silence {silence:.2f} s, all free {free_time:.1f} s"
    )


# ---------------------------------------------------------------------------------------------
# spectra


def read_channel(path, channel=0):
    xs = []
    with open(path) as f:
        next(f)
        for line in f:
            xs.append(float(line.split(",")[channel]))
    return xs


def fft(x):
    """In-place iterative radix-2 FFT of a list of complex numbers (length a power of two)."""
    n = len(x)
    j = 0
    for i in range(1, n):
        bit = n >> 1
        while j & bit:
            j ^= bit
            bit >>= 1
        j |= bit
        if i < j:
            x[i], x[j] = x[j], x[i]
    size = 2
    while size <= n:
        w = cmath.exp(-2j * math.pi / size)
        half = size // 2
        tw = [1.0 + 0j]
        for _ in range(half - 1):
            tw.append(tw[-1] * w)
        for start in range(0, n, size):
            for k in range(half):
                u = x[start + k]
                v = x[start + k + half] * tw[k]
                x[start + k] = u + v
                x[start + k + half] = u - v
        size *= 2
    return x


def blackman_harris(i, n):
    """4-term Blackman-Harris window: side lobes below -92 dB, so they are never taken for peaks."""
    x = 2 * math.pi * i / (n - 1)
    return 0.35875 - 0.48829 * math.cos(x) + 0.14128 * math.cos(2 * x) - 0.01168 * math.cos(3 * x)


def spectrum(seg, pad=4):
    """Blackman-Harris windowed magnitude spectrum (dB, and the bin width in Hz), zero-padded to at
    least `pad` times the segment. Two partials closer than about 4 / (segment length) merge."""
    n = len(seg)
    mean = sum(seg) / n
    size = 1
    while size < pad * n:
        size *= 2
    buf = [complex((s - mean) * blackman_harris(i, n), 0) for i, s in enumerate(seg)]
    buf += [0j] * (size - n)
    fft(buf)
    mags = [20 * math.log10(abs(c) + 1e-300) for c in buf[: size // 2]]
    return mags, FS / size


def find_peaks(mags, df, fmin, fmax, floor_db):
    """Local maxima above (max - floor_db), with parabolic interpolation: (Hz, dB)."""
    lo, hi = max(1, int(fmin / df)), min(len(mags) - 2, int(fmax / df))
    top = max(mags[lo:hi + 1])
    out = []
    for i in range(lo, hi + 1):
        if mags[i] > mags[i - 1] and mags[i] >= mags[i + 1] and mags[i] > top - floor_db:
            a, b, c = mags[i - 1], mags[i], mags[i + 1]
            den = a - 2 * b + c
            p = 0.5 * (a - c) / den if den != 0 else 0.0
            out.append(((i + p) * df, b - 0.25 * (a - c) * p))
    return out, top


def segment(xs, t0, t1):
    return xs[int(round(t0 * FS)) : int(round(t1 * FS))]


def cmd_peaks(a):
    xs = read_channel(a.csv, a.channel)
    mags, df = spectrum(segment(xs, a.t_from, a.t_to), pad=a.pad)
    peaks, top = find_peaks(mags, df, a.fmin, a.fmax, a.floor)
    peaks.sort(key=lambda p: -p[1])
    peaks = sorted(peaks[: a.top])
    print(f"{a.t_from}..{a.t_to} s: {len(peaks)} strongest peaks below {a.fmax} Hz (dB re strongest):")
    for f, db in peaks:
        print(f"  {f:9.2f} Hz  {db - top:7.1f} dB")


def cmd_partials(a):
    xs = read_channel(a.csv, a.channel)
    dur = len(xs) / FS
    e_mags, df = spectrum(segment(xs, 0.0, 0.5))
    l_mags, _ = spectrum(segment(xs, dur - 0.5, dur))
    peaks, top = find_peaks(e_mags, df, a.fmin, a.fmax, a.floor)
    print(f"partials of the first 0.5 s (within {a.floor} dB of the strongest), and their level in the last 0.5 s")
    print("   freq (Hz)   first 0.5 s   last 0.5 s  (dB re the strongest partial of the first 0.5 s)")
    counts = {40: 0, 60: 0}
    for f, db in peaks:
        i = int(round(f / df))
        late = max(l_mags[max(0, i - 3) : i + 4])
        for thr in counts:
            if late - top > -thr:
                counts[thr] += 1
        print(f"  {f:9.2f}   {db - top:9.1f}   {late - top:9.1f}")
    for thr, c in counts.items():
        print(f"partials still above -{thr} dB in the last 0.5 s: {c}")


# ---------------------------------------------------------------------------------------------
# configurations of the reconfigurable instrument


def string_k(f, n=10):
    return (math.sin(math.pi * f / FS) / math.sin(math.pi / (2 * (2 * n + 1)))) ** 2


def jacobi_eigenvalues(m):
    """Eigenvalues of a small symmetric matrix (cyclic Jacobi)."""
    n = len(m)
    a = [row[:] for row in m]
    for _ in range(100):
        off = sum(a[i][j] ** 2 for i in range(n) for j in range(n) if i != j)
        if off < 1e-30:
            break
        for p in range(n):
            for q in range(p + 1, n):
                if abs(a[p][q]) < 1e-300:
                    continue
                theta = (a[q][q] - a[p][p]) / (2 * a[p][q])
                t = (1 if theta >= 0 else -1) / (abs(theta) + math.sqrt(theta * theta + 1))
                c = 1 / math.sqrt(t * t + 1)
                s = t * c
                for k in range(n):
                    akp, akq = a[k][p], a[k][q]
                    a[k][p], a[k][q] = c * akp - s * akq, s * akp + c * akq
                for k in range(n):
                    apk, aqk = a[p][k], a[q][k]
                    a[p][k], a[q][k] = c * apk - s * aqk, s * apk + c * aqk
    return sorted(a[i][i] for i in range(n))


def closed_string_modes(pairs, freqs, kl, n=10):
    """Lowest modes (Hz) of every connected group of strings (masses 1, anchors fixed)."""
    # union the strings that the active pairs join
    parent = {}

    def find(x):
        parent.setdefault(x, x)
        while parent[x] != x:
            x = parent[x]
        return x

    for p in pairs:
        l, r = p[:2], p[2:]
        parent[find(l)] = find(r)
    comps = {}
    for s in sorted({p[:2] for p in pairs} | {p[2:] for p in pairs}):
        comps.setdefault(find(s), []).append(s)
    out = []
    for strings in sorted(comps.values()):
        strings.sort()
        idx = {s: i * n for i, s in enumerate(strings)}
        size = n * len(strings)
        k = [[0.0] * size for _ in range(size)]

        def spring(i, j, kk):
            k[i][i] += kk
            if j is not None:
                k[j][j] += kk
                k[i][j] -= kk
                k[j][i] -= kk

        for s in strings:
            ks = string_k(freqs[s], n)
            b = idx[s]
            spring(b, None, ks)  # anchor link
            for m in range(1, n):
                spring(b + m - 1, b + m, ks)
        for p in pairs:
            if p[:2] in idx:
                spring(idx[p[:2]] + n - 1, idx[p[2:]] + n - 1, kl)
        lam = jacobi_eigenvalues(k)
        f1 = FS / math.pi * math.asin(math.sqrt(lam[0]) / 2)
        out.append(("+".join(strings), f1))
    return out


FREQS = {"L1": 220.0, "L2": 277.18, "L3": 329.63, "R1": 220.0, "R2": 246.94, "R3": 392.0}


def cmd_configs(a):
    rows = read_events(a.events)
    ev = spring_events(rows)
    xs = read_channel(a.csv, 0) if a.csv else None
    dur = len(xs) / FS if xs else a.duration
    active = set()
    bounds = [(0.0, frozenset())]
    for _, t, link, state in ev:
        p = pair_name(link)
        (active.add if state else active.discard)(p)
        bounds.append((t, frozenset(active)))
    bounds.append((dur, None))
    print(f"configurations lasting at least {a.min} s (measured: peaks of the output from 20 ms after the change)")
    for (t0, conf), (t1, _) in zip(bounds, bounds[1:]):
        if t1 - t0 < a.min:
            continue
        desc = " ".join(sorted(conf)) or "(all free)"
        pred = closed_string_modes(sorted(conf), FREQS, a.kl) if conf else []
        ptxt = ", ".join(f"{g} {f:.1f} Hz" for g, f in pred) or "-"
        line = f"  {t0:7.3f}..{t1:7.3f} s  {desc:22s} predicted lowest mode: {ptxt}"
        if xs:
            mags, df = spectrum(segment(xs, t0 + 0.02, t1))
            peaks, top = find_peaks(mags, df, 50, a.fmax, a.floor)
            peaks.sort(key=lambda p: -p[1])
            loudest = peaks[0][0] if peaks else None
            strongest = sorted(peaks[: a.top])
            line += "\n      measured peaks: " + ", ".join(f"{f:.1f}" + ("*" if f == loudest else "") for f, db in strongest)
        print(line)
    print("(* the strongest peak; measured peaks are the strongest ones, in Hz, sorted by frequency)")


def cmd_level(a):
    xs = read_channel(a.csv, a.channel)
    peak = max(abs(x) for x in xs)
    seg = segment(xs, a.t_from, a.t_to)
    m = max(abs(x) for x in seg)
    print(f"{a.t_from}..{a.t_to} s: max |x| = {m:.3e}, {20 * math.log10(m / peak):.1f} dB re the peak of the whole file ({peak:.3e})")


def cmd_energy(a):
    with open(a.energy) as f:
        r = list(csv.reader(f))
    head, body = r[0], r[1:]
    steps = [int(x[0]) for x in body]
    i = min(range(len(steps)), key=lambda k: abs(steps[k] - a.step))
    print(",".join(head))
    for row in body[max(0, i - a.rows) : i + a.rows + 1]:
        print(",".join(row))


def main():
    signal.signal(signal.SIGPIPE, signal.SIG_DFL)  # `| head` ends quietly
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    sub = ap.add_subparsers(dest="cmd", required=True)
    p = sub.add_parser("events")
    p.add_argument("events")
    p.set_defaults(fn=cmd_events)
    p = sub.add_parser("score")
    p.add_argument("events")
    p.add_argument("--gap", type=float, default=0.5)
    p.set_defaults(fn=cmd_score)
    p = sub.add_parser("summary")
    p.add_argument("events")
    p.add_argument("--duration", type=float, required=True)
    p.add_argument("--gap", type=float, default=0.5)
    p.set_defaults(fn=cmd_summary)
    for name, fn in (("peaks", cmd_peaks), ("partials", cmd_partials)):
        p = sub.add_parser(name)
        p.add_argument("csv")
        p.add_argument("--channel", type=int, default=0)
        p.add_argument("--fmin", type=float, default=20.0)
        p.add_argument("--fmax", type=float, default=2000.0)
        p.add_argument("--floor", type=float, default=60.0, help="dB below the strongest peak")
        if name == "peaks":
            p.add_argument("--from", dest="t_from", type=float, required=True)
            p.add_argument("--to", dest="t_to", type=float, required=True)
            p.add_argument("--top", type=int, default=8)
            p.add_argument("--pad", type=int, default=4)
        p.set_defaults(fn=fn)
    p = sub.add_parser("configs")
    p.add_argument("events")
    p.add_argument("csv", nargs="?")
    p.add_argument("--duration", type=float, default=24.0)
    p.add_argument("--min", type=float, default=0.2)
    p.add_argument("--kl", type=float, default=0.005)
    p.add_argument("--fmax", type=float, default=1500.0)
    p.add_argument("--floor", type=float, default=40.0)
    p.add_argument("--top", type=int, default=10)
    p.set_defaults(fn=cmd_configs)
    p = sub.add_parser("level")
    p.add_argument("csv")
    p.add_argument("--channel", type=int, default=0)
    p.add_argument("--from", dest="t_from", type=float, required=True)
    p.add_argument("--to", dest="t_to", type=float, required=True)
    p.set_defaults(fn=cmd_level)
    p = sub.add_parser("energy")
    p.add_argument("energy")
    p.add_argument("--step", type=int, required=True)
    p.add_argument("--rows", type=int, default=3)
    p.set_defaults(fn=cmd_energy)
    a = ap.parse_args()
    a.fn(a)


if __name__ == "__main__":
    sys.exit(main())
