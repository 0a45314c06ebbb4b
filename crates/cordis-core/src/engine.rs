//! The stepping side: a network compiled into dense struct-of-arrays state.
//!
//! # How a step is computed, and why it is bit-exact on any number of threads
//!
//! A step has two phases:
//!
//! 1. **Links.** Every interaction computes its force `f(n)` from `x(n)` and `x(n-1)` and stores
//!    it in its own slot of one buffer `sf`; every force input (ENF) on a mobile material stores
//!    its sample `n` in its own slot. Nothing is accumulated, so this phase gives the same bits
//!    whatever order (or thread) the links are computed in. The slots follow a storage order of
//!    the links chosen for speed ([`link_order`]), not their declaration order.
//! 2. **Materials.** Every material sums its terms itself — a *gather*: starting from `+0.0`, it
//!    adds the slots of its links in declaration order, negated where it is end 1 (end 1 before
//!    end 2 for a link tied to the same material twice), then the slots of its ENF inputs in
//!    declaration order. Materials whose terms form arithmetic progressions of slots (strings,
//!    rows of membranes) apply one sign per progression (a multiplication by `±1`); the others
//!    flip the sign bit of each end-1 term. That is exactly the sum FORMALISM.md prescribes
//!    (`F - f` and `F + (-f)` are the same IEEE operation, and negation is exact, whether by a
//!    sign flip or by `-1 * f`), so each `F(n)` has the bits of the
//!    reference stepper's. (Only the sign of a NaN may differ, and a NaN force makes `x(n+1)`
//!    non-finite: a blow-up, whose outputs are never delivered.) Then it computes `x(n+1)` from
//!    `x(n)`, `x(n-1)` and `F(n)`, again independently of every other material.
//!
//! The order of the terms of each sum is fixed at compile time (the per-material edge lists
//! `eidx`), not by who computes what: cutting the links and the materials into contiguous parts,
//! one per thread, changes nothing in the arithmetic. With threads, the parts run in lock-step,
//! one barrier after each phase (see [`crate::parallel`] and [`Job`]).
//!
//! **The compact step.** A small network whose links and MAS are mostly read through index lists
//! (an instrument of short strings and devices, an irregular network; see [`Kernel::new`]) has
//! little for the vector loops to do, and the gather's index lists and per-segment set-up cost
//! more than they save. On one thread such a network is stepped as FORMALISM.md writes it: each
//! link's force, as it is computed, is subtracted from its end 1's accumulator and added to its
//! end 2's; then the ENF inputs; then every material updates in one contiguous loop. Its links
//! are stored in each material's declaration order, so each accumulator sums the same terms in
//! the same order as the gather, from `+0.0`: the same bits. With threads, such a network takes
//! the two phases above (it only does when a caller lowers the threshold).
//!
//! Positions live in three buffers that take turns: `pos[n % 3]` holds `x(n)`, `pos[(n + 2) % 3]`
//! `x(n-1)`, and the materials phase writes `x(n+1)` into the third, `pos[(n + 1) % 3]`, which
//! held `x(n-2)`. Nothing the links or materials phases read is written during a step, so the
//! single-thread step can interleave them tile by tile (see [`Tile`]).

use std::cell::Cell;
use std::ops::Range;
use std::sync::atomic::{AtomicUsize, Ordering};

use crate::curve::{kept_len, ExactCurve, LongCurve};
use crate::lanes::{Avx512, LANES};
use crate::lines::Lines;
use crate::parallel::{Poisoned, Pool, SharedBuf, SpinBarrier, Task};
use crate::{Curve, Interaction, LinkId, MatId, Material, Network, Output, Probe, Signal};

mod grid;
mod pull;

/// The law of a run of consecutive links (in declaration order) that share it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Law {
    Res,
    Fro,
    Ref,
    But,
    Lnl,
}

impl Law {
    /// Relative cost of one link, to balance the threads' shares.
    fn cost(self) -> u64 {
        match self {
            Law::Res | Law::Fro | Law::Ref => 2,
            Law::But => 3,
            Law::Lnl => 8,
        }
    }
}

/// A link computed alone ([`Kernel::link_alone`]: one an output reads in the steps that keep no
/// force buffer, the pull and grid steps, or a grid's fix's): its slot, its ends' slots and its
/// law.
#[derive(Clone, Copy, Debug)]
struct Recorded {
    slot: u32,
    a: u32,
    b: u32,
    law: Law,
}

/// Links `start..end` (declaration order) all have law `law`. When `uniform`, they also all have
/// the parameters (K, Z, S, or the curves) of link `start`, so the loop reads them once.
#[derive(Clone, Copy, Debug)]
struct Run {
    law: Law,
    start: usize,
    end: usize,
    uniform: bool,
    ends: Ends,
}

/// Where the ends of the links of a run are.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Ends {
    /// Link `l`'s ends are `la[l]`, `lb[l]`.
    Indexed,
    /// Link `start + i`'s ends are `a0 + i sa` and `b0 + i sb` (equal to `la`, `lb`, as
    /// `Kernel::new` checks): no index to load, and with unit steps the positions are contiguous
    /// slices, so the loop vectorises (strings, rows of membranes).
    Step { a0: u32, sa: u32, b0: u32, sb: u32 },
    /// The links are those of storage slots `Kernel::listed[from..to]` (ascending, each within
    /// `start..end`, which is only their span): short indexed runs of one tile with the same law
    /// and parameters, gathered into one loop (see [`Kernel::gather_short`]). Only in `tile_runs`.
    Listed { from: u32, to: u32 },
}

impl Run {
    /// The links `start..end` (within this run) as a run of their own.
    fn cut(&self, start: usize, end: usize) -> Run {
        let i = (start - self.start) as u32;
        let ends = match self.ends {
            Ends::Indexed => Ends::Indexed,
            Ends::Listed { .. } => unreachable!("listed runs are gathered after every cut"),
            Ends::Step { a0, sa, b0, sb } => Ends::Step {
                a0: a0 + i * sa,
                sa,
                b0: b0 + i * sb,
                sb,
            },
        };
        Run {
            start,
            end,
            ends,
            ..*self
        }
    }
}

/// How [`Kernel::build_with`] orders the mobile materials in storage, within their kind (MAS,
/// CEL, ENX).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Mobiles {
    /// By degree (declaration order within a degree): the gather's segments are long.
    ByDegree,
    /// In declaration order: a membrane's MAS stay in their rows whatever their degree.
    Declared,
    /// Near their neighbours: in the order of a breadth-first walk of the links between mobile
    /// materials, cut into windows of [`WINDOW`] materials of a kind ([`WIDE_WINDOW`] where the
    /// kinds of their terms are mixed), within a window by the pair of their LNL terms when
    /// there are several pairs ([`TermKinds::pair`]), by degree, then by the kinds of their terms
    /// ([`term_kinds`]), then in the walk's order. The pull step's storage (see
    /// [`local_order`]).
    Local,
}

/// Mobile materials of a kind per window of [`Mobiles::Local`]: a few pull-step groups of each
/// degree, whose neighbours' pairs are near each other in the pair buffer (docs/BENCHMARKS-LOG.md,
/// twenty-fifth session).
const WINDOW: usize = 256;

/// [`WINDOW`] for a network whose link terms are of mixed kinds ([`term_kinds`]): sorted by
/// kinds within wider windows, more rows of the pull step have one kind of term (a random
/// network of BUT and LNL links half and half: rows of both kinds of lanes 60 % with windows of
/// 256 MAS, 12 % with 4,096), at the cost of some of the locality of its pairs' reads (the REF
/// network ran about 5 % slower in windows of 4,096; docs/BENCHMARKS-LOG.md, thirtieth session).
const WIDE_WINDOW: usize = 16 * WINDOW;

/// How [`Kernel::build_with`] joins progressions into loops with exceptions.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Joins {
    /// Not at all: every progression is a loop of its own (the compact step's storage).
    Off,
    /// Across at most [`GAP_MAX`] items within a run of one law and parameters ([`bridged`]): a
    /// membrane's rows are one loop.
    Rows,
    /// Also across runs of one law and different parameters, the links of one law and distance
    /// stored as one band ([`link_order`], [`joined`]): short strings of their own stiffnesses
    /// are one loop.
    Runs,
}

/// Shortest stretch of identical links that gets a uniform run of its own.
const UNIFORM_MIN: usize = 8;
/// Shortest arithmetic progression of link ends, or of edges, that gets a loop without indices
/// (shorter ones cost more in loop set-up than they save: the small reconfigurable instrument ran
/// 25 % slower with 8; with 16 rather than 32 the rows of a 30x30 or 20x20 membrane are
/// vectorised, 1.4-1.55x faster, and larger models run the same).
const STEP_MIN: usize = 16;

/// Mobile materials `mats` (storage slots) all have `degree` edges. With `streams`, the edges are
/// arithmetic progressions: edge `j` of material `mats.start + i` is `base + i step`, `(base,
/// step) = Kernel::streams[streams.start + j]` (equal to `eidx`, as `Kernel::new` checks); without,
/// they are read from `eidx`, from `eoff[mats.start]` on.
#[derive(Clone, Debug)]
struct Segment {
    mats: Range<usize>,
    degree: usize,
    streams: Option<Range<usize>>,
    /// With streams that all have unit steps: the slot of each term of the first MAS (`j < degree`)
    /// and the signs (bit `j`: term `j` negated), decoded once here rather than at every step.
    unit: Option<([u32; UNIT_TERMS], u32)>,
}

/// Most terms of a MAS whose sum is a unit-step loop (see [`Kernel::update_mas`]).
const UNIT_TERMS: usize = 6;

#[derive(Clone, Copy, Debug)]
struct Cel {
    m: f64,
    a: f64,
    b: f64,
    r: f64,
}

impl Cel {
    /// `x(n+1)` from `x(n)`, `x(n-1)` and `F(n)` (FORMALISM.md, with `a`, `b` computed once).
    #[inline(always)]
    fn next(&self, x: f64, xp: f64, f: f64) -> f64 {
        self.r + self.a * (x - self.r) + self.b * (xp - self.r) + f / self.m
    }
}

/// An LNL law (elastic curve of `d`, viscous curve of `v`), in the fastest form that evaluates
/// exactly as [`Curve::eval`].
#[derive(Clone, Debug)]
#[allow(clippy::large_enum_variant)] // (one per distinct law, read by value in the loops)
enum Lnl {
    /// both curves of at most 16 points once kept ([`ExactCurve::kept`]: the usual springs,
    /// contacts, dampers and sticking springs, and curves drawn point by point), each evaluated
    /// without a branch in a loop the compiler vectorises
    Exact(ExactPair),
    /// a curve of more points: [`Curve::eval`] one link at a time, and [`LongCurve`]s in the
    /// vector paths
    Any(Box<AnyPair>),
}

/// An LNL law of a curve of more than 16 points: the curves, and the same as [`LongCurve`]s.
#[derive(Clone, Debug)]
struct AnyPair {
    k: Curve,
    z: Curve,
    long: (LongCurve, LongCurve),
}

impl AnyPair {
    fn new(k: &Curve, z: &Curve) -> AnyPair {
        AnyPair {
            k: k.clone(),
            z: z.clone(),
            long: (LongCurve::new(k), LongCurve::new(z)),
        }
    }

    #[inline(always)]
    fn force(&self, d: f64, v: f64) -> f64 {
        self.k.eval(d) + self.z.eval(v)
    }

    /// Whether both curves evaluate several at a time ([`LongCurve::widens`]).
    fn widens(&self) -> bool {
        self.long.0.widens() && self.long.1.widens()
    }

    /// Whether the force is never `-0.0`, as [`ExactPair::never_minus_zero`].
    fn never_minus_zero(&self) -> bool {
        self.long.0.never_minus_zero() || self.long.1.never_minus_zero()
    }

    /// Whether `other` has the same curves, bit for bit.
    fn same_bits(&self, other: &AnyPair) -> bool {
        self.long.0.same_bits(&other.long.0) && self.long.1.same_bits(&other.long.1)
    }
}

/// A function of an [`ExactPair`]'s two curves, generic in their point counts (so that it is
/// compiled for each pair: [`ExactPair::visit`]).
trait PairFn {
    type Out;
    fn call<const A: usize, const B: usize>(
        self,
        k: &ExactCurve<A>,
        z: &ExactCurve<B>,
    ) -> Self::Out;
}

/// Generates `ExactPair` (one variant per pair of point counts), its constructor and the
/// dispatch of a run over it.
macro_rules! exact_pairs {
    ($(($v:ident, $a:literal, $b:literal)),* $(,)?) => {
        #[derive(Clone, Copy, Debug)]
        #[allow(clippy::enum_variant_names)]
        #[allow(clippy::large_enum_variant)] // (one per distinct law, read by value in the loops)
        enum ExactPair {
            $($v(ExactCurve<$a>, ExactCurve<$b>),)*
        }

        impl ExactPair {
            /// The pair of curves `k` and `z`, each without the points that the selects may
            /// skip ([`ExactCurve::kept`]: the same bits) and padded to the smallest pair of
            /// point counts that holds them ([`ExactPair::shape`]: a curve of 1 point is one of
            /// 2, of 5 to 8 points one of 8, of 9 to 16 one of 16); `None` for a curve of more
            /// than 16 points once kept.
            fn new(k: &Curve, z: &Curve) -> Option<ExactPair> {
                let (a, b) = Self::shape(kept_len(k), kept_len(z))?;
                $(
                    if (a, b) == ($a, $b) {
                        let (k, z) = (ExactCurve::<$a>::kept(k)?, ExactCurve::<$b>::kept(z)?);
                        return Some(ExactPair::$v(k, z));
                    }
                )*
                None
            }

            /// The point counts of the smallest pair that pairs of `a` and `b` points pad to,
            /// if any: at least as many, and 0 only for 0 (the zero curve pads only to itself).
            fn shape(a: usize, b: usize) -> Option<(usize, usize)> {
                let fits = |n: usize, m: usize| m >= n && (n == 0) == (m == 0);
                [$(($a, $b)),*]
                    .into_iter()
                    .filter(|&(x, y)| fits(a, x) && fits(b, y))
                    .min_by_key(|&(x, y)| (x + y, x))
            }

            #[inline(always)]
            fn force(&self, d: f64, v: f64) -> f64 {
                match self {
                    $(ExactPair::$v(k, z) => k.eval(d) + z.eval(v),)*
                }
            }

            /// Whether both curves evaluate eight at a time ([`ExactCurve::widens`]).
            fn widens(&self) -> bool {
                match self {
                    $(ExactPair::$v(k, z) => k.widens() && z.widens(),)*
                }
            }

            /// Whether the force `k(d) + z(v)` is never `-0.0`: one of the curves never gives
            /// `-0.0` ([`ExactCurve::never_minus_zero`]), and a sum is `-0.0` only when both
            /// terms are.
            fn never_minus_zero(&self) -> bool {
                match self {
                    $(ExactPair::$v(k, z) => k.never_minus_zero() || z.never_minus_zero(),)*
                }
            }

            /// Whether `other` has the same curves, bit for bit.
            fn same_bits(&self, other: &ExactPair) -> bool {
                match (self, other) {
                    $((ExactPair::$v(k, z), ExactPair::$v(k2, z2)) => {
                        k.same_bits(k2) && z.same_bits(z2)
                    })*
                    _ => false,
                }
            }

            /// The point counts of the two curves.
            fn counts(&self) -> (usize, usize) {
                match self {
                    $(ExactPair::$v(..) => ($a, $b),)*
                }
            }

            /// The pair with its curves padded to `a` and `b` points ([`ExactCurve::padded`]:
            /// the same force everywhere, bit for bit), if they pad to them.
            fn padded(&self, a: usize, b: usize) -> Option<ExactPair> {
                struct Pad(usize, usize);
                impl PairFn for Pad {
                    type Out = Option<ExactPair>;
                    fn call<const A: usize, const B: usize>(
                        self,
                        k: &ExactCurve<A>,
                        z: &ExactCurve<B>,
                    ) -> Option<ExactPair> {
                        match (self.0, self.1) {
                            $(($a, $b) => Some(ExactPair::$v(k.padded()?, z.padded()?)),)*
                            _ => None,
                        }
                    }
                }
                self.visit(Pad(a, b))
            }

            /// Appends the numbers of both curves to `out` ([`ExactCurve::write`]).
            fn write(&self, out: &mut Vec<f64>) {
                match self {
                    $(ExactPair::$v(k, z) => {
                        k.write(out);
                        z.write(out);
                    })*
                }
            }

            /// `f` called with the two curves, at their point counts.
            #[inline(always)]
            fn visit<F: PairFn>(&self, f: F) -> F::Out {
                match self {
                    $(ExactPair::$v(k, z) => f.call(k, z),)*
                }
            }
        }

        impl Kernel {
            /// A uniform LNL run of curves `pair`.
            #[inline(always)]
            fn exact_run(
                &self,
                pair: ExactPair,
                run: &Run,
                st: &Positions<'_, impl Sink>,
                lf: &mut [f64],
            ) {
                match pair {
                    // (not `by_velocity`: the curves' look-ups do not vectorise in a chain's
                    // lanes, 3.8x slower on the LNL string)
                    $(ExactPair::$v(ck, cz) => self.each(run, st, lf, |_, xa, pa, xb, pb| {
                        ck.eval(xa - xb) + cz.eval((xa - pa) - (xb - pb))
                    }),)*
                }
            }
        }
    };
}

exact_pairs!(
    (P00, 0, 0),
    (P20, 2, 0),
    (P30, 3, 0),
    (P40, 4, 0),
    (P02, 0, 2),
    (P03, 0, 3),
    (P04, 0, 4),
    (P22, 2, 2),
    (P23, 2, 3),
    (P24, 2, 4),
    (P32, 3, 2),
    (P33, 3, 3),
    (P34, 3, 4),
    (P42, 4, 2),
    (P43, 4, 3),
    (P44, 4, 4),
    (P80, 8, 0),
    (P82, 8, 2),
    (P83, 8, 3),
    (P84, 8, 4),
    (P88, 8, 8),
    (P08, 0, 8),
    (P28, 2, 8),
    (P38, 3, 8),
    (P48, 4, 8),
    (P16_0, 16, 0),
    (P16_2, 16, 2),
    (P16_3, 16, 3),
    (P16_4, 16, 4),
    (P16_16, 16, 16),
    (P0_16, 0, 16),
    (P2_16, 2, 16),
    (P3_16, 3, 16),
    (P4_16, 4, 16),
);

impl Lnl {
    fn new(k: &Curve, z: &Curve) -> Lnl {
        if let Some(pair) = ExactPair::new(k, z) {
            Lnl::Exact(pair)
        } else {
            Lnl::Any(Box::new(AnyPair::new(k, z)))
        }
    }

    #[inline(always)]
    fn force(&self, d: f64, v: f64) -> f64 {
        match self {
            Lnl::Exact(pair) => pair.force(d, v),
            Lnl::Any(c) => c.force(d, v),
        }
    }
}

/// How a MAS turns its force into an acceleration.
#[derive(Clone, Debug)]
enum MasLaw {
    /// Every MAS has the inertia `1/inv`, a power of two: multiply by `inv` (the same bits as
    /// dividing, see [`is_power_of_two`]).
    UniformInv(f64),
    /// Every MAS has inertia `m`: divide by it.
    UniformDiv(f64),
    /// Per-MAS reciprocals, all of powers of two.
    Inv(Vec<f64>),
    /// Per-MAS inertias.
    Div(Vec<f64>),
}

#[derive(Clone, Copy, Debug)]
enum Channel {
    Position(u32),
    Force(u32),
    /// terms `start..end` of `Kernel::sum_terms`
    Sum(usize, usize),
}

#[derive(Clone, Copy, Debug)]
enum Term {
    Position(u32),
    Force(u32),
}

/// The share of one thread: runs of links, a range of ENF inputs and a range of materials.
#[derive(Clone, Debug, Default)]
struct Part {
    /// Runs of links (pieces of `Kernel::whole.runs`); the parts' runs cover every link once.
    runs: Vec<Run>,
    enf: Range<usize>,
    /// Storage slots whose next position this part computes, within `0..n_mce` (MAS, CEL, ENX).
    mats: Range<usize>,
    /// `runs` cut into consecutive chunks of about equal cost (ranges of `runs`), and `mats` into
    /// consecutive ranges: the units the threads claim (see `Job`).
    link_chunks: Vec<Range<usize>>,
    mat_chunks: Vec<Range<usize>>,
}

/// A tile of the single-thread step: the links of `Kernel::tile_runs[runs]`, then the materials
/// `mats` (storage slots), whose every link is computed by then.
#[derive(Clone, Debug)]
struct Tile {
    runs: Range<usize>,
    mats: Range<usize>,
    /// the first of `Kernel::mas_segments` that reaches `mats` (see [`Kernel::first_segment`])
    seg: usize,
}

/// Materials per tile: their positions and their links' forces (about 320 kB) fit in the L2
/// cache. With a membrane's rows one loop (see [`bridged`]), longer loops pay more than the L1
/// cache: tiles of 1,024 materials (which fit in L1) ran the 100x100 membrane at 0.76-0.88x10^9
/// mass-steps/s, of 4,096 to 16,384 at 0.88-0.98x10^9, and the 316x316 one at 0.74-0.75x10^9,
/// then 0.83-0.90x10^9 (docs/BENCHMARKS-LOG.md, fifth session).
const TILE: usize = 8192;

/// Materials within this many storage slots of each other are neighbours in memory: a link
/// between them is local (see `Kernel::scattered`), and a ground link joins the progression of a
/// material that near (see [`placed_in_bands`]).
const NEAR: usize = 1024;

/// Most moving materials for the compact step: random networks of 1,000 and 10,000 masses ran
/// 1.4x and 1.05x faster with it than with the gather, one of 100,000 masses 4 % slower (its
/// scattered accumulators no longer fit in the caches).
const COMPACT_MAX: usize = 16_384;

