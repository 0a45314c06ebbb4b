//! Engine throughput: mass-steps per second of `Engine::process` on the benchmark models, next to
//! an in-process baseline, a plain Rust port of the generic C kernel `cref.c` (schedule "ideal").
//!
//! ```text
//! cargo bench -p cordis-core --bench engine                      # every model
//! cargo bench -p cordis-core --bench engine -- string 1000       # a selection
//! cargo bench -p cordis-core --bench engine -- membrane 32x32 random
//! CORDIS_BENCH_WORK=2e6 cargo bench -p cordis-core --bench engine   # a quick run
//! cargo bench -p cordis-core --bench engine -- threads 100000    # 1 vs 2 threads
//! CORDIS_SIMD=avx2 cargo bench -p cordis-core --bench engine -- random   # as on a CPU without AVX-512
//! ```
//!
//! Models (every parameter as in the C baselines: M = 1, REF K = 0.1, Z = 0.0001, V0 = 1):
//! - `string N`: N masses between two SOL grounds, N+1 links, strike on mass N/4, SOX on N/2;
//! - `but N`, `lnl N`: the same string with every link a BUT (threshold so large that it is always
//!   in contact) or an LNL (3-point curves, linear with slopes K and Z): the nonlinear-module cost;
//! - `membrane R C` (or `membrane RxC`): 4-neighbour REF links, one ground per missing neighbour of a
//!   border mass, strike at (2,2), SOX at the centre;
//! - `rimmed R C` (or `rimmed RxC`): the same membrane declared as the language's `membrane`
//!   generator does (one rim, its links after the grid's); no default size;
//! - `free R C`: that membrane without its rim (a free border); `struck R C`: with its rim and a
//!   hammer (a MAS of inertia 4 declared after the membrane, falling from x = 2 at 0.01 per step
//!   onto the mass at (R/3, C/3) through a BUT link, K and Z as the membrane's, S = 0): the unit
//!   of work counts the hammer; `pair R C`: that struck membrane and a second one with its rim
//!   declared after it, the two centres tied by a REF link (both membranes count); `graded R C`:
//!   the membrane with its rim, the masses of row r of inertia M (1 + r / R);
//! - `strings S N` (or `strings SxN`): S strings of N masses, each declared as the language's
//!   `string` generator does (two grounds of its own), string s of stiffness K (1 + s / 100),
//!   each struck on its mass N/4, SOX on the middle of the first; no default size;
//! - `random N`: N masses, each the end 1 of 2 REF links to masses drawn by a seeded LCG (4 links
//!   per mass on average), one ground tied to mass 0, strike on N/4, SOX on N/2.
//! - `random-but N`, `random-lnl N`: the same network with every link a BUT of threshold 0 (a
//!   null-length spring in contact while `x2 - x1 < 0`), or an LNL as the `lnl` string's;
//!   `random-struck N`: the REF network and a hammer as `struck`'s, on mass N/3 (the hammer
//!   counts in the unit of work); `random-lnl-mixed N`: LNL links of two pairs of curves (the
//!   second 1.1 times as stiff), a link's pair chosen by its end 2, so mixed in nearly every
//!   group's rows; `random-lnl-halves N`: two random networks of N/2 masses (each struck on
//!   its mass N/4), the links of each of its own pair, tied by one LNL link;
//!   `random-lnl-struck N`: the LNL network and a hammer as `random-struck`'s;
//!   `random-but-lnl N`: BUT links of threshold 0 and LNL links, a link's law chosen by its end
//!   2, so mixed in nearly every group's rows.
//! - `lnl-drawn N`, `lnl-fine N`, `lnl-full N`, `lnl-long N` (default 1000), `random-lnl-drawn
//!   N`, `random-lnl-fine N`, `random-lnl-full N`, `random-lnl-long N`: the `lnl` string and the
//!   `random-lnl` network with a stiffness curve of 7, 13, 16 or 33 points (a hardening spring
//!   drawn point by point, drawn finely, drawn at 16 points, sampled from its formula); `random-lnl-long-halves N`: `random-lnl-halves` with the
//!   first half's pair `random-lnl-long`'s (a pair of 33 points and one of 3, by region).
//! - `lnl-stick N` (default 1000), `random-lnl-stick N`: the `lnl` string and the `random-lnl`
//!   network with the papers' sticking spring as the stiffness curve (4 points, two of them
//!   jumps: a spring of slope K that exists only while the elongation is within ±L).
//! - `random-damped N`: the `random` network with each mass tied to the ground by a FRO of
//!   viscosity 1e-5 (air damping): rows of REF and FRO terms.
//!
//! `threads [N [T [KIND...]]]` times a string of N masses, a membrane of about N masses (316x316
//! for 100,000), a `pair` of membranes of about N/2 masses each (224x224), and random networks of
//! N masses, of REF links and of LNL links as `random-lnl`, `random-lnl-long` and
//! `random-lnl-mixed` (or only the models whose names start with the KINDs named: `string`,
//! `membrane`, `pair`, `random`, `random_lnl`, ...) on 1 and on T threads (default 2), printing
//! both figures, their ratio, the load average and whether the outputs are bit-identical.
//!
//! A kind without a size selects its default models. Work per timed run: `CORDIS_BENCH_WORK`
//! mass-steps (default 2e8, as `baselines.sh`), i.e. `steps = work / masses` (at least 1000). Each
//! model is timed 5 times, cordis and the baseline back to back, and the medians are printed.
//! cordis runs in blocks of 1024 frames (`CORDIS_BENCH_BLOCK`, e.g. 64 as a real-time host's) into
//! one reused output buffer.
#![allow(clippy::unwrap_used)] // tests and benches may panic on failure

use std::hint::black_box;
use std::ops::Range;
use std::time::Instant;

use cordis_core::{Curve, Engine, Interaction, MatId, Material, Network, SimdLimit};

const M: f64 = 1.0;
const K: f64 = 0.1;
const Z: f64 = 0.0001;
const V0: f64 = 1.0;
/// The FRO of `random-damped`'s masses to the ground (air damping).
const AIR: f64 = 1.0e-5;
/// BUT threshold: far beyond any elongation of these models, so the links are always active.
const BUT_S: f64 = 1.0e3;
/// Half-width of the LNL curves: far beyond any elongation or velocity of these models.
const LNL_L: f64 = 1.0e3;
/// Frames per `Engine::process` call unless `CORDIS_BENCH_BLOCK` says otherwise.
const DEFAULT_BLOCK: usize = 1024;
const RUNS: usize = 5;
const DEFAULT_WORK: u64 = 200_000_000;
const MIN_STEPS: u64 = 1000;
/// Steps in 10 s at 44.1 kHz.
const TEN_SECONDS: u64 = 441_000;

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Law {
    Ref,
    But,
    Lnl,
    /// REF links and a hammer (the random network only)
    Struck,
    /// LNL links of two pairs of curves, the second's stiffness 1.1 times the first's, the pair
    /// of a link chosen by its end 2 (the random network only): mixed in nearly every row
    LnlMixed,
    /// Two random networks of N/2 masses, the LNL links of each of its own pair of curves (as
    /// `LnlMixed`'s), tied by one LNL link: rows of one pair
    LnlHalves,
    /// LNL links and a hammer (the random network only)
    LnlStruck,
    /// BUT links of threshold 0 and LNL links, a link's law chosen by its end 2 (the random
    /// network only): mixed in nearly every row
    ButLnl,
    /// LNL links of curves drawn point by point ([`drawn`]): 7 points, and `Lnl`'s viscous curve
    LnlDrawn,
    /// LNL links of curves drawn finely ([`fine`]): 13 points, and `Lnl`'s viscous curve
    LnlFine,
    /// LNL links of a 16-point curve ([`full`]): no point of padding, and `Lnl`'s viscous curve
    LnlFull,
    /// LNL links of curves sampled ([`sampled`]): 33 points, and `Lnl`'s viscous curve
    LnlLong,
    /// LNL links of the sticking spring ([`sticking`]): 4 points, and `Lnl`'s viscous curve
    LnlStick,
    /// `LnlHalves` with the first half's pair `LnlLong`'s (the random network only): a pair of
    /// 33 points and one of 3, by region
    LnlLongHalves,
    /// REF links and each mass tied to the ground by a FRO (air damping; the random network only)
    Damped,
}

impl Law {
    fn interaction(self) -> Interaction {
        match self {
            Law::Ref | Law::Struck | Law::Damped => Interaction::Ref { k: K, z: Z },
            Law::LnlMixed | Law::LnlHalves | Law::LnlStruck | Law::ButLnl => Law::Lnl.interaction(),
            Law::But => Interaction::But {
                k: K,
                z: Z,
                s: BUT_S,
            },
            Law::Lnl => lnl(K),
            Law::LnlDrawn => drawn(K),
            Law::LnlFine => fine(K),
            Law::LnlFull => full(K),
            Law::LnlLong | Law::LnlLongHalves => sampled(K),
            Law::LnlStick => sticking(K),
        }
    }
}

/// A BUT link of threshold 0 (K and Z as the models' REF links): a null-length spring in contact
/// while `x2 - x1 < 0`: a hammer's felt, and the random networks' BUT.
fn contact() -> Interaction {
    Interaction::But { k: K, z: Z, s: 0.0 }
}

/// An LNL link of 3-point curves through 0 with slopes `k` and Z.
fn lnl(k: f64) -> Interaction {
    let curve = |slope: f64| {
        Curve::new(&[(-LNL_L, -slope * LNL_L), (0.0, 0.0), (LNL_L, slope * LNL_L)])
            .expect("a valid curve")
    };
    Interaction::Lnl {
        lk: curve(k),
        lz: curve(Z),
    }
}

/// An LNL link of a 7-point stiffness curve, as a user draws a hardening spring point by point:
/// slope `k` from `-L` to `L` (points at 0, ±L/2 and ±L), `2k` beyond, to ±2L; and the 3-point
/// viscous curve of slope Z (`lnl`'s). The models stay within ±L, where it is `lnl(k)`'s spring
/// (so the Rust generic's linear string checks it), but the engine evaluates all 7 points.
fn drawn(k: f64) -> Interaction {
    hardening(k, &[-2.0, -1.0, -0.5, 0.0, 0.5, 1.0, 2.0])
}

/// An LNL link of a 13-point stiffness curve, [`drawn`]'s spring drawn more finely: points at 0,
/// ±L/4, ±L/2, ±3L/4, ±L, ±3L/2 and ±2L.
fn fine(k: f64) -> Interaction {
    let at = [0.0, 0.25, 0.5, 0.75, 1.0, 1.5, 2.0];
    let mut ts: Vec<f64> = at.iter().rev().map(|t| -t).collect();
    ts.extend(&at[1..]);
    hardening(k, &ts)
}

/// An LNL link of a 16-point stiffness curve, [`drawn`]'s spring drawn every L/4 from -2L to
/// 7L/4: a curve the engine keeps at 16 points, no point of padding to skip.
fn full(k: f64) -> Interaction {
    let ts: Vec<f64> = (-8..8).map(|i| f64::from(i) / 4.0).collect();
    hardening(k, &ts)
}

/// An LNL link of a 33-point stiffness curve, [`drawn`]'s spring sampled every L/8 from -2L to
/// 2L, as a curve computed from a formula is.
fn sampled(k: f64) -> Interaction {
    let ts: Vec<f64> = (-16..=16).map(|i| f64::from(i) / 8.0).collect();
    hardening(k, &ts)
}

/// An LNL link of the simple sticking device's spring (FORMALISM.md, "Devices from the papers"):
/// the 4-point curve `(-S, 0) (-S, -k S) (S, k S) (S, 0)` of `S = L`, a spring of slope `k` that
/// exists only while the elongation is within ±L; and `lnl(k)`'s viscous curve (the device
/// damps through two BUTs instead; here the viscous curve keeps the link `lnl(k)`'s within ±L, so
/// the Rust generic's linear kernel checks it).
fn sticking(k: f64) -> Interaction {
    let s = LNL_L;
    with_lnl_damper(&[(-s, 0.0), (-s, -k * s), (s, k * s), (s, 0.0)])
}

/// An LNL link of the stiffness curve through `points` and `lnl`'s viscous curve (slope Z).
fn with_lnl_damper(points: &[(f64, f64)]) -> Interaction {
    let Interaction::Lnl { lz, .. } = lnl(K) else {
        unreachable!("an LNL link")
    };
    Interaction::Lnl {
        lk: Curve::new(points).expect("a valid curve"),
        lz,
    }
}

/// [`drawn`]'s spring through the points of abscissas `ts` times `L`, and `lnl(k)`'s viscous
/// curve.
fn hardening(k: f64, ts: &[f64]) -> Interaction {
    let l = LNL_L;
    let points: Vec<(f64, f64)> = (ts.iter())
        .map(|&t| {
            let y = if t.abs() <= 1.0 {
                t
            } else {
                t.signum() * (2.0 * t.abs() - 1.0)
            };
            (t * l, k * y * l)
        })
        .collect();
    with_lnl_damper(&points)
}

#[derive(Clone, Debug, PartialEq, Eq)]
enum Spec {
    String(usize, Law),
    Membrane(usize, usize),
    /// A membrane laid out as the language's `membrane` generator declares it, with a rim or
    /// without, or struck by a hammer.
    Rimmed(usize, usize, Rim),
    /// A random network, its links of one law.
    Random(usize, Law),
    /// `strings S N`: S strings of N masses, each as the language's `string` generator declares
    /// it (its masses, a left ground and its link, the inner links, a right ground and its
    /// link), string `s` of stiffness `K (1 + s / 100)`; a bank of short strings (a harp, a
    /// piano's unison courses).
    Strings(usize, usize),
}

const DEFAULT_MODELS: [Spec; 6] = [
    Spec::String(1000, Law::Ref),
    Spec::String(10000, Law::Ref),
    Spec::Membrane(100, 100),
    Spec::Random(10000, Law::Ref),
    Spec::String(1000, Law::But),
    Spec::String(1000, Law::Lnl),
];

struct Model {
    name: String,
    net: Network,
    /// Mobile masses: the unit of work (grounds are not counted, as in `baselines.sh`).
    masses: usize,
    /// The SOX mass.
    out: MatId,
}

fn mass(net: &mut Network, v0: f64) -> MatId {
    net.add_material(Material::Mas { m: M, x0: 0.0, v0 })
}

fn ground(net: &mut Network) -> MatId {
    net.add_material(Material::Sol { x0: 0.0 })
}

/// A hammer (a MAS of inertia 4, falling from x = 2 at 0.01 per step) declared now, tied to
/// `target` by a BUT link (K and Z as the models' REF links, S = 0).
fn hammer(net: &mut Network, target: MatId) {
    let hammer = net.add_material(Material::Mas {
        m: 4.0 * M,
        x0: 2.0,
        v0: -0.01,
    });
    net.add_link(contact(), target, hammer);
}

/// As `gen_models.py build_string`: ground, N masses, ground, chained by N+1 links.
fn string(n: usize, law: Law) -> Model {
    let mut net = Network::new();
    let g0 = ground(&mut net);
    let masses: Vec<MatId> = (0..n)
        .map(|i| mass(&mut net, if i == n / 4 { V0 } else { 0.0 }))
        .collect();
    let g1 = ground(&mut net);
    let chain: Vec<MatId> = std::iter::once(g0)
        .chain(masses.iter().copied())
        .chain(std::iter::once(g1))
        .collect();
    for w in chain.windows(2) {
        net.add_link(law.interaction(), w[0], w[1]);
    }
    let out = masses[n / 2];
    net.add_position_output(out);
    let name = match law {
        Law::Ref => format!("string_N{n}"),
        Law::But => format!("string_but_N{n}"),
        Law::Lnl => format!("string_lnl_N{n}"),
        Law::LnlDrawn => format!("string_lnl_drawn_N{n}"),
        Law::LnlFine => format!("string_lnl_fine_N{n}"),
        Law::LnlFull => format!("string_lnl_full_N{n}"),
        Law::LnlLong => format!("string_lnl_long_N{n}"),
        Law::LnlStick => format!("string_lnl_stick_N{n}"),
        _ => unreachable!("a string's links are of one law"),
    };
    Model {
        name,
        net,
        masses: n,
        out,
    }
}

/// `strings` strings of `n` masses, each declared as the language's `string` generator does,
/// string `s` of stiffness `K (1 + s / 100)` and struck on its mass `n / 4`; SOX on the middle
/// of the first string.
fn strings(strings: usize, n: usize) -> Model {
    let mut net = Network::new();
    let mut out = None;
    for s in 0..strings {
        let k = K * (1.0 + s as f64 / 100.0);
        let law = Interaction::Ref { k, z: Z };
        let masses: Vec<MatId> = (0..n)
            .map(|i| mass(&mut net, if i == n / 4 { V0 } else { 0.0 }))
            .collect();
        let left = ground(&mut net);
        net.add_link(law.clone(), left, masses[0]);
        for w in masses.windows(2) {
            net.add_link(law.clone(), w[0], w[1]);
        }
        let right = ground(&mut net);
        net.add_link(law, masses[n - 1], right);
        out = out.or(Some(masses[n / 2]));
    }
    let out = out.expect("at least one string");
    net.add_position_output(out);
    Model {
        name: format!("strings_{strings}x{n}"),
        net,
        masses: strings * n,
        out,
    }
}

/// What the language-style membrane of [`membrane`] has around it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Rim {
    /// One rim (`sol`), tied to each edge mass per missing neighbour.
    Fixed,
    /// Nothing: a free border.
    Free,
    /// The rim, and a hammer falling onto the mass at (R/3, C/3).
    Struck,
    /// Struck, and a second membrane with a rim after it, its centre tied to the first's by a
    /// link of the membranes' law (two sheets of the grid step).
    Pair,
    /// The rim, and each mass of row `r` of inertia `M (1 + r / R)`: per-mass inertias, divided
    /// by.
    Graded,
}

/// As `gen_models.py build_membrane` (one ground per missing neighbour, horizontal links row by row
/// then vertical links column by column), struck at (2,2) and observed at the centre as in
/// `baselines.sh`. With a `rim`: laid out as the language's `membrane` generator declares it
/// (docs/LANGUAGE.md) instead: the horizontal links row by row, the vertical links row by row, then
/// one rim (`sol`) and a link from it to each edge mass per missing neighbour, row by row (no rim
/// for `Rim::Free`; a hammer after it for `Rim::Struck`; a second membrane after that for
/// `Rim::Pair`).
fn membrane(rows: usize, cols: usize, rim: Option<Rim>) -> Model {
    if rim == Some(Rim::Pair) {
        let mut pair = membrane(rows, cols, Some(Rim::Struck));
        let second = pair.net.append(&membrane(rows, cols, Some(Rim::Fixed)).net);
        let centre = MatId(second.0 + (rows / 2 * cols + cols / 2) as u32);
        pair.net.add_link(Law::Ref.interaction(), pair.out, centre);
        pair.net.outputs.truncate(1); // (the first's SOX only, which the generic kernel records)
        pair.masses += rows * cols;
        pair.name = format!("pair_{rows}x{cols}");
        return pair;
    }
    if rim == Some(Rim::Graded) {
        let mut graded = membrane(rows, cols, Some(Rim::Fixed));
        for (i, mat) in graded
            .net
            .materials
            .iter_mut()
            .take(rows * cols)
            .enumerate()
        {
            if let Material::Mas { m, .. } = mat {
                *m = M * (1.0 + (i / cols) as f64 / rows as f64);
            }
        }
        graded.name = format!("graded_{rows}x{cols}");
        return graded;
    }
    let mut net = Network::new();
    let mut idx = Vec::with_capacity(rows * cols);
    for r in 0..rows {
        for c in 0..cols {
            idx.push(mass(&mut net, if (r, c) == (2, 2) { V0 } else { 0.0 }));
        }
    }
    let at = |r: usize, c: usize| idx[r * cols + c];
    let law = Law::Ref.interaction();
    let mut masses = rows * cols;
    if let Some(rim) = rim {
        for r in 0..rows {
            for c in 0..cols - 1 {
                net.add_link(law.clone(), at(r, c), at(r, c + 1));
            }
        }
        for r in 0..rows - 1 {
            for c in 0..cols {
                net.add_link(law.clone(), at(r, c), at(r + 1, c));
            }
        }
        if rim != Rim::Free {
            let sol = ground(&mut net);
            for r in 0..rows {
                for c in 0..cols {
                    let missing = [r == 0, r == rows - 1, c == 0, c == cols - 1];
                    for _ in missing.iter().filter(|&&m| m) {
                        net.add_link(law.clone(), sol, at(r, c));
                    }
                }
            }
        }
        if rim == Rim::Struck {
            hammer(&mut net, at(rows / 3, cols / 3));
            masses += 1;
        }
    } else {
        for r in 0..rows {
            let g = ground(&mut net);
            net.add_link(law.clone(), g, at(r, 0));
            for c in 0..cols - 1 {
                net.add_link(law.clone(), at(r, c), at(r, c + 1));
            }
            let g = ground(&mut net);
            net.add_link(law.clone(), at(r, cols - 1), g);
        }
        for c in 0..cols {
            let g = ground(&mut net);
            net.add_link(law.clone(), g, at(0, c));
            for r in 0..rows - 1 {
                net.add_link(law.clone(), at(r, c), at(r + 1, c));
            }
            let g = ground(&mut net);
            net.add_link(law.clone(), at(rows - 1, c), g);
        }
    }
    let out = at(rows / 2, cols / 2);
    net.add_position_output(out);
    let kind = match rim {
        None => "membrane",
        Some(Rim::Fixed) => "rimmed",
        Some(Rim::Free) => "free",
        Some(Rim::Struck) => "struck",
        Some(Rim::Pair | Rim::Graded) => unreachable!("built from the other membranes above"),
    };
    Model {
        name: format!("{kind}_{rows}x{cols}"),
        net,
        masses,
        out,
    }
}

/// `model` in the plain-text netlist format of the C baseline kit (`gen_models.py`): the C generic
/// kernel `cref.c` reads it, so it can be timed on every benchmark model (the kit's own generator
/// has strings and membranes only). Node `i` is material `i`; MAS, SOL and REF only.
fn netlist(model: &Model) -> String {
    use std::fmt::Write;
    let net = &model.net;
    let mut s = format!(
        "# oracle netlist v1 -- model {} (written by cordis's engine benchmark)\ncounts {} {} 0 1\n",
        model.name,
        net.materials.len(),
        net.links.len()
    );
    for (i, m) in net.materials.iter().enumerate() {
        let (x0, x1) = m.initial_state();
        match m {
            Material::Mas { m, .. } => writeln!(s, "node {i} mass {m:?} 0.0 {x0:?} {x1:?}"),
            Material::Sol { .. } => writeln!(s, "node {i} ground {x0:?}"),
            _ => panic!("netlists hold MAS and SOL only"),
        }
        .unwrap();
    }
    for (l, link) in net.links.iter().enumerate() {
        let Interaction::Ref { k, z } = link.law else {
            panic!("netlists hold REF links only")
        };
        let (a, b) = (link.a.index(), link.b.index());
        writeln!(s, "link {l} springDamper {a} {b} {k:?} {z:?} 0.0 0.0").unwrap();
    }
    writeln!(s, "out 0 {}", model.out.index()).unwrap();
    s
}

/// 64-bit LCG (Knuth's MMIX constants); the high bits are the random ones.
struct Lcg(u64);

impl Lcg {
    fn below(&mut self, n: usize) -> usize {
        self.0 = self
            .0
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        ((self.0 >> 33) % n as u64) as usize
    }
}

/// N masses; mass i is end 1 of two REF links to other masses drawn at random (so 4 links per mass
/// on average, scattered over the whole state); one ground tied to mass 0.
fn random(n: usize, law: Law) -> Model {
    // (a BUT of threshold 0: a null-length spring in contact while `x2 - x1 < 0`, about half the
    // time; the strings' threshold would leave every mass of a random network pushed one way)
    let interaction = match law {
        Law::But => contact(),
        law => law.interaction(),
    };
    let halves = matches!(law, Law::LnlHalves | Law::LnlLongHalves);
    let mut net = Network::new();
    let struck = |i: usize| i == n / 4 || (halves && i == n / 2 + n / 4);
    let masses: Vec<MatId> = (0..n)
        .map(|i| mass(&mut net, if struck(i) { V0 } else { 0.0 }))
        .collect();
    let g = ground(&mut net);
    net.add_link(Law::Ref.interaction(), g, masses[0]);
    let mut rng = Lcg(0x00c0_4d15_2026_1122);
    for (i, &a) in masses.iter().enumerate() {
        // (the masses `i` may draw from: all, or those of its half)
        let (from, count) = match (halves, i < n / 2) {
            (false, _) => (0, n),
            (true, true) => (0, n / 2),
            (true, false) => (n / 2, n - n / 2),
        };
        for _ in 0..2 {
            let j = from + (i - from + 1 + rng.below(count - 1)) % count; // any mass but i
            let second = match law {
                Law::LnlMixed => j % 2 == 1,
                _ => halves && i >= n / 2,
            };
            let link = if law == Law::ButLnl && j % 2 == 1 {
                contact()
            } else if second {
                lnl(1.1 * K)
            } else {
                interaction.clone()
            };
            net.add_link(link, a, masses[j]);
        }
    }
    if matches!(law, Law::Struck | Law::LnlStruck) {
        hammer(&mut net, masses[n / 3]);
    }
    if halves {
        net.add_link(interaction, masses[0], masses[n - 1]);
    }
    if law == Law::Damped {
        for &m in &masses {
            net.add_link(Interaction::Fro { z: AIR }, m, g);
        }
    }
    let out = masses[n / 2];
    net.add_position_output(out);
    Model {
        name: match law {
            Law::Ref => format!("random_N{n}"),
            Law::But => format!("random_but_N{n}"),
            Law::Lnl => format!("random_lnl_N{n}"),
            Law::Struck => format!("random_struck_N{n}"),
            Law::LnlMixed => format!("random_lnl_mixed_N{n}"),
            Law::LnlHalves => format!("random_lnl_halves_N{n}"),
            Law::LnlStruck => format!("random_lnl_struck_N{n}"),
            Law::ButLnl => format!("random_but_lnl_N{n}"),
            Law::LnlDrawn => format!("random_lnl_drawn_N{n}"),
            Law::LnlFine => format!("random_lnl_fine_N{n}"),
            Law::LnlFull => format!("random_lnl_full_N{n}"),
            Law::LnlLong => format!("random_lnl_long_N{n}"),
            Law::LnlStick => format!("random_lnl_stick_N{n}"),
            Law::LnlLongHalves => format!("random_lnl_long_halves_N{n}"),
            Law::Damped => format!("random_damped_N{n}"),
        },
        net,
        masses: n + usize::from(matches!(law, Law::Struck | Law::LnlStruck)),
        out,
    }
}

fn build(spec: &Spec) -> Model {
    match *spec {
        Spec::String(n, law) => string(n, law),
        Spec::Membrane(r, c) => membrane(r, c, None),
        Spec::Rimmed(r, c, rim) => membrane(r, c, Some(rim)),
        Spec::Random(n, law) => random(n, law),
        Spec::Strings(s, n) => strings(s, n),
    }
}

/// Plain Rust port of the generic C kernel `cref.c`, schedule "ideal": structure-of-arrays state
/// with the mobile masses first and the grounds after them; per step, one loop over the list of
/// spring-dampers computing each force and scattering it onto both ends (then one over the
/// collisions, i.e. BUT), then one loop over the masses. The output is recorded before the mass
/// update, as cordis does (sample s is x(s)), so that both produce the same samples.
struct Generic {
    nm: usize,
    x: Vec<f64>,
    xp: Vec<f64>,
    f: Vec<f64>,
    x0: Vec<f64>,
    x1: Vec<f64>,
    c_inv_m: Vec<f64>,
    grav: Vec<f64>,
    li: Vec<u32>,
    lj: Vec<u32>,
    lk: Vec<f64>,
    lz: Vec<f64>,
    ci: Vec<u32>,
    cj: Vec<u32>,
    ck: Vec<f64>,
    cz: Vec<f64>,
    ct: Vec<f64>,
    out: usize,
}

impl Generic {
    /// REF links become spring-dampers and BUT links collisions, as in `cref.c`. LNL links (which
    /// `cref.c` does not have) become spring-dampers with the slopes of their curves at 0: the
    /// linear kernel the nonlinear one is compared with.
    fn new(net: &Network, out: MatId) -> Generic {
        let n = net.materials.len();
        let mut map = vec![0u32; n];
        let mut next = 0u32;
        let mut c_inv_m = Vec::new();
        for (i, m) in net.materials.iter().enumerate() {
            if let Material::Mas { m, .. } = m {
                map[i] = next;
                next += 1;
                c_inv_m.push(1.0 / m);
            }
        }
        let nm = next as usize;
        for (i, m) in net.materials.iter().enumerate() {
            match m {
                Material::Mas { .. } => {}
                Material::Sol { .. } => {
                    map[i] = next;
                    next += 1;
                }
                other => panic!("the generic baseline has no {}", other.kind()),
            }
        }
        let mut x0 = vec![0.0; n];
        let mut x1 = vec![0.0; n];
        for (i, m) in net.materials.iter().enumerate() {
            let (a, b) = m.initial_state();
            x0[map[i] as usize] = a;
            x1[map[i] as usize] = b;
        }
        let mut g = Generic {
            nm,
            x: vec![0.0; n],
            xp: vec![0.0; n],
            f: vec![0.0; n],
            x0,
            x1,
            c_inv_m,
            grav: vec![0.0; nm],
            li: Vec::new(),
            lj: Vec::new(),
            lk: Vec::new(),
            lz: Vec::new(),
            ci: Vec::new(),
            cj: Vec::new(),
            ck: Vec::new(),
            cz: Vec::new(),
            ct: Vec::new(),
            out: map[out.index()] as usize,
        };
        for link in &net.links {
            let (i, j) = (map[link.a.index()], map[link.b.index()]);
            let (k, z) = match &link.law {
                Interaction::Ref { k, z } => (*k, *z),
                // (a RES or FRO as a REF with the other product of a zero factor: the same
                // values, `0 dv` or `0 dx` adding a zero)
                Interaction::Res { k } => (*k, 0.0),
                Interaction::Fro { z } => (0.0, *z),
                Interaction::Lnl { lk, lz } => (lk.slope(0.0), lz.slope(0.0)),
                Interaction::But { k, z, s } => {
                    g.ci.push(i);
                    g.cj.push(j);
                    g.ck.push(*k);
                    g.cz.push(*z);
                    g.ct.push(*s);
                    continue;
                }
            };
            g.li.push(i);
            g.lj.push(j);
            g.lk.push(k);
            g.lz.push(z);
        }
        g
    }

    fn reset(&mut self) {
        self.x.copy_from_slice(&self.x0);
        self.xp.copy_from_slice(&self.x1);
        self.f.fill(0.0);
    }

    #[inline]
    fn links(&mut self) {
        let (x, xp, f) = (&self.x, &self.xp, &mut self.f);
        for l in 0..self.li.len() {
            let (i, j) = (self.li[l] as usize, self.lj[l] as usize);
            let fl = self.lk[l] * (x[i] - x[j]) + self.lz[l] * ((x[i] - xp[i]) - (x[j] - xp[j]));
            f[i] -= fl;
            f[j] += fl;
        }
        for c in 0..self.ci.len() {
            let (i, j) = (self.ci[c] as usize, self.cj[c] as usize);
            let t = self.ct[c];
            if x[j] - x[i] < t {
                let fl = self.ck[c] * ((x[i] + t) - x[j])
                    + self.cz[c] * (((x[i] + t) - (xp[i] + t)) - (x[j] - xp[j]));
                f[i] -= fl;
                f[j] += fl;
            }
        }
    }

    #[inline]
    fn masses(&mut self) {
        let nm = self.nm;
        for i in 0..nm {
            let xn = 2.0 * self.x[i] - self.xp[i] + (self.f[i] - self.grav[i]) * self.c_inv_m[i];
            self.xp[i] = self.x[i];
            self.x[i] = xn;
            self.f[i] = 0.0;
        }
        self.f[nm..].fill(0.0); // grounds: forces discarded
    }

    /// Runs `steps` steps from the initial state; returns the sum of the output samples.
    fn run(&mut self, steps: u64) -> f64 {
        self.reset();
        let mut acc = 0.0;
        for _ in 0..steps {
            self.links();
            acc += self.x[self.out];
            self.masses();
        }
        acc
    }
}

/// Hand-specialised kernels for the benchmark membrane (`membrane`: M = 1, uniform REF K, Z, one
/// ground per missing neighbour, all at 0): a padded `(R+2) x (C+2)` grid whose border is the
/// grounds, neighbours implicit, no index anywhere. Two arithmetics:
/// - `exact`: the reference stepper's (FORMALISM.md): each link's force `K (x1 - x2) + Z ((x1 -
///   x1') - (x2 - x2'))` computed once (a row's horizontal links, and the vertical links below
///   it, into row buffers), each mass summing its four terms in the membrane's declaration order
///   (left `+`, right `-`, up `+`, down `-`, from `+0.0`), then `2x - x' + F / M`. The same bits
///   as cordis (the `ceiling` mode checks it): the fastest a kernel bound to the reference's
///   arithmetic can be on this model, written by hand for it.
/// - `factored`: the C stencil baseline's (`cstencil.c`): `K (Σx - 4x) + Z (Σv - 4v)` per mass, no
///   link force at all: about half the floating-point operations, not the reference's bits.
/// - `fused`: `factored` with fused multiply-adds where `gcc -O3 -march=native` contracts
///   `cstencil.c`'s expressions (`K (sx - 4x) + Z (sv - 4v)` and `2x - x' + f M`): what the C
///   stencil baseline actually runs on a CPU with FMA.
#[derive(Clone, Copy, PartialEq, Eq)]
enum Arithmetic {
    Exact,
    Factored,
    Fused,
}

struct Stencil {
    rows: usize,
    cols: usize,
    x: Vec<f64>,
    xp: Vec<f64>,
    xn: Vec<f64>,
    x0: Vec<f64>,
    x1: Vec<f64>,
    h: Vec<f64>,
    up: Vec<f64>,
    down: Vec<f64>,
    out: usize,
}

impl Stencil {
    fn new(rows: usize, cols: usize) -> Stencil {
        let w = cols + 2;
        let n = (rows + 2) * w;
        let model = membrane(rows, cols, None);
        let mut x0 = vec![0.0; n];
        let mut x1 = vec![0.0; n];
        for r in 0..rows {
            for c in 0..cols {
                // the masses are the first materials, row by row
                let (a, b) = model.net.materials[r * cols + c].initial_state();
                (x0[(r + 1) * w + c + 1], x1[(r + 1) * w + c + 1]) = (a, b);
            }
        }
        Stencil {
            rows,
            cols,
            x: vec![0.0; n],
            xp: vec![0.0; n],
            xn: vec![0.0; n],
            x0,
            x1,
            h: vec![0.0; cols + 1],
            up: vec![0.0; cols],
            down: vec![0.0; cols],
            out: (rows / 2 + 1) * w + cols / 2 + 1,
        }
    }

    fn reset(&mut self) {
        self.x.copy_from_slice(&self.x0);
        self.xp.copy_from_slice(&self.x1);
        self.xn.fill(0.0);
    }

    /// The reference's force of a link from `(xa, pa)` (end 1) to `(xb, pb)` (end 2).
    #[inline(always)]
    fn link(xa: f64, pa: f64, xb: f64, pb: f64) -> f64 {
        K * (xa - xb) + Z * ((xa - pa) - (xb - pb))
    }

    /// The vertical links from row `r` (padded) down to row `r + 1`, columns `1..=cols`.
    #[inline(always)]
    fn vertical(x: &[f64], xp: &[f64], w: usize, r: usize, out: &mut [f64]) {
        let (a, b) = (r * w + 1, (r + 1) * w + 1);
        let n = out.len();
        let (xa, pa, xb, pb) = (&x[a..a + n], &xp[a..a + n], &x[b..b + n], &xp[b..b + n]);
        for ((o, (&xa, &pa)), (&xb, &pb)) in
            out.iter_mut().zip(xa.iter().zip(pa)).zip(xb.iter().zip(pb))
        {
            *o = Stencil::link(xa, pa, xb, pb);
        }
    }

    #[inline(always)]
    fn step_exact(&mut self) {
        let (w, cols) = (self.cols + 2, self.cols);
        let (x, xp) = (&self.x, &self.xp);
        Stencil::vertical(x, xp, w, 0, &mut self.up); // the top grounds' links
        for r in 1..=self.rows {
            let row = r * w;
            let (xr, pr) = (&x[row..row + w], &xp[row..row + w]);
            let ends = (xr[..=cols].iter().zip(&pr[..=cols])).zip(xr[1..].iter().zip(&pr[1..]));
            for (h, ((&xa, &pa), (&xb, &pb))) in self.h.iter_mut().zip(ends) {
                *h = Stencil::link(xa, pa, xb, pb);
            }
            Stencil::vertical(x, xp, w, r, &mut self.down);
            let next = &mut self.xn[row + 1..row + 1 + cols];
            let own = xr[1..=cols].iter().zip(&pr[1..=cols]);
            let horizontal = self.h[..cols].iter().zip(&self.h[1..]);
            let vertical = self.up.iter().zip(&self.down);
            for (((nx, (&xc, &pc)), (&hl, &hr)), (&vu, &vd)) in
                next.iter_mut().zip(own).zip(horizontal).zip(vertical)
            {
                let f = 0.0 + hl - hr + vu - vd;
                *nx = 2.0 * xc - pc + f * M;
            }
            std::mem::swap(&mut self.up, &mut self.down);
        }
    }

    #[inline(always)]
    fn step_factored<const FUSED: bool>(&mut self) {
        let (w, cols) = (self.cols + 2, self.cols);
        let (x, xp) = (&self.x, &self.xp);
        for r in 1..=self.rows {
            fn at(buf: &[f64], w: usize, cols: usize, row: usize, dc: usize) -> &[f64] {
                &buf[row * w + dc..row * w + dc + cols]
            }
            let at = |buf, row, dc| at(buf, w, cols, row, dc);
            let next = &mut self.xn[r * w + 1..r * w + 1 + cols];
            let (xc, pc) = (at(x, r, 1), at(xp, r, 1));
            let (xl, pl, xr, pr) = (at(x, r, 0), at(xp, r, 0), at(x, r, 2), at(xp, r, 2));
            let (xu, pu, xd, pd) = (
                at(x, r - 1, 1),
                at(xp, r - 1, 1),
                at(x, r + 1, 1),
                at(xp, r + 1, 1),
            );
            for i in 0..cols {
                let (x0, v0) = (xc[i], xc[i] - pc[i]);
                let sx = xl[i] + xr[i] + xu[i] + xd[i];
                let sv = (xl[i] - pl[i]) + (xr[i] - pr[i]) + (xu[i] - pu[i]) + (xd[i] - pd[i]);
                next[i] = if FUSED {
                    let f = K.mul_add((-4.0f64).mul_add(x0, sx), Z * (-4.0f64).mul_add(v0, sv));
                    f.mul_add(M, 2.0f64.mul_add(x0, -pc[i]))
                } else {
                    let f = K * (sx - 4.0 * x0) + Z * (sv - 4.0 * v0);
                    2.0 * x0 - pc[i] + f * M
                };
            }
        }
    }