/// Most moving materials for which the compact step is taken whatever the network: below this,
/// the vector loops of a string's progressions save less than their set-up costs (60 s of a
/// 24-mass string ring 0.17-0.20 s instead of 0.22-0.24 s, of a 30-mass string with a bouncing
/// ball 0.23-0.24 s instead of 0.28-0.30 s; a 40-mass string is faster with them: 0.16-0.18 s
/// instead of 0.25-0.28 s).
const TINY: usize = 2 * STEP_MIN;

/// The cost of a chunk of work that is worth a claim (about 2,000 links or 700 masses: a few
/// microseconds), and the most chunks a part is cut into.
const CHUNK_COST: u64 = 4096;
const CHUNKS_MAX: u64 = 16;

/// Everything `Engine::new` compiles: read-only while stepping (so threads share it freely).
#[derive(Clone, Debug)]
struct Kernel {
    // materials, storage order: MAS `0..n_mas`, CEL `..n_mc`, ENX `..n_mce`, SOL `..nm`
    nm: usize,
    n_mas: usize,
    n_mc: usize,
    n_mce: usize,
    x_init: Vec<f64>,
    xp_init: Vec<f64>,
    mas: MasLaw,
    cel: Vec<Cel>,
    enx: Vec<Signal>,
    /// storage slot of each material, by declaration index
    slot: Vec<u32>,
    // links, in declaration order; every `la`/`lb` is < `nm` (checked in `new`)
    nl: usize,
    la: Vec<u32>,
    lb: Vec<u32>,
    lk: Vec<f64>,
    lz: Vec<f64>,
    /// BUT thresholds (empty when the network has no BUT)
    ls: Vec<f64>,
    /// The distinct LNL laws (elastic and viscous curves), and which one each link has (0 for
    /// the links of other laws)
    lnl: Vec<Lnl>,
    lnl_of: Vec<u32>,
    /// ENF inputs on mobile materials (MAS, CEL), declaration order; input `i` writes slot
    /// `nl + i` of `sf`. (Forces on SOL and ENX are discarded, so their inputs are not stepped.)
    enf: Vec<Signal>,
    /// Edges of mobile material `s` (storage slot `< n_mc`): `eidx[eoff[s]..eoff[s + 1]]`, slots
    /// of `sf` in the order their terms are summed: `l` where the material is end 2 of link
    /// (slot) `l`, `l | NEG` where it is end 1 ([`NEG`]: negate `sf[l]`), `nl + i` for ENF input
    /// `i`. Every entry is `< sf_len` without `NEG` (checked in `new`).
    eoff: Vec<u32>,
    eidx: Vec<u32>,
    /// The MAS cut into segments of one degree (storage order groups them by degree).
    mas_segments: Vec<Segment>,
    /// `(base, step)` of the edge progressions of the segments
    streams: Vec<(u32, u32)>,
    sf_len: usize,
    // outputs
    channels: Vec<Channel>,
    sum_terms: Vec<(f64, Term)>,
    /// storage slot of each link, by declaration index (see [`link_order`])
    lslot: Vec<u32>,
    /// the vector instructions the stepping loops are compiled for (detected once, in `new`)
    simd: Simd,
    /// one part with everything: the single-thread step
    whole: Part,
    /// one part per thread (see `Engine::set_threads`)
    parts: Vec<Part>,
    /// the single-thread step, tile by tile (see `Kernel::tiling`)
    tiles: Vec<Tile>,
    tile_runs: Vec<Run>,
    /// the link slots of the `Ends::Listed` runs of `tile_runs`
    listed: Vec<u32>,
    /// fewer than half of the links have both ends moving and more than [`NEAR`] apart in
    /// storage: no locality (see `Engine::is_parallel`)
    scattered: bool,
    /// step with [`State::step_compact`] (see [`Kernel::new`])
    compact: bool,
    /// the storage slot of the material of each ENF input of `enf`
    enf_slot: Vec<u32>,
    /// The exceptions of the progressions (see [`bridged`]), ascending: the links (slots) of
    /// `Ends::Step` runs whose ends are not the run's terms, and the MAS (slots) of segments with
    /// streams whose edges are not the streams' terms. Each loop computes them with the terms,
    /// then recomputes them from `la`, `lb` or `eidx` (see [`Kernel::fixes`]).
    link_fix: Vec<u32>,
    mas_fix: Vec<u32>,
    /// the pull step, when the network takes it (see [`Kernel::new`] and `engine/pull.rs`)
    pull: Option<Box<pull::Pull>>,
    /// the pull step's share of each thread, cut into the chunks the threads claim (see
    /// `Engine::set_threads` and `Pull::partition`)
    pull_shares: Vec<Vec<pull::Share>>,
    /// the grid step, when the network is a membrane it takes (see `engine/grid.rs`)
    grid: Option<Box<grid::Grid>>,
    /// the rows of the grid step of each thread (see `Engine::set_threads`)
    grid_shares: Vec<Vec<Range<usize>>>,
}

/// The state that stepping changes.
#[derive(Clone, Debug)]
struct State {
    n: u64,
    /// `n % 3`, kept in step with `n` (see [`State::set_step`])
    c: usize,
    /// `pos[n % 3]` is `x(n)`, `pos[(n + 2) % 3]` is `x(n-1)`, `pos[(n + 1) % 3]` is `x(n-2)`
    /// (storage order; SOL positions in all three).
    pos: [Lines; 3],
    /// `f(n)` of the links `[0, nl)` (by storage slot), ENF samples `[nl, ..)`.
    sf: Vec<f64>,
    /// Whether the last block took the pull or grid step, which store `f(n-1)` only of the links
    /// the outputs read: [`Engine::link_force`] then computes it from the positions.
    forces_behind: bool,
    /// `x(n)` and `x(n-1)` of the moving materials (`0..n_mce`) at the start of the block.
    snap: [Vec<f64>; 2],
    blown: Option<BlowUp>,
    /// `F(n)` of each material while a compact step accumulates it (empty otherwise)
    acc: Vec<f64>,
    /// the row buffers of the grid step, `Grid::scratch_len` per thread (empty without one)
    grid: Lines,
    /// `(x, x - x')` of each material, for the pull step: one buffer for step `n`, one for `n + 1`
    /// (empty without a pull step)
    pairs: [Vec<[f64; 2]>; 2],
}

/// The state right after step `n`, as an observer sees it (see [`Engine::process_observed`]).
#[derive(Clone, Copy, Debug)]
pub struct StepView<'a> {
    n: u64,
    k: &'a Kernel,
    /// `x(n+1)`, `x(n)`
    x: &'a [f64],
    xp: &'a [f64],
    lf: &'a [f64],
}

impl StepView<'_> {
    /// The step just computed.
    pub fn step(&self) -> u64 {
        self.n
    }

    /// `x(n)`: the position the interactions of step `n` saw.
    pub fn position(&self, m: MatId) -> f64 {
        self.xp[self.k.slot[m.index()] as usize]
    }

    /// `x(n+1)`: the position step `n` computed.
    pub fn next_position(&self, m: MatId) -> f64 {
        self.x[self.k.slot[m.index()] as usize]
    }

    /// `f(n)` of an interaction.
    pub fn link_force(&self, l: LinkId) -> f64 {
        self.lf[self.k.lslot[l.index()] as usize]
    }
}

/// Where and when a simulation blew up.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct BlowUp {
    /// The first sample index `n` at which some position `x(n)` is not finite.
    pub step: u64,
    /// The first material module, in declaration order, whose `x(n)` is not finite at that step.
    pub material: MatId,
    /// How many frames of the block that failed hold valid output (they record `x` up to `step-1`).
    pub valid_frames: usize,
}

impl std::fmt::Display for BlowUp {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "the position of material #{} became non-finite at sample {}",
            self.material.0, self.step
        )
    }
}

impl std::error::Error for BlowUp {}

/// The worker threads of an engine and the counters by which they claim chunks of work: not
/// cloned with it (a clone starts its own when it needs them).
#[derive(Debug, Default)]
struct PoolSlot(Option<Threads>);

#[derive(Debug)]
struct Threads {
    pool: Pool,
    /// per part: the chunks of links claimed so far in this block (`[0, threads)`), then the
    /// chunks of materials (`[threads, 2 threads)`); the grid step's chunks of rows, or the pull
    /// step's chunks of groups, per share, in the first `threads`
    claims: Box<[Claim]>,
}

/// A claim counter alone on its cache lines (two, for the adjacent-line prefetcher).
#[derive(Debug, Default)]
#[repr(align(128))]
struct Claim(AtomicUsize);

impl Claim {
    /// Every counter back to 0, before a block (the workers are idle: `Pool::run` publishes the
    /// stores to them with the job).
    fn reset(claims: &[Claim]) {
        for c in claims {
            c.0.store(0, Ordering::Relaxed);
        }
    }

    /// The next chunk `i < limit` of this counter, each to exactly one caller (a unique
    /// compare-and-swap from `i` to `i + 1`); `None` once they are all taken. The counter never
    /// goes beyond `limit`, so the next step's chunks are `limit..limit + chunks`.
    #[inline]
    fn next(&self, limit: usize) -> Option<usize> {
        let mut i = self.0.load(Ordering::Relaxed);
        while i < limit {
            match self
                .0
                .compare_exchange_weak(i, i + 1, Ordering::Relaxed, Ordering::Relaxed)
            {
                Ok(_) => return Some(i),
                Err(now) => i = now,
            }
        }
        None
    }

    /// The chunks thread `t` claims in step `s` (counting the block's steps), one at a time, as
    /// `(q, j)`: chunk `j` of share `q`. Its own share's first, then what is left of the others'
    /// (so a thread whose core runs slower is helped rather than waited for); `claims[q]` counts
    /// share `q`'s chunks, `chunks(q)` per step, and every chunk of a step is claimed before its
    /// barrier, so the next step's are the next `chunks(q)` values of the counter.
    ///
    /// An iterator, not a function that calls a closure per chunk: the loop's body stays in the
    /// caller and is compiled with its target features. A closure is not (rust-lang/rust#58279):
    /// the gather step's loops inlined into one ran without vector instructions, at half the
    /// speed (docs/BENCHMARKS-LOG.md, sixteenth session).
    #[inline(always)]
    fn claimed<F: Fn(usize) -> usize>(
        claims: &[Claim],
        t: usize,
        s: usize,
        chunks: F,
    ) -> Claimed<'_, F> {
        assert!(t < claims.len());
        Claimed {
            claims,
            t,
            s,
            chunks,
            k: 0,
        }
    }
}

/// The chunks a thread claims in a step: see [`Claim::claimed`].
struct Claimed<'c, F> {
    claims: &'c [Claim],
    t: usize,
    s: usize,
    chunks: F,
    /// the share whose chunks are being claimed is `(t + k) % claims.len()`
    k: usize,
}

impl<F: Fn(usize) -> usize> Iterator for Claimed<'_, F> {
    type Item = (usize, usize);

    #[inline(always)]
    fn next(&mut self) -> Option<(usize, usize)> {
        let shares = self.claims.len();
        while self.k < shares {
            let q = (self.t + self.k) % shares;
            let len = (self.chunks)(q);
            let base = self.s * len;
            if let Some(i) = self.claims[q].next(base + len) {
                return Some((q, i - base));
            }
            self.k += 1;
        }
        None
    }
}

impl Clone for PoolSlot {
    fn clone(&self) -> PoolSlot {
        PoolSlot(None)
    }
}

/// A compiled network, ready to step.
///
/// Lifecycle (as in fundsp and nih-plug): [`Engine::new`] allocates everything; [`Engine::reset`]
/// returns to the initial conditions; [`Engine::process`] steps a block of frames into a caller
/// buffer and never allocates. Output is bit-for-bit deterministic and independent of how the
/// run is cut into blocks, and of the number of threads (see [`Engine::set_threads`]).
///
/// Storage: material modules are reordered by kind (MAS, CEL, ENX, SOL) so that each kind's update
/// is one tight loop. Links are stored in an order chosen for speed (`link_order` in `engine.rs`) and cut into
/// runs of one law (and, for long enough stretches, the same parameters). Each link's force is computed
/// once per step into its own slot; each material then sums the forces of its links in their
/// declaration order, then its ENF inputs in theirs: the floating-point sums are exactly those of
/// the plain, one-module-at-a-time definition, and the output equals the reference stepper bit for
/// bit (module documentation of `engine.rs`).
#[derive(Clone, Debug)]
pub struct Engine {
    k: Kernel,
    st: State,
    threads: usize,
    parallel_threshold: usize,
    pool: PoolSlot,
}

impl Engine {
    /// Networks whose materials plus links number fewer than this step on one thread, whatever
    /// [`Engine::set_threads`] says (see [`Engine::set_parallel_threshold`]). Below it a step
    /// takes a few microseconds on one core, and the two barriers a step costs with threads would
    /// eat most of the gain. Networks without locality need [`Engine::SCATTERED_FACTOR`] times more.
    pub const DEFAULT_PARALLEL_THRESHOLD: usize = 20_000;

    /// How many times the threshold (see [`Engine::set_parallel_threshold`]) a network without
    /// locality must be to step on several threads.
    pub const SCATTERED_FACTOR: usize = 5;

    /// Compiles `net`. All allocation happens here.
    ///
    /// # Panics
    /// If a link, input or output refers to a module the network does not have (ids from another
    /// network): a programmer error. The model crate validates user input before building.
    #[track_caller]
    pub fn new(net: &Network) -> Engine {
        Engine::with_kernel(Kernel::new(net))
    }

    /// [`Engine::new`] compiled for `simd` (which the CPU has): the tests' way to the steps
    /// that a CPU with other vector units takes.
    #[cfg(test)]
    fn new_for(net: &Network, simd: Simd) -> Engine {
        Engine::with_kernel(Kernel::new_for(net, simd))
    }

    fn with_kernel(k: Kernel) -> Engine {
        let nm = k.nm;
        let mut st = State {
            n: 0,
            c: 0,
            pos: [Lines::zeros(nm), Lines::zeros(nm), Lines::zeros(nm)],
            sf: vec![0.0; k.sf_len],
            forces_behind: false,
            snap: [vec![0.0; k.n_mce], vec![0.0; k.n_mce]],
            blown: None,
            acc: vec![0.0; if k.compact { k.nm } else { 0 }],
            pairs: [(); 2]
                .map(|()| vec![[0.0; 2]; k.pull.as_ref().map_or(0, |p| p.buffer_len(nm))]),
            grid: Lines::zeros(k.grid.as_ref().map_or(0, |g| g.scratch_len())),
        };
        st.reset(&k);
        Engine {
            k,
            st,
            threads: 1,
            parallel_threshold: Engine::DEFAULT_PARALLEL_THRESHOLD,
            pool: PoolSlot(None),
        }
    }

    /// Steps with `threads` threads (the calling thread and `threads - 1` workers) in
    /// [`Engine::process`], when the network is large enough (see
    /// [`Engine::set_parallel_threshold`]). 0 counts as 1. The default is 1: no thread is started.
    ///
    /// The output is the same, bit for bit, for every number of threads and every block size.
    /// The worker threads are started here (this allocates) and kept, parked, until the engine is
    /// dropped or this is called again; a clone of the engine starts its own on its first
    /// threaded `process`. [`Engine::process_observed`] always steps on the calling thread.
    ///
    /// Use as many threads as there are free cores, not more: the threads wait for each other
    /// twice per step, by spinning first.
    pub fn set_threads(&mut self, threads: usize) {
        let threads = threads.max(1);
        if threads != self.threads || self.k.parts.len() != threads {
            self.threads = threads;
            self.k.parts = self.k.partition(threads, self.st.line());
            self.k.pull_shares = self.k.pull_partition(threads);
            self.grid_partition();
            self.pool = PoolSlot(None);
        }
        self.start_pool();
    }

    /// The number of threads set by [`Engine::set_threads`].
    pub fn threads(&self) -> usize {
        self.threads
    }

    /// Threads are used only for networks with at least `size` materials plus links (default
    /// [`Engine::DEFAULT_PARALLEL_THRESHOLD`]; 0 uses them for any network, as the tests do), or
    /// [`Engine::SCATTERED_FACTOR`] times `size` for a network without locality (where most
    /// links tie two moving materials more than a tile, 1,024 materials, apart in storage, as in
    /// a random network): each core
    /// then reads positions the other wrote anywhere in the state, and the exchange costs more
    /// than the second core brings until the network is large (on two cores, a random network of
    /// 10,000 masses, 30,000 modules, stepped 0.76x as fast on two threads as on one; one of
    /// 100,000 masses 1.1x).
    pub fn set_parallel_threshold(&mut self, size: usize) {
        self.parallel_threshold = size;
        self.start_pool();
    }

    /// True when [`Engine::process`] steps on more than one thread.
    pub fn is_parallel(&self) -> bool {
        let factor = if self.k.scattered {
            Engine::SCATTERED_FACTOR
        } else {
            1
        };
        self.threads > 1 && self.k.nm + self.k.nl >= self.parallel_threshold.saturating_mul(factor)
    }

    /// The grid step's rows and row buffers for [`Engine::threads`] threads.
    fn grid_partition(&mut self) {
        if let Some(g) = self.k.grid.as_deref() {
            self.k.grid_shares = g.partition(self.threads);
            let len = self.threads * g.scratch_len();
            if self.st.grid.len() != len {
                self.st.grid = Lines::zeros(len);
            }
        }
    }

    fn start_pool(&mut self) {
        if !self.is_parallel() {
            self.pool = PoolSlot(None);
        } else if self.pool.0.as_ref().map(|t| t.pool.threads()) != Some(self.threads) {
            // (a clone has its own buffers, aligned differently: cut the parts for them)
            self.k.parts = self.k.partition(self.threads, self.st.line());
            self.k.pull_shares = self.k.pull_partition(self.threads);
            self.grid_partition();
            self.pool = PoolSlot(Some(Threads {
                pool: Pool::new(self.threads),
                claims: (0..2 * self.threads).map(|_| Claim::default()).collect(),
            }));
        }
    }

    /// Back to the initial conditions, step 0.
    pub fn reset(&mut self) {
        self.st.reset(&self.k);
    }

    /// Number of output channels (SOX and SOF, in declaration order).
    pub fn channels(&self) -> usize {
        self.k.channels.len()
    }

    /// The index `n` of the next step.
    pub fn step_index(&self) -> u64 {
        self.st.n
    }

    /// Number of material modules.
    pub fn material_count(&self) -> usize {
        self.k.nm
    }

    /// `x(n)` of a material module, `n` being [`Engine::step_index`].
    pub fn position(&self, m: MatId) -> f64 {
        self.st.cur()[self.k.slot[m.index()] as usize]
    }

    /// `x(n-1)` of a material module.
    pub fn previous_position(&self, m: MatId) -> f64 {
        self.st.prev()[self.k.slot[m.index()] as usize]
    }

    /// `f(n-1)`: the force the interaction computed at the last step (0 before the first).
    pub fn link_force(&self, l: LinkId) -> f64 {
        let s = self.k.lslot[l.index()] as usize;
        // (after a block of the pull or grid step, which keep the forces nowhere: computed from
        // `x(n-1)` and `x(n-2)`, as the last step did, rather than for every link after every
        // block)
        match self.st.forces_behind.then(|| self.k.alone(s)).flatten() {
            Some(r) => {
                let roles = Roles::at(self.st.c);
                let (prev, before) = (&self.st.pos[roles.prev], &self.st.pos[roles.next]);
                self.k.link_alone(&r, prev, before)
            }
            None => self.st.sf[s],
        }
    }

    /// Steps `frames` times, writing one frame of [`Engine::channels`] values per step into `out`
    /// (frames interleaved over channels). Never allocates (with threads: once they are started,
    /// see [`Engine::set_threads`]).
    ///
    /// After every block the positions are checked; if one is not finite, the block is replayed
    /// (on the calling thread) from a snapshot to find the first step and module that went bad,
    /// and a [`BlowUp`] is returned. The engine then refuses to step until [`Engine::reset`].
    ///
    /// # Panics
    /// If `out.len() != frames * self.channels()`.
    #[track_caller]
    pub fn process(&mut self, frames: usize, out: &mut [f64]) -> Result<(), BlowUp> {
        if self.k.grid.is_some() && frames > 0 && self.st.blown.is_none() {
            self.process_grid(frames, out)
        } else if self.is_parallel() && frames > 0 && self.st.blown.is_none() {
            if self.k.pull.is_some() {
                self.process_pull_parallel(frames, out)
            } else {
                self.process_parallel(frames, out)
            }
        } else if self.k.pull.is_some() && frames > 0 && self.st.blown.is_none() {
            self.process_pull(frames, out)
        } else {
            self.observing(frames, out, None)
        }
    }

    /// [`Engine::process`], calling `observe` after every step with a view of the state (for
    /// event logs and energy meters). With a no-op observer this gives exactly the output of
    /// `process`. It always steps on the calling thread, whatever [`Engine::set_threads`] says.
    ///
    /// The observer sees each step once, in order. When a block blows up it has also seen the
    /// steps of that block up to its end (non-finite values included): discard what it gathered.
    #[track_caller]
    pub fn process_observed<O: FnMut(&StepView<'_>)>(
        &mut self,
        frames: usize,
        out: &mut [f64],
        observe: &mut O,
    ) -> Result<(), BlowUp> {
        self.observing(frames, out, Some(observe))
    }