    /// [`Stencil::steps`] compiled for the widest vectors this CPU has, as cordis's loops are.
    fn run(&mut self, steps: u64, arith: Arithmetic) -> f64 {
        #[cfg(target_arch = "x86_64")]
        {
            #[target_feature(enable = "avx512f")]
            fn avx512(st: &mut Stencil, steps: u64, arith: Arithmetic) -> f64 {
                st.steps(steps, arith)
            }
            // (FMA as well, for `Fused`: `avx512f` implies it; without it `mul_add` is a library call)
            #[target_feature(enable = "avx2,fma")]
            fn avx2(st: &mut Stencil, steps: u64, arith: Arithmetic) -> f64 {
                st.steps(steps, arith)
            }
            if std::is_x86_feature_detected!("avx512f") {
                // SAFETY: the CPU has the feature.
                return unsafe { avx512(self, steps, arith) };
            }
            if std::is_x86_feature_detected!("avx2") && std::is_x86_feature_detected!("fma") {
                // SAFETY: the CPU has the features.
                return unsafe { avx2(self, steps, arith) };
            }
        }
        self.steps(steps, arith)
    }

    /// Runs `steps` steps of one arithmetic; returns the sum of the output samples.
    #[inline(always)]
    fn steps(&mut self, steps: u64, arith: Arithmetic) -> f64 {
        self.steps_traced(steps, arith, None)
    }

    /// [`Stencil::steps`], also pushing each output sample onto `trace`.
    #[inline(always)]
    fn steps_traced(
        &mut self,
        steps: u64,
        arith: Arithmetic,
        mut trace: Option<&mut Vec<f64>>,
    ) -> f64 {
        self.reset();
        let mut acc = 0.0;
        for _ in 0..steps {
            match arith {
                Arithmetic::Exact => self.step_exact(),
                Arithmetic::Factored => self.step_factored::<false>(),
                Arithmetic::Fused => self.step_factored::<true>(),
            }
            acc += self.x[self.out];
            if let Some(t) = trace.as_deref_mut() {
                t.push(self.x[self.out]);
            }
            // x(n-1) <- x(n) <- x(n+1); the grounds (border) stay 0 in all three
            std::mem::swap(&mut self.xp, &mut self.x);
            std::mem::swap(&mut self.x, &mut self.xn);
        }
        acc
    }
}

/// The reads a generic kernel cannot avoid on `net`: for each link, the two positions of each
/// end (`x(n)`, `x(n-1)`, as any force law with a damping term needs), in declaration order,
/// summed so that nothing is optimised away; no force, no store. `paired` keeps a material's two
/// positions side by side (one cache line for both), the layout that needs the fewest lines.
struct Reads {
    x: Vec<f64>,
    xp: Vec<f64>,
    pairs: Vec<[f64; 2]>,
    la: Vec<u32>,
    lb: Vec<u32>,
}

impl Reads {
    fn new(net: &Network) -> Reads {
        let n = net.materials.len();
        Reads {
            x: (0..n).map(|i| i as f64).collect(),
            xp: (0..n).map(|i| -(i as f64)).collect(),
            pairs: (0..n).map(|i| [i as f64, -(i as f64)]).collect(),
            la: net.links.iter().map(|l| l.a.index() as u32).collect(),
            lb: net.links.iter().map(|l| l.b.index() as u32).collect(),
        }
    }

    /// Returns the bits of every read, XOR-ed (a one-cycle dependency per link, so that the loop
    /// is bound by the reads, not by the latency of a floating-point sum).
    fn run(&self, steps: u64, paired: bool) -> u64 {
        #[cfg(target_arch = "x86_64")]
        {
            #[target_feature(enable = "avx512f")]
            fn avx512(r: &Reads, steps: u64, paired: bool) -> u64 {
                r.steps(steps, paired)
            }
            if std::is_x86_feature_detected!("avx512f") {
                // SAFETY: the CPU has the feature.
                return unsafe { avx512(self, steps, paired) };
            }
        }
        self.steps(steps, paired)
    }

    /// [`Reads::run`] with AVX-512 gathers (see [`gathered_reads`]), over the links `part.0 /
    /// part.1` of the list (`(0, 1)`: all; `None` without AVX-512).
    fn gathered(&self, steps: u64, part: (usize, usize)) -> Option<u64> {
        #[cfg(target_arch = "x86_64")]
        if std::is_x86_feature_detected!("avx512f") {
            let (p, parts) = part;
            let n = self.la.len();
            let links = n * p / parts..n * (p + 1) / parts;
            let (la, lb) = (&self.la[links.clone()], &self.lb[links]);
            let mut acc = 0;
            for _ in 0..steps {
                // SAFETY: the CPU has AVX-512F; the ends are material indices, within `x` and
                // `xp`, which nothing writes.
                acc ^=
                    black_box(unsafe { gathered_reads(la, lb, self.x.as_ptr(), self.xp.as_ptr()) });
            }
            return Some(acc);
        }
        let _ = (steps, part);
        None
    }

    /// Seconds for `steps` passes of [`link_reads`] on `threads` threads, each over its own share
    /// of the links, with no synchronisation at all between them.
    fn reads_on(&self, steps: u64, threads: usize) -> f64 {
        let t = Instant::now();
        std::thread::scope(|scope| {
            for p in 0..threads {
                let n = self.la.len();
                let links = n * p / threads..n * (p + 1) / threads;
                let (la, lb) = (&self.la[links.clone()], &self.lb[links]);
                scope.spawn(move || {
                    let mut acc = 0;
                    for _ in 0..steps {
                        // SAFETY: the ends are material indices, within `x` and `xp`, which
                        // nothing writes.
                        acc ^= unsafe { link_reads(la, lb, self.x.as_ptr(), self.xp.as_ptr()) };
                    }
                    black_box(acc)
                });
            }
        });
        t.elapsed().as_secs_f64()
    }

    #[inline(always)]
    fn steps(&self, steps: u64, paired: bool) -> u64 {
        let mut acc = 0;
        for _ in 0..steps {
            let mut s = 0u64;
            for (&a, &b) in self.la.iter().zip(&self.lb) {
                let (a, b) = (a as usize, b as usize);
                s ^= if paired {
                    let (pa, pb) = (self.pairs[a], self.pairs[b]);
                    (pa[0].to_bits() ^ pa[1].to_bits()) ^ (pb[0].to_bits() ^ pb[1].to_bits())
                } else {
                    (self.x[a].to_bits() ^ self.xp[a].to_bits())
                        ^ (self.x[b].to_bits() ^ self.xp[b].to_bits())
                };
            }
            acc ^= black_box(s);
        }
        acc
    }
}

/// The bits of `x[a]`, `xp[a]`, `x[b]`, `xp[b]` of every link (ends `la`, `lb`; whole blocks of
/// eight), XOR-ed, eight links per AVX-512 gather.
///
/// # Safety
/// The CPU must have AVX-512F, every end must be an index within the arrays `x` and `xp` point
/// to, and nothing may write those arrays meanwhile.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f")]
unsafe fn gathered_reads(la: &[u32], lb: &[u32], x: *const f64, xp: *const f64) -> u64 {
    use std::arch::x86_64::*;
    let mut s = _mm512_setzero_si512();
    for i in (0..la.len().min(lb.len()) / 8 * 8).step_by(8) {
        // SAFETY: `i + 8 <=` both lengths; the gathered elements are in bounds (the caller's
        // promise).
        unsafe {
            let a = _mm256_loadu_si256(la.as_ptr().add(i).cast());
            let b = _mm256_loadu_si256(lb.as_ptr().add(i).cast());
            let v = _mm512_xor_si512(
                _mm512_xor_si512(
                    _mm512_castpd_si512(_mm512_i32gather_pd::<8>(a, x)),
                    _mm512_castpd_si512(_mm512_i32gather_pd::<8>(a, xp)),
                ),
                _mm512_xor_si512(
                    _mm512_castpd_si512(_mm512_i32gather_pd::<8>(b, x)),
                    _mm512_castpd_si512(_mm512_i32gather_pd::<8>(b, xp)),
                ),
            );
            s = _mm512_xor_si512(s, v);
        }
    }
    _mm512_reduce_or_epi64(s) as u64
}

/// The bits of `x[a]`, `xp[a]`, `x[b]`, `xp[b]` of every link (ends `la`, `lb`; whole blocks of
/// eight), XOR-ed: [`gathered_reads`] where the CPU has AVX-512F, else one load at a time.
///
/// # Safety
/// Every end must be an index within the arrays `x` and `xp` point to, and nothing may write
/// those arrays meanwhile.
unsafe fn link_reads(la: &[u32], lb: &[u32], x: *const f64, xp: *const f64) -> u64 {
    #[cfg(target_arch = "x86_64")]
    if std::is_x86_feature_detected!("avx512f") {
        // SAFETY: the CPU has AVX-512F; the ends are the caller's promise.
        return unsafe { gathered_reads(la, lb, x, xp) };
    }
    let whole = la.len().min(lb.len()) / 8 * 8;
    let mut s = 0u64;
    for (&a, &b) in la[..whole].iter().zip(&lb[..whole]) {
        let (a, b) = (a as usize, b as usize);
        // SAFETY: `a` and `b` are within both arrays, which nothing writes (the caller's
        // promise).
        s ^= unsafe {
            ((*x.add(a)).to_bits() ^ (*xp.add(a)).to_bits())
                ^ ((*x.add(b)).to_bits() ^ (*xp.add(b)).to_bits())
        };
    }
    s
}

/// How [`link_reads`] reads on this CPU, for the output.
fn link_reads_are() -> &'static str {
    #[cfg(target_arch = "x86_64")]
    if std::is_x86_feature_detected!("avx512f") {
        return "gathered";
    }
    "one by one"
}

/// The least a parallel step must do on a network: the threads read both ends of their share of
/// the links ([`link_reads`]), meet at a barrier, write the positions of their share of the
/// masses (the next step's reads on the other threads must fetch them), and meet again: no
/// force, no sum, no force buffer shared. Seconds for `steps` steps.
fn exchange_on(reads: &Reads, masses: usize, steps: u64, threads: usize) -> f64 {
    use std::sync::atomic::{AtomicU64, AtomicUsize, Ordering};
    let x: Vec<AtomicU64> = reads
        .x
        .iter()
        .map(|v| AtomicU64::new(v.to_bits()))
        .collect();
    let xp: Vec<AtomicU64> = reads
        .xp
        .iter()
        .map(|v| AtomicU64::new(v.to_bits()))
        .collect();
    let arrived = AtomicUsize::new(0);
    // spin barrier: the `g`-th meeting is complete when `threads * g` threads have arrived
    let meet = |g: usize| {
        arrived.fetch_add(1, Ordering::AcqRel);
        while arrived.load(Ordering::Acquire) < threads * g {
            std::hint::spin_loop();
        }
    };
    let t = Instant::now();
    std::thread::scope(|scope| {
        for p in 0..threads {
            let (x, xp, meet) = (&x, &xp, &meet);
            let nl = reads.la.len();
            let links = nl * p / threads..nl * (p + 1) / threads;
            let mats = masses * p / threads..masses * (p + 1) / threads;
            scope.spawn(move || {
                let (la, lb) = (&reads.la[links.clone()], &reads.lb[links]);
                let mut acc = 0u64;
                for step in 0..steps as usize {
                    // SAFETY: the ends are material indices, within `x` and `xp`, which
                    // nobody writes in this phase (the barriers separate the phases).
                    let (px, pxp) = (x.as_ptr().cast(), xp.as_ptr().cast());
                    acc ^= unsafe { link_reads(la, lb, px, pxp) };
                    meet(2 * step + 1);
                    for i in mats.clone() {
                        let v = x[i].load(Ordering::Relaxed);
                        xp[i].store(v, Ordering::Relaxed);
                        x[i].store(v ^ (acc & 1), Ordering::Relaxed);
                    }
                    meet(2 * step + 2);
                }
                black_box(acc);
            });
        }
    });
    t.elapsed().as_secs_f64()
}

/// `ceiling threads [N [T]]`: on a random network of N masses, the reads of [`link_reads`] on 1
/// and on T threads (no synchronisation: an upper bound on what threads can gain), next to
/// cordis on 1 and T threads.
fn floor_threads_mode(n: usize, threads: usize) {
    let work = work();
    let model = random(n, Law::Ref);
    let steps = (work / model.masses as u64).max(MIN_STEPS);
    let mass_steps = (model.masses as u64 * steps) as f64;
    let reads = Reads::new(&model.net);
    let mut one = Engine::new(&model.net);
    let mut many = Engine::new(&model.net);
    many.set_threads(threads);
    many.set_parallel_threshold(0);
    let mut buf = vec![0.0; block() * one.channels()];
    let (mut r1, mut rn, mut c1, mut cn) = (Vec::new(), Vec::new(), Vec::new(), Vec::new());
    let (mut e1, mut en) = (Vec::new(), Vec::new());
    let m = model.masses;
    for _ in 0..RUNS {
        r1.push(reads.reads_on(steps, 1));
        rn.push(reads.reads_on(steps, threads));
        e1.push(exchange_on(&reads, m, steps, 1));
        en.push(exchange_on(&reads, m, steps, threads));
        timed(&mut c1, || run_cordis(&mut one, black_box(steps), &mut buf));
        timed(&mut cn, || {
            run_cordis(&mut many, black_box(steps), &mut buf)
        });
    }
    let (r1, rn, c1, cn) = (median(r1), median(rn), median(c1), median(cn));
    let (e1, en) = (median(e1), median(en));
    println!(
        "{}: {work:.3e} mass-steps per run, median of {RUNS}; load average {}\n\
         {:<23}1 thread {:.3e}, {threads} threads {:.3e}: x{:.2}\n\
         reads + writes:        1 thread {:.3e}, {threads} threads {:.3e}: x{:.2}\n\
         cordis:                1 thread {:.3e}, {threads} threads {:.3e}: x{:.2}",
        model.name,
        load_average(),
        format!("reads only ({}):", link_reads_are()),
        mass_steps / r1,
        mass_steps / rn,
        r1 / rn,
        mass_steps / e1,
        mass_steps / en,
        e1 / en,
        mass_steps / c1,
        mass_steps / cn,
        c1 / cn,
        work = work as f64
    );
}

/// Layouts of the pull step's reads, hand-written on the links of a random network of REF links:
/// the MAS stored by degree, eight a group, a group's `k`-th links in a row of eight lanes (a lane
/// of a MAS with fewer links reads the MAS itself, a term of `+0.0`); every link's `K` and `Z` the
/// same (in registers, as the engine's when its rows have one row of parameters); no LNL, no mask,
/// no output: an upper bound for each layout, not cordis. With AVX-512 a group is one vector
/// ([`Layout::Pairs`] and [`Layout::Cached`]); with AVX2 two of four lanes, as the engine's AVX2
/// pull step, in every [`Layout`].
///
/// Every layout but [`Layout::Own`], [`Layout::Summed`], [`Layout::Lean`], [`Layout::LeanTwins`]
/// and the four mixed ones ([`Layout::Mixed`]) computes the same operations on the same operands,
/// so the same bits (checked); `summed`, `lean`, `leantwins`, `mixed`, `mixedgather` and
/// `mixed16` reorder each MAS's sum (`summed` and `lean` the same way, the three mixed ones the
/// same way: their distance from the others' positions is printed, and `ceiling drift` follows it
/// over a 10 s render).
struct PullLayouts {
    /// MAS (the buffers hold whole groups: the last group's slots past `n` are padding)
    n: usize,
    /// per row: the other ends (their slots)
    at: Vec<[u32; 8]>,
    /// per group: the end of its rows in `at`
    ends: Vec<usize>,
    /// per row: the lanes' own slots ([`Layout::Own`])
    own: Vec<[u32; 8]>,
    /// `at` in bytes into the pair buffers ([`Layout::Lean`])
    bytes: Vec<[u32; 8]>,
    /// `at` in 16 bits ([`Layout::Mixed16`]; empty past 65,536 slots)
    narrow: Vec<[u16; 8]>,
    /// subtracted from every slot's starting `x(0) = (slot % 7) 1e-3` (with `x(-1) = 0`: the
    /// start's velocities; `0.0` but in `ceiling drift`)
    shift: f64,
    /// per row of group `g`: where each lane's MAS writes its `x(n+1)` in the mailbox, an index
    /// `8 r + j` (row `r`, lane `j`) that reads it ([`Layout::Mailbox`]); each MAS of the group
    /// has one such *write row* for each of the group's rows: it is read once for each of its
    /// links, and once for each of its group's rows it has no link in
    to: Vec<[u32; 8]>,
}

/// What each row of [`PullLayouts`] reads, and where.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
enum Layout {
    /// As the engine's pull step: a MAS's `x(n)` and `v(n) = x(n) - x(n-1)` side by side in a
    /// pair buffer; a row loads its eight other ends' pairs (16 bytes each, at scattered slots)
    /// and splits them into two vectors; each step writes `x(n+1)` and the next pairs.
    Pairs,
    /// The other ends' `x(n)` alone (8 bytes each) from the position buffer, and their `x(n-1)`
    /// from a buffer of the row's own (one vector a row, read, then overwritten with the `x(n)`
    /// just loaded: the next step's `x(n-1)`), so `v(n)` is the same subtraction; each step
    /// writes `x(n+1)` alone.
    Cached,
    /// [`Layout::Pairs`] with every lane reading its own MAS's pair: the same instructions, with
    /// no scattered read (the rows' pairs are the group's own, in the L1): what the instructions
    /// cost alone. Not the network's physics (its bits differ from the others').
    Own,
    /// Reads in order, writes scattered: a *mailbox* holds, for each row's lane, the other end's
    /// `x(n)`, and, in a second one, its `x(n-1)`, so a row reads two vectors where they lie and
    /// `v(n)` is the same subtraction; each MAS, once its `x(n+1)` is computed, writes it to every
    /// place that reads it (a third mailbox, the three taking turns as the positions do).
    Mailbox,
    /// [`Layout::Pairs`]'s reads and each link's differences `x - xj`, `v - vj` (the reference's
    /// operands), but summed before `K` and `Z` multiply them, once a group: `F = -(K Σd + Z Σdv)`,
    /// a sum reordered (not the reference's bits). A row keeps its pairs as loaded, `[x0 v0 | x2
    /// v2]` and `[x1 v1 | x3 v3]`, and takes them from the group's own, interleaved the same way,
    /// so that it splits nothing: two subtractions and two additions a half row, against two
    /// unpacks, two subtractions, two multiplications and two additions.
    Summed,
    /// [`Layout::Summed`] with each row's offsets in bytes, loaded one by one into the address
    /// (no shift, as the engine's offsets are bytes): the fewest instructions a row can have
    /// under the rules, an offset and a 16-byte load a lane and two operations a pair.
    Lean,
    /// Pairs of `x(n)` and `x(n-1)` (not `v(n)`), and no other buffer: a row computes each other
    /// end's `v(n) = x(n) - x(n-1)` (the reference's operands: the same bits), a group reads its
    /// own `x(n)` and `x(n-1)` from its pairs and writes `x(n+1)` and `x(n)` to the next, so the
    /// step's buffers are two pairs and the rows (480 KB at 10,000 MAS against the others' 720 KB
    /// in five: within a 512 KB L2 cache, where theirs are not).
    Twins,
    /// [`Layout::Lean`]'s rows on [`Layout::Twins`]'s pairs: the fewest instructions and the
    /// fewest bytes. A row sums each pair's differences `x - xj` and `x(n-1) - xj(n-1)` as
    /// loaded, and a group's `Σdv` is `Σd - Σdp` (a reordering of the reference's `(x - x') -
    /// (xj - xj')`, so not its bits, nor summed's).
    LeanTwins,
    /// Each MAS's `u = K x(n) + Z v(n)` computed once a step (every link's `K` and `Z` the same)
    /// and kept apart from its positions, 8 bytes a MAS (the first half of the pair buffers,
    /// taking turns as the pairs do): a MAS's force is `Σ (uj - u)`, summed as
    /// `Σ uj - R u` over its group's `R` rows (a lane with no link in a row reads its own `u`), a
    /// sum reordered and `K` and `Z` distributed (not the reference's bits). A row loads four
    /// scalars a half (two `movsd`, two `movhpd`, an insert) and adds them; a group reads its
    /// `x(n)` and `x(n-1)` in order and writes `x(n+1)` and `u(n+1)`.
    Mixed,
    /// [`Layout::Mixed`] with each half row's four `u` read by one AVX2 gather.
    MixedGather,
    /// [`Layout::Mixed`] with the rows' slots in 16 bits (half the rows' bytes; networks of at
    /// most 65,536 slots).
    Mixed16,
    /// [`Layout::Mixed`] with every lane reading its own `u`, as [`Layout::Own`]: what its
    /// instructions cost with no scattered read (not the network's physics).
    MixedOwn,
}

/// The vector width a [`PullLayouts`] step is written in.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
enum Width {
    Avx512,
    Avx2,
}

/// A raw buffer shared by the threads of [`PullLayouts::run`].
#[derive(Clone, Copy)]
struct Shared(*mut f64);
// SAFETY: the threads of `PullLayouts::run` write disjoint slots, and read no slot a thread writes
// in the same step (the barrier between steps orders the writes before the next step's reads).
unsafe impl Send for Shared {}
unsafe impl Sync for Shared {}

impl PullLayouts {
    fn new(net: &Network, n: usize) -> PullLayouts {
        let mut ends: Vec<Vec<u32>> = vec![Vec::new(); n];
        for l in &net.links {
            let (a, b) = (l.a.index(), l.b.index());
            if a < n && b < n {
                ends[a].push(b as u32);
                ends[b].push(a as u32);
            }
        }
        // (stored by degree, as the engine's windows store a group's MAS, so that a group's
        // MAS have about as many links: `slot[i]` is MAS `i`'s slot, `mas[s]` the MAS in slot `s`)
        let mut mas: Vec<usize> = (0..n).collect();
        mas.sort_by_key(|&i| ends[i].len());
        let mut slot = vec![0u32; n];
        for (s, &i) in mas.iter().enumerate() {
            slot[i] = s as u32;
        }
        let (mut at, mut bounds, mut own) = (Vec::new(), Vec::new(), Vec::new());
        // (the last group, when partial, padded with slots of no MAS, which read themselves)
        for g in 0..n.div_ceil(8) {
            let lanes = &mas[8 * g..(8 * g + 8).min(n)];
            let rows = lanes.iter().map(|&i| ends[i].len()).max().unwrap_or(0);
            for r in 0..rows {
                let other = |j: usize| {
                    lanes
                        .get(j)
                        .and_then(|&i| ends[i].get(r))
                        .map(|&o| slot[o as usize])
                };
                at.push(std::array::from_fn(|j| {
                    other(j).unwrap_or((8 * g + j) as u32)
                }));
                own.push(std::array::from_fn(|j| (8 * g + j) as u32));
            }
            bounds.push(at.len());
        }
        // (each slot's readers: the entries `8 r + j` whose lane reads it, in row order)
        let mut readers: Vec<Vec<u32>> = vec![Vec::new(); 8 * bounds.len()];
        for (r, row) in at.iter().enumerate() {
            for (j, &o) in row.iter().enumerate() {
                readers[o as usize].push((8 * r + j) as u32);
            }
        }
        let mut to = Vec::with_capacity(at.len());
        let mut start = 0;
        for (g, &end) in bounds.iter().enumerate() {
            let lanes = &readers[8 * g..8 * g + 8];
            // (a slot is read once for each of its links, and by its own lane in each row it has
            // no link in: as many times as its group has rows)
            assert!(lanes.iter().all(|r| r.len() == end - start));
            to.extend((0..end - start).map(|w| std::array::from_fn(|j| lanes[j][w])));
            start = end;
        }
        let bytes = at.iter().map(|row| row.map(|o| 16 * o)).collect();
        let narrow = if 8 * bounds.len() <= 1 << 16 {
            at.iter().map(|row| row.map(|o| o as u16)).collect()
        } else {
            Vec::new()
        };
        PullLayouts {
            n,
            at,
            ends: bounds,
            own,
            bytes,
            narrow,
            shift: 0.0,
            to,
        }
    }

    /// Seconds for `steps` steps of `layout` in `width` on `threads` threads (each a consecutive
    /// range of groups of about equal rows, [`PullLayouts::share`]; a spin barrier after each
    /// step), and the final positions (whole groups); `None` where the CPU lacks `width`, or for a
    /// layout not written in it.
    fn run(
        &self,
        steps: usize,
        threads: usize,
        width: Width,
        layout: Layout,
    ) -> Option<(f64, Vec<f64>)> {
        #[cfg(not(target_arch = "x86_64"))]
        {
            let _ = (steps, threads, width, layout);
            None
        }
        #[cfg(target_arch = "x86_64")]
        {
            use std::sync::atomic::{AtomicUsize, Ordering};
            let has = match width {
                Width::Avx512 => {
                    std::is_x86_feature_detected!("avx512f")
                        && matches!(layout, Layout::Pairs | Layout::Cached)
                }
                Width::Avx2 => {
                    std::is_x86_feature_detected!("avx2")
                        && (layout != Layout::Mixed16 || !self.narrow.is_empty())
                }
            };
            if !has {
                return None;
            }
            // (whole groups: the slots past the MAS are padding)
            let n = 8 * self.ends.len();
            let x0 = |i: usize| (i % 7) as f64 * 1e-3 - self.shift;
            // x(n) in pos[0], x(n-1) = 0 in pos[2]
            let mut pos: Vec<Vec<f64>> = vec![(0..n).map(x0).collect(), vec![0.0; n], vec![0.0; n]];
            // (`x(n)` and `v(n)`, or for the twins `x(n)` and `x(n-1)`)
            let twins = matches!(layout, Layout::Twins | Layout::LeanTwins);
            let mixed = matches!(
                layout,
                Layout::Mixed | Layout::MixedGather | Layout::Mixed16 | Layout::MixedOwn
            );
            // (for the mixed layouts `u(0) = K x(0) + Z v(0)`, `v(0) = x(0)`, then padding)
            let pairs0: Vec<f64> = if mixed {
                (0..2 * n)
                    .map(|i| if i < n { K * x0(i) + Z * x0(i) } else { 0.0 })
                    .collect()
            } else {
                (0..n)
                    .flat_map(|i| [x0(i), if twins { 0.0 } else { x0(i) }])
                    .collect()
            };
            let mut pairs = [pairs0.clone(), pairs0];
            let mut cache = vec![0.0; 8 * self.at.len()];
            // (the mailboxes as the positions: `x(n)` in 0, `x(n-1)` = 0 in 2)
            let entries = if layout == Layout::Mailbox {
                8 * self.at.len()
            } else {
                0
            };
            let mut mail: Vec<Vec<f64>> = vec![
                (self.at.iter().flatten())
                    .take(entries)
                    .map(|&o| x0(o as usize))
                    .collect(),
                vec![0.0; entries],
                vec![0.0; entries],
            ];
            let pos_at: Vec<Shared> = pos.iter_mut().map(|p| Shared(p.as_mut_ptr())).collect();
            let mail_at: Vec<Shared> = mail.iter_mut().map(|p| Shared(p.as_mut_ptr())).collect();
            let pairs_at = pairs.each_mut().map(|p| Shared(p.as_mut_ptr()));
            let cache_at = Shared(cache.as_mut_ptr());
            let arrived = AtomicUsize::new(0);
            let t = Instant::now();
            std::thread::scope(|scope| {
                for th in 0..threads {
                    let (pos_at, mail_at, arrived) = (&pos_at, &mail_at, &arrived);
                    let own = self.share(th, threads);
                    scope.spawn(move || {
                        // (the whole `Shared`, not its field: a closure captures what it names)
                        let (cache_at, pairs_at) = (cache_at, pairs_at);
                        for s in 0..steps {
                            let turn =
                                |b: &[Shared]| (b[s % 3].0, b[(s + 2) % 3].0, b[(s + 1) % 3].0);
                            let (cur, prev, next) = turn(pos_at);
                            let (pc, pn) = (pairs_at[s % 2].0, pairs_at[(s + 1) % 2].0);
                            let g = own.clone();
                            // SAFETY: the CPU has `width` (checked above); every index of `at`,
                            // `own`, `narrow` and `to` is a slot below `n` or an entry of the
                            // mailboxes, each buffer holds `n` slots (pairs `2 n`, of which the
                            // mixed layouts' `u` take the first `n`; the cache and the
                            // mailboxes 8 a row), and the thread writes only its own groups' slots
                            // of `next`, `pn` and the cache, and the entries of `next`'s mailbox
                            // its own MAS's readers have (each entry one MAS's), none of which a
                            // thread reads in this step.
                            unsafe {
                                match (width, layout) {
                                    (Width::Avx512, Layout::Cached) => {
                                        self.step_cached(g, cur, prev, next, cache_at.0)
                                    }
                                    // (the pairs: `has` above leaves no other)
                                    (Width::Avx512, _) => {
                                        self.step_pairs(g, cur, prev, next, pc, pn)
                                    }
                                    (Width::Avx2, layout) => {
                                        let pos = (cur.cast_const(), prev.cast_const(), next);
                                        // (the rows as the layout reads them)
                                        let at = match layout {
                                            Layout::Own | Layout::MixedOwn => &self.own,
                                            Layout::Lean | Layout::LeanTwins => &self.bytes,
                                            _ => &self.at,
                                        };
                                        let pairs = &Pairs4 { at, pc, pn };
                                        match layout {
                                            Layout::Pairs | Layout::Own => {
                                                self.step_pairs_avx2(g, pos, pairs)
                                            }
                                            Layout::Cached => {
                                                let cache = cache_at.0;
                                                self.step_cached_avx2(
                                                    g,
                                                    pos,
                                                    &Cached4 { at, cur, cache },
                                                )
                                            }
                                            Layout::Twins => self.step_twins_avx2(g, pairs),
                                            Layout::LeanTwins => {
                                                self.step_lean_twins_avx2(g, pairs)
                                            }
                                            Layout::Summed => self.step_summed_avx2(g, pos, pairs),
                                            Layout::Lean => self.step_lean_avx2(g, pos, pairs),
                                            Layout::Mixed | Layout::MixedOwn => {
                                                self.step_mixed_avx2(g, pos, pairs)
                                            }
                                            Layout::Mixed16 => {
                                                let narrow = &self.narrow;
                                                self.step_mixed16_avx2(g, pos, pairs, narrow)
                                            }
                                            Layout::MixedGather => {
                                                self.step_mixed_gather_avx2(g, pos, pairs)
                                            }
                                            Layout::Mailbox => {
                                                let (cur, prev, next) = turn(mail_at);
                                                let mail = Mailbox4 { cur, prev, next };
                                                self.step_mailbox_avx2(g, pos, &mail)
                                            }
                                        }
                                    }
                                }
                            }
                            arrived.fetch_add(1, Ordering::AcqRel);
                            while arrived.load(Ordering::Acquire) < threads * (s + 1) {
                                std::hint::spin_loop();
                            }
                        }
                    });
                }
            });
            let secs = t.elapsed().as_secs_f64();
            if twins {
                let last = pairs[steps % 2].iter().step_by(2).copied().collect();
                return Some((secs, last));
            }
            Some((secs, pos.swap_remove(steps % 3)))
        }
    }

    /// The groups thread `th` of `threads` steps: consecutive groups, the shares cut where the
    /// rows before them are closest to equal parts of all the rows (the MAS are stored by degree,
    /// so equal numbers of groups would give the last thread the most rows).
    fn share(&self, th: usize, threads: usize) -> std::ops::Range<usize> {
        let (groups, rows) = (self.ends.len(), self.ends.last().copied().unwrap_or(0));
        let cut = |t: usize| match t {
            0 => 0,
            t if t == threads => groups,
            t => self.ends.partition_point(|&e| e <= rows * t / threads),
        };
        cut(th)..cut(th + 1)
    }