    /// The body of [`Engine::process_observed`], and of [`Engine::process`] where it takes
    /// neither the grid, the pull step nor threads (`observe` `None`). Not generic: one compiled
    /// block loop serves `process` and every observer of every crate, rather than one for each
    /// observer's type in each crate that observes, each the whole step at its three widths
    /// (docs/ARCHITECTURE.md, "Build times"). An observer is called through a pointer, once a
    /// step.
    #[track_caller]
    fn observing(
        &mut self,
        frames: usize,
        out: &mut [f64],
        observe: Option<&mut dyn FnMut(&StepView<'_>)>,
    ) -> Result<(), BlowUp> {
        let ch = self.k.channels.len();
        assert_eq!(
            out.len(),
            frames * ch,
            "output buffer must hold frames * channels values"
        );
        if let Some(b) = self.st.blown {
            return Err(BlowUp {
                valid_frames: 0,
                ..b
            });
        }
        self.st.take_snapshot(self.k.n_mce);
        let n0 = self.st.n;
        self.observed_block(frames, out, observe);
        self.check_block(n0, frames, out)
    }

    /// The block loop of [`Engine::observing`], compiled for the CPU's vector instructions. Not
    /// inlined, so that the replay of [`Engine::check_block`] calls the same compiled copy rather
    /// than a copy of its own, for the crate's compile time.
    #[inline(never)]
    fn observed_block(
        &mut self,
        frames: usize,
        out: &mut [f64],
        observe: Option<&mut dyn FnMut(&StepView<'_>)>,
    ) {
        if frames > 0 {
            self.st.forces_behind = false; // (every gather or compact step stores every force)
        }
        let block = Block {
            k: &self.k,
            st: &mut self.st,
            frames,
            out,
            observe,
        };
        vectorised(self.k.simd, block);
    }

    /// [`Engine::process`] on the pool's threads.
    #[track_caller]
    fn process_parallel(&mut self, frames: usize, out: &mut [f64]) -> Result<(), BlowUp> {
        let ch = self.k.channels.len();
        assert_eq!(
            out.len(),
            frames * ch,
            "output buffer must hold frames * channels values"
        );
        self.start_pool(); // only a clone, or an engine after a worker panic, has none yet
        let n0 = self.st.n;
        let result = {
            let Some(Threads { pool, claims }) = self.pool.0.as_ref() else {
                unreachable!("start_pool starts a pool when is_parallel")
            };
            Claim::reset(claims);
            let [p0, p1, p2] = &mut self.st.pos;
            let [s0, s1] = &mut self.st.snap;
            // The job borrows the state buffers mutably until `pool.run` returns, which is after
            // every thread is done with them; nothing else touches them meanwhile.
            let job = Job {
                k: &self.k,
                pos: [SharedBuf::new(p0), SharedBuf::new(p1), SharedBuf::new(p2)],
                sf: SharedBuf::new(&mut self.st.sf),
                snap: [SharedBuf::new(s0), SharedBuf::new(s1)],
                claims,
                n0,
                frames,
                channels: ch,
            };
            pool.run_steps(&job, |barrier| job.run_share(0, Some(out), barrier))
        };
        self.drop_pool_if_failed(result);
        self.st.forces_behind = false; // (every step stored every link's force)
        self.st.set_step(n0 + frames as u64);
        self.check_block(n0, frames, out)
    }

    /// After a threaded block: a worker that panicked leaves the pool unusable, so it is dropped
    /// (the next threaded block starts a new one) and the panic goes on on this thread.
    fn drop_pool_if_failed(&mut self, result: Result<(), Poisoned>) {
        if result.is_err() {
            self.pool = PoolSlot(None);
            panic!("an engine worker thread panicked");
        }
    }

    /// [`Engine::process`] with the pull step.
    #[track_caller]
    fn process_pull(&mut self, frames: usize, out: &mut [f64]) -> Result<(), BlowUp> {
        let Some(pull) = self.k.pull.as_deref() else {
            unreachable!("process takes the pull step only when there is one")
        };
        assert_eq!(
            out.len(),
            frames * self.k.channels.len(),
            "output buffer must hold frames * channels values"
        );
        self.st.take_snapshot(self.k.n_mce);
        let n0 = self.st.n;
        pull.block(&self.k, &mut self.st, frames, out);
        self.check_block(n0, frames, out)?;
        self.st.forces_behind = true;
        Ok(())
    }

    /// [`Engine::process`] with the pull step on the pool's threads.
    #[track_caller]
    fn process_pull_parallel(&mut self, frames: usize, out: &mut [f64]) -> Result<(), BlowUp> {
        assert_eq!(
            out.len(),
            frames * self.k.channels.len(),
            "output buffer must hold frames * channels values"
        );
        self.start_pool(); // only a clone, or an engine after a worker panic, has none yet
        let Some(pull) = self.k.pull.as_deref() else {
            unreachable!("process takes the pull step only when there is one")
        };
        self.st.take_snapshot(self.k.n_mce);
        pull.prepare(&self.k, &mut self.st);
        let (n0, c0) = (self.st.n, self.st.c);
        let result = {
            let Some(Threads { pool, claims }) = self.pool.0.as_ref() else {
                unreachable!("start_pool starts a pool when is_parallel")
            };
            Claim::reset(claims);
            let [p0, p1, p2] = &mut self.st.pos;
            let [q0, q1] = &mut self.st.pairs;
            // The job borrows the state buffers mutably until `pool.run` returns, which is after
            // every thread is done with them; nothing else touches them meanwhile.
            let job = pull::PullJob {
                k: &self.k,
                pull,
                shares: &self.k.pull_shares,
                claims,
                pos: [SharedBuf::new(p0), SharedBuf::new(p1), SharedBuf::new(p2)],
                pairs: [
                    SharedBuf::new(q0.as_flattened_mut()),
                    SharedBuf::new(q1.as_flattened_mut()),
                ],
                sf: SharedBuf::new(&mut self.st.sf),
                n0,
                c0,
                frames,
            };
            assert_eq!(job.shares.len(), pool.threads());
            pool.run_steps(&job, |barrier| job.run_share(0, Some(out), barrier))
        };
        self.drop_pool_if_failed(result);
        self.st.set_step(n0 + frames as u64);
        self.check_block(n0, frames, out)?;
        self.st.forces_behind = true;
        Ok(())
    }

    /// [`Engine::process`] with the grid step, on the pool's threads when [`Engine::is_parallel`].
    #[track_caller]
    fn process_grid(&mut self, frames: usize, out: &mut [f64]) -> Result<(), BlowUp> {
        assert_eq!(
            out.len(),
            frames * self.k.channels.len(),
            "output buffer must hold frames * channels values"
        );
        self.st.take_snapshot(self.k.n_mce);
        let (n0, c0) = (self.st.n, self.st.c);
        let parallel = self.is_parallel();
        if parallel {
            self.start_pool(); // only a clone, or an engine after a worker panic, has none yet
        }
        let Some(grid) = self.k.grid.as_deref() else {
            unreachable!("process takes the grid step only when there is one")
        };
        if parallel {
            let result = {
                let Some(Threads { pool, claims }) = self.pool.0.as_ref() else {
                    unreachable!("start_pool starts a pool when is_parallel")
                };
                Claim::reset(claims);
                let [p0, p1, p2] = &mut self.st.pos;
                // The job borrows the state buffers mutably until `pool.run` returns, which is
                // after every thread is done with them; nothing else touches them meanwhile.
                let job = grid::GridJob {
                    k: &self.k,
                    grid,
                    shares: &self.k.grid_shares,
                    claims,
                    pos: [SharedBuf::new(p0), SharedBuf::new(p1), SharedBuf::new(p2)],
                    sf: SharedBuf::new(&mut self.st.sf),
                    scratch: SharedBuf::new(&mut self.st.grid),
                    n0,
                    c0,
                    frames,
                };
                assert_eq!(job.shares.len(), pool.threads());
                pool.run_steps(&job, |barrier| job.run_share(0, Some(out), barrier))
            };
            self.drop_pool_if_failed(result);
            self.st.set_step(n0 + frames as u64);
        } else {
            grid.block(&self.k, &mut self.st, frames, out);
        }
        self.check_block(n0, frames, out)?;
        self.st.forces_behind = true;
        Ok(())
    }

    /// After a block from step `n0`: if a position is not finite, replays the block from the
    /// snapshot one step at a time to find the first bad step and module.
    fn check_block(&mut self, n0: u64, frames: usize, out: &mut [f64]) -> Result<(), BlowUp> {
        if all_finite(self.st.cur()) {
            return Ok(());
        }
        let ch = self.k.channels.len();
        self.st.restore_snapshot(n0, self.k.n_mce);
        for frame in 0..frames {
            // (`process`'s block loop, a block of one step: no compiled copy of the step of its
            // own, which took 7 % of the crate's optimisation time)
            self.observed_block(1, &mut out[frame * ch..(frame + 1) * ch], None);
            if let Some(bad) = self.first_non_finite() {
                out[(frame + 1) * ch..].fill(0.0);
                let b = BlowUp {
                    step: self.st.n,
                    material: bad,
                    valid_frames: frame + 1,
                };
                self.st.blown = Some(b);
                return Err(b);
            }
        }
        unreachable!("a replay from the same state must reproduce the same non-finite position")
    }

    fn first_non_finite(&self) -> Option<MatId> {
        let x = self.st.cur();
        self.k
            .slot
            .iter()
            .position(|&s| !x[s as usize].is_finite())
            .map(|i| MatId(i as u32))
    }
}

impl State {
    /// Step index `n`, and which buffer holds `x(n)`.
    fn set_step(&mut self, n: u64) {
        self.n = n;
        self.c = (n % 3) as usize;
    }

    /// Where `sf` starts within a 64-byte cache line, in slots.
    fn line(&self) -> usize {
        self.sf.as_ptr() as usize / std::mem::size_of::<f64>() % 8
    }

    fn cur(&self) -> &[f64] {
        &self.pos[Roles::at(self.c).cur]
    }

    fn prev(&self) -> &[f64] {
        &self.pos[Roles::at(self.c).prev]
    }

    fn reset(&mut self, k: &Kernel) {
        self.set_step(0);
        self.pos[0].copy_from_slice(&k.x_init);
        self.pos[1].copy_from_slice(&k.x_init); // (x(n+1) is written over the mobile ones)
        self.pos[2].copy_from_slice(&k.xp_init);
        self.sf.fill(0.0);
        self.forces_behind = false;
        self.blown = None;
    }

    /// Saves `x(n)`, `x(n-1)` of the moving materials (SOL positions never change).
    fn take_snapshot(&mut self, n_mce: usize) {
        let r = Roles::at(self.c);
        self.snap[0].copy_from_slice(&self.pos[r.cur][..n_mce]);
        self.snap[1].copy_from_slice(&self.pos[r.prev][..n_mce]);
    }

    /// Back to the snapshot taken at step `n0`.
    fn restore_snapshot(&mut self, n0: u64, n_mce: usize) {
        self.set_step(n0);
        let r = Roles::at(self.c);
        self.pos[r.cur][..n_mce].copy_from_slice(&self.snap[0]);
        self.pos[r.prev][..n_mce].copy_from_slice(&self.snap[1]);
    }

    /// One step on the calling thread: link forces, outputs, material update.
    #[inline(always)]
    fn step(&mut self, k: &Kernel, frame: &mut [f64]) {
        if k.compact {
            return self.step_compact(k, frame);
        }
        let n = self.n;
        let nl = k.nl;
        let roles = Roles::at(self.c);
        debug_assert_eq!(self.c as u64, n % 3);
        let (cur, prev, next) = roles.split(&mut self.pos);
        k.inputs(0..k.enf.len(), n, &mut self.sf[nl..]);
        let state = Positions::new(k, cur, prev);
        for tile in &k.tiles {
            for run in &k.tile_runs[tile.runs.clone()] {
                k.run_links(run, &state, &mut self.sf[run.start..run.end]);
            }
            let mats = tile.mats.clone();
            let sf = Forces(&self.sf);
            let next = &mut next[mats.clone()];
            k.materials_phase(mats, tile.seg, n, (cur, prev), next, sf);
        }
        k.record(cur, &self.sf[..nl], frame);
        self.n = n + 1;
        self.c = roles.next;
    }
}

impl State {
    /// One step of a compact kernel: each run's link forces, each added to its ends'
    /// accumulators as it is computed (end 1 `F -= f`, end 2 `F += f`: with the links stored in
    /// each material's declaration order, every `F(n)` is summed in FORMALISM.md's order from
    /// `+0.0`, the same bits as the gather), then the ENF inputs, the outputs, and the materials
    /// in contiguous loops.
    #[inline(always)]
    fn step_compact(&mut self, k: &Kernel, frame: &mut [f64]) {
        let n = self.n;
        let roles = Roles::at(self.c);
        let (cur, prev, next) = roles.split(&mut self.pos);
        {
            let state = Positions::with_sink(k, cur, prev, Accumulate::new(k, &mut self.acc));
            for run in &k.whole.runs {
                k.run_links(run, &state, &mut self.sf[run.start..run.end]);
            }
        }
        let acc = &mut self.acc[..];
        for (sig, &s) in k.enf.iter().zip(&k.enf_slot) {
            acc[s as usize] += sig.at(n);
        }
        k.record(cur, &self.sf[..k.nl], frame);
        let (nm, nc) = (k.n_mas, k.n_mc);
        let sf = Forces(&self.sf);
        let forces = acc[..nm].iter();
        k.mas_with(
            0..nm,
            (&cur[..nm], &prev[..nm], &mut next[..nm], sf),
            forces,
            |&f, _| f,
        );
        let cel = (next[nm..nc].iter_mut()).zip(cur[nm..nc].iter().zip(&prev[nm..nc]));
        for ((p, (&x, &xp)), (&f, c)) in cel.zip(acc[nm..nc].iter().zip(&k.cel)) {
            *p = c.next(x, xp, f);
        }
        for (p, sig) in next[k.n_mc..k.n_mce].iter_mut().zip(&k.enx) {
            *p = sig.at(n + 1);
        }
        acc.fill(0.0);
        self.n = n + 1;
        self.c = roles.next;
    }
}

/// Fewest MAS for the pull step in a network with an LNL curve that jumps at its first point, as
/// the sticking spring of FORMALISM.md does ([`jumps_first`]; such a curve evaluates eight at a
/// time, `curve.rs`'s `first_segment`). The smallest such networks measured went either way: the
/// reconfigurable instrument (60 MAS, three CEL, nine sticking springs among 129 links) rendered
/// 1.4x slower with the pull step than with the step it takes otherwise (the compact or gather
/// step; its nine springs alone made the pull step 0.2 s slower in 24 s of sound, the other step
/// no slower), a random network of 64 MAS of sticking springs 1.7x faster; from 256 MAS on,
/// random networks of them ran 2.2x to 3x faster (docs/BENCHMARKS-LOG.md, forty-seventh and
/// forty-eighth sessions, on Emerald Rapids). On Zen 5, since the pull step builds its curves'
/// vectors with AVX-512 (forty-ninth session), the instrument renders 5 % faster with it and random
/// networks of 16 to 255 MAS 1.4x to 2.6x; on Zen 4, since a CEL's terms are summed in runs of one
/// kind (fiftieth), the instrument 1.15x faster; kept until measured again where it was set. On
/// Zen 3 with AVX2 alone, the instrument 1.10x slower with the AVX2 pull step, which stores its
/// springs' forces, than with the compact step (fifty-ninth).
const JUMPS_PULL_MIN: usize = 256;

/// Whether an LNL curve of `net` jumps at its first point ([`JUMPS_PULL_MIN`]).
fn jumps_first(net: &Network) -> bool {
    let jumps = |c: &Curve| {
        let mut p = c.points();
        matches!((p.next(), p.next()), (Some(a), Some(b)) if a.0 == b.0)
    };
    (net.links.iter())
        .any(|l| matches!(&l.law, Interaction::Lnl { lk, lz } if jumps(lk) || jumps(lz)))
}

impl Kernel {
    /// Compiles `net`, choosing how to step it: a network of at most [`COMPACT_MAX`] moving
    /// materials whose links and MAS are mostly read through index lists (small instruments,
    /// irregular networks), or of at most [`TINY`], gets the compact step
    /// ([`State::step_compact`]), with its links stored in each material's declaration order and
    /// no exceptions; the others the gather step, with the links in the storage order of
    /// [`link_order`] and progressions joined across exceptions ([`bridged`]). Both give the
    /// reference's bits.
    /// A network without locality (one that takes the compact step, whose links are scattered,
    /// or whose links and MAS are mostly read through index lists) also gets the pull step
    /// (`engine/pull.rs`) when the CPU has AVX-512 or AVX2 and its links are RES, FRO, REF, BUT
    /// and LNL whose curves the pull step takes (`pull::Pull::new` says which): [`Engine::process`]
    /// then takes it, on one thread or on the pool's (`pull::PullJob`).
    /// Membranes, each of one
    /// REF law, their borders fixed or free, and strings, alone or with at most half as much
    /// around them, get the grid step instead when the CPU has AVX-512 or AVX2 (`engine/grid.rs`,
    /// `grid::GridJob`), which keeps every force in registers; their network is stored with its
    /// MAS in declaration order ([`Mobiles::Declared`]).
    #[track_caller]
    fn new(net: &Network) -> Kernel {
        Kernel::new_for(net, Simd::detect())
    }

    /// [`Kernel::new`] compiled for `simd` (which the CPU has).
    #[track_caller]
    fn new_for(net: &Network, simd: Simd) -> Kernel {
        if grid::may_hold(net) {
            // (stored with its MAS in declaration order, so that a membrane's border and struck
            // MAS stay in their rows)
            let mut k = Kernel::build_with(net, false, Joins::Rows, Mobiles::Declared);
            k.simd = simd;
            if let Some(g) = grid::Grid::new(&k) {
                k.grid = Some(Box::new(g));
                return k;
            }
        }
        let mut k = Kernel::choose(net);
        k.simd = simd;
        if (k.compact || k.scattered || k.mostly_indexed())
            && (k.n_mas >= JUMPS_PULL_MIN || !jumps_first(net))
            && pull::Pull::new(&k).is_some()
        {
            // stored again with each MAS near its neighbours ([`Mobiles::Local`]), for the
            // pull step's reads of their pairs; the other steps (observers, replays) take any
            // storage order. Whether the network is scattered (for the threads' threshold) is
            // what the order by degree says.
            let (scattered, compact) = (k.scattered, k.compact);
            drop(k);
            // (links in declaration order: their bands matter to the other steps only, and
            // placing them would take longer than the rest of the build)
            let mut local = Kernel::build_with(net, true, Joins::Off, Mobiles::Local);
            if compact {
                // (as `choose` made it, for observers and replays; the gather step otherwise)
                local.make_compact(net, Mobiles::Local);
            }
            local.simd = simd;
            local.scattered = scattered;
            local.pull = pull::Pull::new(&local).map(Box::new);
            return local;
        }
        k
    }

    /// The shares of the pull step for `threads` threads (none without a pull step).
    fn pull_partition(&self, threads: usize) -> Vec<Vec<pull::Share>> {
        (self.pull.as_ref()).map_or_else(Vec::new, |p| p.partition(self, threads))
    }

    /// [`Kernel::new`] without the pull step.
    #[track_caller]
    fn choose(net: &Network) -> Kernel {
        let k = Kernel::build(net, false, true);
        if k.n_mce > COMPACT_MAX || !(k.mostly_indexed() || k.n_mce <= TINY) {
            if !k.varied_progressions() {
                return k;
            }
            // (strings of their own stiffnesses: stored again with the links of one law and
            // distance one band, their progressions joined, see `joined`, when that makes fewer
            // runs)
            let runs = k.whole.runs.len();
            drop(k);
            let joined = Kernel::build_with(net, false, Joins::Runs, Mobiles::ByDegree);
            if joined.whole.runs.len() < runs {
                return joined;
            }
            drop(joined);
            return Kernel::build(net, false, true);
        }
        // (the compact step accumulates each force as it is computed: it has no exceptions to
        // recompute)
        if k.link_fix.is_empty() && k.mas_fix.is_empty() {
            let mut k = k;
            k.make_compact(net, Mobiles::ByDegree);
            k
        } else {
            let mut plain = Kernel::build(net, false, false);
            if plain.make_compact(net, Mobiles::ByDegree) {
                plain
            } else {
                k
            }
        }
    }

    /// Whether two progressions of one law (runs with `Ends::Step`) have different parameters, or
    /// one has per-link parameters: strings of their own stiffnesses, which [`Joins::Runs`] may
    /// store as one loop.
    fn varied_progressions(&self) -> bool {
        let mut seen: Vec<(Law, [u64; 3], u32)> = Vec::new();
        for r in (self.whole.runs.iter()).filter(|r| matches!(r.ends, Ends::Step { .. })) {
            let bits = |v: &[f64]| v.get(r.start).map_or(0, |x| x.to_bits());
            let lnl = self.lnl_of.get(r.start).copied().unwrap_or(0);
            let key = (r.law, [bits(&self.lk), bits(&self.lz), bits(&self.ls)], lnl);
            // (at most one key per law is kept: the second of a law returns)
            if !r.uniform || seen.iter().any(|s| s.0 == key.0 && *s != key) {
                return true;
            }
            if !seen.contains(&key) {
                seen.push(key);
            }
        }
        false
    }

    /// Gives this kernel (built without exceptions) the compact step, stored as it is or rebuilt
    /// with its links in declaration order (its materials as `mobiles` says), if either fits
    /// it; returns whether it did.
    fn make_compact(&mut self, net: &Network, mobiles: Mobiles) -> bool {
        assert!(self.link_fix.is_empty() && self.mas_fix.is_empty());
        if !self.in_declaration_order() {
            // (stored in declaration order, a network whose laws alternate falls into many
            // short runs, whose set-up the compact step does not win back)
            let ordered = Kernel::build_with(net, true, Joins::Off, mobiles);
            if ordered.whole.runs.len() > self.whole.runs.len() {
                return false;
            }
            *self = ordered;
        }
        self.compact = true;
        true
    }

    /// Whether at least half of the links are in runs without progressions and at least half of
    /// the MAS in segments without streams: then the vector loops have little to do, and the
    /// compact step, which accumulates each force onto its ends as it is computed and updates
    /// the materials in one contiguous loop, saves the gather's per-segment work and its index
    /// lists (docs/BENCHMARKS-LOG.md, "The compact step").
    fn mostly_indexed(&self) -> bool {
        let links = (self.whole.runs.iter())
            .filter(|r| r.ends == Ends::Indexed)
            .map(|r| r.end - r.start)
            .sum::<usize>();
        let mas = (self.mas_segments.iter())
            .filter(|g| g.streams.is_none())
            .map(|g| g.mats.len())
            .sum::<usize>();
        2 * links >= self.nl && 2 * mas >= self.n_mas
    }

    /// Whether every mobile material's links are stored in its declaration order, so that
    /// accumulating the forces in storage order sums each material's terms in FORMALISM.md's
    /// order (its ENF inputs come after its links in both).
    fn in_declaration_order(&self) -> bool {
        (0..self.n_mc).all(|s| {
            let edges = &self.eidx[self.eoff[s] as usize..self.eoff[s + 1] as usize];
            let links = edges
                .iter()
                .map(|&j| j & !NEG)
                .filter(|&l| (l as usize) < self.nl);
            links.clone().zip(links.skip(1)).all(|(a, b)| a < b)
        })
    }

    /// [`Kernel::new`] with the links stored in [`link_order`], or in declaration order when
    /// `declaration_order`; with `bridge`, progressions joined across exceptions ([`bridged`],
    /// [`Joins::Rows`]), each ground link placed only where no other is ([`placed_in_bands`]) and
    /// the SOLs stored in the order of their links. Stepping is not chosen yet (`compact` is
    /// false).
    #[track_caller]
    fn build(net: &Network, declaration_order: bool, bridge: bool) -> Kernel {
        let joins = if bridge { Joins::Rows } else { Joins::Off };
        Kernel::build_with(net, declaration_order, joins, Mobiles::ByDegree)
    }

    /// [`Kernel::build`] with the progressions joined as `joins` says and the mobile materials
    /// ordered in storage as `mobiles` says.
    #[track_caller]
    fn build_with(
        net: &Network,
        declaration_order: bool,
        joins: Joins,
        mobiles: Mobiles,
    ) -> Kernel {
        let bridge = joins != Joins::Off;
        let nm = net.materials.len();
        assert!(
            u32::try_from(nm).is_ok(),
            "too many material modules for one engine"
        );
        let rank = |m: &Material| -> u8 {
            match m {
                Material::Mas { .. } => 0,
                Material::Cel { .. } => 1,
                Material::Enx { .. } => 2,
                Material::Sol { .. } => 3,
            }
        };
        // Degree of each material (its link ends): mobile materials are grouped by degree within
        // their kind so that the gather runs in segments of one degree (fixed-length, branch-free
        // sums; see `Kernel::update_mas`), unless `mobiles` keeps them in declaration order (a
        // membrane's rows, for the grid step: see `engine/grid.rs`). ENF inputs are not counted:
        // a MAS struck by one stays among its neighbours, a segment of its own.
        let mut degree = vec![0usize; nm];
        for link in &net.links {
            for id in [link.a, link.b] {
                if let Some(d) = degree.get_mut(id.index()) {
                    *d += 1;
                }
            }
        }
        let mut order: Vec<usize> = (0..nm).collect();
        if mobiles == Mobiles::Local {
            // (stable: the other materials in declaration order within a kind)
            let tk = term_kinds(net);
            let size = if tk.mixed { WIDE_WINDOW } else { WINDOW };
            let (window, walk) = local_order(net, rank, size);
            order.sort_by_cached_key(|&i| {
                let m = &net.materials[i];
                let (pair, d, kinds) = if m.is_mobile() {
                    (tk.pair(i), degree[i], tk.kinds[i])
                } else {
                    (0, 0, 0)
                };
                (rank(m), window[i], pair, d, kinds, walk[i])
            });
        } else {
            // stable: declaration order within a kind and degree
            order.sort_by_key(|&i| {
                let m = &net.materials[i];
                let by_degree = m.is_mobile() && mobiles == Mobiles::ByDegree;
                (rank(m), if by_degree { degree[i] } else { 0 })
            });
        }
        let mut slot = vec![0u32; nm];
        for (s, &i) in order.iter().enumerate() {
            slot[i] = s as u32;
        }
        let (mut x_init, mut xp_init) = (vec![0.0; nm], vec![0.0; nm]);
        let (mut mas_m, mut cel, mut enx) = (Vec::new(), Vec::new(), Vec::new());
        for (s, &i) in order.iter().enumerate() {
            let m = &net.materials[i];
            (x_init[s], xp_init[s]) = m.initial_state();
            match m {
                Material::Mas { m, .. } => mas_m.push(*m),
                Material::Cel { m, k, z, r, .. } => cel.push(Cel {
                    m: *m,
                    a: 2.0 - (k + z) / m,
                    b: z / m - 1.0,
                    r: *r,
                }),
                Material::Enx { signal } => enx.push(signal.clone()),
                Material::Sol { .. } => {}
            }
        }
        let n_mas = mas_m.len();
        let n_mc = n_mas + cel.len();
        let n_mce = n_mc + enx.len();
        let mas = match mas_m.first() {
            Some(&m0) if mas_m.iter().all(|m| m.to_bits() == m0.to_bits()) => {
                if is_power_of_two(m0) {
                    MasLaw::UniformInv(1.0 / m0)
                } else {
                    MasLaw::UniformDiv(m0)
                }
            }
            _ if mas_m.iter().all(|&m| is_power_of_two(m)) => {
                MasLaw::Inv(mas_m.iter().map(|m| 1.0 / m).collect())
            }
            _ => MasLaw::Div(mas_m),
        };

        let nl = net.links.len();
        let lslot = if declaration_order {
            (0..net.links.len() as u32).collect()
        } else {
            link_order(net, &slot, n_mc, bridge, joins == Joins::Runs)
        };
        let mut by_slot = vec![0usize; nl];
        for (d, &l) in lslot.iter().enumerate() {
            by_slot[l as usize] = d;
        }
        if bridge {
            // SOLs in the order their links are stored: the grounds of a membrane's top row are
            // then consecutive, as the masses they hold, and their links a unit-step loop
            let mut first = vec![usize::MAX; nm - n_mce];
            for (l, &d) in by_slot.iter().enumerate() {
                let link = &net.links[d];
                for id in [link.a, link.b] {
                    // (a foreign id is refused below)
                    if let Some(&s) = slot.get(id.index()).filter(|&&s| s as usize >= n_mce) {
                        let f = &mut first[s as usize - n_mce];
                        *f = (*f).min(l);
                    }
                }
            }
            let mut by_use: Vec<usize> = (0..nm - n_mce).collect();
            by_use.sort_by_key(|&i| first[i]); // (stable: unused SOLs keep their order)
            let mut renumbered = vec![0u32; nm - n_mce];
            for (i, &old) in by_use.iter().enumerate() {
                renumbered[old] = (n_mce + i) as u32;
            }
            for s in slot.iter_mut().filter(|s| **s as usize >= n_mce) {
                *s = renumbered[*s as usize - n_mce];
            }
            for init in [&mut x_init, &mut xp_init] {
                let old = init[n_mce..].to_vec();
                for (i, v) in old.into_iter().enumerate() {
                    init[renumbered[i] as usize] = v;
                }
            }
        }
        let slot_of = |id: MatId| -> u32 {
            assert!(
                id.index() < nm,
                "link or input refers to material #{} of {nm}",
                id.0
            );
            slot[id.index()]
        };
        let (mut la, mut lb) = (Vec::with_capacity(nl), Vec::with_capacity(nl));
        let (mut lk, mut lz, mut ls) = (vec![0.0; nl], vec![0.0; nl], vec![0.0; nl]);
        let mut curves = vec![(Curve::zero(), Curve::zero()); nl];
        let mut laws = Vec::with_capacity(nl);
        for (l, &d) in by_slot.iter().enumerate() {
            let link = &net.links[d];
            la.push(slot_of(link.a));
            lb.push(slot_of(link.b));
            laws.push(match &link.law {
                Interaction::Res { k } => {
                    lk[l] = *k;
                    Law::Res
                }
                Interaction::Fro { z } => {
                    lz[l] = *z;
                    Law::Fro
                }
                Interaction::Ref { k, z } => {
                    (lk[l], lz[l]) = (*k, *z);
                    Law::Ref
                }
                Interaction::But { k, z, s } => {
                    (lk[l], lz[l], ls[l]) = (*k, *z, *s);
                    Law::But
                }
                Interaction::Lnl { lk: ck, lz: cz } => {
                    curves[l] = (ck.clone(), cz.clone());
                    Law::Lnl
                }
            });
        }
        // Runs: maximal stretches of one law; within them, stretches of identical parameters
        // long enough to pay become uniform runs.
        let same = |i: usize, j: usize| {
            laws[i] == laws[j]
                && lk[i].to_bits() == lk[j].to_bits()
                && lz[i].to_bits() == lz[j].to_bits()
                && ls[i].to_bits() == ls[j].to_bits()
                && same_curve(&curves[i].0, &curves[j].0)
                && same_curve(&curves[i].1, &curves[j].1)
        };
        let mut runs: Vec<Run> = Vec::new();
        let mut l = 0;
        while l < nl {
            let mut e = l + 1;
            while e < nl && same(l, e) {
                e += 1;
            }
            let law = laws[l];
            if e - l >= UNIFORM_MIN {
                runs.push(Run {
                    law,
                    start: l,
                    end: e,
                    uniform: true,
                    ends: Ends::Indexed,
                });
            } else {
                match runs.last_mut() {
                    Some(r) if !r.uniform && r.law == law => r.end = e,
                    _ => runs.push(Run {
                        law,
                        start: l,
                        end: e,
                        uniform: false,
                        ends: Ends::Indexed,
                    }),
                }
            }
            l = e;
        }
        // LNL laws: one per stretch of identical curves.
        let mut lnl: Vec<Lnl> = Vec::new();
        // (kept only when some link needs it: a few bytes per module count on large models)
        let mut lnl_of = if laws.contains(&Law::Lnl) {
            vec![0u32; nl]
        } else {
            Vec::new()
        };
        for l in 0..nl {
            if laws[l] != Law::Lnl {
                continue;
            }
            if l == 0 || laws[l - 1] != Law::Lnl || !same(l - 1, l) {
                lnl.push(Lnl::new(&curves[l].0, &curves[l].1));
            }
            lnl_of[l] = (lnl.len() - 1) as u32;
        }
        drop(curves);
        let ls = if laws.contains(&Law::But) {
            ls
        } else {
            Vec::new() // only BUT has an S
        };

        // Within runs, stretches whose ends are arithmetic progressions need no index (with
        // `bridge`, but for a few exceptions, recomputed after the loop: see `bridged`).
        let mut link_fix = Vec::new();
        let runs: Vec<Run> = runs
            .iter()
            .flat_map(|run| {
                let (la, lb) = (&la[run.start..run.end], &lb[run.start..run.end]);
                let ends = |i: usize, j: usize| if j == 0 { la[i] } else { lb[i] };
                let pieces = stretches(
                    la.len(),
                    2,
                    ends,
                    bridge.then_some((run.start, &mut link_fix)),
                );
                pieces.into_iter().map(move |(r, steps)| {
                    let mut piece = run.cut(run.start + r.start, run.start + r.end);
                    if let Some(st) = steps {
                        piece.ends = Ends::Step {
                            a0: st[0].0,
                            sa: st[0].1,
                            b0: st[1].0,
                            sb: st[1].1,
                        };
                    }
                    piece
                })
            })
            .collect();
        // (progressions continued across a change of parameters: strings of different
        // stiffnesses, one after the other)
        let runs = if joins == Joins::Runs {
            joined(runs, &mut link_fix)
        } else {
            runs
        };
        // every term of a progression is its link's end, or, at the exceptions, a slot between
        // two that are (so `< nm`)
        for run in &runs {
            if let Ends::Step { a0, sa, b0, sb } = run.ends {
                for (i, l) in (run.start..run.end).enumerate() {
                    let i = i as u32;
                    let (a, b) = (a0 + i * sa, b0 + i * sb);
                    let fix = link_fix.binary_search(&(l as u32)).is_ok();
                    assert!(la[l] == a && lb[l] == b || fix && (a.max(b) as usize) < nm);
                }
            }
        }

        // ENF inputs on mobile materials; the others act on nothing.
        let mut enf = Vec::new();
        let mut enf_slot = Vec::new();
        for fi in &net.forces {
            let s = slot_of(fi.target) as usize;
            if s < n_mc {
                enf.push(fi.signal.clone());
                enf_slot.push(s);
            }
        }
        let sf_len = nl + enf.len();
        assert!(
            sf_len < NEG as usize,
            "too many interactions for one engine"
        );

        // Edge lists: for each mobile material, the `sf` slots it sums, in the order of
        // FORMALISM.md (links in declaration order, end 1 before end 2; then its ENF inputs).
        let mut eoff = vec![0u32; n_mc + 1];
        let mut count = |s: u32| {
            if (s as usize) < n_mc {
                eoff[s as usize + 1] += 1;
            }
        };
        for l in 0..nl {
            count(la[l]);
            count(lb[l]);
        }
        for &s in &enf_slot {
            eoff[s + 1] += 1;
        }
        for s in 0..n_mc {
            eoff[s + 1] += eoff[s];
        }
        let mut eidx = vec![0u32; eoff[n_mc] as usize];
        let mut cursor: Vec<u32> = eoff[..n_mc].to_vec();
        let mut push = |s: u32, j: usize| {
            if (s as usize) < n_mc {
                eidx[cursor[s as usize] as usize] = j as u32;
                cursor[s as usize] += 1;
            }
        };
        for &l in &lslot {
            // in declaration order
            let l = l as usize;
            push(la[l], NEG as usize | l); // end 1 receives -f: a negated term
            push(lb[l], l); // end 2 receives +f
        }
        for (i, &s) in enf_slot.iter().enumerate() {
            push(s as u32, nl + i);
        }
        let degree = |s: usize| (eoff[s + 1] - eoff[s]) as usize;
        let mut by_degree: Vec<(Range<usize>, usize)> = Vec::new();
        for s in 0..n_mas {
            match by_degree.last_mut() {
                Some((r, d)) if *d == degree(s) => r.end = s + 1,
                _ => by_degree.push((s..s + 1, degree(s))),
            }
        }
        let (mut mas_segments, mut streams) = (Vec::new(), Vec::new());
        let mut mas_fix = Vec::new();
        for (r, d) in by_degree {
            let e0 = eoff[r.start] as usize;
            let edge = |i: usize, j: usize| eidx[e0 + i * d + j];
            let pieces = stretches(r.len(), d, edge, bridge.then_some((r.start, &mut mas_fix)));
            for (p, steps) in pieces {
                let mats = r.start + p.start..r.start + p.end;
                let seg_streams = steps.map(|st| {
                    let first = streams.len();
                    streams.extend(st);
                    first..streams.len()
                });
                if let Some(st) = &seg_streams {
                    // every term is the MAS's edge or, at the exceptions, a slot between two
                    // that are (so `< sf_len`, with their sign, which may not be the exception's
                    // own: `update_mas` recomputes it from its edges)
                    for s in mats.clone() {
                        let fix = mas_fix.binary_search(&(s as u32)).is_ok();
                        for j in 0..d {
                            let (base, step) = streams[st.start + j];
                            let term = base + (s - mats.start) as u32 * step;
                            let edge = eidx[eoff[s] as usize + j];
                            assert!(
                                edge == term
                                    || fix
                                        && term & NEG == base & NEG
                                        && ((term & !NEG) as usize) < sf_len
                            );
                        }
                    }
                }
                let unit = (seg_streams.as_ref())
                    .map(|st| &streams[st.clone()])
                    .filter(|st| {
                        (1..=UNIT_TERMS).contains(&d) && st.iter().all(|&(_, step)| step == 1)
                    })
                    .map(|st| {
                        let mut slots = [0u32; UNIT_TERMS];
                        let mut neg = 0u32;
                        for (j, &(base, _)) in st.iter().enumerate() {
                            let (slot, mask) = signed(base);
                            slots[j] = slot;
                            neg |= u32::from(mask != 0) << j;
                        }
                        (slots, neg)
                    });
                mas_segments.push(Segment {
                    mats,
                    degree: d,
                    streams: seg_streams,
                    unit,
                });
            }
        }
        // The gather reads `sf` unchecked at these indices: make the bound local and obvious.
        assert!(eidx.iter().all(|&j| ((j & !NEG) as usize) < sf_len));

        let check_link = |l: LinkId| -> u32 {
            assert!(l.index() < nl, "output refers to link #{} of {nl}", l.0);
            lslot[l.index()]
        };
        let mut sum_terms = Vec::new();
        let mut channels = Vec::with_capacity(net.outputs.len());
        for o in &net.outputs {
            channels.push(match o {
                Output::Position(m) => Channel::Position(slot_of(*m)),
                Output::Force(l) => Channel::Force(check_link(*l)),
                Output::Sum(terms) => {
                    assert!(!terms.is_empty(), "a sum output needs at least one term");
                    let start = sum_terms.len();
                    for &(g, p) in terms {
                        sum_terms.push((
                            g,
                            match p {
                                Probe::Position(m) => Term::Position(slot_of(m)),
                                Probe::Force(l) => Term::Force(check_link(l)),
                            },
                        ));
                    }
                    Channel::Sum(start, sum_terms.len())
                }
            });
        }
        // (the runs tile the links in storage order: `Kernel::link_run` searches them by halves)
        let mut end = 0;
        for r in &runs {
            assert!(
                r.start == end && r.end > r.start,
                "runs out of storage order"
            );
            end = r.end;
        }
        assert_eq!(end, nl, "runs must cover every link");
        let whole = Part {
            runs: runs.clone(),
            enf: 0..enf.len(),
            mats: 0..n_mce,
            ..Part::default()
        };
        let mut k = Kernel {
            nm,
            n_mas,
            n_mc,
            n_mce,
            x_init,
            xp_init,
            mas,
            cel,
            enx,
            slot,
            nl,
            la,
            lb,
            lk,
            lz,
            ls,
            lnl,
            lnl_of,
            enf,
            eoff,
            eidx,
            mas_segments,
            streams,
            sf_len,
            channels,
            sum_terms,
            lslot,
            simd: Simd::detect(),
            whole,
            parts: Vec::new(),
            tiles: Vec::new(),
            tile_runs: Vec::new(),
            listed: Vec::new(),
            scattered: false,
            compact: false,
            enf_slot: enf_slot.iter().map(|&s| s as u32).collect(),
            link_fix,
            mas_fix,
            pull: None,
            pull_shares: Vec::new(),
            grid: None,
            grid_shares: Vec::new(),
        };
        // (a link to a SOL reads a position nobody writes; the others are local when their ends
        // are within [`NEAR`] slots of each other in storage)
        let local = (k.la.iter().zip(&k.lb))
            .filter(|&(&a, &b)| a.abs_diff(b) as usize <= NEAR || a.max(b) as usize >= k.n_mce)
            .count();
        k.scattered = 2 * local < nl;
        k.parts = vec![k.whole.clone()];
        (k.tiles, k.tile_runs, k.listed) = k.tiling(TILE);
        k
    }

    /// The tiles of the single-thread step, `tile` materials each, and their run pieces: each
    /// link goes to the first tile that has one of its mobile ends (any tile, the first, when it
    /// has none), or, for a run whose links are not in the order of their tiles, the whole run
    /// to the first tile any of its links needs. A tile's links are computed just before its
    /// materials are updated, while the forces and positions they share are in the L1 cache.
    fn tiling(&self, tile: usize) -> (Vec<Tile>, Vec<Run>, Vec<u32>) {
        let bounds = self.tile_bounds(tile);
        let count = bounds.len() - 1;
        let tile_of = |s: u32| {
            let s = s as usize;
            if s < self.n_mc {
                bounds.partition_point(|&b| b <= s) - 1
            } else {
                usize::MAX
            }
        };
        let ready = |l: usize| match tile_of(self.la[l]).min(tile_of(self.lb[l])) {
            usize::MAX => 0,
            t => t,
        };
        let mut per_tile: Vec<Vec<Run>> = vec![Vec::new(); count];
        for run in &self.whole.runs {
            let r = run.start..run.end;
            let ordered = r
                .clone()
                .zip(r.clone().skip(1))
                .all(|(a, b)| ready(a) <= ready(b));
            if !ordered {
                let first = r.map(ready).min().unwrap_or(0);
                per_tile[first].push(*run);
                continue;
            }
            let mut start = run.start;
            for l in run.start + 1..=run.end {
                if l == run.end || ready(l) != ready(start) {
                    per_tile[ready(start)].push(run.cut(start, l));
                    start = l;
                }
            }
        }
        let (mut tiles, mut runs, mut listed) = (Vec::with_capacity(count), Vec::new(), Vec::new());
        for (t, pieces) in per_tile.into_iter().enumerate() {
            let first = runs.len();
            runs.extend(self.gather_short(pieces, &mut listed));
            tiles.push(Tile {
                runs: first..runs.len(),
                mats: bounds[t]..bounds[t + 1],
                seg: self.first_segment(bounds[t]),
            });
        }
        (tiles, runs, listed)
    }

    /// A tile's run pieces with its short indexed runs (fewer than [`STEP_MIN`] links) of the same
    /// law and parameters gathered into one `Ends::Listed` run each, in place of the first of
    /// them, their slots appended to `listed`: the two ground links between the rows of a
    /// membrane are one loop per tile instead of a loop per row. The forces are the same, link by
    /// link: only the order in which links are computed changes, and the tiled step sums nothing
    /// while it computes them.
    fn gather_short(&self, pieces: Vec<Run>, listed: &mut Vec<u32>) -> Vec<Run> {
        let short = |r: &Run| r.ends == Ends::Indexed && r.end - r.start < STEP_MIN;
        // (law, uniform, and a uniform run's parameters: those of its first link)
        let key = |r: &Run| {
            let s = r.start;
            let bits = |v: &[f64]| v.get(s).map_or(0, |x| x.to_bits());
            let params = (bits(&self.lk), bits(&self.lz), bits(&self.ls));
            let lnl = self.lnl_of.get(s).copied().unwrap_or(0);
            (r.law, r.uniform, r.uniform.then_some((params, lnl)))
        };
        let mut out: Vec<Run> = Vec::with_capacity(pieces.len());
        // per group: where it is in `out`, and its slots
        let mut groups: Vec<(usize, Vec<u32>)> = Vec::new();
        for run in pieces {
            if !short(&run) {
                out.push(run);
                continue;
            }
            let group = groups
                .iter_mut()
                .find(|(at, _)| key(&out[*at]) == key(&run));
            match group {
                Some((_, slots)) => slots.extend(run.start as u32..run.end as u32),
                None => {
                    groups.push((out.len(), (run.start as u32..run.end as u32).collect()));
                    out.push(run);
                }
            }
        }
        for (at, mut slots) in groups {
            if slots.len() == out[at].end - out[at].start {
                continue; // a single run: kept as it is
            }
            slots.sort_unstable();
            let from = listed.len() as u32;
            listed.extend(&slots);
            let run = &mut out[at];
            (run.start, run.end) = (slots[0] as usize, slots[slots.len() - 1] as usize + 1);
            run.ends = Ends::Listed {
                from,
                to: listed.len() as u32,
            };
        }
        out
    }

    /// Where the tiles of the single-thread step start (then `n_mce`, at least one tile): at most
    /// `tile` materials each, cut between MAS segments where the segments are shorter than a tile
    /// (a membrane's rows), so that no row is cut into two pieces, each with its own loop
    /// remainders; a longer segment is cut every `tile` materials.
    fn tile_bounds(&self, tile: usize) -> Vec<usize> {
        let (mut bounds, mut last) = (vec![0], 0);
        let ends = (self.mas_segments.iter().map(|g| g.mats.end)).chain([self.n_mce]);
        let mut seg_start = 0;
        for end in ends {
            // (a segment that fits in a tile starts a new one rather than being cut; a longer one
            // is cut anyway)
            if end - last > tile && seg_start > last && end - seg_start <= tile {
                last = seg_start;
                bounds.push(last);
            }
            while end - last > tile {
                last += tile;
                bounds.push(last);
            }
            seg_start = end;
        }
        if last < self.n_mce || bounds.len() == 1 {
            bounds.push(self.n_mce);
        }
        bounds
    }

    /// Cuts links, inputs and materials into `threads` parts of about equal cost.
    ///
    /// Materials and inputs: contiguous ranges. Links: each goes to the thread that owns its end 2
    /// (or its end 1, when end 2 is not mobile), so that the thread that sums a material's terms
    /// mostly wrote them itself, and reads the positions it wrote: on a string or a membrane only
    /// the links that cross a boundary between parts move between cores. Force slots that share a
    /// cache line all go to one thread (`line` is the slot offset of `sf` within its cache line),
    /// so that two cores never write one line in the same phase (on a membrane, every column of
    /// links is cut between two threads). When that cuts the runs into short pieces (a network
    /// without locality, where it would not help) or unbalances the threads by more than a quarter,
    /// links are cut into contiguous ranges of declaration order instead. Either way the arithmetic
    /// is the same: the links phase accumulates nothing.
    fn partition(&self, threads: usize, line: usize) -> Vec<Part> {
        let enf = split(self.enf.len(), threads, |_| 1);
        let mats = split(self.n_mce, threads, |s| {
            if s < self.n_mc {
                2 + u64::from(self.eoff[s + 1] - self.eoff[s])
            } else {
                4 // ENX: a signal
            }
        });
        let mut parts: Vec<Part> = enf
            .into_iter()
            .zip(mats)
            .map(|(enf, mats)| Part {
                enf,
                mats,
                ..Part::default()
            })
            .collect();
        if threads > 1 && self.nl > 0 {
            let owner_of = |s: u32| {
                let s = s as usize;
                (s < self.n_mc).then(|| parts.iter().position(|p| p.mats.contains(&s)))?
            };
            let by_ends = |l: usize| {
                owner_of(self.lb[l])
                    .or_else(|| owner_of(self.la[l]))
                    .unwrap_or(l * threads / self.nl) // both ends fixed: by position
            };
            // the owner of the first slot of the cache line of slot `l`
            let owner = |l: usize| by_ends(((l + line) / 8 * 8).saturating_sub(line));
            let mut pieces: Vec<(usize, Run)> = Vec::new();
            for run in &self.whole.runs {
                let mut start = run.start;
                let mut t = owner(start);
                for l in run.start + 1..=run.end {
                    let u = if l < run.end { owner(l) } else { usize::MAX };
                    if u != t {
                        pieces.push((t, run.cut(start, l)));
                        (start, t) = (l, u);
                    }
                }
            }
            let mut cost = vec![0u64; threads];
            for (t, r) in &pieces {
                cost[*t] += r.law.cost() * (r.end - r.start) as u64;
            }
            let mean = cost.iter().sum::<u64>() / threads as u64;
            let balanced = cost.iter().all(|&c| c <= mean + mean / 4 + 8);
            let long = pieces.len() * 8 <= self.nl;
            if balanced && long {
                for (t, r) in pieces {
                    parts[t].runs.push(r);
                }
                for part in &mut parts {
                    self.chunk(part, line);
                }
                return parts;
            }
        }
        let mut cost_of = Vec::with_capacity(self.nl);
        for r in &self.whole.runs {
            cost_of.extend(std::iter::repeat_n(r.law.cost(), r.end - r.start));
        }
        // (these cuts may share a cache line: two per thread, not one per column)
        for (part, links) in parts
            .iter_mut()
            .zip(split(self.nl, threads, |l| cost_of[l]))
        {
            part.runs = self
                .whole
                .runs
                .iter()
                .filter(|r| r.start < links.end && r.end > links.start)
                .map(|r| r.cut(r.start.max(links.start), r.end.min(links.end)))
                .collect();
            self.chunk(part, line);
        }
        parts
    }

    /// Cuts a part's runs and materials into chunks of about equal cost (see [`CHUNK_COST`]);
    /// runs are cut where a cache line of force slots starts (`line` as in `partition`), so that
    /// two threads working on neighbouring chunks do not write one line.
    fn chunk(&self, part: &mut Part, line: usize) {
        let cost = |r: &Run| r.law.cost() * (r.end - r.start) as u64;
        let total: u64 = part.runs.iter().map(cost).sum();
        let count = (total / CHUNK_COST).clamp(1, CHUNKS_MAX);
        let (mut runs, mut chunks) = (Vec::with_capacity(part.runs.len()), Vec::new());
        let (mut acc, mut first, mut k) = (0u64, 0usize, 1u64);
        for run in std::mem::take(&mut part.runs) {
            let mut run = run;
            loop {
                let target = total * k / count;
                if k < count && acc + cost(&run) > target {
                    // cut where the target is reached, at the next cache line
                    let need = target.saturating_sub(acc).div_ceil(run.law.cost()) as usize;
                    let at = (run.start + need + line).div_ceil(8) * 8 - line;
                    if run.start < at && at < run.end {
                        let head = run.cut(run.start, at);
                        acc += cost(&head);
                        runs.push(head);
                        run = run.cut(at, run.end);
                    }
                    chunks.push(first..runs.len());
                    first = runs.len();
                    k += 1;
                    continue;
                }
                acc += cost(&run);
                runs.push(run);
                break;
            }
        }
        chunks.push(first..runs.len());
        chunks.retain(|c| !c.is_empty());
        part.runs = runs;
        part.link_chunks = chunks;
        let mats = part.mats.clone();
        let mat_cost = |s: usize| {
            if s < self.n_mc {
                2 + u64::from(self.eoff[s + 1] - self.eoff[s])
            } else {
                4
            }
        };
        let total: u64 = mats.clone().map(mat_cost).sum();
        let count = (total / CHUNK_COST).clamp(1, CHUNKS_MAX) as usize;
        part.mat_chunks = split(mats.len(), count, |i| mat_cost(mats.start + i))
            .into_iter()
            .map(|r| mats.start + r.start / 8 * 8..mats.start + r.end / 8 * 8)
            .collect();
        if let Some(last) = part.mat_chunks.last_mut() {
            last.end = mats.end; // (the rounding leaves the tail to the last chunk)
        }
        part.mat_chunks.retain(|c| !c.is_empty());
    }

    /// The samples `n` of the ENF inputs `r` into `ef` (exactly `r`'s slots).
    #[inline(always)]
    fn inputs(&self, r: Range<usize>, n: u64, ef: &mut [f64]) {
        for (v, sig) in ef.iter_mut().zip(&self.enf[r]) {
            *v = sig.at(n);
        }
    }

    /// The forces of one run of links.
    #[inline(always)]
    fn run_links(&self, run: &Run, st: &Positions<'_, impl Sink>, lf: &mut [f64]) {
        let r = run.start..run.end;
        let s0 = run.start;
        // Each law with the expressions of FORMALISM.md, d = x1 - x2 and v = (x1 - x1') - (x2 -
        // x2'): from the ends' positions (LNL), or from their positions and velocities (the
        // `LinkLaw`s, see `Kernel::by_velocity`).
        match (run.law, run.uniform) {
            (Law::Res, true) => self.uniform::<ResLaw, _>(run, st, lf),
            (Law::Fro, true) => self.uniform::<FroLaw, _>(run, st, lf),
            (Law::Ref, true) => self.uniform::<RefLaw, _>(run, st, lf),
            (Law::But, true) => self.uniform::<ButLaw, _>(run, st, lf),
            (Law::Res, false) => self.varied::<ResLaw, _>(run, st, lf),
            (Law::Fro, false) => self.varied::<FroLaw, _>(run, st, lf),
            (Law::Ref, false) => self.varied::<RefLaw, _>(run, st, lf),
            (Law::But, false) => self.varied::<ButLaw, _>(run, st, lf),
            (Law::Lnl, true) => match &self.lnl[self.lnl_of[s0] as usize] {
                Lnl::Exact(pair) => self.exact_run(*pair, run, st, lf),
                law => self.each(run, st, lf, |_, xa, pa, xb, pb| {
                    law.force(xa - xb, (xa - pa) - (xb - pb))
                }),
            },
            (Law::Lnl, false) => {
                let (lnl, of) = (&self.lnl, &self.lnl_of[r]);
                self.each(run, st, lf, |i, xa, pa, xb, pb| {
                    lnl[of[i] as usize].force(xa - xb, (xa - pa) - (xb - pb))
                });
            }
        }
    }

    /// A uniform run of a law with parameters.
    #[inline(always)]
    fn uniform<L: LinkLaw, S: Sink>(&self, run: &Run, st: &Positions<'_, S>, lf: &mut [f64]) {
        let s0 = run.start;
        let (k, z, s) = (
            self.lk[s0],
            self.lz[s0],
            self.ls.get(s0).map_or(0.0, |s| *s),
        );
        self.by_velocity::<L, S, _>(run, st, lf, Shared(k, z, s));
    }

    /// A run of a law with parameters, each link with its own.
    #[inline(always)]
    fn varied<L: LinkLaw, S: Sink>(&self, run: &Run, st: &Positions<'_, S>, lf: &mut [f64]) {
        let r = run.start..run.end;
        let (k, z) = (&self.lk[r.clone()], &self.lz[r.clone()]);
        // (no S without a BUT: the laws that have none ignore the slice they are given)
        let s = self.ls.get(r).unwrap_or(k);
        self.by_velocity::<L, S, _>(run, st, lf, PerLink { k, z, s });
    }

    /// Computes the force of law `L` for every link `i` of `run`, with parameters
    /// `params.at(i)`, storing it into `lf`: a chain (see [`chain`]) with AVX-512, or
    /// [`Kernel::each`] with the velocities computed there, operand for operand.
    #[inline(always)]
    fn by_velocity<L: LinkLaw, S: Sink, P: LinkParams>(
        &self,
        run: &Run,
        st: &Positions<'_, S>,
        lf: &mut [f64],
        params: P,
    ) {
        let law = |(k, z, s): (f64, f64, f64), xa, va, xb, vb| L::force(k, z, s, xa, va, xb, vb);
        let force = |i, xa, va, xb, vb| law(params.at(i), xa, va, xb, vb);
        let by_ends = |i, xa: f64, pa: f64, xb: f64, pb: f64| force(i, xa, xa - pa, xb, xb - pb);
        if let (
            Some(cpu),
            Ends::Step {
                a0,
                sa: 1,
                b0,
                sb: 1,
            },
        ) = (self.tails(), run.ends)
        {
            if b0 == a0 + 1 && !S::ACCUMULATES {
                let (n, a) = (run.end - run.start, a0 as usize);
                let (x, xp) = (&st.x[a..a + n + 1], &st.xp[a..a + n + 1]);
                chain(cpu, x, xp, &mut lf[..n], params, law);
                self.fix_links(run, st, lf, by_ends);
                return;
            }
        }
        self.each(run, st, lf, by_ends);
    }

    /// Runs `force(i, x1(n), x1(n-1), x2(n), x2(n-1))` for every link `i` of `run`, storing `f`
    /// into `lf` (exactly the run's range).
    #[inline(always)]
    fn each<S: Sink>(
        &self,
        run: &Run,
        st: &Positions<'_, S>,
        lf: &mut [f64],
        force: impl Fn(usize, f64, f64, f64, f64) -> f64,
    ) {
        let n = run.end - run.start;
        let lf = &mut lf[..n];
        match run.ends {
            Ends::Indexed => {
                let (la, lb) = (&self.la[run.start..run.end], &self.lb[run.start..run.end]);
                for (i, ((&a, &b), f)) in la.iter().zip(lb).zip(lf.iter_mut()).enumerate() {
                    *f = force(i, st.x(a), st.xp(a), st.x(b), st.xp(b));
                    st.sink.take(a, b, *f);
                }
            }
            Ends::Step {
                a0,
                sa: 1,
                b0,
                sb: 1,
            } => {
                // contiguous: plain slices (checked once here), which the compiler vectorises
                let (a, b) = (a0 as usize..a0 as usize + n, b0 as usize..b0 as usize + n);
                let (xa, pa, xb, pb) = (&st.x[a.clone()], &st.xp[a], &st.x[b.clone()], &st.xp[b]);
                // (with AVX-512 the last `n % 8` links are one masked block, below)
                let tails = self.tails();
                let body = tails.map_or(n, |_| n - n % LANES);
                for (i, (((f, &xa), &pa), (&xb, &pb))) in (lf[..body].iter_mut())
                    .zip(xa)
                    .zip(pa)
                    .zip(xb.iter().zip(pb))
                    .enumerate()
                {
                    *f = force(i, xa, pa, xb, pb);
                    st.sink.take(a0 + i as u32, b0 + i as u32, *f);
                }
                if let Some(cpu) = tails.filter(|_| body < n) {
                    let (xa, pa) = (cpu.load(&xa[body..]), cpu.load(&pa[body..]));
                    let (xb, pb) = (cpu.load(&xb[body..]), cpu.load(&pb[body..]));
                    // (the lanes past the end compute on zeros, with the run's last index, and
                    // are not stored)
                    let mut f = [0.0; LANES];
                    for (j, f) in f.iter_mut().enumerate() {
                        *f = force((body + j).min(n - 1), xa[j], pa[j], xb[j], pb[j]);
                    }
                    cpu.store(&mut lf[body..], f);
                    for (i, &f) in lf.iter().enumerate().skip(body) {
                        st.sink.take(a0 + i as u32, b0 + i as u32, f);
                    }
                }
            }
            Ends::Listed { from, to } => {
                for &l in &self.listed[from as usize..to as usize] {
                    let l = l as usize;
                    let (a, b, i) = (self.la[l], self.lb[l], l - run.start);
                    lf[i] = force(i, st.x(a), st.xp(a), st.x(b), st.xp(b));
                    st.sink.take(a, b, lf[i]);
                }
            }
            Ends::Step { a0, sa, b0, sb } => {
                let (mut a, mut b) = (a0, b0);
                for (i, f) in lf.iter_mut().enumerate() {
                    *f = force(i, st.x(a), st.xp(a), st.x(b), st.xp(b));
                    st.sink.take(a, b, *f);
                    a = a.wrapping_add(sa);
                    b = b.wrapping_add(sb);
                }
            }
        }
        // (a sink would have taken the wrong forces: a kernel whose step accumulates has no
        // exceptions, see `Kernel::make_compact`)
        if let (Ends::Step { .. }, false) = (run.ends, S::ACCUMULATES) {
            self.fix_links(run, st, lf, force);
        }
    }

    /// The exceptions of a run with `Ends::Step`, computed with the progression's terms, now with
    /// their ends.
    #[inline(always)]
    fn fix_links<S: Sink>(
        &self,
        run: &Run,
        st: &Positions<'_, S>,
        lf: &mut [f64],
        force: impl Fn(usize, f64, f64, f64, f64) -> f64,
    ) {
        for &l in self.fixes(&self.link_fix, run.start..run.end) {
            let l = l as usize;
            let (a, b, i) = (self.la[l], self.lb[l], l - run.start);
            lf[i] = force(i, st.x(a), st.xp(a), st.x(b), st.xp(b));
        }
    }

    /// The exceptions of `list` (`Kernel::link_fix` or `Kernel::mas_fix`) within `r`.
    #[inline(always)]
    fn fixes<'a>(&self, list: &'a [u32], r: Range<usize>) -> &'a [u32] {
        if list.is_empty() {
            return list;
        }
        let from = list.partition_point(|&l| (l as usize) < r.start);
        let to = from + list[from..].partition_point(|&l| (l as usize) < r.end);
        &list[from..to]
    }