    /// The rows of group `g`.
    fn rows(&self, g: usize) -> std::ops::Range<usize> {
        let start = if g == 0 { 0 } else { self.ends[g - 1] };
        start..self.ends[g]
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx512f")]
    unsafe fn step_pairs(
        &self,
        groups: std::ops::Range<usize>,
        cur: *const f64,
        prev: *const f64,
        next: *mut f64,
        pc: *const f64,
        pn: *mut f64,
    ) {
        use std::arch::x86_64::*;
        // SAFETY (the whole body): the caller's promise (`run`).
        unsafe {
            let xs = _mm512_setr_epi64(0, 2, 4, 6, 8, 10, 12, 14);
            let vs = _mm512_setr_epi64(1, 3, 5, 7, 9, 11, 13, 15);
            let (lo, hi) = (
                _mm512_setr_epi64(0, 8, 1, 9, 2, 10, 3, 11),
                _mm512_setr_epi64(4, 12, 5, 13, 6, 14, 7, 15),
            );
            let inv = _mm512_set1_pd(1.0 / M);
            for g in groups {
                let x = _mm512_loadu_pd(cur.add(8 * g));
                let xp = _mm512_loadu_pd(prev.add(8 * g));
                let v = _mm512_sub_pd(x, xp);
                let mut f = _mm512_setzero_pd();
                for r in self.rows(g) {
                    let at = &self.at[r];
                    let p = |j: usize| _mm_loadu_pd(pc.add(2 * at[j] as usize));
                    let two = |a: usize| {
                        _mm256_insertf128_pd::<1>(_mm256_castpd128_pd256(p(a)), p(a + 1))
                    };
                    let a = _mm512_insertf64x4::<1>(_mm512_castpd256_pd512(two(0)), two(2));
                    let b = _mm512_insertf64x4::<1>(_mm512_castpd256_pd512(two(4)), two(6));
                    let (xj, vj) = (
                        _mm512_permutex2var_pd(a, xs, b),
                        _mm512_permutex2var_pd(a, vs, b),
                    );
                    f = Self::term(f, x, v, xj, vj);
                }
                let xn = _mm512_add_pd(
                    _mm512_sub_pd(_mm512_add_pd(x, x), xp),
                    _mm512_mul_pd(f, inv),
                );
                _mm512_storeu_pd(next.add(8 * g), xn);
                let vn = _mm512_sub_pd(xn, x);
                _mm512_storeu_pd(pn.add(16 * g), _mm512_permutex2var_pd(xn, lo, vn));
                _mm512_storeu_pd(pn.add(16 * g + 8), _mm512_permutex2var_pd(xn, hi, vn));
            }
        }
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx512f")]
    unsafe fn step_cached(
        &self,
        groups: std::ops::Range<usize>,
        cur: *const f64,
        prev: *const f64,
        next: *mut f64,
        cache: *mut f64,
    ) {
        use std::arch::x86_64::*;
        // SAFETY (the whole body): the caller's promise (`run`).
        unsafe {
            let inv = _mm512_set1_pd(1.0 / M);
            for g in groups {
                let x = _mm512_loadu_pd(cur.add(8 * g));
                let xp = _mm512_loadu_pd(prev.add(8 * g));
                let v = _mm512_sub_pd(x, xp);
                let mut f = _mm512_setzero_pd();
                for r in self.rows(g) {
                    let at = &self.at[r];
                    let p = |j: usize| *cur.add(at[j] as usize);
                    let xj = _mm512_setr_pd(p(0), p(1), p(2), p(3), p(4), p(5), p(6), p(7));
                    let c = cache.add(8 * r);
                    let xjp = _mm512_loadu_pd(c);
                    _mm512_storeu_pd(c, xj);
                    f = Self::term(f, x, v, xj, _mm512_sub_pd(xj, xjp));
                }
                let xn = _mm512_add_pd(
                    _mm512_sub_pd(_mm512_add_pd(x, x), xp),
                    _mm512_mul_pd(f, inv),
                );
                _mm512_storeu_pd(next.add(8 * g), xn);
            }
        }
    }

    /// [`PullLayouts::step_avx2`] of each layout, each a function of its own so that callgrind's
    /// `--toggle-collect` counts it apart (`'*step_pairs_avx2*'`: the pairs and `own`, which run
    /// the same instructions).
    ///
    /// # Safety
    /// As [`PullLayouts::step_avx2`].
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    #[inline(never)]
    unsafe fn step_pairs_avx2(&self, groups: Range<usize>, pos: Pos, reads: &Pairs4) {
        // SAFETY: the caller's promise.
        unsafe { self.step_avx2(groups, pos, reads) }
    }

    /// See [`PullLayouts::step_pairs_avx2`].
    ///
    /// # Safety
    /// As [`PullLayouts::step_avx2`].
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    #[inline(never)]
    unsafe fn step_cached_avx2(&self, groups: Range<usize>, pos: Pos, reads: &Cached4) {
        // SAFETY: the caller's promise.
        unsafe { self.step_avx2(groups, pos, reads) }
    }

    /// See [`PullLayouts::step_pairs_avx2`].
    ///
    /// # Safety
    /// As [`PullLayouts::step_avx2`].
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    #[inline(never)]
    unsafe fn step_mailbox_avx2(&self, groups: Range<usize>, pos: Pos, reads: &Mailbox4) {
        // SAFETY: the caller's promise.
        unsafe { self.step_avx2(groups, pos, reads) }
    }

    /// [`Layout::Twins`]: [`PullLayouts::step_avx2`]'s step on pairs of `x(n)` and `x(n-1)`.
    ///
    /// # Safety
    /// As [`PullLayouts::step_avx2`].
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    #[inline(never)]
    unsafe fn step_twins_avx2(&self, groups: Range<usize>, reads: &Pairs4) {
        use std::arch::x86_64::*;
        // SAFETY (the whole body): the caller's promise.
        unsafe {
            let inv = _mm256_set1_pd(1.0 / M);
            for g in groups {
                let mut x = [_mm256_setzero_pd(); 2];
                let mut xp = [_mm256_setzero_pd(); 2];
                for h in 0..2 {
                    let (lo, hi) = reads.twins_own(g, h);
                    (x[h], xp[h]) = (_mm256_unpacklo_pd(lo, hi), _mm256_unpackhi_pd(lo, hi));
                }
                let v = [_mm256_sub_pd(x[0], xp[0]), _mm256_sub_pd(x[1], xp[1])];
                let mut f = [_mm256_setzero_pd(); 2];
                for r in self.rows(g) {
                    for h in 0..2 {
                        let (xj, xjp) = reads.row(r, h);
                        f[h] = Self::term_avx2(f[h], x[h], v[h], xj, _mm256_sub_pd(xj, xjp));
                    }
                }
                for h in 0..2 {
                    let sum = _mm256_sub_pd(_mm256_add_pd(x[h], x[h]), xp[h]);
                    let xn = _mm256_add_pd(sum, _mm256_mul_pd(f[h], inv));
                    reads.twins_wrote(g, h, xn, x[h]);
                }
            }
        }
    }

    /// [`Layout::LeanTwins`]: [`PullLayouts::step_twins_avx2`]'s pairs, each row's differences
    /// summed as loaded, the offsets in bytes.
    ///
    /// # Safety
    /// As [`PullLayouts::step_avx2`] (`reads.at` in bytes).
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    #[inline(never)]
    unsafe fn step_lean_twins_avx2(&self, groups: Range<usize>, reads: &Pairs4) {
        use std::arch::x86_64::*;
        // SAFETY (the whole body): the caller's promise.
        unsafe {
            let inv = _mm256_set1_pd(1.0 / M);
            let (k, z) = (_mm256_set1_pd(K), _mm256_set1_pd(Z));
            for g in groups {
                let own = [0, 1].map(|h| {
                    let (lo, hi) = reads.twins_own(g, h);
                    [lo, hi]
                });
                let d = self.summed_rows::<true>(g, &own, reads);
                for h in 0..2 {
                    let [lo, hi] = own[h];
                    let (x, xp) = (_mm256_unpacklo_pd(lo, hi), _mm256_unpackhi_pd(lo, hi));
                    let (sd, sdp) = (
                        _mm256_unpacklo_pd(d[h][0], d[h][1]),
                        _mm256_unpackhi_pd(d[h][0], d[h][1]),
                    );
                    let sdv = _mm256_sub_pd(sd, sdp);
                    let g_sum = _mm256_add_pd(_mm256_mul_pd(k, sd), _mm256_mul_pd(z, sdv));
                    let f = _mm256_sub_pd(_mm256_setzero_pd(), g_sum);
                    let sum = _mm256_sub_pd(_mm256_add_pd(x, x), xp);
                    let xn = _mm256_add_pd(sum, _mm256_mul_pd(f, inv));
                    reads.twins_wrote(g, h, xn, x);
                }
            }
        }
    }

    /// The sums over group `g`'s rows of `own - loaded`, each half's two vectors as a row's pairs
    /// are loaded ([`Pairs4::loaded`], `reads.at` in bytes where `BYTES`), `own` the group's own
    /// pairs laid out the same way.
    ///
    /// # Safety
    /// The CPU has AVX2; `reads`' promise holds for the group's rows.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    #[inline]
    unsafe fn summed_rows<const BYTES: bool>(
        &self,
        g: usize,
        own: &[[V4; 2]; 2],
        reads: &Pairs4,
    ) -> [[V4; 2]; 2] {
        use std::arch::x86_64::*;
        let mut d = [[_mm256_setzero_pd(); 2]; 2];
        for r in self.rows(g) {
            for h in 0..2 {
                // SAFETY: the caller's promise.
                let (a, b) = unsafe { reads.loaded::<BYTES>(r, h) };
                d[h][0] = _mm256_add_pd(d[h][0], _mm256_sub_pd(own[h][0], a));
                d[h][1] = _mm256_add_pd(d[h][1], _mm256_sub_pd(own[h][1], b));
            }
        }
        d
    }

    /// [`Layout::Summed`]: [`PullLayouts::step_summed_as`] of slots.
    ///
    /// # Safety
    /// As [`PullLayouts::step_avx2`].
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    #[inline(never)]
    unsafe fn step_summed_avx2(&self, groups: Range<usize>, pos: Pos, reads: &Pairs4) {
        // SAFETY: the caller's promise.
        unsafe { self.step_summed_as::<false>(groups, pos, reads) }
    }

    /// [`Layout::Lean`]: [`PullLayouts::step_summed_as`] of bytes (`reads.at` in bytes).
    ///
    /// # Safety
    /// As [`PullLayouts::step_avx2`].
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    #[inline(never)]
    unsafe fn step_lean_avx2(&self, groups: Range<usize>, pos: Pos, reads: &Pairs4) {
        // SAFETY: the caller's promise.
        unsafe { self.step_summed_as::<true>(groups, pos, reads) }
    }

    /// [`Layout::Mixed`]: [`PullLayouts::step_mixed_as`] by scalar loads.
    ///
    /// # Safety
    /// As [`PullLayouts::step_mixed_as`].
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    #[inline(never)]
    unsafe fn step_mixed_avx2(&self, groups: Range<usize>, pos: Pos, reads: &Pairs4) {
        // SAFETY: the caller's promise.
        unsafe {
            let load = |r: usize, h: usize| mixed_lanes(reads.pc, &reads.at[r][4 * h..]);
            self.step_mixed_as(groups, pos, reads.pn, load)
        }
    }

    /// [`Layout::Mixed16`]: [`PullLayouts::step_mixed_as`] by scalar loads, 16-bit slots.
    ///
    /// # Safety
    /// As [`PullLayouts::step_mixed_as`], `narrow` the rows.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    #[inline(never)]
    unsafe fn step_mixed16_avx2(
        &self,
        groups: Range<usize>,
        pos: Pos,
        reads: &Pairs4,
        narrow: &[[u16; 8]],
    ) {
        // SAFETY: the caller's promise.
        unsafe {
            let load = |r: usize, h: usize| mixed_lanes(reads.pc, &narrow[r][4 * h..]);
            self.step_mixed_as(groups, pos, reads.pn, load)
        }
    }

    /// [`Layout::MixedGather`]: [`PullLayouts::step_mixed_as`] by gathers.
    ///
    /// # Safety
    /// As [`PullLayouts::step_mixed_as`].
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    #[inline(never)]
    unsafe fn step_mixed_gather_avx2(&self, groups: Range<usize>, pos: Pos, reads: &Pairs4) {
        use std::arch::x86_64::*;
        // SAFETY: the caller's promise.
        unsafe {
            let load = |r: usize, h: usize| {
                let i = _mm_loadu_si128(reads.at[r].as_ptr().add(4 * h).cast());
                _mm256_i32gather_pd::<8>(reads.pc, i)
            };
            self.step_mixed_as(groups, pos, reads.pn, load)
        }
    }

    /// The step of the mixed layouts ([`Layout::Mixed`]): `load(r, h)` gives the `u(n)` of the
    /// other ends of lanes `4 h..4 h + 4` of row `r`; `un` takes each slot's `u(n+1)`.
    ///
    /// # Safety
    /// As [`PullLayouts::step_avx2`], `load` reading within its buffer for the groups' rows and
    /// `un` holding a `f64` a slot.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    #[inline]
    unsafe fn step_mixed_as(
        &self,
        groups: Range<usize>,
        (cur, prev, next): Pos,
        un: *mut f64,
        load: impl Fn(usize, usize) -> V4,
    ) {
        use std::arch::x86_64::*;
        // SAFETY (the whole body): the caller's promise.
        unsafe {
            let inv = _mm256_set1_pd(1.0 / M);
            let (k, z) = (_mm256_set1_pd(K), _mm256_set1_pd(Z));
            for g in groups {
                let (x, xp) = (group_x(cur, g), group_x(prev, g));
                let mut s = [_mm256_setzero_pd(); 2];
                let rows = self.rows(g);
                let count = _mm256_set1_pd(rows.len() as f64);
                for r in rows {
                    for (h, s) in s.iter_mut().enumerate() {
                        *s = _mm256_add_pd(*s, load(r, h));
                    }
                }
                for h in 0..2 {
                    let v = _mm256_sub_pd(x[h], xp[h]);
                    let u = _mm256_add_pd(_mm256_mul_pd(k, x[h]), _mm256_mul_pd(z, v));
                    let f = _mm256_sub_pd(s[h], _mm256_mul_pd(count, u));
                    let sum = _mm256_sub_pd(_mm256_add_pd(x[h], x[h]), xp[h]);
                    let xn = _mm256_add_pd(sum, _mm256_mul_pd(f, inv));
                    let vn = _mm256_sub_pd(xn, x[h]);
                    let u = _mm256_add_pd(_mm256_mul_pd(k, xn), _mm256_mul_pd(z, vn));
                    _mm256_storeu_pd(next.add(8 * g + 4 * h), xn);
                    _mm256_storeu_pd(un.add(8 * g + 4 * h), u);
                }
            }
        }
    }

    /// [`PullLayouts::step_avx2`]'s step with each half row's differences summed as loaded,
    /// split and multiplied once a group; `reads.at` in bytes where `BYTES`, else slots.
    ///
    /// # Safety
    /// As [`PullLayouts::step_avx2`].
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    #[inline]
    unsafe fn step_summed_as<const BYTES: bool>(
        &self,
        groups: Range<usize>,
        (cur, prev, next): Pos,
        reads: &Pairs4,
    ) {
        use std::arch::x86_64::*;
        // SAFETY (the whole body): the caller's promise.
        unsafe {
            let inv = _mm256_set1_pd(1.0 / M);
            let (k, z) = (_mm256_set1_pd(K), _mm256_set1_pd(Z));
            for g in groups {
                let (x, xp) = (group_x(cur, g), group_x(prev, g));
                let v = [_mm256_sub_pd(x[0], xp[0]), _mm256_sub_pd(x[1], xp[1])];
                // the group's own pairs as a row's are loaded: `[x0 v0 | x2 v2]`, `[x1 v1 | x3 v3]`
                let own = [0, 1].map(|h| {
                    [
                        _mm256_unpacklo_pd(x[h], v[h]),
                        _mm256_unpackhi_pd(x[h], v[h]),
                    ]
                });
                let d = self.summed_rows::<BYTES>(g, &own, reads);
                let (mut xn, mut vn) = ([_mm256_setzero_pd(); 2], [_mm256_setzero_pd(); 2]);
                for h in 0..2 {
                    let (sd, sdv) = (
                        _mm256_unpacklo_pd(d[h][0], d[h][1]),
                        _mm256_unpackhi_pd(d[h][0], d[h][1]),
                    );
                    let g_sum = _mm256_add_pd(_mm256_mul_pd(k, sd), _mm256_mul_pd(z, sdv));
                    let f = _mm256_sub_pd(_mm256_setzero_pd(), g_sum);
                    let sum = _mm256_sub_pd(_mm256_add_pd(x[h], x[h]), xp[h]);
                    xn[h] = _mm256_add_pd(sum, _mm256_mul_pd(f, inv));
                    vn[h] = _mm256_sub_pd(xn[h], x[h]);
                    _mm256_storeu_pd(next.add(8 * g + 4 * h), xn[h]);
                }
                reads.wrote(self, g, xn, vn);
            }
        }
    }

    /// A step of `reads`' layout in AVX2, a group as two vectors of four lanes, as the engine's
    /// AVX2 pull step: the rows' terms, then `x(n+1)` into `next` and what the layout keeps of it.
    ///
    /// # Safety
    /// The CPU has AVX2; the groups' slots are within `cur`, `prev` and `next`, and `reads`' promise
    /// holds for the groups' rows.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    #[inline]
    unsafe fn step_avx2(&self, groups: Range<usize>, (cur, prev, next): Pos, reads: &impl Reads4) {
        use std::arch::x86_64::*;
        // SAFETY (the whole body): the caller's promise.
        unsafe {
            let inv = _mm256_set1_pd(1.0 / M);
            for g in groups {
                let (x, xp) = (group_x(cur, g), group_x(prev, g));
                let v = [_mm256_sub_pd(x[0], xp[0]), _mm256_sub_pd(x[1], xp[1])];
                let mut f = [_mm256_setzero_pd(); 2];
                for r in self.rows(g) {
                    for h in 0..2 {
                        let (xj, vj) = reads.row(r, h);
                        f[h] = Self::term_avx2(f[h], x[h], v[h], xj, vj);
                    }
                }
                let (mut xn, mut vn) = ([_mm256_setzero_pd(); 2], [_mm256_setzero_pd(); 2]);
                for h in 0..2 {
                    // as the AVX-512 steps compute it
                    let sum = _mm256_sub_pd(_mm256_add_pd(x[h], x[h]), xp[h]);
                    xn[h] = _mm256_add_pd(sum, _mm256_mul_pd(f[h], inv));
                    vn[h] = _mm256_sub_pd(xn[h], x[h]);
                    _mm256_storeu_pd(next.add(8 * g + 4 * h), xn[h]);
                }
                reads.wrote(self, g, xn, vn);
            }
        }
    }

    /// [`PullLayouts::term`] on four lanes.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    #[inline]
    fn term_avx2(f: V4, x: V4, v: V4, xj: V4, vj: V4) -> V4 {
        use std::arch::x86_64::*;
        let (k, z) = (_mm256_set1_pd(K), _mm256_set1_pd(Z));
        let spring = _mm256_mul_pd(k, _mm256_sub_pd(x, xj));
        let damper = _mm256_mul_pd(z, _mm256_sub_pd(v, vj));
        _mm256_sub_pd(f, _mm256_add_pd(spring, damper))
    }

    /// `f - (K (x - xj) + Z (v - vj))`, as the engine's REF term.
    #[cfg(target_arch = "x86_64")]
    #[inline(always)]
    fn term(
        f: std::arch::x86_64::__m512d,
        x: std::arch::x86_64::__m512d,
        v: std::arch::x86_64::__m512d,
        xj: std::arch::x86_64::__m512d,
        vj: std::arch::x86_64::__m512d,
    ) -> std::arch::x86_64::__m512d {
        use std::arch::x86_64::*;
        // SAFETY: the CPU has AVX-512F (the callers' target feature, this function being inlined
        // into them).
        unsafe {
            let (k, z) = (_mm512_set1_pd(K), _mm512_set1_pd(Z));
            let spring = _mm512_mul_pd(k, _mm512_sub_pd(x, xj));
            let damper = _mm512_mul_pd(z, _mm512_sub_pd(v, vj));
            _mm512_sub_pd(f, _mm512_add_pd(spring, damper))
        }
    }
}

/// Four `f64` lanes.
#[cfg(target_arch = "x86_64")]
type V4 = std::arch::x86_64::__m256d;

/// The four `f64` of `u` at the slots `at[0..4]`, by two scalar loads and two high loads.
///
/// # Safety
/// The CPU has AVX2; `at` has four slots, each within `u`.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
#[inline]
unsafe fn mixed_lanes<T: Copy + Into<u32>>(u: *const f64, at: &[T]) -> V4 {
    use std::arch::x86_64::*;
    // SAFETY: the caller's promise.
    unsafe {
        let p = |j: usize| u.add(at[j].into() as usize);
        let lo = _mm_loadh_pd(_mm_load_sd(p(0)), p(1));
        let hi = _mm_loadh_pd(_mm_load_sd(p(2)), p(3));
        _mm256_insertf128_pd::<1>(_mm256_castpd128_pd256(lo), hi)
    }
}

/// Group `g`'s eight `f64` of `b` (positions a slot), as two vectors.
///
/// # Safety
/// The CPU has AVX2; group `g`'s slots are within `b`.
#[cfg(target_arch = "x86_64")]
#[inline(always)]
unsafe fn group_x(b: *const f64, g: usize) -> [V4; 2] {
    use std::arch::x86_64::*;
    // SAFETY: the caller's promise.
    unsafe { [0, 1].map(|h| _mm256_loadu_pd(b.add(8 * g + 4 * h))) }
}

/// `x(n)`, `x(n-1)` and `x(n+1)` of a [`PullLayouts`] step.
#[cfg(target_arch = "x86_64")]
type Pos = (*const f64, *const f64, *mut f64);

/// How a [`Layout`] reads its rows and keeps a group's `x(n+1)` in AVX2
/// ([`PullLayouts::step_avx2`]).
#[cfg(target_arch = "x86_64")]
trait Reads4 {
    /// `x(n)` and `v(n)` of the other ends of lanes `4 h..4 h + 4` of row `r`.
    ///
    /// # Safety
    /// The CPU has AVX2; the layout's buffers hold row `r`'s reads.
    unsafe fn row(&self, r: usize, h: usize) -> (V4, V4);

    /// What the layout keeps beyond the positions of group `g`'s `x(n+1)` and `v(n+1)` (two
    /// vectors each) of `layouts`.
    ///
    /// # Safety
    /// The CPU has AVX2; the layout's buffers hold group `g`'s writes.
    #[inline(always)]
    unsafe fn wrote(&self, layouts: &PullLayouts, g: usize, xn: [V4; 2], vn: [V4; 2]) {
        let _ = (layouts, g, xn, vn);
    }
}

/// [`Layout::Pairs`] (`at` the rows) or [`Layout::Own`] (`at` the lanes' own slots) in AVX2: the
/// pairs read from `pc`, the next ones written to `pn`.
#[cfg(target_arch = "x86_64")]
struct Pairs4<'a> {
    at: &'a [[u32; 8]],
    pc: *const f64,
    pn: *mut f64,
}

#[cfg(target_arch = "x86_64")]
impl Pairs4<'_> {
    /// Group `g`'s own pairs of `x(n)` and `x(n-1)` ([`Layout::Twins`]), lanes `4 h..4 h + 4`,
    /// as a row's are loaded: `[x0 p0 | x2 p2]` and `[x1 p1 | x3 p3]`, `p` for `x(n-1)`.
    ///
    /// # Safety
    /// The CPU has AVX2; group `g`'s pairs are within `pc`.
    #[inline(always)]
    unsafe fn twins_own(&self, g: usize, h: usize) -> (V4, V4) {
        use std::arch::x86_64::*;
        // SAFETY: the caller's promise; in memory `[x0 p0 x1 p1]`, `[x2 p2 x3 p3]`.
        unsafe {
            let at = |i: usize| _mm256_loadu_pd(self.pc.add(16 * g + 8 * h + 4 * i));
            let (a, b) = (at(0), at(1));
            (
                _mm256_permute2f128_pd::<0x20>(a, b),
                _mm256_permute2f128_pd::<0x31>(a, b),
            )
        }
    }

    /// Writes group `g`'s next pairs of `x(n+1)` (`xn`) and `x(n)` (`x`), lanes `4 h..4 h + 4`
    /// ([`Layout::Twins`]).
    ///
    /// # Safety
    /// The CPU has AVX2; group `g`'s pairs are within `pn`.
    #[inline(always)]
    unsafe fn twins_wrote(&self, g: usize, h: usize, xn: V4, x: V4) {
        use std::arch::x86_64::*;
        // SAFETY: the caller's promise.
        unsafe {
            let (a, b) = (_mm256_unpacklo_pd(xn, x), _mm256_unpackhi_pd(xn, x));
            let p = self.pn.add(16 * g + 8 * h);
            _mm256_storeu_pd(p, _mm256_permute2f128_pd::<0x20>(a, b));
            _mm256_storeu_pd(p.add(4), _mm256_permute2f128_pd::<0x31>(a, b));
        }
    }

    /// `[x0 v0 | x2 v2]` and `[x1 v1 | x3 v3]` of the other ends of lanes `4 h..4 h + 4` of row
    /// `r`, as loaded; `at` in bytes where `BYTES`, else slots.
    ///
    /// # Safety
    /// The CPU has AVX2; every entry of `at[r]` is (the offset of) a pair of `pc`.
    #[inline(always)]
    unsafe fn loaded<const BYTES: bool>(&self, r: usize, h: usize) -> (V4, V4) {
        use std::arch::x86_64::*;
        // SAFETY: the caller's promise.
        unsafe {
            let at = &self.at[r];
            let p = |j: usize| {
                let o = at[4 * h + j] as usize;
                _mm_loadu_pd(if BYTES {
                    self.pc.cast::<u8>().add(o).cast::<f64>()
                } else {
                    self.pc.add(2 * o)
                })
            };
            let two =
                |a: usize, b: usize| _mm256_insertf128_pd::<1>(_mm256_castpd128_pd256(p(a)), p(b));
            (two(0, 2), two(1, 3))
        }
    }
}