    /// Link (slot) `l` as a run of its own, read through the index lists (a progression's cut
    /// could land on an exception): `None` if it is in no run.
    fn link_run(&self, l: usize) -> Option<Run> {
        // (the runs are in storage order, see `Kernel::build_with`)
        let runs = &self.whole.runs;
        let run = runs
            .get(runs.partition_point(|r| r.end <= l))
            .filter(|r| (r.start..r.end).contains(&l))?;
        Some(Run {
            ends: Ends::Indexed,
            ..run.cut(l, l + 1)
        })
    }

    /// The links (slots) `l` where `wanted[l]`, as runs: each run of the kernel that has them
    /// all, the others' stretches of wanted links read through the index lists. `None` if a
    /// wanted link is in no run.
    fn runs_of(&self, wanted: &[bool]) -> Option<Vec<Run>> {
        let mut runs = Vec::new();
        let mut covered = 0;
        for run in &self.whole.runs {
            let want = &wanted[run.start..run.end];
            covered += want.iter().filter(|&&w| w).count();
            if want.iter().all(|&w| w) {
                runs.push(*run);
                continue;
            }
            let mut l = run.start;
            while l < run.end {
                if !wanted[l] {
                    l += 1;
                    continue;
                }
                let end = l + wanted[l..run.end].iter().take_while(|&&w| w).count();
                runs.push(Run {
                    ends: Ends::Indexed,
                    ..run.cut(l, end)
                });
                l = end;
            }
        }
        (covered == wanted.iter().filter(|&&w| w).count()).then_some(runs)
    }

    /// Each link's law, by link slot.
    fn laws(&self) -> Vec<Law> {
        let mut law = vec![Law::Ref; self.nl];
        for run in &self.whole.runs {
            law[run.start..run.end].fill(run.law);
        }
        law
    }

    /// The links the outputs read (SOF and sums of them), for the steps that keep no force
    /// buffer (the pull and grid steps): `None` if one is in no run.
    fn recorded_links(&self) -> Option<Vec<Recorded>> {
        let mut recorded: Vec<usize> = Vec::new();
        for c in &self.channels {
            match *c {
                Channel::Force(l) => recorded.push(l as usize),
                Channel::Sum(a, b) => {
                    recorded.extend(self.sum_terms[a..b].iter().filter_map(|(_, t)| match *t {
                        Term::Force(l) => Some(l as usize),
                        Term::Position(_) => None,
                    }))
                }
                Channel::Position(_) => {}
            }
        }
        recorded.sort_unstable();
        recorded.dedup();
        recorded.into_iter().map(|l| self.alone(l)).collect()
    }

    /// Link `l` (a storage slot), to be computed alone ([`Kernel::link_alone`]): `None` if it is
    /// in no run.
    fn alone(&self, l: usize) -> Option<Recorded> {
        Some(Recorded {
            slot: l as u32,
            a: self.la[l],
            b: self.lb[l],
            law: self.link_run(l)?.law,
        })
    }

    /// The force of link `r` from the positions `cur` and `prev`, computed alone, as
    /// [`Kernel::each`] computes a link read through the index lists (one run of its own each
    /// through [`Kernel::run_links`] took 13 % of the reconfigurable instrument's pull step for
    /// the six its outputs read, docs/BENCHMARKS-LOG.md, fiftieth session).
    #[inline]
    fn link_alone(&self, r: &Recorded, cur: &[f64], prev: &[f64]) -> f64 {
        let (l, a, b) = (r.slot as usize, r.a as usize, r.b as usize);
        let (xa, pa, xb, pb) = (cur[a], prev[a], cur[b], prev[b]);
        let (va, vb) = (xa - pa, xb - pb);
        let (k, z) = (self.lk[l], self.lz[l]);
        match r.law {
            Law::Res => ResLaw::force(k, z, 0.0, xa, va, xb, vb),
            Law::Fro => FroLaw::force(k, z, 0.0, xa, va, xb, vb),
            Law::Ref => RefLaw::force(k, z, 0.0, xa, va, xb, vb),
            Law::But => ButLaw::force(k, z, self.ls[l], xa, va, xb, vb),
            Law::Lnl => self.lnl[self.lnl_of[l] as usize].force(xa - xb, va - vb),
        }
    }