#[cfg(target_arch = "x86_64")]
impl Reads4 for Pairs4<'_> {
    #[inline(always)]
    unsafe fn row(&self, r: usize, h: usize) -> (V4, V4) {
        use std::arch::x86_64::*;
        // SAFETY: the caller's promise.
        unsafe {
            // split as the engine's AVX2 `pairs` splits them
            let (a, b) = self.loaded::<false>(r, h);
            (_mm256_unpacklo_pd(a, b), _mm256_unpackhi_pd(a, b))
        }
    }

    #[inline(always)]
    unsafe fn wrote(&self, _: &PullLayouts, g: usize, xn: [V4; 2], vn: [V4; 2]) {
        use std::arch::x86_64::*;
        for h in 0..2 {
            // SAFETY: the caller's promise: group `g`'s pairs are within `pn`.
            unsafe {
                let (a, b) = (
                    _mm256_unpacklo_pd(xn[h], vn[h]),
                    _mm256_unpackhi_pd(xn[h], vn[h]),
                );
                let p = self.pn.add(16 * g + 8 * h);
                _mm256_storeu_pd(p, _mm256_permute2f128_pd::<0x20>(a, b));
                _mm256_storeu_pd(p.add(4), _mm256_permute2f128_pd::<0x31>(a, b));
            }
        }
    }
}

/// [`Layout::Cached`] in AVX2: the other ends' `x(n)` read from `cur`, their `x(n-1)` from the
/// row's eight `f64` of `cache`, overwritten with the `x(n)` read.
#[cfg(target_arch = "x86_64")]
struct Cached4<'a> {
    at: &'a [[u32; 8]],
    cur: *const f64,
    cache: *mut f64,
}

#[cfg(target_arch = "x86_64")]
impl Reads4 for Cached4<'_> {
    #[inline(always)]
    unsafe fn row(&self, r: usize, h: usize) -> (V4, V4) {
        use std::arch::x86_64::*;
        // SAFETY: the caller's promise: every slot of `at[r]` is within `cur`, and the cache
        // holds eight `f64` a row.
        unsafe {
            let at = &self.at[r];
            let p = |j: usize| *self.cur.add(at[4 * h + j] as usize);
            let xj = _mm256_setr_pd(p(0), p(1), p(2), p(3));
            let c = self.cache.add(8 * r + 4 * h);
            let xjp = _mm256_loadu_pd(c);
            _mm256_storeu_pd(c, xj);
            (xj, _mm256_sub_pd(xj, xjp))
        }
    }
}

/// [`Layout::Mailbox`] in AVX2: the mailboxes of `x(n)`, `x(n-1)` and `x(n+1)`, eight `f64` a
/// row each.
#[cfg(target_arch = "x86_64")]
struct Mailbox4 {
    cur: *const f64,
    prev: *const f64,
    next: *mut f64,
}

#[cfg(target_arch = "x86_64")]
impl Reads4 for Mailbox4 {
    #[inline(always)]
    unsafe fn row(&self, r: usize, h: usize) -> (V4, V4) {
        use std::arch::x86_64::*;
        let (mc, mp) = (self.cur, self.prev);
        // SAFETY: the caller's promise: each mailbox holds eight `f64` a row.
        unsafe {
            let e = 8 * r + 4 * h;
            let (xj, xjp) = (_mm256_loadu_pd(mc.add(e)), _mm256_loadu_pd(mp.add(e)));
            (xj, _mm256_sub_pd(xj, xjp))
        }
    }

    #[inline(always)]
    unsafe fn wrote(&self, layouts: &PullLayouts, g: usize, xn: [V4; 2], _: [V4; 2]) {
        use std::arch::x86_64::*;
        let mut lanes = [0.0; 8];
        // SAFETY: the caller's promise: each mailbox holds eight `f64` a row, and every entry of
        // `to` is below eight a row (`PullLayouts::new`).
        unsafe {
            _mm256_storeu_pd(lanes.as_mut_ptr(), xn[0]);
            _mm256_storeu_pd(lanes.as_mut_ptr().add(4), xn[1]);
            for w in layouts.rows(g) {
                for (&e, &x) in layouts.to[w].iter().zip(&lanes) {
                    *self.next.add(e as usize) = x;
                }
            }
        }
    }
}

/// `ceiling pull [N [T]]`: [`PullLayouts`] on a random network of N masses, each layout in each
/// width the CPU has on 1 and T threads (alternating, median of [`RUNS`]), next to cordis on 1 and
/// T threads.
fn pull_layouts_mode(n: usize, threads: usize) {
    let work = work();
    let model = random(n, Law::Ref);
    let layouts = PullLayouts::new(&model.net, model.masses);
    let steps = (work / layouts.n as u64).max(MIN_STEPS) as usize;
    let mass_steps = (layouts.n * steps) as f64;
    let mut one = Engine::new(&model.net);
    let mut many = Engine::new(&model.net);
    many.set_threads(threads);
    many.set_parallel_threshold(0);
    let mut buf = vec![0.0; block() * one.channels()];
    let kinds: Vec<(Width, Layout)> = [Width::Avx512, Width::Avx2]
        .into_iter()
        .flat_map(|w| {
            [
                Layout::Pairs,
                Layout::Cached,
                Layout::Own,
                Layout::Mailbox,
                Layout::Summed,
                Layout::Lean,
                Layout::Twins,
                Layout::LeanTwins,
                Layout::Mixed,
                Layout::MixedGather,
                Layout::Mixed16,
                Layout::MixedOwn,
            ]
            .map(|l| (w, l))
        })
        .filter(|&(w, l)| layouts.run(1, 1, w, l).is_some())
        .collect();
    if kinds.is_empty() {
        println!("no AVX2 or AVX-512 on this CPU: no layout to time, cordis alone");
    }
    // per kind and thread count (1, T), then cordis's
    let mut times = vec![[Vec::new(), Vec::new()]; kinds.len() + 1];
    let (mut sums, mut own_sums, mut summed_sums) = (Vec::new(), Vec::new(), Vec::new());
    let (mut lean_twins_sums, mut lean_twins_off) = (Vec::new(), 0.0f64);
    let (mut mixed_sums, mut mixed_off, mut mixed_own_sums) = (Vec::new(), 0.0f64, Vec::new());
    let hash = |xs: &[f64]| xs.iter().fold(0u64, |h, x| h.rotate_left(5) ^ x.to_bits());
    // (the pairs' last positions, and the largest difference of `summed`'s from them, with the
    // pairs' largest magnitude)
    let (mut pairs_x, mut summed_off) = (Vec::new(), (0.0f64, 0.0f64));
    for _ in 0..RUNS {
        for (i, &(width, layout)) in kinds.iter().enumerate() {
            for (t, count) in [1, threads].into_iter().enumerate() {
                let (secs, xs) =
                    (layouts.run(steps, count, width, layout)).expect("the width was found above");
                times[i][t].push(secs);
                match layout {
                    Layout::Own => own_sums.push(hash(&xs)),
                    Layout::MixedOwn => mixed_own_sums.push(hash(&xs)),
                    Layout::Mixed | Layout::MixedGather | Layout::Mixed16 => {
                        mixed_sums.push(hash(&xs));
                        let off = xs.iter().zip(&pairs_x).map(|(a, b)| (a - b).abs());
                        mixed_off = mixed_off.max(off.fold(0.0, f64::max));
                    }
                    Layout::LeanTwins => {
                        lean_twins_sums.push(hash(&xs));
                        let off = xs.iter().zip(&pairs_x).map(|(a, b)| (a - b).abs());
                        lean_twins_off = lean_twins_off.max(off.fold(0.0, f64::max));
                    }
                    Layout::Summed | Layout::Lean => {
                        summed_sums.push(hash(&xs));
                        let off = xs
                            .iter()
                            .zip(&pairs_x)
                            .map(|(a, b): (&f64, &f64)| (a - b).abs());
                        let peak = pairs_x.iter().map(|x: &f64| x.abs()).fold(0.0, f64::max);
                        summed_off = (summed_off.0.max(off.fold(0.0, f64::max)), peak);
                    }
                    _ => {
                        sums.push(hash(&xs));
                        pairs_x = xs;
                    }
                }
            }
        }
        let [a, b] = &mut times[kinds.len()];
        timed(a, || {
            run_cordis(&mut one, black_box(steps as u64), &mut buf)
        });
        timed(b, || {
            run_cordis(&mut many, black_box(steps as u64), &mut buf)
        });
    }
    let same = |s: &[u64]| s.iter().all(|&x| x == s[0]);
    let each = |s: &[u64]| {
        if same(s) {
            "the same in every run"
        } else {
            "DIFFERENT between runs"
        }
    };
    println!(
        "{} ({} MAS, {} rows): {work:.3e} mass-steps per run, median of {RUNS}; load average \
         {}; the layouts' bits {} (`own` {}, `summed` and `lean` {}, at most {:.2e} from the others' \
         positions, whose largest is {:.2e}; `leantwins` {}, at most {:.2e} from them; `mixed`, \
         `mixedgather` and `mixed16` {}, at most {:.2e}; `mixedown` {})\n\
         layout           1 thread  {threads} threads   ratio  1 thread / cordis's",
        model.name,
        layouts.n,
        layouts.at.len(),
        load_average(),
        if same(&sums) { "the same" } else { "DIFFERENT" },
        each(&own_sums),
        each(&summed_sums),
        summed_off.0,
        summed_off.1,
        each(&lean_twins_sums),
        lean_twins_off,
        each(&mixed_sums),
        mixed_off,
        each(&mixed_own_sums),
        work = work as f64
    );
    let e1 = median(times[kinds.len()][0].clone());
    let names = kinds
        .iter()
        .map(|(w, l)| format!("{w:?} {l:?}").to_lowercase());
    for (name, [t1, tt]) in names.chain(["cordis".to_string()]).zip(times) {
        let (t1, tt) = (median(t1), median(tt));
        println!(
            "{name:<16} {:.3e} {:.3e} {:>7.2} {:>7.2}",
            mass_steps / t1,
            mass_steps / tt,
            t1 / tt,
            e1 / t1
        );
    }
}

/// `ceiling drift [N [STEPS]]`: how far the layouts of [`PullLayouts`] that reorder a MAS's sum
/// ([`Layout::Summed`], [`Layout::LeanTwins`], [`Layout::Mixed`]) end from the reference's bits
/// ([`Layout::Pairs`]) after 1,000, 10,000 and 100,000 steps and STEPS (441,000 by default: 10 s
/// at 44.1 kHz), on one thread in AVX2, each distance next to the largest position and as a
/// share of it (the rules allow 1e-12 of the signal's peak): from `ceiling pull`'s start, where
/// the network drifts, then from one whose velocities' mean is about zero; then the same sums on
/// the model itself ([`drift_model`]).
fn drift_mode(n: usize, steps: usize) {
    let model = random(n, Law::Ref);
    let mut layouts = PullLayouts::new(&model.net, model.masses);
    if layouts.run(1, 1, Width::Avx2, Layout::Pairs).is_none() {
        println!("no AVX2 on this CPU: no layout to run");
        return;
    }
    // (as `ceiling pull` starts, the network drifts: no link holds it, and the start's mean
    // velocity is about 3e-3 a step; then with the velocities' mean about 0)
    for shift in [0.0, 3e-3] {
        layouts.shift = shift;
        drift_table(&model, &layouts, steps);
    }
    drift_model(&model, steps);
}

/// [`drift_mode`]'s last table: the bench's `random` model as declared (one ground link, the MAS
/// `n / 4` struck), stepped by [`Generic`] (the Rust port of `cref.c`, whose output on REF
/// models the bench finds bit-identical to the engine's) and by the same loops with each MAS's sum reordered as summed's (`F = -(K Σd + Z Σdv)`)
/// and as mixed's (`F = Σ uj - d u`, `d` its links); each one's largest distance from the
/// reference's output (its SOX signal) so far, and that over the signal's peak so far.
fn drift_model(model: &Model, steps: usize) {
    let [mut r, mut a, mut b] = [0; 3].map(|_| Generic::new(&model.net, model.out));
    let (k, z) = (r.lk[0], r.lz[0]);
    if !r.ci.is_empty() || r.lk.iter().any(|&c| c != k) || r.lz.iter().any(|&c| c != z) {
        println!(
            "{}: not REF links of one K and Z alone; no table",
            model.name
        );
        return;
    }
    for g in [&mut r, &mut a, &mut b] {
        g.reset();
    }
    let ends = r.x.len();
    let mut degree = vec![0.0; ends];
    for (&i, &j) in r.li.iter().zip(&r.lj) {
        degree[i as usize] += 1.0;
        degree[j as usize] += 1.0;
    }
    let (mut sdv, mut u) = (vec![0.0; ends], vec![0.0; ends]);
    let (out, mut peak, mut off) = (r.out, 0.0f64, [0.0f64; 2]);
    println!(
        "{} as declared (one ground link, MAS {} struck), its SOX signal: each reordered sum's \
         largest distance from the reference's so far, and that over the signal's peak so far",
        model.name,
        model.masses / 4
    );
    println!(
        "{:>8} {:>10}   {:>19}   {:>19}",
        "steps", "peak", "summed", "mixed"
    );
    for step in 1..=steps {
        r.links();
        r.masses();
        // summed: the links' differences summed, `K` and `Z` applied once a MAS
        for (&i, &j) in a.li.iter().zip(&a.lj) {
            let (i, j) = (i as usize, j as usize);
            let d = a.x[i] - a.x[j];
            let dv = (a.x[i] - a.xp[i]) - (a.x[j] - a.xp[j]);
            (a.f[i], a.f[j], sdv[i], sdv[j]) = (a.f[i] + d, a.f[j] - d, sdv[i] + dv, sdv[j] - dv);
        }
        for (f, dv) in a.f[..a.nm].iter_mut().zip(&sdv) {
            *f = -(k * *f + z * dv);
        }
        sdv.fill(0.0);
        a.masses();
        // mixed: each end's `u = K x + Z v` once a step, each MAS's `Σ uj - d u`
        for (i, u) in u.iter_mut().enumerate() {
            *u = k * b.x[i] + z * (b.x[i] - b.xp[i]);
        }
        for (&i, &j) in b.li.iter().zip(&b.lj) {
            let (i, j) = (i as usize, j as usize);
            (b.f[i], b.f[j]) = (b.f[i] + u[j], b.f[j] + u[i]);
        }
        for ((f, d), u) in b.f[..b.nm].iter_mut().zip(&degree).zip(&u) {
            *f -= d * u;
        }
        b.masses();
        peak = peak.max(r.x[out].abs());
        for (o, g) in off.iter_mut().zip([&a, &b]) {
            *o = o.max((g.x[out] - r.x[out]).abs());
        }
        if [1_000, 10_000, 100_000, steps].contains(&step) {
            let cell = |o: f64| format!("{o:.2e} ({:.1e})", o / peak);
            println!(
                "{step:>8} {peak:>10.3e}   {:>19}   {:>19}",
                cell(off[0]),
                cell(off[1])
            );
        }
    }
}

/// [`drift_mode`]'s table for `layouts` as they start.
fn drift_table(model: &Model, layouts: &PullLayouts, steps: usize) {
    let at = |steps: usize, layout: Layout| {
        let (_, xs) = layouts.run(steps, 1, Width::Avx2, layout)?;
        // (the MAS alone, not the last group's padding)
        Some(xs[..layouts.n].to_vec())
    };
    println!(
        "{} ({} MAS, starting at x(0) = (slot % 7) 1e-3 - {:e}, x(-1) = 0): each reordered \
         layout's largest distance from the pairs' positions (the reference's bits), and that \
         over the pairs' largest position",
        model.name, layouts.n, layouts.shift
    );
    println!(
        "{:>8} {:>10}   {:>19}   {:>19}   {:>19}",
        "steps", "largest x", "summed", "leantwins", "mixed"
    );
    let checks = [1_000, 10_000, 100_000].into_iter().filter(|&s| s < steps);
    for s in checks.chain([steps]) {
        let pairs = at(s, Layout::Pairs).expect("AVX2 was found above");
        let peak = pairs.iter().fold(0.0f64, |m, x| m.max(x.abs()));
        let cells = [Layout::Summed, Layout::LeanTwins, Layout::Mixed].map(|l| {
            let xs = at(s, l).expect("AVX2 was found above");
            let off = (xs.iter().zip(&pairs)).fold(0.0f64, |m, (a, b)| m.max((a - b).abs()));
            format!("{off:.2e} ({:.1e})", off / peak)
        });
        println!(
            "{s:>8} {peak:>10.3e}   {:>19}   {:>19}   {:>19}",
            cells[0], cells[1], cells[2]
        );
    }
}

/// A curve's segment table for [`curve_eval`], padded to `P` segments (8, 16 or 32, a power of two
/// as the engine pads), its last point repeated with slope `0.0`, and what a guess of the
/// segment needs: a uniform grid of `P` buckets over `[x[0], x[n-1]]` and, for each bucket, the
/// segment of the least `x` that falls in it. Hand-written for `ceiling curves`, apart from the
/// engine's `WideCurve` and `WideLong` (which the bench cannot reach), with their arithmetic.
#[cfg(target_arch = "x86_64")]
struct CurveLanes {
    p: usize,
    /// `x[0..P]`, `y[0..P]`, `slope[0..P]`, `g[0..P]` (each bucket's segment, as `f64` bits),
    /// `x[i + 1]` for `i` in `0..P` (infinity past the last point)
    table: Vec<f64>,
    /// `x[2 j]`, `j` in `0..16` (the 32-segment search's coarse abscissas)
    coarse: [f64; 16],
    first: f64,
    last: (f64, f64),
    scale: f64,
    /// whether no bucket holds more than one abscissa inside it (else the guess is not exact)
    exact: bool,
    /// each bucket's least `x`
    edges: Vec<f64>,
}

#[cfg(target_arch = "x86_64")]
impl CurveLanes {
    fn new(c: &Curve) -> CurveLanes {
        let pts: Vec<(f64, f64)> = c.points().collect();
        let n = pts.len();
        assert!((2..=33).contains(&n), "a curve of 2 to 33 points");
        let p = if n <= 9 {
            8
        } else if n <= 17 {
            16
        } else {
            32
        };
        let at = |i: usize| pts[i.min(n - 1)];
        // (`Curve::new`'s slopes, the same bits)
        let slope = |i: usize| {
            let (a, b) = (pts[i], pts[i + 1]);
            if b.0 > a.0 {
                (b.1 - a.1) / (b.0 - a.0)
            } else {
                0.0
            }
        };
        let first = pts[0].0;
        let scale = p as f64 / (pts[n - 1].0 - first);
        // the segment of `x`: the last of `0..P` whose abscissa is `<= x` (`x` raised to x[0])
        let segment = |x: f64| (0..p).rev().find(|&j| at(j).0 <= x.max(first)).unwrap_or(0);
        // the least `x` of bucket `b`: bisection over the doubles in order (the bucket of `x`
        // never decreases as `x` grows: a subtraction, a product and a `min` are monotonic)
        let key = |x: f64| {
            let b = x.to_bits() as i64;
            if b < 0 {
                i64::MIN - b
            } else {
                b
            }
        };
        let unkey = |k: i64| {
            f64::from_bits(if k < 0 {
                (i64::MIN - k) as u64
            } else {
                k as u64
            })
        };
        let least = |b: usize| {
            let (mut lo, mut hi) = (key(first), key(f64::MAX));
            while lo < hi {
                let mid = (i128::from(lo) + i128::from(hi)).div_euclid(2) as i64;
                if curve_bucket(first, scale, p, unkey(mid)) >= b {
                    hi = mid;
                } else {
                    lo = mid + 1;
                }
            }
            unkey(hi)
        };
        let starts: Vec<f64> = (0..p).map(least).collect();
        let exact = (0..p).all(|b| {
            let end = if b + 1 < p {
                unkey(key(starts[b + 1]) - 1)
            } else {
                pts[n - 1].0
            };
            segment(end).min(n - 2) <= segment(starts[b]) + 1
        });
        let mut table = Vec::with_capacity(5 * p);
        table.extend((0..p).map(|i| at(i).0));
        table.extend((0..p).map(|i| at(i).1));
        table.extend((0..p).map(|i| if i + 1 < n { slope(i) } else { 0.0 }));
        table.extend(starts.iter().map(|&x| f64::from_bits(segment(x) as u64)));
        table.extend((0..p).map(|i| {
            if i + 1 < n {
                pts[i + 1].0
            } else {
                f64::INFINITY
            }
        }));
        CurveLanes {
            p,
            table,
            coarse: std::array::from_fn(|j| at(2 * j).0),
            first,
            last: pts[n - 1],
            scale,
            exact,
            edges: starts,
        }
    }
}