    /// The outputs of a step of the pull or grid step: the forces of the `recorded` links (see
    /// [`Kernel::recorded_links`]) into `sf`, each computed alone, then `frame`.
    #[inline]
    fn record_with(
        &self,
        recorded: &[Recorded],
        cur: &[f64],
        prev: &[f64],
        sf: &mut [f64],
        frame: &mut [f64],
    ) {
        for r in recorded {
            sf[r.slot as usize] = self.link_alone(r, cur, prev);
        }
        self.record(cur, &sf[..self.nl], frame);
    }

    /// Outputs record `x(n)` and `f(n)`.
    #[inline(always)]
    fn record(&self, x: &[f64], lf: &[f64], frame: &mut [f64]) {
        let terms = &self.sum_terms;
        let term = |t: &Term| match *t {
            Term::Position(s) => x[s as usize],
            Term::Force(l) => lf[l as usize],
        };
        for (o, c) in frame.iter_mut().zip(&self.channels) {
            *o = match *c {
                Channel::Position(s) => x[s as usize],
                Channel::Force(l) => lf[l as usize],
                Channel::Sum(a, b) => {
                    let (g0, t0) = &terms[a];
                    let mut acc = g0 * term(t0);
                    for (g, t) in &terms[a + 1..b] {
                        acc += g * term(t);
                    }
                    acc
                }
            };
        }
    }

    /// Phase 2 for materials `mats` (storage slots within `0..n_mce`): each sums its forces and
    /// writes `x(n+1)` over `x(n-1)` in `next`, which is exactly `mats` of the `x(n-1)` buffer; `seg`
    /// is [`Kernel::first_segment`] of `mats.start`.
    #[inline(always)]
    fn materials_phase(
        &self,
        mats: Range<usize>,
        seg: usize,
        n: u64,
        (cur, prev): (&[f64], &[f64]),
        next: &mut [f64],
        sf: Forces<'_>,
    ) {
        assert!(next.len() == mats.len() && sf.0.len() == self.sf_len);
        assert!(cur.len() == self.nm && prev.len() == self.nm);
        let m0 = mats.start;
        let within = |r: Range<usize>| {
            let start = r.start.max(mats.start);
            start..r.end.min(mats.end).max(start)
        };
        let mas = within(0..self.n_mas);
        if !mas.is_empty() {
            let next = &mut next[mas.start - m0..mas.end - m0];
            self.update_mas(mas.clone(), seg, (&cur[mas.clone()], &prev[mas], next, sf));
        }
        let cel = within(self.n_mas..self.n_mc);
        if !cel.is_empty() {
            let next = &mut next[cel.start - m0..cel.end - m0];
            let params = &self.cel[cel.start - self.n_mas..cel.end - self.n_mas];
            let edges = self.csr(cel.clone());
            let xs = cur[cel.clone()].iter().zip(&prev[cel]);
            for (((p, (&x, &xp)), e), c) in next.iter_mut().zip(xs).zip(edges).zip(params) {
                *p = c.next(x, xp, sum(e, sf));
            }
        }
        let enx = within(self.n_mc..self.n_mce);
        if !enx.is_empty() {
            let next = &mut next[enx.start - m0..enx.end - m0];
            let sigs = &self.enx[enx.start - self.n_mc..enx.end - self.n_mc];
            for (p, sig) in next.iter_mut().zip(sigs) {
                *p = sig.at(n + 1);
            }
        }
    }

    /// The first of the MAS segments (in storage order) that ends after storage slot `s`: where
    /// the MAS update of materials from `s` on starts (computed once per tile).
    fn first_segment(&self, s: usize) -> usize {
        self.mas_segments.partition_point(|g| g.mats.end <= s)
    }

    /// The edge lists of materials `r`, from the offsets.
    #[inline(always)]
    fn csr(&self, r: Range<usize>) -> impl Iterator<Item = &[u32]> + '_ {
        self.eoff[r.start..=r.end]
            .windows(2)
            .map(|w| &self.eidx[w[0] as usize..w[1] as usize])
    }

    /// MAS `r` (storage slots): `x(n+1) = 2 x(n) - x(n-1) + F(n) / M`, one segment at a time.
    #[inline(always)]
    fn update_mas(
        &self,
        r: Range<usize>,
        first: usize,
        (cur, prev, next, sf): (&[f64], &[f64], &mut [f64], Forces<'_>),
    ) {
        debug_assert_eq!(first, self.first_segment(r.start));
        for seg in &self.mas_segments[first..] {
            if seg.mats.start >= r.end {
                break;
            }
            let (start, end) = (seg.mats.start.max(r.start), seg.mats.end.min(r.end));
            if start >= end {
                continue;
            }
            let local = start - r.start..end - r.start;
            let (cur, prev, next) = (&cur[local.clone()], &prev[local.clone()], &mut next[local]);
            let d = seg.degree;
            let Some(streams) = &seg.streams else {
                let e0 = self.eoff[start] as usize;
                let edges = &self.eidx[e0..e0 + d * (end - start)];
                let ms = (cur, prev, next, sf);
                match d {
                    1 => self.mas_with(start..end, ms, edges.chunks_exact(1), sum),
                    2 => self.mas_with(start..end, ms, edges.chunks_exact(2), sum),
                    3 => self.mas_with(start..end, ms, edges.chunks_exact(3), sum),
                    4 => self.mas_with(start..end, ms, edges.chunks_exact(4), sum),
                    5 => self.mas_with(start..end, ms, edges.chunks_exact(5), sum),
                    6 => self.mas_with(start..end, ms, edges.chunks_exact(6), sum),
                    _ => self.mas_with(start..end, ms, self.csr(start..end), sum),
                }
                continue;
            };
            self.mas_streams(seg, streams, start..end, (cur, prev, &mut *next, sf));
            // the exceptions, computed with the streams' terms, now with their edges
            // (the inertias' form chosen once, not per exception: many short strings have one
            // per string)
            let fixes = self.fixes(&self.mas_fix, start..end);
            if !fixes.is_empty() {
                let ms = (start, cur, prev, &mut *next, sf);
                match &self.mas {
                    MasLaw::UniformInv(inv) => {
                        self.fix_mas(fixes, ms, |_, x, p, f| by_inv(x, p, f, *inv))
                    }
                    MasLaw::UniformDiv(m) => {
                        self.fix_mas(fixes, ms, |_, x, p, f| by_div(x, p, f, *m))
                    }
                    MasLaw::Inv(inv) => {
                        self.fix_mas(fixes, ms, |s, x, p, f| by_inv(x, p, f, inv[s]))
                    }
                    MasLaw::Div(m) => self.fix_mas(fixes, ms, |s, x, p, f| by_div(x, p, f, m[s])),
                }
            }
        }
    }

    /// The exceptions `fixes` (MAS slots from `start` on) of a segment with streams, recomputed
    /// from their edges: `next[i] = update(s, cur[i], prev[i], F)` for MAS `s = start + i`.
    #[inline(always)]
    fn fix_mas(
        &self,
        fixes: &[u32],
        (start, cur, prev, next, sf): (usize, &[f64], &[f64], &mut [f64], Forces<'_>),
        update: impl Fn(usize, f64, f64, f64) -> f64,
    ) {
        for &s in fixes {
            let (s, i) = (s as usize, s as usize - start);
            let f = sum(
                &self.eidx[self.eoff[s] as usize..self.eoff[s + 1] as usize],
                sf,
            );
            next[i] = update(s, cur[i], prev[i], f);
        }
    }

    /// The MAS `r` of segment `seg`, whose edges are its `streams` (the exceptions too, which
    /// `update_mas` then recomputes); `cur`, `prev`, `next` are exactly `r`.
    #[inline(always)]
    fn mas_streams(
        &self,
        seg: &Segment,
        streams: &Range<usize>,
        r: Range<usize>,
        (cur, prev, next, sf): (&[f64], &[f64], &mut [f64], Forces<'_>),
    ) {
        let (start, end) = (r.start, r.end);
        let d = seg.degree;
        // progressions: edge j of the i-th MAS from `start` is `base_j + i step_j`
        let i0 = (start - seg.mats.start) as u32;
        let n = end - start;
        if let Some((slots, mask)) = seg.unit {
            // unit steps, decoded in `build`: (slot, step, negated) of each term from `start`
            // on; the sign of a stream is constant, so `f - t` (exactly the reference's
            // `F -= f`) is chosen outside the loop, and the common patterns get loops with the
            // signs built in
            let term = move |j: usize| (slots[j] + i0, 1, mask >> j & 1 == 1);
            let ms = (start..end, cur, prev, next, sf);
            match (d, mask) {
                (2, 0b10) => self.mas_signed::<2, 0b10>(ms, term), // a string
                (2, 0b01) => self.mas_signed::<2, 0b01>(ms, term),
                (2, 0b00) => self.mas_signed::<2, 0b00>(ms, term),
                (2, 0b11) => self.mas_signed::<2, 0b11>(ms, term),
                (4, 0b1010) => self.mas_signed::<4, 0b1010>(ms, term), // a membrane
                (1, _) => self.mas_unit::<1>(ms, term),
                (2, _) => self.mas_unit::<2>(ms, term),
                (3, _) => self.mas_unit::<3>(ms, term),
                (4, _) => self.mas_unit::<4>(ms, term),
                (5, _) => self.mas_unit::<5>(ms, term),
                _ => self.mas_unit::<6>(ms, term),
            }
            return;
        }
        let streams = &self.streams[streams.clone()];
        // (slot, step, negated) of each stream from `start` on; the sign of a stream is
        // constant, so `f - t` (exactly the reference's `F -= f`) is chosen outside the loop
        let term = |j: usize| {
            let (base, step) = streams[j];
            let (slot, mask) = signed(base + i0 * step);
            (slot, step, mask != 0)
        };
        match d {
            0 => self.mas_with(start..end, (cur, prev, next, sf), 0..n, |_, _| 0.0),
            _ => {
                self.mas_with(start..end, (cur, prev, next, sf), 0..n, |i, sf| {
                    let i = i as u32;
                    let mut f = 0.0;
                    for j in 0..d {
                        let (slot, step, neg) = term(j);
                        let t = sf.get(slot + i * step);
                        if neg {
                            f -= t;
                        } else {
                            f += t;
                        }
                    }
                    f
                });
            }
        }
    }

    /// MAS `r` whose `D` edges are unit-step progressions (strings, rows of membranes): term `j`
    /// of the `i`-th MAS is `±sf[slot_j + i]`, `(slot_j, 1, negated_j) = term(j)`, so each term
    /// is a slice of `sf` and the loop is vectorised. The sign is applied as a multiplication by
    /// `±1.0` (exact), so the sum is the reference's `F += f` / `F -= f`, term by term in edge order.
    #[inline(always)]
    fn mas_unit<const D: usize>(
        &self,
        ms: MasArgs<'_, '_>,
        term: impl Fn(usize) -> (u32, u32, bool),
    ) {
        let signs: [f64; D] = std::array::from_fn(|j| if term(j).2 { -1.0 } else { 1.0 });
        self.mas_terms::<D>(ms, &term, |j, f, t| f + signs[j] * t);
    }

    /// [`Kernel::mas_unit`] with the signs known at compile time: bit `j` of `NEG` set when term
    /// `j` is subtracted (`F -= f`, as the reference writes it), clear when it is added.
    #[inline(always)]
    fn mas_signed<const D: usize, const NEG: u32>(
        &self,
        ms: MasArgs<'_, '_>,
        term: impl Fn(usize) -> (u32, u32, bool),
    ) {
        self.mas_terms::<D>(
            ms,
            &term,
            |j, f, t| {
                if NEG >> j & 1 == 1 {
                    f - t
                } else {
                    f + t
                }
            },
        );
    }

    /// The loop of [`Kernel::mas_unit`] and [`Kernel::mas_signed`]: `F(n)` of the `i`-th MAS is
    /// `add(D - 1, ... add(1, add(0, +0.0, t_0), t_1) ..., t_{D-1})`, `t_j` its term `j`.
    #[inline(always)]
    fn mas_terms<const D: usize>(
        &self,
        ms: MasArgs<'_, '_>,
        term: &impl Fn(usize) -> (u32, u32, bool),
        add: impl Fn(usize, f64, f64) -> f64,
    ) {
        let (r, cur, prev, next, sf) = ms;
        let n = r.len();
        // (with AVX-512 the last `n % 8` MAS are one masked block, below)
        let tails = self.tails();
        let body = tails.map_or(n, |_| n - n % LANES);
        let (cur, prev, next) = (&cur[..n], &prev[..n], &mut next[..n]);
        let terms = unit_terms::<D>(sf, 0..body, term);
        self.mas_with(
            r.start..r.start + body,
            (&cur[..body], &prev[..body], &mut next[..body], sf),
            0..body,
            |i, _| {
                let mut f = 0.0;
                for (j, t) in terms.iter().enumerate() {
                    f = add(j, f, t[i]);
                }
                f
            },
        );
        let Some(cpu) = tails.filter(|_| body < n) else {
            return;
        };
        let (x, xp) = (cpu.load(&cur[body..]), cpu.load(&prev[body..]));
        // `F(n)` of each lane, term by term in edge order, as in the loop above
        let mut f = [0.0; LANES];
        for (j, s) in unit_terms::<D>(sf, body..n, term).iter().enumerate() {
            for (f, t) in f.iter_mut().zip(cpu.load(s)) {
                *f = add(j, *f, t);
            }
        }
        // each lane's `1 / M` to multiply by, or `M` to divide by, as `mas_with` does (the lanes
        // past the end compute on zeros, a division by zero too, and are not stored)
        let rest = r.start + body..r.end;
        let (by, multiply) = match &self.mas {
            MasLaw::UniformInv(inv) => ([*inv; LANES], true),
            MasLaw::UniformDiv(m) => ([*m; LANES], false),
            MasLaw::Inv(inv) => (cpu.load(&inv[rest]), true),
            MasLaw::Div(ms) => (cpu.load(&ms[rest]), false),
        };
        let mut out = [0.0; LANES];
        for (j, o) in out.iter_mut().enumerate() {
            *o = if multiply {
                by_inv(x[j], xp[j], f[j], by[j])
            } else {
                by_div(x[j], xp[j], f[j], by[j])
            };
        }
        cpu.store(&mut next[body..], out);
    }

    /// The proof of AVX-512 when the loops are compiled for it: their last `n % 8` items are
    /// then one masked block (see [`crate::lanes`]).
    #[inline(always)]
    fn tails(&self) -> Option<Avx512> {
        match self.simd {
            #[cfg(target_arch = "x86_64")]
            Simd::Avx512(cpu) => Some(cpu),
            _ => None,
        }
    }

    /// The MAS loop over `r`: `next` holds `x(n-1)` on entry and `x(n+1)` on exit; `force(e, sf)`
    /// is `F(n)` of the MAS whose item of `edges` is `e`.
    #[inline(always)]
    fn mas_with<E>(
        &self,
        r: Range<usize>,
        (cur, prev, next, sf): (&[f64], &[f64], &mut [f64], Forces<'_>),
        edges: impl Iterator<Item = E>,
        force: impl Fn(E, Forces<'_>) -> f64,
    ) {
        let items = next.iter_mut().zip(cur.iter().zip(prev)).zip(edges);
        match &self.mas {
            MasLaw::UniformInv(inv) => {
                for ((p, (&x, &xp)), e) in items {
                    *p = by_inv(x, xp, force(e, sf), *inv);
                }
            }
            MasLaw::UniformDiv(m) => {
                for ((p, (&x, &xp)), e) in items {
                    *p = by_div(x, xp, force(e, sf), *m);
                }
            }
            MasLaw::Inv(inv) => {
                for (((p, (&x, &xp)), e), &inv) in items.zip(&inv[r]) {
                    *p = by_inv(x, xp, force(e, sf), inv);
                }
            }
            MasLaw::Div(ms) => {
                for (((p, (&x, &xp)), e), &m) in items.zip(&ms[r]) {
                    *p = by_div(x, xp, force(e, sf), m);
                }
            }
        }
    }
}

/// The forces of a chain of links, link `i` from material `i` to material `i + 1` of `x`, `xp`
/// (`x(n)`, `x(n-1)` of materials `0..=lf.len()`, consecutive storage slots): a string, or a
/// membrane's rows joined. Each material's velocity `x - x'` is computed once, eight at a time,
/// and serves as the `x1 - x1'` of one link and the `x2 - x2'` of the one before: `force(i, xa,
/// va, xb, vb)` (a [`LinkLaw::force`]) gets the operands [`Kernel::each`] gives it, the same bits,
/// with one subtraction and two loads fewer per link (the next material's `x` and `v` are the
/// block's lanes shifted by one). Used for RES, FRO, REF and BUT; not for LNL, whose curves'
/// look-ups do not vectorise in these lanes.
#[inline(always)]
fn chain(
    cpu: Avx512,
    x: &[f64],
    xp: &[f64],
    lf: &mut [f64],
    params: impl LinkParams,
    force: impl Fn((f64, f64, f64), f64, f64, f64, f64) -> f64,
) {
    let n = lf.len();
    assert!(x.len() == n + 1 && xp.len() == n + 1);
    // `x` and `x - x'` of the materials `from..from + 8` (lanes past the end `0.0`)
    let block = |from: usize| {
        let (x, p) = (cpu.load(&x[from..]), cpu.load(&xp[from..]));
        let v: [f64; LANES] = std::array::from_fn(|j| x[j] - p[j]);
        (x, v)
    };
    let (mut xa, mut va) = block(0);
    // the materials one further: lanes 1..8 of this block, then lane 0 of the next
    let next = |a: &[f64; LANES], b: &[f64; LANES]| -> [f64; LANES] {
        std::array::from_fn(|j| if j + 1 < LANES { a[j + 1] } else { b[0] })
    };
    let body = n.saturating_sub(LANES) / LANES * LANES; // blocks whose next block is whole
    let mut i = 0;
    while i < body {
        // (whole blocks while `i < body`; the loop below takes over from any `i`)
        let (Some(xn), Some(pn)) = (
            x[i + LANES..].first_chunk::<LANES>(),
            xp[i + LANES..].first_chunk::<LANES>(),
        ) else {
            break;
        };
        let xn = *xn;
        let vn: [f64; LANES] = std::array::from_fn(|j| xn[j] - pn[j]);
        let (xb, vb) = (next(&xa, &xn), next(&va, &vn));
        // (whole blocks of parameters too: loaded as lanes, not one by one)
        let [k, z, s] = params.block(i);
        let f: [f64; LANES] =
            std::array::from_fn(|j| force((k[j], z[j], s[j]), xa[j], va[j], xb[j], vb[j]));
        lf[i..i + LANES].copy_from_slice(&f);
        (xa, va) = (xn, vn);
        i += LANES;
    }
    while i < n {
        let (xn, vn) = block((i + LANES).min(n + 1));
        let (xb, vb) = (next(&xa, &xn), next(&va, &vn));
        // (the lanes past the end compute with the last link's index, and are not stored)
        let f: [f64; LANES] = std::array::from_fn(|j| {
            force(params.at((i + j).min(n - 1)), xa[j], va[j], xb[j], vb[j])
        });
        cpu.store(&mut lf[i..], f);
        (xa, va) = (xn, vn);
        i += LANES;
    }
}

/// The parameters (K, Z, S) of the links of a run, as [`chain`] reads them.
trait LinkParams: Copy {
    /// those of the run's link `i`
    fn at(self, i: usize) -> (f64, f64, f64);
    /// those of links `i..i + LANES`, all of them the run's: K, Z and S as blocks of lanes
    fn block(self, i: usize) -> [[f64; LANES]; 3];
}

/// The parameters of every link of a uniform run.
#[derive(Clone, Copy)]
struct Shared(f64, f64, f64);

impl LinkParams for Shared {
    #[inline(always)]
    fn at(self, _: usize) -> (f64, f64, f64) {
        (self.0, self.1, self.2)
    }

    #[inline(always)]
    fn block(self, _: usize) -> [[f64; LANES]; 3] {
        [[self.0; LANES], [self.1; LANES], [self.2; LANES]]
    }
}

/// Each link's own parameters: `k[i]`, `z[i]`, `s[i]` (slices of the run's links).
#[derive(Clone, Copy)]
struct PerLink<'a> {
    k: &'a [f64],
    z: &'a [f64],
    s: &'a [f64],
}

impl LinkParams for PerLink<'_> {
    #[inline(always)]
    fn at(self, i: usize) -> (f64, f64, f64) {
        (self.k[i], self.z[i], self.s[i])
    }

    #[inline(always)]
    fn block(self, i: usize) -> [[f64; LANES]; 3] {
        // (one bound check per slice and block, so that the loads are vectors)
        let lanes = |v: &[f64]| {
            *v[i..]
                .first_chunk::<LANES>()
                .expect("a whole block of links")
        };
        [lanes(self.k), lanes(self.z), lanes(self.s)]
    }
}

/// A MAS's `x(n+1) = 2 x(n) - x(n-1) + F(n) / M` (FORMALISM.md), with `1 / M` a power of two:
/// multiplied by `inv` (the same bits, see [`is_power_of_two`]).
#[inline(always)]
fn by_inv(x: f64, xp: f64, f: f64, inv: f64) -> f64 {
    2.0 * x - xp + f * inv
}

/// A MAS's `x(n+1)`, dividing by `m`.
#[inline(always)]
fn by_div(x: f64, xp: f64, f: f64, m: f64) -> f64 {
    2.0 * x - xp + f / m
}

/// Which of the three position buffers holds what at step `n` (see the module documentation).
#[derive(Clone, Copy, Debug)]
struct Roles {
    /// `x(n)`
    cur: usize,
    /// `x(n-1)`
    prev: usize,
    /// `x(n-2)`, overwritten with `x(n+1)` by step `n`
    next: usize,
}

impl Roles {
    #[inline(always)]
    fn of(n: u64) -> Roles {
        Roles::at((n % 3) as usize)
    }

    /// The roles when `x(n)` is in buffer `c` (`n % 3`, tracked without dividing).
    #[inline(always)]
    fn at(c: usize) -> Roles {
        Roles {
            cur: c,
            prev: (c + 2) % 3,
            next: (c + 1) % 3,
        }
    }

    /// `(x(n), x(n-1), next)` of the three buffers.
    #[inline(always)]
    fn split(self, pos: &mut [Lines; 3]) -> (&[f64], &[f64], &mut [f64]) {
        let [p0, p1, p2] = pos;
        match self.cur {
            0 => (p0, p2, p1),
            1 => (p1, p0, p2),
            _ => (p2, p1, p0),
        }
    }
}

/// The `D` slices of `sf` that MAS `r` (counted from the first of a unit-step segment) read, term
/// `j` of the first MAS being slot `term(j).0`.
#[inline(always)]
fn unit_terms<'a, const D: usize>(
    sf: Forces<'a>,
    r: Range<usize>,
    term: &impl Fn(usize) -> (u32, u32, bool),
) -> [&'a [f64]; D] {
    // (a loop rather than `array::from_fn`, which the compiler left as a call)
    let mut terms: [&'a [f64]; D] = [&[]; D];
    for (j, t) in terms.iter_mut().enumerate() {
        let s = term(j).0 as usize;
        *t = &sf.0[s + r.start..s + r.end];
    }
    terms
}

/// The arguments of a MAS loop: storage slots, `x(n)` and `x(n-1)` of those MAS, where their
/// `x(n+1)` goes, the forces.
type MasArgs<'a, 'b> = (
    Range<usize>,
    &'a [f64],
    &'a [f64],
    &'b mut [f64],
    Forces<'a>,
);

/// The widest vector instructions of this CPU that the stepping loops are compiled for. The
/// loops never fuse a multiply and an add (Rust does not contract floating-point expressions),
/// so every width computes the same IEEE operations on the same values: the same bits.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Simd {
    None,
    #[cfg(target_arch = "x86_64")]
    Avx2,
    /// (with the proof that the CPU has it, for the loops' masked tails: see [`crate::lanes`])
    #[cfg(target_arch = "x86_64")]
    Avx512(Avx512),
}

impl Simd {
    fn detect() -> Simd {
        #[cfg(target_arch = "x86_64")]
        {
            if let Some(cpu) = Avx512::detect() {
                return Simd::Avx512(cpu);
            }
            if crate::SimdLimit::current() >= crate::SimdLimit::Avx2
                && std::is_x86_feature_detected!("avx2")
            {
                return Simd::Avx2;
            }
        }
        Simd::None
    }
}

/// Work that [`vectorised`] compiles for a vector width: `run` and everything it calls on the
/// stepping path are `#[inline(always)]`, so they are inlined into (and compiled with the target
/// features of) the function that calls `run`.
trait Vectorised {
    type Output;
    fn run(self) -> Self::Output;
}

/// Runs `work`, compiled for the vector instructions `simd` names.
#[inline(always)]
fn vectorised<W: Vectorised>(simd: Simd, work: W) -> W::Output {
    #[cfg(target_arch = "x86_64")]
    {
        #[target_feature(enable = "avx2")]
        fn avx2<W: Vectorised>(work: W) -> W::Output {
            work.run()
        }
        #[target_feature(enable = "avx512f")]
        fn avx512<W: Vectorised>(work: W) -> W::Output {
            work.run()
        }
        match simd {
            // SAFETY: `Simd::detect` found the feature on this CPU (an engine is never moved to
            // another machine while it runs).
            Simd::Avx512(_) => return unsafe { avx512(work) },
            // SAFETY: as above.
            Simd::Avx2 => return unsafe { avx2(work) },
            Simd::None => {}
        }
    }
    work.run()
}

/// The block loop of [`Engine::observing`], with its observer if it has one.
struct Block<'a, 'o> {
    k: &'a Kernel,
    st: &'a mut State,
    frames: usize,
    out: &'a mut [f64],
    observe: Option<&'o mut dyn FnMut(&StepView<'_>)>,
}

impl Vectorised for Block<'_, '_> {
    type Output = ();
    #[inline(always)]
    fn run(self) {
        let Block {
            k,
            st,
            frames,
            out,
            mut observe,
        } = self;
        let ch = k.channels.len();
        for frame in 0..frames {
            st.step(k, &mut out[frame * ch..(frame + 1) * ch]);
            if let Some(observe) = observe.as_deref_mut() {
                let r = Roles::at(st.c);
                observe(&StepView {
                    n: st.n - 1,
                    k,
                    x: &st.pos[r.cur],
                    xp: &st.pos[r.prev],
                    lf: &st.sf[..k.nl],
                });
            }
        }
    }
}

/// One thread's share of a parallel block.
struct Share<'a, 'j> {
    job: &'a Job<'j>,
    t: usize,
    out: Option<&'a mut [f64]>,
    barrier: &'a SpinBarrier,
}

impl Vectorised for Share<'_, '_> {
    type Output = Result<(), Poisoned>;
    #[inline(always)]
    fn run(self) -> Result<(), Poisoned> {
        self.job.run_part(self.t, self.out, self.barrier)
    }
}

/// A link law with parameters `K`, `Z`, `S` (each law reads those it has), as a function of
/// `(x1(n), v1, x2(n), v2)` with the velocities `v = x(n) - x(n-1)`, so that the expressions of
/// FORMALISM.md, `d = x1 - x2` and `v = (x1 - x1') - (x2 - x2')`, are `xa - xb` and `va - vb`,
/// operand for operand, whether each velocity is computed once per link end ([`Kernel::each`])
/// or once per material ([`chain`]).
trait LinkLaw {
    fn force(k: f64, z: f64, s: f64, xa: f64, va: f64, xb: f64, vb: f64) -> f64;
}

struct ResLaw;
struct FroLaw;
struct RefLaw;
/// BUT: active while `x2 - x1 < S`, then `K (d + S) + Z v`.
struct ButLaw;

impl LinkLaw for ResLaw {
    #[inline(always)]
    fn force(k: f64, _: f64, _: f64, xa: f64, _: f64, xb: f64, _: f64) -> f64 {
        k * (xa - xb)
    }
}

impl LinkLaw for FroLaw {
    #[inline(always)]
    fn force(_: f64, z: f64, _: f64, _: f64, va: f64, _: f64, vb: f64) -> f64 {
        z * (va - vb)
    }
}

impl LinkLaw for RefLaw {
    #[inline(always)]
    fn force(k: f64, z: f64, _: f64, xa: f64, va: f64, xb: f64, vb: f64) -> f64 {
        k * (xa - xb) + z * (va - vb)
    }
}

impl LinkLaw for ButLaw {
    #[inline(always)]
    fn force(k: f64, z: f64, s: f64, xa: f64, va: f64, xb: f64, vb: f64) -> f64 {
        // (computed in both cases, then chosen: a select the vector loops make a blend)
        let f = k * ((xa - xb) + s) + z * (va - vb);
        if xb - xa < s {
            f
        } else {
            0.0
        }
    }
}

/// Whether every value of `x` is finite, as `x.iter().all(|v| v.is_finite())` but in eight
/// sums without an exit at the first bad value, which LLVM vectorises (a loop that may leave
/// early it does not): `v * 0.0` is ±0 for a finite `v` and NaN otherwise (`inf * 0` is NaN),
/// and a NaN stays in a sum. Once a block, over every position (docs/BENCHMARKS-LOG.md,
/// seventieth session).
fn all_finite(x: &[f64]) -> bool {
    let mut acc = [0.0f64; 8];
    let mut chunks = x.chunks_exact(8);
    for c in &mut chunks {
        for (a, &v) in acc.iter_mut().zip(c) {
            *a += v * 0.0;
        }
    }
    for (a, &v) in acc.iter_mut().zip(chunks.remainder()) {
        *a += v * 0.0;
    }
    acc.iter().sum::<f64>() == 0.0
}

/// `F(n)`: from `+0.0`, the terms of one material in its edge order.
#[inline(always)]
fn sum(edges: &[u32], sf: Forces<'_>) -> f64 {
    let mut f = 0.0;
    for &j in edges {
        let (slot, mask) = signed(j);
        f += f64::from_bits(sf.get(slot).to_bits() ^ mask);
    }
    f
}

/// Cuts `0..len` into stretches where each of the `width` columns `get(i, j)` is an arithmetic
/// progression with a non-negative step, `(first, step)`, at least [`STEP_MIN`] long; the rest into
/// stretches without (`None`). In order, covering `0..len`.
#[allow(clippy::type_complexity)]
fn progressions(
    len: usize,
    width: usize,
    get: impl Fn(usize, usize) -> u32,
) -> Vec<(Range<usize>, Option<Vec<(u32, u32)>>)> {
    let mut out: Vec<(Range<usize>, Option<Vec<(u32, u32)>>)> = Vec::new();
    let mut i = 0;
    while i < len {
        let steps: Option<Vec<u32>> = (i + 1 < len)
            .then(|| {
                (0..width)
                    .map(|j| get(i + 1, j).checked_sub(get(i, j)))
                    .collect()
            })
            .flatten();
        let mut e = i + 1;
        if let Some(steps) = &steps {
            let on = |e: usize, j: usize| {
                u64::from(get(e, j)) == u64::from(get(i, j)) + (e - i) as u64 * u64::from(steps[j])
            };
            while e < len && (0..width).all(|j| on(e, j)) {
                e += 1;
            }
        }
        match steps {
            Some(steps) if e - i >= STEP_MIN => {
                out.push((
                    i..e,
                    Some((0..width).map(|j| (get(i, j), steps[j])).collect()),
                ));
                i = e;
            }
            _ => {
                match out.last_mut() {
                    Some((r, None)) => r.end = i + 1,
                    _ => out.push((i..i + 1, None)),
                }
                i += 1;
            }
        }
    }
    out
}

/// [`progressions`], joined across exceptions ([`bridged`]) when `fix` is given: `(at, list)`,
/// the exceptions are then appended to `list`, offset by `at`.
#[allow(clippy::type_complexity)]
fn stretches(
    len: usize,
    width: usize,
    get: impl Fn(usize, usize) -> u32,
    fix: Option<(usize, &mut Vec<u32>)>,
) -> Vec<(Range<usize>, Option<Vec<(u32, u32)>>)> {
    let pieces = progressions(len, width, get);
    let Some((at, list)) = fix else {
        return pieces;
    };
    let (pieces, exceptions) = bridged(pieces);
    list.extend(exceptions.into_iter().map(|i| (at + i) as u32));
    pieces
}

/// For [`Mobiles::Local`]: each material's window and its place in the walk (by declaration
/// index; `0` for the materials that are not mobile, which keep their declaration order).
///
/// The walk is breadth-first over the links whose two ends are mobile (a SOL tied to many
/// materials would make them all neighbours), from each mobile material not yet reached, in
/// declaration order. Materials of one `kind` are counted off into windows of `size` in the
/// walk's order. Only the storage order depends on it, and with it no sum: each material's terms
/// are summed in FORMALISM.md's order whatever its slot.
fn local_order(
    net: &Network,
    kind: impl Fn(&Material) -> u8,
    size: usize,
) -> (Vec<usize>, Vec<usize>) {
    let nm = net.materials.len();
    let mobile = |i: usize| net.materials[i].is_mobile();
    // the links between mobile materials, as lists of neighbours (compressed rows)
    let pairs = (net.links.iter())
        .map(|l| (l.a.index(), l.b.index()))
        .filter(|&(a, b)| a < nm && b < nm && mobile(a) && mobile(b));
    let mut start = vec![0usize; nm + 1];
    for (a, b) in pairs.clone() {
        start[a + 1] += 1;
        start[b + 1] += 1;
    }
    for i in 0..nm {
        start[i + 1] += start[i];
    }
    let mut next = start.clone();
    let mut near = vec![0usize; start[nm]];
    for (a, b) in pairs {
        near[next[a]] = b;
        next[a] += 1;
        near[next[b]] = a;
        next[b] += 1;
    }
    let mut walk = vec![0usize; nm];
    let mut seen = vec![false; nm];
    let mut queue = std::collections::VecDeque::new();
    let mut reached = 0;
    for root in (0..nm).filter(|&i| mobile(i)) {
        if seen[root] {
            continue;
        }
        seen[root] = true;
        queue.push_back(root);
        while let Some(i) = queue.pop_front() {
            walk[i] = reached;
            reached += 1;
            for &j in &near[start[i]..start[i + 1]] {
                if !seen[j] {
                    seen[j] = true;
                    queue.push_back(j);
                }
            }
        }
    }
    let mut by_walk: Vec<usize> = (0..nm).filter(|&i| mobile(i)).collect();
    by_walk.sort_by_key(|&i| (kind(&net.materials[i]), walk[i]));
    let mut window = vec![0usize; nm];
    let mut counted = (u8::MAX, 0);
    for &i in &by_walk {
        let k = kind(&net.materials[i]);
        if counted.0 != k {
            counted = (k, 0);
        }
        window[i] = counted.1 / size;
        counted.1 += 1;
    }
    (window, walk)
}

/// For [`Mobiles::Local`]: the kinds of each material's first [`KINDS_MAX`] link terms, in
/// FORMALISM.md's order (the links' declaration order), as one number that sorts as the list
/// (term `r`'s kind in bits `60 - 4 r..64 - 4 r`); whether the kinds are mixed: at least one term
/// in 16 of the mobile materials is not of the most common kind; and how many distinct pairs of
/// LNL curves there are. A kind is 0 for RES, FRO and REF, 1 for BUT, and `2 + p` for an LNL of
/// the `p`-th distinct pair of curves (the 14th and later pairs share 15).
///
/// Sorted by it within a window and a degree, the MAS of a pull-step group tend to have terms of
/// one kind in each row: a row of BUT and LNL lanes would compute both kinds of force, a row of
/// several pairs of curves evaluates each pair, and a row without LNL lanes skips the curves
/// (docs/BENCHMARKS-LOG.md, thirtieth session). Mixed kinds take windows of [`WIDE_WINDOW`], in
/// which more MAS of a kind meet. With several pairs, the MAS of one pair ([`TermKinds::pair`])
/// come first in a window, ahead of degree, so that the pull step's groups of one pair make long
/// runs (`Pull::runs`, thirty-first session).
fn term_kinds(net: &Network) -> TermKinds {
    let nm = net.materials.len();
    let mut kinds = vec![0u64; nm];
    let mut count = vec![0u8; nm];
    let mut terms = [0usize; 16];
    let mut pairs: Vec<(&Curve, &Curve)> = Vec::new();
    for link in &net.links {
        let kind = match &link.law {
            Interaction::But { .. } => 1,
            Interaction::Lnl { lk, lz } => {
                let p = match pairs.iter().position(|&(a, b)| a == lk && b == lz) {
                    Some(p) => p,
                    None if pairs.len() < 13 => {
                        pairs.push((lk, lz));
                        pairs.len() - 1
                    }
                    None => 13,
                };
                2 + p as u64
            }
            _ => 0,
        };
        for id in [link.a, link.b] {
            let i = id.index();
            if i >= nm || !net.materials[i].is_mobile() {
                continue;
            }
            terms[kind as usize] += 1;
            if usize::from(count[i]) < KINDS_MAX {
                kinds[i] |= kind << (60 - 4 * u32::from(count[i]));
                count[i] += 1;
            }
        }
    }
    let all: usize = terms.iter().sum();
    let most = terms.iter().max().copied().unwrap_or(0);
    TermKinds {
        kinds,
        mixed: 16 * (all - most) >= all && all > most,
        pairs: pairs.len(),
    }
}

/// What [`term_kinds`] finds.
struct TermKinds {
    /// Each material's kinds of terms, as one number.
    kinds: Vec<u64>,
    /// Whether the kinds are mixed.
    mixed: bool,
    /// How many distinct pairs of LNL curves the links have (counted up to 13).
    pairs: usize,
}

impl TermKinds {
    /// The LNL pair of material `i`'s terms: 0 when none is LNL, its LNL kind when all its LNL
    /// terms have one pair, 16 when they have several; 0 for every material when the network
    /// has fewer than two pairs.
    fn pair(&self, i: usize) -> u8 {
        if self.pairs < 2 {
            return 0;
        }
        let mut pair = 0;
        for r in 0..KINDS_MAX {
            let kind = (self.kinds[i] >> (60 - 4 * r) & 0xf) as u8;
            if kind >= 2 && pair != kind {
                if pair != 0 {
                    return 16;
                }
                pair = kind;
            }
        }
        pair
    }
}

/// Link terms per material that [`term_kinds`] records.
const KINDS_MAX: usize = 16;

/// Most items between two progressions that continue each other that are recomputed one at a
/// time rather than cutting the loop (see [`bridged`]).
const GAP_MAX: usize = 2;

/// Whether the columns `then`, `(first value, step)` each, starting `at` items after `first`,
/// continue them: the same steps, and each first value where `first`'s column would be then
/// ([`bridged`] and [`joined`] join only such progressions).
fn progression_continues(first: &[(u32, u32)], then: &[(u32, u32)], at: u64) -> bool {
    first.len() == then.len()
        && (first.iter().zip(then))
            .all(|(&(a, s), &(b, t))| s == t && u64::from(a) + at * u64::from(s) == u64::from(b))
}

/// The pieces of [`progressions`] with each two progressions that continue each other (the same
/// steps, and the second's first values where the first's would be) across at most [`GAP_MAX`]
/// items without progression made one, those items its exceptions; returns the pieces and the
/// exceptions (ascending). A membrane's rows are then one loop: only the item of each row end
/// that breaks the pattern (a ground link, the left term of a row's first mass) is recomputed
/// with its own operands after the loop, which writes it with the progression's. Every value of
/// a merged progression, exceptions included, lies between two values of its items (the steps
/// are non-negative), so it indexes nothing the items do not.
#[allow(clippy::type_complexity)]
fn bridged(
    pieces: Vec<(Range<usize>, Option<Vec<(u32, u32)>>)>,
) -> (Vec<(Range<usize>, Option<Vec<(u32, u32)>>)>, Vec<usize>) {
    let mut out: Vec<(Range<usize>, Option<Vec<(u32, u32)>>)> = Vec::with_capacity(pieces.len());
    let mut exceptions = Vec::new();
    let mut rest = pieces.into_iter().peekable();
    while let Some(piece) = rest.next() {
        // a gap between the last progression and the next one, which continues it
        let continues = |gap: &Range<usize>, next: &(Range<usize>, Option<Vec<(u32, u32)>>)| {
            let (Some((r, Some(st))), (rb, Some(sb))) = (out.last(), next) else {
                return false;
            };
            gap.len() <= GAP_MAX && progression_continues(st, sb, (rb.start - r.start) as u64)
        };
        match piece {
            (gap, None) if rest.peek().is_some_and(|next| continues(&gap, next)) => {
                let (next, _) = rest.next().expect("peeked");
                exceptions.extend(gap);
                out.last_mut().expect("continued").0.end = next.end;
            }
            piece => out.push(piece),
        }
    }
    (out, exceptions)
}

/// Longest uniform run that [`joined`] makes part of a run with varied parameters: a loop that
/// reads its parameters once saves a load per parameter and link, a run's set-up, loop tails and
/// the MAS segment of its own cost tens of links (50 strings of 100 masses ran 1.2-1.9x faster
/// joined, 20 strings of 250 at the same speed: docs/BENCHMARKS-LOG.md, thirteenth session).
const JOIN_MAX: usize = 256;

/// The run pieces (in storage order) with each two progressions of one law that continue each
/// other (the same steps, the second's first terms where the first's would be) across at most
/// [`GAP_MAX`] links of that law read through the index lists made one run with varied
/// parameters, those links its exceptions (appended to `fix`, which is then sorted), when each of
/// the two is uniform and shorter than [`JOIN_MAX`], or varied. Many short strings, each of its
/// own stiffness, are then one loop, their ground links between them exceptions, as the rows of
/// a membrane are (see [`bridged`]). The forces are the same, link by link: the joined run reads
/// each link's own parameters.
fn joined(pieces: Vec<Run>, fix: &mut Vec<u32>) -> Vec<Run> {
    let step = |r: &Run| match r.ends {
        Ends::Step { a0, sa, b0, sb } => Some((a0, sa, b0, sb)),
        _ => None,
    };
    let short = |r: &Run| !r.uniform || r.end - r.start < JOIN_MAX;
    let mut out: Vec<Run> = Vec::with_capacity(pieces.len());
    // whether the last piece of `out` may be joined to the next progression: a short progression,
    // or one made of joined ones
    let mut open = false;
    let mut i = 0;
    while i < pieces.len() {
        let next = pieces[i];
        let law = out.last().map(|r| r.law);
        let mut j = i;
        let mut gap = 0;
        while j < pieces.len()
            && pieces[j].ends == Ends::Indexed
            && Some(pieces[j].law) == law
            && gap + pieces[j].end - pieces[j].start <= GAP_MAX
        {
            gap += pieces[j].end - pieces[j].start;
            j += 1;
        }
        let continues = |prev: &Run, then: &Run| {
            let (Some((a0, sa, b0, sb)), Some((a1, ta, b1, tb))) = (step(prev), step(then)) else {
                return false;
            };
            let at = (then.start - prev.start) as u64;
            prev.law == then.law
                && progression_continues(&[(a0, sa), (b0, sb)], &[(a1, ta), (b1, tb)], at)
        };
        match (out.last_mut(), pieces.get(j)) {
            (Some(prev), Some(then)) if open && short(then) && continues(prev, then) => {
                fix.extend(prev.end as u32..then.start as u32);
                prev.end = then.end;
                prev.uniform = false;
                i = j + 1;
            }
            _ => {
                open = step(&next).is_some() && short(&next);
                out.push(next);
                i += 1;
            }
        }
    }
    fix.sort_unstable();
    out
}