/// The bucket of `x` on a grid of `p` buckets from `first`, `scale` buckets a unit: the scalar
/// form of [`curve_eval`]'s guess, the same operations.
#[cfg(target_arch = "x86_64")]
fn curve_bucket(first: f64, scale: f64, p: usize, x: f64) -> usize {
    ((x.max(first) - first) * scale).min((p - 1) as f64) as usize
}

/// [`CurveLanes`] in vectors: its five tables (each in four vectors of eight, the first one or
/// two repeated where `P` is 8 or 16), the coarse abscissas and the numbers broadcast.
#[cfg(target_arch = "x86_64")]
struct CurveVecs {
    t: [[std::arch::x86_64::__m512d; 4]; 5],
    coarse: [std::arch::x86_64::__m512d; 4],
    /// `x[0]`, `x[P/2]`, `x[n-1]`, `y[n-1]`, the buckets a unit, `P - 1`
    first: std::arch::x86_64::__m512d,
    mid: std::arch::x86_64::__m512d,
    xl: std::arch::x86_64::__m512d,
    yl: std::arch::x86_64::__m512d,
    scale: std::arch::x86_64::__m512d,
    top: std::arch::x86_64::__m512d,
}

#[cfg(target_arch = "x86_64")]
impl CurveVecs {
    /// `t[i]` of table `t` in each lane: one `vpermpd` for 8 numbers, one `vpermt2pd` for 16,
    /// two and a select for 32 (each index below `P`). Like every method here,
    /// `#[inline(always)]` without target features: compiled with those of [`curve_eval`].
    ///
    /// # Safety
    /// The CPU must have AVX-512F.
    #[inline(always)]
    unsafe fn look<const P: usize>(
        t: &[std::arch::x86_64::__m512d; 4],
        i: std::arch::x86_64::__m512i,
    ) -> std::arch::x86_64::__m512d {
        use std::arch::x86_64::*;
        // SAFETY: the caller's promise.
        unsafe {
            if P == 8 {
                return _mm512_permutexvar_pd(i, t[0]);
            }
            let a = _mm512_permutex2var_pd(t[0], i, t[1]);
            if P == 16 {
                return a;
            }
            let b = _mm512_permutex2var_pd(t[2], i, t[3]);
            _mm512_mask_mov_pd(a, _mm512_cmpge_epi64_mask(i, _mm512_set1_epi64(16)), b)
        }
    }

    /// One halving of the search: `i + h` where `t[i + h] <= x`.
    ///
    /// # Safety
    /// The CPU must have AVX-512F.
    #[inline(always)]
    unsafe fn halve<const P: usize>(
        i: std::arch::x86_64::__m512i,
        h: i64,
        t: &[std::arch::x86_64::__m512d; 4],
        x: std::arch::x86_64::__m512d,
    ) -> std::arch::x86_64::__m512i {
        use std::arch::x86_64::*;
        // SAFETY: the caller's promise.
        unsafe {
            let next = _mm512_add_epi64(i, _mm512_set1_epi64(h));
            let m = _mm512_cmp_pd_mask::<_CMP_LE_OQ>(Self::look::<P>(t, next), x);
            _mm512_mask_mov_epi64(i, m, next)
        }
    }

    /// The curve at each lane of `x` (see [`curve_eval`]).
    ///
    /// # Safety
    /// The CPU must have AVX-512F and AVX-512DQ.
    #[inline(always)]
    unsafe fn eval<const P: usize, const GUESS: bool>(
        &self,
        x: std::arch::x86_64::__m512d,
    ) -> std::arch::x86_64::__m512d {
        use std::arch::x86_64::*;
        // SAFETY: the caller's promise.
        unsafe {
            let x = _mm512_max_pd(x, self.first);
            let [xs, ys, slopes, starts, nexts] = &self.t;
            let i = if GUESS {
                let b = _mm512_min_pd(
                    _mm512_mul_pd(_mm512_sub_pd(x, self.first), self.scale),
                    self.top,
                );
                let s = _mm512_castpd_si512(Self::look::<P>(starts, _mm512_cvttpd_epi64(b)));
                let up = _mm512_cmp_pd_mask::<_CMP_LE_OQ>(Self::look::<P>(nexts, s), x);
                _mm512_mask_add_epi64(s, up, s, _mm512_set1_epi64(1))
            } else {
                let half = _mm512_cmp_pd_mask::<_CMP_LE_OQ>(self.mid, x);
                let i = _mm512_maskz_mov_epi64(half, _mm512_set1_epi64(P.min(16) as i64 / 2));
                let halve = Self::halve::<P>;
                if P == 8 {
                    halve(halve(i, 2, xs, x), 1, xs, x)
                } else if P == 16 {
                    halve(halve(halve(i, 4, xs, x), 2, xs, x), 1, xs, x)
                } else {
                    let c = &self.coarse;
                    let j = halve(halve(halve(i, 4, c, x), 2, c, x), 1, c, x);
                    halve(_mm512_slli_epi64::<1>(j), 1, xs, x)
                }
            };
            let look = Self::look::<P>;
            let (x0, y, s) = (look(xs, i), look(ys, i), look(slopes, i));
            let along = _mm512_add_pd(y, _mm512_mul_pd(_mm512_sub_pd(x, x0), s));
            _mm512_mask_mov_pd(self.yl, _mm512_cmp_pd_mask::<_CMP_LT_OQ>(x, self.xl), along)
        }
    }
}

/// `c` at each of `xs` (whole blocks of eight), by the engine's binary search (`GUESS` false:
/// as `WideCurve::eval` for 8 and 16, `WideLong::eval` for 32, the first halving against
/// `x[P/2]` broadcast) or by a guess from the buckets corrected by one compare; then the
/// segment's numbers looked up and `y + (x - x0) slope`, `y[n-1]` at or past the last point
/// (`x` first raised to `x[0]`, a NaN too, as the engine does). Returns the sum of the values
/// over `rounds` passes and, for one pass, their bits.
///
/// # Safety
/// The CPU must have AVX-512F and AVX-512DQ.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f,avx512dq")]
unsafe fn curve_eval<const P: usize, const GUESS: bool>(
    c: &CurveLanes,
    xs: &[f64],
    rounds: usize,
) -> (f64, Vec<u64>) {
    use std::arch::x86_64::*;
    let p = c.p;
    assert!(c.table.len() == 5 * p && p == P && [8, 16, 32].contains(&p));
    // SAFETY: every load reads eight numbers within `table` (asserted: table `k` is its numbers
    // `k P .. (k + 1) P`, and `j` below `P / 8`), `coarse` or a block of `xs`; the CPU has the
    // instructions (the caller's promise).
    unsafe {
        let mut t = [[_mm512_setzero_pd(); 4]; 5];
        for (k, tk) in t.iter_mut().enumerate() {
            for (j, v) in tk.iter_mut().enumerate() {
                *v = _mm512_loadu_pd(c.table.as_ptr().add(k * p + 8 * (j % (p / 8))));
            }
        }
        let lo = _mm512_loadu_pd(c.coarse.as_ptr());
        let hi = _mm512_loadu_pd(c.coarse.as_ptr().add(8));
        let v = CurveVecs {
            t,
            coarse: [lo, hi, lo, hi],
            first: _mm512_set1_pd(c.first),
            mid: _mm512_set1_pd(c.table[p / 2]),
            xl: _mm512_set1_pd(c.last.0),
            yl: _mm512_set1_pd(c.last.1),
            scale: _mm512_set1_pd(c.scale),
            top: _mm512_set1_pd((p - 1) as f64),
        };
        let mut bits = Vec::new();
        let mut acc = _mm512_setzero_pd();
        for _ in 0..rounds {
            for b in xs.chunks_exact(8) {
                let f = v.eval::<P, GUESS>(_mm512_loadu_pd(b.as_ptr()));
                if rounds == 1 {
                    let mut out = [0.0; 8];
                    _mm512_storeu_pd(out.as_mut_ptr(), f);
                    bits.extend(out.map(f64::to_bits));
                }
                acc = _mm512_add_pd(acc, f);
            }
        }
        (_mm512_reduce_add_pd(acc), bits)
    }
}

/// [`curve_eval`] compiled for `c`'s `P` and the search or the guess.
///
/// # Safety
/// The CPU must have AVX-512F and AVX-512DQ.
#[cfg(target_arch = "x86_64")]
unsafe fn curve_run(c: &CurveLanes, xs: &[f64], guess: bool, rounds: usize) -> (f64, Vec<u64>) {
    // SAFETY: the caller's promise.
    unsafe {
        match (c.p, guess) {
            (8, false) => curve_eval::<8, false>(c, xs, rounds),
            (8, true) => curve_eval::<8, true>(c, xs, rounds),
            (16, false) => curve_eval::<16, false>(c, xs, rounds),
            (16, true) => curve_eval::<16, true>(c, xs, rounds),
            (32, false) => curve_eval::<32, false>(c, xs, rounds),
            _ => curve_eval::<32, true>(c, xs, rounds),
        }
    }
}

/// `ceiling curves`: the stiffness curves of `lnl-drawn` (7 points, padded to 8), `lnl-fine`
/// (13, padded to 16) and `lnl-long` (33 points, 32 segments) evaluated eight lanes at a time
/// by [`curve_eval`], by the engine's binary search and by a guess from a uniform grid corrected
/// by one compare; both checked against `Curve::eval`'s bits, then timed on 4,096 stretches
/// within ±2 (as the bench's networks' stretches) and within ±2.5 L (every segment),
/// alternating, median of [`RUNS`].
fn curves_mode() {
    #[cfg(target_arch = "x86_64")]
    {
        if !(std::is_x86_feature_detected!("avx512f") && std::is_x86_feature_detected!("avx512dq"))
        {
            println!("no AVX-512 on this CPU: no curves to time");
            return;
        }
        let mut rng = Lcg(0x00c0_4d15_2026_1201);
        let mut uniform = |w: f64| (rng.below(1 << 30) as f64 / f64::from(1 << 30) - 0.5) * w;
        println!("LNL stiffness curves, eight lanes at a time; evaluations/s, median of {RUNS}");
        let curves = [
            ("drawn (7 points)", drawn(K)),
            ("fine (13 points)", fine(K)),
            ("long (33 points)", sampled(K)),
        ];
        for (name, law) in curves {
            let Interaction::Lnl { lk, .. } = law else {
                unreachable!("an LNL link")
            };
            let c = CurveLanes::new(&lk);
            let mut xs = vec![
                f64::NAN,
                f64::INFINITY,
                f64::NEG_INFINITY,
                0.0,
                -0.0,
                f64::MAX,
            ];
            for (x, _) in lk.points() {
                xs.extend([x, x.next_up(), x.next_down()]);
            }
            for &e in &c.edges {
                xs.extend([e, e.next_down(), e.next_up()]);
            }
            xs.extend((0..100_000).map(|_| uniform(6.0 * LNL_L)));
            xs.resize(xs.len().next_multiple_of(8), 0.0);
            let want: Vec<u64> = xs.iter().map(|&x| lk.eval(x).to_bits()).collect();
            // SAFETY: the CPU has AVX-512F and DQ (checked above).
            let same = |g: bool| unsafe { curve_run(&c, &xs, g, 1) }.1 == want;
            println!(
                "{name}: {} segments, buckets {}; the search's bits {}, the guess's {}",
                c.p,
                if c.exact {
                    "of at most one abscissa inside"
                } else {
                    "NOT EXACT"
                },
                if same(false) {
                    "the curve's"
                } else {
                    "DIFFERENT"
                },
                if same(true) {
                    "the curve's"
                } else {
                    "DIFFERENT"
                },
            );
            for (what, width) in [("within ±2", 4.0), ("within ±2.5 L", 5.0 * LNL_L)] {
                let xs: Vec<f64> = (0..4096).map(|_| uniform(width)).collect();
                let rounds = (work() / 4096).max(1) as usize;
                let (mut ts, mut tg) = (Vec::new(), Vec::new());
                for _ in 0..RUNS {
                    // SAFETY: as above.
                    timed(&mut ts, || unsafe { curve_run(&c, &xs, false, rounds) });
                    timed(&mut tg, || unsafe { curve_run(&c, &xs, true, rounds) });
                }
                let evals = (4096 * rounds) as f64;
                let (ts, tg) = (median(ts), median(tg));
                println!(
                    "  {what}: search {:.3e}, guess {:.3e}: guess / search {:.2}",
                    evals / ts,
                    evals / tg,
                    ts / tg
                );
            }
        }
    }
    #[cfg(not(target_arch = "x86_64"))]
    println!("no AVX-512 on this CPU: no curves to time");
}

/// `ceiling pingpong`: how long a cache line takes to go from one core to the other and back:
/// two threads hand a counter to each other 2,000,000 times through one atomic (each waits,
/// spinning, for the other's increment). Half the round trip is what one thread waits each time
/// it reads a pair the other wrote in the step before; the random network's two-thread ratio
/// follows it (docs/BENCHMARKS-LOG.md, fifty-eighth session). Then, three times, what two threads
/// give on arithmetic alone, with nothing shared (eight chains of a multiply and an add each): the
/// most two vCPUs give any step, whatever it shares (seventy-second session).
fn pingpong_mode() {
    use std::sync::atomic::{AtomicU64, Ordering};
    const TRIPS: u64 = 2_000_000;
    #[repr(align(128))]
    struct Line(AtomicU64);
    let line = Line(AtomicU64::new(0));
    let started = Instant::now();
    std::thread::scope(|s| {
        s.spawn(|| {
            for i in 0..TRIPS {
                while line.0.load(Ordering::Acquire) != 2 * i + 1 {
                    std::hint::spin_loop();
                }
                line.0.store(2 * i + 2, Ordering::Release);
            }
        });
        for i in 0..TRIPS {
            line.0.store(2 * i + 1, Ordering::Release);
            while line.0.load(Ordering::Acquire) != 2 * i + 2 {
                std::hint::spin_loop();
            }
        }
    });
    let trip = started.elapsed().as_secs_f64() / TRIPS as f64;
    println!(
        "cache line between two threads: round trip {:.1} ns, one way {:.1} ns ({TRIPS} trips; \
         load average {} at start)",
        trip * 1e9,
        trip * 0.5e9,
        load_average()
    );
    // arithmetic alone: eight chains of a multiply and an add, on one thread then on two
    fn spin() -> f64 {
        let mut a: [f64; 8] = std::array::from_fn(|i| 1.0 + i as f64 * 1e-9);
        let (m, c) = (black_box(0.999_999_999), black_box(1e-9));
        for _ in 0..50_000_000 {
            for x in &mut a {
                *x = *x * m + c;
            }
        }
        a.iter().sum()
    }
    for _ in 0..3 {
        let started = Instant::now();
        black_box(spin());
        let one = started.elapsed().as_secs_f64();
        let started = Instant::now();
        std::thread::scope(|s| {
            s.spawn(|| black_box(spin()));
            black_box(spin());
        });
        let two = started.elapsed().as_secs_f64();
        println!(
            "arithmetic alone: 1 thread {one:.3} s, 2 threads {two:.3} s for twice the work: \
             ratio {:.2}",
            2.0 * one / two
        );
    }
}

/// `ceiling signs`: how often the links of `random-lnl-long 10000` change the sign of their
/// stretch `x(b) - x(a)` (their curves' breakpoint at 0) from one step to the next over steps
/// 3,001 to 4,000, and how often a row of eight lanes does (materials in groups of eight in
/// declaration order, a row the k-th link end of each, ends in the links' order): what keeping
/// each link's segment of the step before would find unchanged.
fn signs_mode() {
    let model = random(10_000, Law::LnlLong);
    let net = &model.net;
    let mut engine = Engine::new(net);
    let mut buf = vec![0.0; engine.channels()];
    let n = net.materials.len();
    let mut ends: Vec<Vec<usize>> = vec![Vec::new(); n];
    for (i, l) in net.links.iter().enumerate() {
        ends[l.a.index()].push(i);
        ends[l.b.index()].push(i);
    }
    let negative = |e: &Engine| -> Vec<bool> {
        (net.links.iter())
            .map(|l| e.position(l.b) - e.position(l.a) < 0.0)
            .collect()
    };
    let (mut links, mut rows, mut steps) = (0.0, 0.0, 0.0);
    let mut before = negative(&engine);
    for step in 1..=4000 {
        engine
            .process(1, &mut buf)
            .expect("the bench's network does not blow up");
        let now = negative(&engine);
        if step > 3000 {
            let changed: Vec<bool> = before.iter().zip(&now).map(|(a, b)| a != b).collect();
            links += changed.iter().filter(|&&c| c).count() as f64 / changed.len() as f64;
            let (mut any, mut all) = (0usize, 0usize);
            for group in ends.chunks(8) {
                let degree = group.iter().map(Vec::len).max().unwrap_or(0);
                for k in 0..degree {
                    all += 1;
                    let lane = |e: &Vec<usize>| e.get(k).is_some_and(|&l| changed[l]);
                    any += usize::from(group.iter().any(lane));
                }
            }
            rows += any as f64 / all as f64;
            steps += 1.0;
        }
        before = now;
    }
    println!(
        "{}: over steps 3,001 to 4,000, links changing the sign of their stretch at a step \
         {:.1} %, rows of eight with such a lane {:.1} %",
        model.name,
        100.0 * links / steps,
        100.0 * rows / steps
    );
}

/// `ceiling [MODEL...]`: for each membrane, cordis against the two hand-specialised kernels of
/// [`Stencil`]; for each random network, cordis and the generic baseline against [`Reads`].
fn ceiling_mode(specs: &[Spec]) {
    let work = work();
    println!(
        "cordis engine against hand-specialised kernels; {work:.3e} mass-steps per run, median of \
         {RUNS} runs (alternating), mass-steps/s; load average {}",
        load_average(),
        work = work as f64
    );
    for spec in specs {
        let model = build(spec);
        let steps = (work / model.masses as u64).max(MIN_STEPS);
        let mass_steps = (model.masses as u64 * steps) as f64;
        let mut engine = Engine::new(&model.net);
        let mut buf = vec![0.0; block() * engine.channels()];
        let mut tc = Vec::new();
        let mut sc = 0.0;
        match *spec {
            Spec::Membrane(rows, cols) => {
                let mut st = Stencil::new(rows, cols);
                let (mut te, mut tf, mut tu) = (Vec::new(), Vec::new(), Vec::new());
                let (mut se, mut sf, mut su) = (0.0, 0.0, 0.0);
                for _ in 0..RUNS {
                    sc = timed(&mut tc, || {
                        run_cordis(&mut engine, black_box(steps), &mut buf)
                    });
                    se = timed(&mut te, || st.run(black_box(steps), Arithmetic::Exact));
                    sf = timed(&mut tf, || st.run(black_box(steps), Arithmetic::Factored));
                    su = timed(&mut tu, || st.run(black_box(steps), Arithmetic::Fused));
                }
                let (tc, te, tf, tu) = (median(tc), median(te), median(tf), median(tu));
                let rel = |s: f64| ((s - sc) / sc.abs().max(f64::MIN_POSITIVE)).abs();
                // the issue's tolerance for other arithmetic: within 1e-12 of the peak over 10 s
                let traces =
                    [Arithmetic::Exact, Arithmetic::Factored, Arithmetic::Fused].map(|a| {
                        let mut t = Vec::with_capacity(TEN_SECONDS as usize);
                        st.steps_traced(TEN_SECONDS, a, Some(&mut t));
                        t
                    });
                let peak = traces[0].iter().fold(0.0f64, |p, v| p.max(v.abs()));
                let off = |t: &[f64]| {
                    let d = t
                        .iter()
                        .zip(&traces[0])
                        .fold(0.0f64, |d, (a, b)| d.max((a - b).abs()));
                    d / peak
                };
                println!(
                    "{}: cordis {:.3e}; exact stencil {:.3e} (cordis / exact {:.2}, output {}); \
                     factored stencil {:.3e} (cordis / factored {:.2}, output rel diff {:.1e}); \
                     fused {:.3e} (cordis / fused {:.2}, output rel diff {:.1e}); over 10 s, \
                     max |factored - exact| / peak {:.1e}, max |fused - exact| / peak {:.1e}",
                    model.name,
                    mass_steps / tc,
                    mass_steps / te,
                    te / tc,
                    if se.to_bits() == sc.to_bits() {
                        "identical"
                    } else {
                        "DIFFERENT"
                    },
                    mass_steps / tf,
                    tf / tc,
                    rel(sf),
                    mass_steps / tu,
                    tu / tc,
                    rel(su),
                    off(&traces[1]),
                    off(&traces[2]),
                );
            }
            _ => {
                let mut generic = Generic::new(&model.net, model.out);
                let reads = Reads::new(&model.net);
                let (mut tg, mut tr, mut tp, mut tv) =
                    (Vec::new(), Vec::new(), Vec::new(), Vec::new());
                for _ in 0..RUNS {
                    sc = timed(&mut tc, || {
                        run_cordis(&mut engine, black_box(steps), &mut buf)
                    });
                    timed(&mut tg, || generic.run(black_box(steps)));
                    timed(&mut tr, || reads.run(black_box(steps), false));
                    timed(&mut tp, || reads.run(black_box(steps), true));
                    let t = Instant::now();
                    if black_box(reads.gathered(black_box(steps), (0, 1))).is_some() {
                        tv.push(t.elapsed().as_secs_f64());
                    }
                }
                let (tc, tg, tr, tp) = (median(tc), median(tg), median(tr), median(tp));
                black_box(sc);
                let gathers = if tv.is_empty() {
                    "no AVX-512".to_string()
                } else {
                    let tv = median(tv);
                    format!("{:.3e} (/ generic {:.2})", mass_steps / tv, tg / tv)
                };
                println!(
                    "{}: cordis {:.3e}; generic {:.3e} (cordis / generic {:.2}); reads only: \
                     scalar {:.3e} (/ generic {:.2}), paired {:.3e} (/ generic {:.2}), \
                     gathered {gathers}",
                    model.name,
                    mass_steps / tc,
                    mass_steps / tg,
                    tg / tc,
                    mass_steps / tr,
                    tg / tr,
                    mass_steps / tp,
                    tg / tp
                );
            }
        }
    }
}

/// Runs `steps` steps of `engine` from its initial state, in blocks of [`block`] frames into `buf`;
/// returns the sum of the output samples.
fn run_cordis(engine: &mut Engine, steps: u64, buf: &mut [f64]) -> f64 {
    engine.reset();
    let ch = engine.channels();
    let block = block() as u64;
    let mut acc = 0.0;
    let mut left = steps;
    while left > 0 {
        let frames = left.min(block) as usize;
        let out = &mut buf[..frames * ch];
        engine
            .process(frames, out)
            .expect("the benchmark models are stable");
        for &v in out.iter() {
            acc += v; // sample by sample, in the order the baseline sums
        }
        left -= frames as u64;
    }
    acc
}

/// Runs `f`, pushing its duration in seconds onto `times`.
fn timed<T>(times: &mut Vec<f64>, f: impl FnOnce() -> T) -> T {
    let t = Instant::now();
    let out = black_box(f());
    times.push(t.elapsed().as_secs_f64());
    out
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

/// Frames per `Engine::process` call: `CORDIS_BENCH_BLOCK`, or [`DEFAULT_BLOCK`].
fn block() -> usize {
    match std::env::var("CORDIS_BENCH_BLOCK") {
        Ok(s) => match s.trim().parse::<usize>() {
            Ok(b) if b >= 1 => b,
            _ => panic!("CORDIS_BENCH_BLOCK must be a number of frames >= 1 (e.g. 64), not {s:?}"),
        },
        Err(_) => DEFAULT_BLOCK,
    }
}

fn work() -> u64 {
    match std::env::var("CORDIS_BENCH_WORK") {
        Ok(s) => match s.trim().parse::<f64>() {
            Ok(w) if w >= 1.0 => w as u64,
            _ => panic!(
                "CORDIS_BENCH_WORK must be a number of mass-steps >= 1 (e.g. 2e6), not {s:?}"
            ),
        },
        Err(_) => DEFAULT_WORK,
    }
}

fn usage() -> ! {
    eprintln!(
        "usage: cargo bench -p cordis-core --bench engine -- [string [N]] [but [N]] [lnl [N]] \
         [membrane [R C | RxC]] [rimmed|free|struck|pair|graded R C | RxC] [strings S N | SxN] \
         [random [N]] [random-but [N]] [random-lnl [N]] [random-struck [N]] \
         [random-lnl-mixed [N]] [random-lnl-halves [N]] [random-lnl-struck [N]] \
         [random-but-lnl [N]] [lnl-drawn [N]] [random-lnl-drawn [N]] [lnl-fine [N]] \
         [random-lnl-fine [N]] [lnl-full [N]] [random-lnl-full [N]] [lnl-long [N]] [random-lnl-long [N]] \
         [random-lnl-long-halves [N]] [lnl-stick [N]] [random-lnl-stick [N]]...\n(no model: every \
         default model)\n   \
         or: cargo bench -p cordis-core --bench engine -- threads [N [T [KIND...]]]   (1 vs T \
         threads, default N = 100000 masses, T = 2)\n   \
         or: cargo bench -p cordis-core --bench engine -- netlist DIR MODEL...   (write the \
         models as netlists for the C generic kernel cref.c)\n   \
         or: cargo bench -p cordis-core --bench engine -- ceiling MODEL... | ceiling threads [N \
         [T]] | ceiling pull [N [T]] | ceiling drift [N [STEPS]] | ceiling curves | ceiling \
         signs | ceiling pingpong   (hand-written kernels: the membrane's stencils, the reads of a \
         random network, on T threads, the pull step's layouts, how far its reordered sums end \
         from the reference's bits, two searches of an LNL curve's segment; how often LNL links \
         change segment; a cache line's trip between two threads)"
    );
    std::process::exit(2)
}

/// Model selection from the command line. Flags (cargo passes `--bench`) are ignored.
fn parse_args(args: &[String]) -> Vec<Spec> {
    let num = |s: &str| s.parse::<usize>().ok().filter(|&n| n > 0);
    let mut specs = Vec::new();
    let mut i = 0;
    while i < args.len() {
        let kind = args[i].as_str();
        i += 1;
        let law = match kind {
            "string" => Some(Law::Ref),
            "but" => Some(Law::But),
            "lnl" => Some(Law::Lnl),
            "lnl-drawn" => Some(Law::LnlDrawn),
            "lnl-fine" => Some(Law::LnlFine),
            "lnl-full" => Some(Law::LnlFull),
            "lnl-long" => Some(Law::LnlLong),
            "lnl-stick" => Some(Law::LnlStick),
            "membrane"
            | "rimmed"
            | "free"
            | "struck"
            | "pair"
            | "graded"
            | "random"
            | "random-but"
            | "random-lnl"
            | "random-struck"
            | "random-lnl-mixed"
            | "random-lnl-halves"
            | "random-lnl-struck"
            | "random-but-lnl"
            | "random-lnl-drawn"
            | "random-lnl-fine"
            | "random-lnl-full"
            | "random-lnl-long"
            | "random-lnl-long-halves"
            | "random-lnl-stick"
            | "random-damped"
            | "strings" => None,
            _ => usage(),
        };
        let random_law = match kind {
            "random-but" => Law::But,
            "random-lnl" => Law::Lnl,
            "random-struck" => Law::Struck,
            "random-lnl-mixed" => Law::LnlMixed,
            "random-lnl-halves" => Law::LnlHalves,
            "random-lnl-struck" => Law::LnlStruck,
            "random-but-lnl" => Law::ButLnl,
            "random-lnl-drawn" => Law::LnlDrawn,
            "random-lnl-fine" => Law::LnlFine,
            "random-lnl-full" => Law::LnlFull,
            "random-lnl-long" => Law::LnlLong,
            "random-lnl-long-halves" => Law::LnlLongHalves,
            "random-lnl-stick" => Law::LnlStick,
            "random-damped" => Law::Damped,
            _ => Law::Ref,
        };
        let first = args.get(i).map(String::as_str);
        let explicit = match (kind, first) {
            (
                "membrane" | "rimmed" | "free" | "struck" | "pair" | "graded" | "strings",
                Some(a),
            ) => {
                let spec = |r, c| match kind {
                    "strings" => Spec::Strings(r, c),
                    "membrane" => Spec::Membrane(r, c),
                    "rimmed" => Spec::Rimmed(r, c, Rim::Fixed),
                    "free" => Spec::Rimmed(r, c, Rim::Free),
                    "pair" => Spec::Rimmed(r, c, Rim::Pair),
                    "graded" => Spec::Rimmed(r, c, Rim::Graded),
                    _ => Spec::Rimmed(r, c, Rim::Struck),
                };
                if let Some((r, c)) = a
                    .split_once('x')
                    .and_then(|(r, c)| Some((num(r)?, num(c)?)))
                {
                    i += 1;
                    Some(spec(r, c))
                } else if let (Some(r), Some(c)) = (num(a), args.get(i + 1).and_then(|c| num(c))) {
                    i += 2;
                    Some(spec(r, c))
                } else {
                    None
                }
            }
            (_, Some(a)) => num(a).map(|n| {
                i += 1;
                match law {
                    Some(law) => Spec::String(n, law),
                    None => Spec::Random(n, random_law),
                }
            }),
            (_, None) => None,
        };
        match explicit {
            Some(Spec::String(n, _) | Spec::Random(n, _)) if n < 2 => usage(),
            Some(Spec::Membrane(r, c) | Spec::Rimmed(r, c, _)) if r < 3 || c < 3 => usage(), // the strike is at (2,2)
            Some(Spec::Strings(_, n)) if n < 2 => usage(),
            Some(spec) => specs.push(spec),
            None if random_law != Law::Ref => specs.push(Spec::Random(10000, random_law)),
            None if matches!(
                law,
                Some(Law::LnlDrawn | Law::LnlFine | Law::LnlFull | Law::LnlLong | Law::LnlStick)
            ) =>
            {
                specs.push(Spec::String(1000, law.expect("a law")))
            }
            None => specs.extend(
                DEFAULT_MODELS
                    .iter()
                    .filter(|s| match (s, kind) {
                        (Spec::String(_, l), _) => Some(*l) == law,
                        (Spec::Membrane(..), k) => k == "membrane",
                        (Spec::Rimmed(..), _) => false,
                        (Spec::Random(..), k) => k == "random",
                        (Spec::Strings(..), _) => false,
                    })
                    .cloned(),
            ),
        }
    }
    if specs.is_empty() {
        specs.extend(DEFAULT_MODELS.iter().cloned());
    }
    specs
}

/// The models of the `threads` mode for about `n` masses: a string, a square membrane, a random
/// network.
fn thread_models(n: usize) -> Vec<Model> {
    let side = |n: usize| ((n as f64).sqrt().round() as usize).max(3);
    vec![
        string(n, Law::Ref),
        membrane(side(n), side(n), None),
        membrane(side(n / 2), side(n / 2), Some(Rim::Pair)),
        random(n, Law::Ref),
        random(n, Law::Lnl),
        random(n, Law::LnlLong),
        random(n, Law::LnlMixed),
    ]
}

/// The 1-minute load average, to print next to timings on a shared machine.
fn load_average() -> String {
    std::fs::read_to_string("/proc/loadavg")
        .ok()
        .and_then(|s| s.split_whitespace().next().map(str::to_string))
        .unwrap_or_else(|| "n/a".to_string())
}

/// `threads [N [T [KIND...]]]`: each model (or those whose name starts with a KIND) stepped on 1
/// and on T threads (default 2), runs alternating, the medians and their ratio; both renders must
/// be bit-identical. Also the time `Engine::new` took for the first engine.
fn threads_mode(n: usize, threads: usize, kinds: &[String]) {
    let work = work();
    println!(
        "cordis engine, 1 thread vs {threads} threads; {work:.3e} mass-steps per run, median of \
         {RUNS} runs (alternating); load average {} at start",
        load_average(),
        work = work as f64
    );
    println!(
        "{:<18} {:>8} {:>12} {:>12} {:>7}  {:>8}  {:>9}  check",
        "model",
        "steps",
        "1 thread",
        format!("{threads} threads"),
        "ratio",
        "load",
        "build ms"
    );
    for model in thread_models(n) {
        if !kinds.is_empty() && !kinds.iter().any(|k| model.name.starts_with(k.as_str())) {
            continue;
        }
        let steps = (work / model.masses as u64).max(MIN_STEPS);
        let mass_steps = (model.masses as u64 * steps) as f64;
        let built = Instant::now();
        let mut one = Engine::new(&model.net);
        let built = built.elapsed().as_secs_f64();
        let mut many = Engine::new(&model.net);
        many.set_threads(threads);
        many.set_parallel_threshold(0); // threads whatever the size: this mode times them
        assert!(many.is_parallel() || threads == 1);
        let mut buf = vec![0.0; block() * one.channels()];
        let (mut t1, mut tn) = (Vec::new(), Vec::new());
        let (mut s1, mut sn) = (0.0, 0.0);
        for _ in 0..RUNS {
            s1 = timed(&mut t1, || run_cordis(&mut one, black_box(steps), &mut buf));
            sn = timed(&mut tn, || {
                run_cordis(&mut many, black_box(steps), &mut buf)
            });
        }
        let (t1, tn) = (median(t1), median(tn));
        let check = if s1.to_bits() == sn.to_bits() {
            "identical"
        } else {
            "DIFFERENT"
        };
        println!(
            "{:<18} {:>8} {:>12.3e} {:>12.3e} {:>7.2}  {:>8}  {:>9.1}  {check}",
            model.name,
            steps,
            mass_steps / t1,
            mass_steps / tn,
            t1 / tn,
            load_average(),
            built * 1e3
        );
    }
}

fn main() {
    match SimdLimit::from_env() {
        Err(e) => {
            eprintln!("{e}");
            std::process::exit(2);
        }
        Ok(Some(limit)) => println!("{}: vector instructions up to {limit:?}", SimdLimit::VAR),
        Ok(None) => {}
    }
    let args: Vec<String> = std::env::args()
        .skip(1)
        .filter(|a| !a.starts_with('-'))
        .collect();
    if args.first().map(String::as_str) == Some("threads") {
        let num = |i: usize, default: usize| {
            args.get(i)
                .map(|s| {
                    s.parse::<usize>()
                        .ok()
                        .filter(|&n| n >= 9)
                        .unwrap_or_else(|| usage())
                })
                .unwrap_or(default)
        };
        let threads = args
            .get(2)
            .map(|s| {
                s.parse::<usize>()
                    .ok()
                    .filter(|&t| t >= 1)
                    .unwrap_or_else(|| usage())
            })
            .unwrap_or(2);
        return threads_mode(num(1, 100_000), threads, args.get(3..).unwrap_or(&[]));
    }
    if args.first().map(String::as_str) == Some("ceiling") {
        let num = |i: usize, default: usize, min: usize| {
            (args.get(i)).map_or(default, |s| {
                (s.parse::<usize>().ok().filter(|&n| n >= min)).unwrap_or_else(|| usage())
            })
        };
        match args.get(1).map(String::as_str) {
            Some("threads") => return floor_threads_mode(num(2, 100_000, 9), num(3, 2, 1)),
            Some("pull") => return pull_layouts_mode(num(2, 10_000, 16), num(3, 2, 1)),
            Some("drift") => return drift_mode(num(2, 10_000, 16), num(3, 441_000, 1)),
            Some("curves") => return curves_mode(),
            Some("signs") => return signs_mode(),
            Some("pingpong") => return pingpong_mode(),
            _ => {}
        }
        return ceiling_mode(&parse_args(&args[1..]));
    }
    if args.first().map(String::as_str) == Some("netlist") {
        let Some(dir) = args.get(1) else { usage() };
        std::fs::create_dir_all(dir).expect("netlist directory created");
        for spec in &parse_args(&args[2..]) {
            let model = build(spec);
            let path = std::path::Path::new(dir).join(format!("{}.net", model.name));
            std::fs::write(&path, netlist(&model)).expect("netlist written");
            println!("{}", path.display());
        }
        return;
    }
    let specs = parse_args(&args);
    let work = work();
    println!(
        "cordis engine vs in-process generic baseline (Rust port of cref.c, ideal schedule); \
         {work:.3e} mass-steps per run, median of {RUNS} runs",
        work = work as f64
    );
    println!(
        "{:<18} {:>8} {:>9} {:>12}   {:>9} {:>12}   {:>6}  check",
        "model", "steps", "cordis s", "mass-steps/s", "generic s", "mass-steps/s", "ratio"
    );
    for spec in &specs {
        let model = build(spec);
        let steps = (work / model.masses as u64).max(MIN_STEPS);
        let mass_steps = (model.masses as u64 * steps) as f64;
        let mut engine = Engine::new(&model.net);
        let mut buf = vec![0.0; block() * engine.channels()];
        let mut generic = Generic::new(&model.net, model.out);
        let (mut tc, mut tg) = (Vec::new(), Vec::new());
        let (mut sc, mut sg) = (0.0, 0.0);
        for _ in 0..RUNS {
            sc = timed(&mut tc, || {
                run_cordis(&mut engine, black_box(steps), &mut buf)
            });
            sg = timed(&mut tg, || generic.run(black_box(steps)));
        }
        let (tc, tg) = (median(tc), median(tg));
        // Both sum the same SOX samples: bit-identical for REF, rounding-close for BUT and LNL.
        let check = if sc == sg {
            "identical".to_string()
        } else {
            format!(
                "rel diff {:.1e}",
                ((sc - sg) / sg.abs().max(f64::MIN_POSITIVE)).abs()
            )
        };
        println!(
            "{:<18} {:>8} {:>9.4} {:>12.3e}   {:>9.4} {:>12.3e}   {:>6.2}  {check}",
            model.name,
            steps,
            tc,
            mass_steps / tc,
            tg,
            mass_steps / tg,
            tg / tc
        );
    }
}