/// Cuts `0..len` into `parts` contiguous ranges of about equal total `cost`.
fn split(len: usize, parts: usize, cost: impl Fn(usize) -> u64) -> Vec<Range<usize>> {
    let total: u128 = (0..len).map(|i| u128::from(cost(i))).sum();
    let mut ranges = Vec::with_capacity(parts);
    let (mut start, mut i, mut acc) = (0, 0, 0u128);
    for t in 1..=parts {
        let target = total * t as u128 / parts as u128;
        while i < len && acc < target {
            acc += u128::from(cost(i));
            i += 1;
        }
        let end = if t == parts { len } else { i };
        ranges.push(start..end);
        start = end;
    }
    ranges
}

/// Two curves with the same points, bit for bit (so they evaluate identically).
fn same_curve(a: &Curve, b: &Curve) -> bool {
    a.len() == b.len()
        && a.points()
            .zip(b.points())
            .all(|(p, q)| p.0.to_bits() == q.0.to_bits() && p.1.to_bits() == q.1.to_bits())
}

/// The storage slot of each link, by declaration index: the order in which the links phase
/// computes them and their forces are stored. It changes no sum (each material still adds its
/// terms in declaration order, through its edge list), only which links are neighbours in memory:
/// links are grouped by law and, where at least [`UNIFORM_MIN`] share them, by parameters; within
/// a group, links whose ends are the same distance apart in material storage (at least
/// [`STEP_MIN`] of them) are sorted by their end 1, so that their ends are contiguous (the
/// horizontal and vertical links of a membrane become two runs of unit-step progressions); the
/// others keep their declaration order. With `by_law`, such a band holds the links of one law
/// and distance whatever their parameters (short strings of different stiffnesses, one after
/// the other in storage, then continue one progression, which [`joined`] makes one loop).
fn link_order(net: &Network, slot: &[u32], n_mc: usize, bridge: bool, by_law: bool) -> Vec<u32> {
    use std::collections::HashMap;
    let nl = net.links.len();
    // parameter classes, numbered by first appearance
    let mut classes: HashMap<(u8, Vec<u64>), u32> = HashMap::new();
    let class: Vec<u32> = net
        .links
        .iter()
        .map(|link| {
            let key = match &link.law {
                Interaction::Res { k } => (0, vec![k.to_bits()]),
                Interaction::Fro { z } => (1, vec![z.to_bits()]),
                Interaction::Ref { k, z } => (2, vec![k.to_bits(), z.to_bits()]),
                Interaction::But { k, z, s } => (3, vec![k.to_bits(), z.to_bits(), s.to_bits()]),
                Interaction::Lnl { lk, lz } => {
                    let mut v = vec![lk.len() as u64];
                    for c in [lk, lz] {
                        v.extend(c.points().flat_map(|(x, y)| [x.to_bits(), y.to_bits()]));
                    }
                    (4, v)
                }
            };
            let next = classes.len() as u32;
            *classes.entry(key).or_insert(next)
        })
        .collect();
    let law = |d: usize| match net.links[d].law {
        Interaction::Res { .. } => 0u8,
        Interaction::Fro { .. } => 1,
        Interaction::Ref { .. } => 2,
        Interaction::But { .. } => 3,
        Interaction::Lnl { .. } => 4,
    };
    let mut members = vec![0usize; classes.len()];
    for &c in &class {
        members[c as usize] += 1;
    }
    // the group of a link: its law, and its class when that class is big enough
    let group = |d: usize| {
        let c = class[d];
        let c = if members[c as usize] >= UNIFORM_MIN {
            c
        } else {
            u32::MAX
        };
        (law(d), c)
    };
    // groups in order of first appearance
    let mut first: HashMap<(u8, u32), usize> = HashMap::new();
    for d in 0..nl {
        first.entry(group(d)).or_insert(d);
    }
    let groups: Vec<usize> = (0..nl).map(|d| first[&group(d)]).collect();
    // The group of a link's band: with `by_law`, its law's (the links of one law and offset are
    // one band whatever their parameters, so that strings of different stiffnesses make one
    // progression, joined across them by `joined`), else its group.
    let mut law_first = [usize::MAX; 5];
    for d in (0..nl).rev() {
        law_first[law(d) as usize] = d;
    }
    let band_group = |d: usize| {
        if by_law {
            law_first[law(d) as usize]
        } else {
            groups[d]
        }
    };
    // (a foreign id sorts anywhere: `Kernel::new` refuses it right after)
    let end = |id: MatId| slot.get(id.index()).map_or(-1, |&s| i64::from(s));
    let offset = |d: usize| end(net.links[d].b) - end(net.links[d].a);
    let mut per_offset: HashMap<(usize, i64), usize> = HashMap::new();
    for d in 0..nl {
        *per_offset.entry((band_group(d), offset(d))).or_default() += 1;
    }
    let bands: Vec<(usize, i64)> = (0..nl).map(|d| (band_group(d), offset(d))).collect();
    let in_band: Vec<bool> = bands.iter().map(|b| per_offset[b] >= STEP_MIN).collect();
    let placed = placed_in_bands(net, slot, n_mc, &groups, &bands, &in_band, bridge);
    let mut order: Vec<usize> = (0..nl).collect();
    order.sort_by_key(|&d| {
        let (g, o) = bands[d];
        let (a, b) = (end(net.links[d].a), end(net.links[d].b));
        if in_band[d] {
            (g, 0u8, o, a, d)
        } else if let Some((o, key)) = placed[d] {
            // (in the band of a link of its group, so of its law: the same band group)
            (g, 0, o, key, d)
        } else {
            let g = groups[d];
            // by the material that sums the link's force (its mobile end, or the smaller)
            let mobile = |s: i64| s >= 0 && (s as usize) < n_mc;
            match (mobile(a), mobile(b)) {
                (true, false) => (g, 1, 0, a, d),
                (false, true) => (g, 2, 0, b, d),
                _ => (g, 3, 0, a.min(b), d),
            }
        }
    });
    let mut lslot = vec![0u32; nl];
    for (l, &d) in order.iter().enumerate() {
        lslot[d] = l as u32;
    }
    lslot
}

/// Places links that are in no band (see [`link_order`]) inside a band, where a material's sum
/// would have them continue a progression: when link `d` is term `j` of mobile material `m` (its
/// edge list, declaration order), and the nearest material `m'` before `m` (or else after it) of
/// the same degree, within [`NEAR`] slots, has as its term `j` a banded link `d'` of the same group,
/// then `d` takes the band of `d'` and the sort key `key(d') + (m - m')`: the slot that term `j`
/// of `m` would have if the progression of `m'` went on. The grounds of a membrane's border
/// (term "left" of a row's first mass, "up" of the top row's masses...) land just before or after
/// the links of their row or column, so every mass of a row sums unit-step progressions, as in a
/// padded stencil. `groups[d]` is the group of link `d` (its law, and its parameters when they are
/// common), `bands[d]` its band (band group, end offset), `in_band[d]` whether it is in a band.
/// Returns `(band offset, key)` per link (declaration index), `None` when unplaced.
fn placed_in_bands(
    net: &Network,
    slot: &[u32],
    n_mc: usize,
    groups: &[usize],
    bands: &[(usize, i64)],
    in_band: &[bool],
    exclusive: bool,
) -> Vec<Option<(i64, i64)>> {
    let nl = net.links.len();
    let mut placed = vec![None; nl];
    if in_band.iter().all(|&b| b) || !in_band.iter().any(|&b| b) {
        return placed;
    }
    // the edge lists of the mobile materials (links only), by storage slot
    let mobile = |id: MatId| {
        slot.get(id.index())
            .map(|&s| s as usize)
            .filter(|&s| s < n_mc)
    };
    let mut off = vec![0usize; n_mc + 1];
    for link in &net.links {
        for s in [mobile(link.a), mobile(link.b)].into_iter().flatten() {
            off[s + 1] += 1;
        }
    }
    for s in 0..n_mc {
        off[s + 1] += off[s];
    }
    let mut edges = vec![0usize; off[n_mc]];
    let mut cursor = off[..n_mc].to_vec();
    for (d, link) in net.links.iter().enumerate() {
        for s in [mobile(link.a), mobile(link.b)].into_iter().flatten() {
            edges[cursor[s]] = d;
            cursor[s] += 1;
        }
    }
    let terms = |s: usize| &edges[off[s]..off[s + 1]];
    let key = |d: usize| {
        slot.get(net.links[d].a.index())
            .map_or(-1, |&s| i64::from(s))
    };
    // With `exclusive`, the places taken, (group, band offset, key): a link whose place is taken
    // stays unplaced (between two rows of a membrane, the right ground of a row and the left
    // ground of the next both ask for the place after the row; only the first gets it, so that
    // the terms of the next rows stay where the progression of the first puts them, and the
    // membrane is one progression with an exception per row, see `bridged`)
    let mut taken: std::collections::HashSet<(usize, i64, i64)> = (0..nl)
        .filter(|&d| in_band[d])
        .map(|d| (bands[d].0, bands[d].1, key(d)))
        .collect();
    // Two sweeps over the materials (forward: the nearest `m'` before; backward: after), each
    // remembering, per term index, the last material of the current degree whose term is banded.
    let mut last: Vec<Option<(usize, usize)>> = Vec::new();
    for forward in [true, false] {
        last.clear();
        let mut degree = usize::MAX;
        let order: Box<dyn Iterator<Item = usize>> = if forward {
            Box::new(0..n_mc)
        } else {
            Box::new((0..n_mc).rev())
        };
        for m in order {
            let t = terms(m);
            if t.len() != degree {
                degree = t.len();
                last.clear();
                last.resize(degree, None);
            }
            for (j, &d) in t.iter().enumerate() {
                if in_band[d] {
                    last[j] = Some((m, d));
                    continue;
                }
                let Some((m2, d2)) = last[j] else { continue };
                let (g2, o2) = bands[d2];
                let at = key(d2) + m as i64 - m2 as i64;
                if placed[d].is_none()
                    && groups[d] == groups[d2]
                    && m.abs_diff(m2) <= NEAR
                    && (!exclusive || taken.insert((g2, o2, at)))
                {
                    placed[d] = Some((o2, at));
                }
            }
        }
    }
    placed
}

/// True when `m` is a (normal) power of two, so that `f / m == f * (1 / m)` for every `f`: both are
/// the correctly rounded value of the same real number `f * 2^-k`.
fn is_power_of_two(m: f64) -> bool {
    let bits = m.to_bits();
    let exponent = (bits >> 52) & 0x7ff;
    m > 0.0
        && bits & ((1u64 << 52) - 1) == 0
        && exponent != 0
        && exponent != 0x7ff
        && (1.0 / m).is_normal()
}

/// Read access to the positions by storage slot, for the link loops.
///
/// Every slot handed to these methods is an entry of `Kernel::la`/`Kernel::lb`, which
/// `Kernel::new` fills only with `slot_of(..)` values, each asserted `< materials.len()`, or a term
/// `a0 + i sa` of an `Ends::Step` run, which `Kernel::new` asserts equal to the entry of `la`/`lb` it
/// replaces; `Positions::new` asserts that `x` and `xp` have exactly `materials.len()` elements. So
/// every access is in bounds, and the unchecked reads below are sound. `tests/engine.rs` (`engine_refuses_foreign_ids`) checks that a
/// network with an out-of-range id is refused by `Engine::new` before any step.
struct Positions<'a, S = Discard> {
    x: &'a [f64],
    xp: &'a [f64],
    sink: S,
}

impl<'a> Positions<'a> {
    /// # Panics
    /// Unless both buffers have one element per material.
    #[inline]
    fn new(k: &Kernel, x: &'a [f64], xp: &'a [f64]) -> Positions<'a> {
        Positions::with_sink(k, x, xp, Discard)
    }
}

impl<'a, S: Sink> Positions<'a, S> {
    /// [`Positions::new`], with every link force also handed to `sink`.
    #[inline]
    fn with_sink(k: &Kernel, x: &'a [f64], xp: &'a [f64], sink: S) -> Positions<'a, S> {
        assert!(x.len() == k.nm && xp.len() == k.nm);
        Positions { x, xp, sink }
    }

    #[inline(always)]
    fn x(&self, i: u32) -> f64 {
        debug_assert!((i as usize) < self.x.len());
        // SAFETY: `i` is a validated storage slot (see the type's documentation).
        unsafe { *self.x.get_unchecked(i as usize) }
    }

    #[inline(always)]
    fn xp(&self, i: u32) -> f64 {
        debug_assert!((i as usize) < self.xp.len());
        // SAFETY: as for `x`; `xp` has the same length.
        unsafe { *self.xp.get_unchecked(i as usize) }
    }
}

/// Where the link loops also hand each force `f`, with its ends `a`, `b` (storage slots).
trait Sink {
    /// whether `take` does anything (then the kernel has no exceptions, see
    /// `Kernel::make_compact`, and the link loops recompute none)
    const ACCUMULATES: bool;
    fn take(&self, a: u32, b: u32, f: f64);
}

/// Nothing: the materials gather the forces from `sf`.
#[derive(Clone, Copy)]
struct Discard;

impl Sink for Discard {
    const ACCUMULATES: bool = false;
    #[inline(always)]
    fn take(&self, _: u32, _: u32, _: f64) {}
}

/// FORMALISM.md's accumulation: end 1 receives `-f` (`F -= f`), end 2 `+f`, as the links come.
///
/// Every `a`, `b` handed to `take` is a link end from `Kernel::la`/`Kernel::lb` or a term of an
/// `Ends::Step` run equal to one (see [`Positions`]), so `< nm`; `Accumulate::new` asserts that the
/// slice has `nm` elements. So every access is in bounds.
struct Accumulate<'a>(&'a [Cell<f64>]);

impl<'a> Accumulate<'a> {
    fn new(k: &Kernel, acc: &'a mut [f64]) -> Accumulate<'a> {
        assert!(acc.len() == k.nm);
        Accumulate(Cell::from_mut(acc).as_slice_of_cells())
    }
}

impl Sink for Accumulate<'_> {
    const ACCUMULATES: bool = true;
    #[inline(always)]
    fn take(&self, a: u32, b: u32, f: f64) {
        debug_assert!((a.max(b) as usize) < self.0.len());
        // SAFETY: `a` and `b` are validated storage slots (see the type's documentation).
        let (fa, fb) = unsafe {
            (
                self.0.get_unchecked(a as usize),
                self.0.get_unchecked(b as usize),
            )
        };
        fa.set(fa.get() - f);
        fb.set(fb.get() + f);
    }
}

/// Read access to the whole `sf` buffer by edge index, for the gather.
///
/// Every index handed to `get` is an entry of `Kernel::eidx` (outside the progressions, where
/// there is no `NEG`), which `Kernel::new` asserts to be `< sf_len` once `NEG` is cleared, or, with
/// `NEG` cleared, a term `base + i step` of a segment's progression, which `Kernel::new` asserts
/// equal to the entry of `eidx` it replaces; `materials_phase` asserts that the slice has exactly `sf_len` elements (it is always
/// the whole `State::sf`, allocated with that length and never resized). So every read is in
/// bounds. `tests/engine.rs` and `tests/parallel.rs` step every module type through this path.
#[derive(Clone, Copy)]
struct Forces<'a>(&'a [f64]);

/// The bit of an edge that says "negate the slot" (the material is end 1 of the link).
const NEG: u32 = 1 << 31;

impl Forces<'_> {
    /// Slot `j` (without `NEG`).
    #[inline(always)]
    fn get(&self, j: u32) -> f64 {
        debug_assert!((j as usize) < self.0.len());
        // SAFETY: `j` is a validated slot (see the type's documentation).
        unsafe { *self.0.get_unchecked(j as usize) }
    }
}

/// `(slot, sign mask)` of an edge: the slot without `NEG`, and the bit to flip the sign by
/// (negation is exact).
#[inline(always)]
fn signed(j: u32) -> (u32, u64) {
    (j & !NEG, u64::from(j >> 31) << 63)
}

/// One block stepped by the pool's threads in lock-step (see `parallel.rs` for the discipline).
///
/// The work of a phase is cut into chunks: the link chunks of every part (runs, whose slots `l`
/// of `sf` they write) and its material chunks (storage slots, whose next position
/// they write in `pos[next]`). Each thread claims its own part's chunks first, then whatever is
/// left of the others', each to exactly one thread per step ([`Claim::claimed`]; the link chunks
/// in their order, the material chunks last first). Thread `t` also
/// writes the slots `nl + enf` of its part, and copies `mats` of its part into the snapshot
/// before the first step. Per step `n`, with `cur`, `prev`, `next` the [`Roles`] of step `n`:
///
/// | phase | reads (everyone) | writes (the claimer of a chunk only) |
/// | --- | --- | --- |
/// | links (then barrier) | `pos[cur]`, `pos[prev]` | the chunk's slots of `sf` |
/// | materials (then barrier) | `pos[cur]`, `pos[prev]`, `sf` | the chunk's slots of `pos[next]` |
///
/// Thread 0 also records the outputs during the materials phase: it reads only `pos[cur]` and the
/// link slots of `sf`, which nobody writes in that phase. The snapshot copies read the position
/// buffers, which nobody writes before the first barrier. So within a phase no element is written
/// by one thread and accessed by another, and the barriers order the phases.
///
/// Which thread computes a chunk changes no bit of the result: a link's force and a material's
/// sum and update are each computed from the same inputs in the same order, whoever does it.
struct Job<'a> {
    k: &'a Kernel,
    pos: [SharedBuf; 3],
    sf: SharedBuf,
    snap: [SharedBuf; 2],
    claims: &'a [Claim],
    n0: u64,
    frames: usize,
    channels: usize,
}

impl Task for Job<'_> {
    fn run(&self, t: usize, barrier: &SpinBarrier) -> Result<(), Poisoned> {
        self.run_share(t, None, barrier)
    }
}

impl Job<'_> {
    /// Thread `t`'s share of the block, compiled for the CPU's vector instructions; thread 0
    /// passes the output buffer. Not inlined: the calling thread and the workers run one
    /// compiled copy (inlined into both, the step without vectors was compiled twice).
    #[inline(never)]
    fn run_share(
        &self,
        t: usize,
        out: Option<&mut [f64]>,
        barrier: &SpinBarrier,
    ) -> Result<(), Poisoned> {
        let share = Share {
            job: self,
            t,
            out,
            barrier,
        };
        vectorised(self.k.simd, share)
    }

    #[inline(always)]
    fn run_part(
        &self,
        t: usize,
        mut out: Option<&mut [f64]>,
        barrier: &SpinBarrier,
    ) -> Result<(), Poisoned> {
        let k = self.k;
        let part = &k.parts[t];
        let nl = k.nl;
        let mats = part.mats.clone();
        let r0 = Roles::of(self.n0);
        let mut r = r0;
        // SAFETY (all blocks below): each access follows the table in the type's documentation:
        // shared reads of buffers nobody writes in the current phase, exclusive writes to the
        // ranges of a chunk this thread claimed (disjoint from every other chunk's:
        // `Kernel::partition` gives each link to exactly one part and `Kernel::chunk` each run
        // piece and material of a part to exactly one chunk, and `0..enf.len()` and `0..n_mce`
        // are cut into consecutive ranges; `parts_own_every_link_once` tests it), and every slice
        // is dropped before the barrier that ends its phase.
        unsafe {
            let (x, xp) = (self.pos[r0.cur].read(), self.pos[r0.prev].read());
            self.snap[0]
                .write(mats.clone())
                .copy_from_slice(&x[mats.clone()]);
            self.snap[1]
                .write(mats.clone())
                .copy_from_slice(&xp[mats.clone()]);
        }
        let parts = &k.parts;
        let threads = parts.len();
        for s in 0..self.frames {
            let n = self.n0 + s as u64;
            // SAFETY: links phase (see above).
            unsafe {
                let (cur, prev) = (self.pos[r.cur].read(), self.pos[r.prev].read());
                let state = Positions::new(k, cur, prev);
                let chunks = |q: usize| parts[q].link_chunks.len();
                for (q, j) in Claim::claimed(&self.claims[..threads], t, s, chunks) {
                    for run in &parts[q].runs[parts[q].link_chunks[j].clone()] {
                        let lf = self.sf.write(run.start..run.end);
                        k.run_links(run, &state, lf);
                    }
                }
                let ef = self.sf.write(nl + part.enf.start..nl + part.enf.end);
                k.inputs(part.enf.clone(), n, ef);
            }
            barrier.wait()?;
            // SAFETY: materials phase (see above).
            unsafe {
                let (cur, prev, sf) = (
                    self.pos[r.cur].read(),
                    self.pos[r.prev].read(),
                    self.sf.read(),
                );
                if let Some(out) = out.as_deref_mut() {
                    let ch = self.channels;
                    k.record(cur, &sf[..nl], &mut out[s * ch..(s + 1) * ch]);
                }
                // (last chunk first: the links phase went up its part, so the materials phase
                // starts where the forces and positions it just touched are still in the cache,
                // and ends where the next step's links phase starts)
                let claims = &self.claims[threads..2 * threads];
                let chunks = |q: usize| parts[q].mat_chunks.len();
                for (q, j) in Claim::claimed(claims, t, s, chunks) {
                    let own = &parts[q].mat_chunks;
                    let mats = own[own.len() - 1 - j].clone();
                    let next = self.pos[r.next].write(mats.clone());
                    let seg = k.first_segment(mats.start);
                    k.materials_phase(mats, seg, n, (cur, prev), next, Forces(sf));
                }
            }
            barrier.wait()?;
            r = Roles::at(r.next);
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests;
