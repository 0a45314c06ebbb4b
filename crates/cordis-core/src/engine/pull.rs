//! The pull step: each MAS computes the forces of its own links, eight MAS at a time.
//!
//! A network without locality (a random network, an irregular instrument of springs and
//! dampers) has no progressions for the vector loops: the gather and the compact step read
//! every link's ends through index lists, one scalar at a time, and scatter or gather its force
//! through another. The pull step drops the force buffer instead. Eight MAS of one *group*
//! (consecutive storage slots; storage orders the MAS near their neighbours, and by degree and
//! the kinds of their terms within windows, `Mobiles::Local`, so a group's MAS have about as many
//! links, the pairs they read are near each other, and a row's terms tend to be of one kind) sum
//! their forces side by side: term `r` of every lane is that MAS's `r`-th link in FORMALISM.md's
//! order, computed from the MAS's own side,
//!
//! `g = K (x_i - x_j) + Z (v_i - v_j)`, with `v = x(n) - x(n-1)`, and `F = F - g`,
//!
//! where `j` is the link's other end, whose `x(n)` and `v(n)` sit side by side in a *pair*
//! buffer, so that one 16-byte load fetches both from one cache line. Each link is computed
//! twice (once from each end), and no force is stored or read back.
//!
//! **Why the bits are the reference's.** FORMALISM.md sums `F(n)` from `+0.0`, adding `-f` for
//! every link where the material is end 1 and `+f` where it is end 2, in declaration order, then
//! the ENF inputs. Where the MAS is end 1, `g` is the reference's `f`, operand for operand
//! (`v_i - v_j` is `(x1 - x1') - (x2 - x2')`, whether `v` is computed once per material or once
//! per link), so `F - g` is `F + (-f)`. Where it is end 2, `g` is `f` with every difference
//! reversed: IEEE subtraction rounds `a - b` and `b - a` to values of opposite sign and equal
//! magnitude, products and sums of negated operands are the negated products and sums, so `g =
//! -f` and `F - g = F + f`; only a zero may come out as `+0.0` on one side and `-0.0` on the
//! other, and adding a zero of either sign to a sum started at `+0.0` gives the same sum (a sum
//! started at `+0.0` is never `-0.0`). A RES (FRO) term has its damper (spring) product masked to
//! `+0.0` (`_mm512_maskz_mul_pd`): the same sum again, and no `0 x inf` where the reference has no
//! such product. Padding terms (lanes with fewer links than the group's most) are fully masked:
//! `F - (+0.0) = F`. So every `F(n)`, then every `x(n+1)` (the update's expressions as in
//! `engine.rs`), has the reference's bits; `tests/engine.rs` checks them step by step.
//!
//! RES, FRO and REF forces are odd in the ends' order. BUT and LNL forces are not (a BUT is
//! oriented, an LNL's curves need not be odd), so a lane whose MAS is end 2 of such a link
//! computes it from the reference's operands, negated exactly, and negates the force: BUT terms
//! in [`sum_but`] (with the threshold's sign turned, and the contact test read from the sign of
//! `d + S`), LNL terms in [`sum_lnl`] (eight at a time as the grid step evaluates them); each
//! function proves its bits. A network of several pairs of LNL curves evaluates them as one shape,
//! each curve padded to the most points of any (the same bits: `ExactCurve::padded`); a row reads
//! its pair from a table, or evaluates each of its pairs and keeps each in its lanes when its LNL
//! lanes have several ([`RowCurves`]), except in long runs of groups of one pair, which are summed
//! as a network of that pair ([`Pull::runs`]). A network with BUT and LNL links both sums its rows
//! as an LNL network does, and a row with BUT lanes computes them as `sum_but` does. The kind of terms a
//! network has ([`Terms`]: springs and dampers, with BUTs, or with LNLs, and BUTs if it has them,
//! of one pair or of a table) chooses the sum once per step; a network with LNL curves that do not
//! evaluate eight at a time or do not pad to one point count (a zero curve among curves that are
//! not), or pairs of curves mixed in most rows whose forces are not stored (below), keeps the
//! other steps. A pair of curves of more
//! than 16 points is evaluated as it is ([`LongCurves`], `curve.rs`'s `WideLong`): as the
//! network's pair when it is the only one; among others, in its own runs of groups, and as one
//! of the table's pairs ([`LONGS`], [`long_forces`]). The loads and shuffles are AVX-512 (the
//! CPU's proof is an [`Avx512`] token). A CPU with AVX2 but not AVX-512 takes the same networks
//! and rows four lanes at a time ([`avx2`]); without either the network keeps the compact or
//! gather step.
//!
//! **LNL forces stored.** Computed from both ends, a link of curves costs two
//! evaluations of them, most of its time for a long curve. So the step of a network of LNL
//! curves ([`Pull::stored`]) evaluates each LNL link once a step, before the rows, eight links of
//! one pair at a time from their ends' pairs ([`Pull::store_forces`]: the reference's `d = x1 -
//! x2` and `v = v1 - v2`, and the pair's bits of `LK(d) + LZ(v)`, the reference's `f`; with
//! several pairs, the links in runs of one pair, [`Pull::stored_runs`], each run padded to whole
//! chunks, so not where that would more than double the links evaluated), and stores the forces
//! past the pairs in the pair buffer. An LNL lane's row offset names its link's force:
//! the row's 16-byte load brings `f` where a pair's `x` would be, and the lane takes `f`, negated
//! where its MAS is end 2, the value its two evaluations gave (the same bits). On threads, each
//! thread stores the forces of its share of the links, and a barrier orders them before the rows
//! ([`PullJob`]). No row evaluates a pair then, so the table, the parts and the runs of several
//! pairs are not built, and networks of pairs mixed in most rows take the step too. Measured in
//! docs/BENCHMARKS-LOG.md, fifty-seventh session, on AVX2: 1.2x on a random network of 3-point
//! curves, 1.65x with 33 points; fifty-eighth: two pairs mixed link by link 1.77x; seventy-sixth,
//! on AVX-512 ([`Pull::store_forces_avx512`]): 1.0x with 3 points, 1.17x with 7, 1.46x with 33,
//! two pairs mixed 1.34x, and no network slower.
//!
//! CEL (few in practice) pull their terms one at a time with the same expressions; ENX read
//! their signal; SOL never change. The pair buffers are rebuilt from the positions at the start
//! of every block, so the pull step and the other steps can take turns on one state.

#[cfg(target_arch = "x86_64")]
use std::arch::x86_64::*;

use std::collections::HashMap;
#[cfg(target_arch = "x86_64")]
use std::hint::black_box;
use std::ops::Range;

use crate::curve::Curve;
use crate::parallel::{Poisoned, SharedBuf, SpinBarrier, Task};

use super::{AnyPair, Claim, ExactPair, Kernel, Law, Lnl, MasLaw, PairFn, Roles, Simd};
use super::{Recorded, State, NEG};
#[cfg(target_arch = "x86_64")]
use crate::curve::{exact_len, ExactCurve, WideCurve, WideLong};
use crate::lanes::Avx512;
#[cfg(target_arch = "x86_64")]
use crate::wide::V8;

#[cfg(target_arch = "x86_64")]
mod avx2;

/// The vector instructions a pull step is compiled for.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Isa {
    /// (with the CPU's proof)
    Avx512(Avx512),
    /// Made only where the CPU has AVX2: [`Simd::detect`](super::Simd) found it, or a test
    /// asked for it on a CPU that has it (`Engine::new_for`, whatever `CORDIS_SIMD` allows).
    Avx2,
}

/// [`Pull::row_curves`] of a row with no LNL lane.
const NO_LNL: u32 = u32::MAX;
/// The fewest groups in a run of one pair ([`Pull::runs`]): a shorter run reads its pair from the
/// table, row by row. (A run is a call of the group loop of its own, with the pair's curves
/// broadcast at its start.)
const MIN_RUN: usize = 8;

/// The bit of [`Pull::row_curves`] that marks a row whose LNL lanes have several pairs of curves.
const PARTS: u32 = 1 << 31;

/// The pairs of curves of more than 16 points ([`Pull::longs`]): pair `i`'s number in
/// [`CelTerms::lnls`] and its position in the table in [`Pull::row_curves`], [`Pull::parts`] and
/// [`Pull::runs`] are `LONGS + i` (it is not in the table; every other pair's number and
/// position is smaller, and every such number below [`PARTS`], checked in `Pull::new`).
const LONGS: u32 = PARTS - (1 << 20);

/// MAS per group: the lanes of one AVX-512 vector.
const LANES: usize = 8;

/// Fewest MAS for the pull step (below, one group would hold every MAS, and the compact step is
/// as fast).
pub(super) const PULL_MIN: usize = 2 * LANES;

/// MAS per chunk of groups on threads (see [`Pull::partition`]): a few hundred microseconds of
/// work on a scattered network, against a claim's tens of nanoseconds; more chunks let a thread
/// take over more of the other's groups when the other's core runs slower.
const CHUNK_MAS: usize = 4096;
/// Fewest chunks per thread, where there are groups enough (so that the tests' networks claim
/// chunks too).
const CHUNKS_MIN: usize = 4;

/// Term `r` of the eight lanes of a group.
#[derive(Clone, Copy, Debug)]
struct Row {
    /// Where the other end's pair is: its byte offset in a pair buffer, `16 s` for storage slot
    /// `s < nm` (checked in `Pull::new`). A padding term names the lane's own MAS, or slot 0.
    at: [u32; LANES],
    /// The lanes whose term has a spring (`K d`), a damper (`Z v`).
    k: u8,
    z: u8,
    /// The lanes whose term is a BUT, and those of them where the lane's MAS is the link's end 2
    /// (see [`sum_but`]).
    b: u8,
    flip: u8,
}

/// A piece of the work of a step: the MAS of `groups`, and the CEL and ENX when `slots` (the
/// storage slots whose `x(n+1)` it writes) reach past the MAS.
#[derive(Clone, Debug)]
pub(super) struct Share {
    pub(super) groups: Range<usize>,
    pub(super) slots: Range<usize>,
}

/// The terms of the CELs, in their summing order, as runs of one kind: CEL `c`'s runs are
/// `runs[off[c]..off[c + 1]]`, each `(kind, count)` taking the next `count` terms of the list of
/// its kind, CEL after CEL. A run is a loop over one kind of term, with no choice between kinds
/// in it: term by term, the three CELs of the reconfigurable instrument (eleven links each) took
/// a fifth of its pull step's time (docs/BENCHMARKS-LOG.md, fiftieth session).
#[derive(Clone, Debug)]
struct CelTerms {
    off: Vec<u32>,
    runs: Vec<(CelKind, u32)>,
    /// RES, FRO and REF links' `g` from the CEL's side: the other end (storage slot), `K`, `Z`
    springs: Vec<(u32, f64, f64)>,
    /// BUTs' `g` from the CEL's side: the other end, `K`, `Z`, the threshold `S` (negated where
    /// the CEL is end 2), and whether it is end 2
    buts: Vec<(u32, f64, f64, f64, bool)>,
    /// LNLs' `g` from the CEL's side: the other end, whether the CEL is end 2, and the link's
    /// pair of curves (as [`Pull::pair_force`] takes it)
    lnls: Vec<(u32, bool, u32)>,
    /// ENF inputs (their samples are added)
    inputs: Vec<u32>,
}

/// The kind of a run of [`CelTerms`]: a law, or inputs.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum CelKind {
    Res,
    Fro,
    Ref,
    But,
    Lnl,
    Input,
}

impl CelTerms {
    /// Appends a term of kind `kind` (already pushed onto its list) to the CEL being built.
    fn push(&mut self, kind: CelKind) {
        let first = *self.off.last().expect("`off` starts with 0") as usize;
        match self.runs[first..].last_mut() {
            Some((last, count)) if *last == kind => *count += 1,
            _ => self.runs.push((kind, 1)),
        }
    }

    /// Whether the runs take exactly the terms of each list, and every slot and number in them
    /// is below its bound: `nm` materials, `enf` inputs, and the pairs `known`.
    fn fits(&self, nm: usize, enf: usize, known: impl Fn(u32) -> bool) -> bool {
        let taken = |kinds: &[CelKind]| -> usize {
            let runs = self.runs.iter().filter(|(kind, _)| kinds.contains(kind));
            runs.map(|&(_, count)| count as usize).sum()
        };
        let springs = [CelKind::Res, CelKind::Fro, CelKind::Ref];
        taken(&springs) == self.springs.len()
            && taken(&[CelKind::But]) == self.buts.len()
            && taken(&[CelKind::Lnl]) == self.lnls.len()
            && taken(&[CelKind::Input]) == self.inputs.len()
            && self.off.last() == Some(&(self.runs.len() as u32))
            && self.springs.iter().all(|&(j, ..)| (j as usize) < nm)
            && self.buts.iter().all(|&(j, ..)| (j as usize) < nm)
            && (self.lnls.iter()).all(|&(j, _, pair)| (j as usize) < nm && known(pair))
            && self.inputs.iter().all(|&i| (i as usize) < enf)
    }
}

/// The next `count` of `list` from `at`, which moves past them.
#[inline(always)]
fn take<'a, T>(list: &'a [T], at: &mut usize, count: u32) -> &'a [T] {
    let start = *at;
    *at += count as usize;
    &list[start..*at]
}

/// The pull step of a network of RES, FRO, REF links and BUT or LNL ones (see the module
/// documentation).
#[derive(Clone, Debug)]
pub(super) struct Pull {
    isa: Isa,
    /// Group `g` is MAS `LANES g..` (storage slots; the last group may be partial); its terms
    /// are `rows[bounds[g]..bounds[g + 1]]`.
    bounds: Vec<u32>,
    rows: Vec<Row>,
    /// `K` and `Z` of each row's lanes, or a single row when every term has the same.
    params: Vec<[[f64; LANES]; 2]>,
    /// The `S` of each row's BUT lanes, negated where the lane's MAS is end 2 (`0.0` in the
    /// other lanes), when the network has a BUT; else empty.
    thresholds: Vec<[f64; LANES]>,
    /// When the network has LNL links (of curves that evaluate eight at a time): their pair of
    /// curves when they share one of at most 16 points; with several pairs, the first such pair
    /// padded to the point counts of the `table` ([`ExactPair::padded`]), or the zero pair when
    /// every pair is long, the loop's shape; `None` for one long pair ([`Pull::longs`]).
    curves: Option<ExactPair>,
    /// The network's distinct pairs of LNL curves of at most 16 points, as declared (the CEL's
    /// terms evaluate them).
    pairs: Vec<ExactPair>,
    /// The network's distinct pairs of LNL curves of more than 16 points (each of which evaluates
    /// several at a time, [`AnyPair::widens`]), as declared, pair `i` numbered [`LONGS`]` + i`.
    /// One alone is the network's pair (`pairs` and `curves` are empty); with others, the table
    /// holds the others, and its rows, parts and runs name each long pair by its number.
    longs: Vec<AnyPair>,
    /// Whether the network has several pairs (long ones among them or not): then each row reads
    /// its own ([`CurveTable`], [`Pull::runs`]).
    several: bool,
    /// Whether the network has RES or FRO links, whose rows the AVX2 step computes with the
    /// masks of their springs and dampers (`avx2::products`; the AVX-512 step always masks).
    masked: bool,
    /// With several pairs and the forces not stored ([`Pull::stored`]): each pair of at most 16
    /// points padded to the most points of any ([`ExactPair::write`]), one after another; else
    /// empty.
    table: Vec<f64>,
    /// With several pairs and the forces not stored, the LNL curves of each row
    /// ([`RowCurves`]): [`NO_LNL`] when the row has no LNL lane; the position in `table` of the
    /// pair of all its LNL lanes when they share one; else [`PARTS`] and the position in `parts`
    /// of the row's *parts*. Else empty.
    row_curves: Vec<u32>,
    /// Runs of parts, each part the position of a pair in `table` and the row's LNL lanes of that
    /// pair, a run ended by lanes `0`.
    parts: Vec<(u32, u8)>,
    /// With several pairs and the forces not stored, the groups in runs, each `(end, pair)`: the
    /// groups from the previous run's end (or 0) to `end`, whose LNL lanes all have the pair at
    /// `pair` in `table`, summed as in a network of that one pair ([`Curves`], the curves in
    /// registers), or (`None`) whose rows read their pairs from the table ([`CurveTable`]). Else
    /// empty. A group with no LNL lane joins the run before it; a run of one pair has at least
    /// [`MIN_RUN`] groups.
    runs: Vec<(u32, Option<u32>)>,
    /// Whether every row computes the kind of terms that only some rows may have: the BUTs of a
    /// BUT network ([`sum_but`]), the springs, dampers and BUTs of an LNL network ([`sum_lnl`]). If
    /// not, a row computes them only if it has one ([`Pull::computes_full_rows`] decides).
    full_rows: bool,
    /// ENF inputs of group `g`: `enf[enf_bounds[g]..enf_bounds[g + 1]]`, `(lane, input)` in the
    /// order they are summed.
    enf_bounds: Vec<u32>,
    enf: Vec<(u8, u32)>,
    /// The terms of the CELs (storage slots `n_mas..n_mc`).
    cel: CelTerms,
    /// The links the outputs read: computed before each step's outputs.
    recorded: Vec<Recorded>,
    /// When the step evaluates each LNL link once a step ([`Pull::store_forces`]): the
    /// byte offsets of the pairs of its ends 1 and 2, eight links a chunk, the links of one pair
    /// of curves after another ([`Pull::stored_runs`], each pair's last chunk padded with links
    /// from pair 0 to pair 0), link `i` of the list storing its force into `f64` number `2 nm +
    /// i` of the pair buffer, which its lanes' rows read. Else empty. Every offset is `16 j` for
    /// a pair `j < nm` ([`Pull::stored_within`]).
    stored: Vec<[[u32; LANES]; 2]>,
    /// `nm`, the pairs the offsets of [`Pull::stored`] lie within (asserted in
    /// [`Pull::build`]): [`Pull::store_forces`] asserts its pairs have as many, once a call, and
    /// reads the chunks' pairs unchecked (checked chunk by chunk, the store pass ran 1.41x the
    /// instructions and 0.95x the speed, sixtieth session).
    stored_within: usize,
    /// The chunks of [`Pull::stored`] in runs of one pair of curves, each `(end, pair)`: the
    /// chunks from the previous run's end (or 0) to `end` are links of `pair` (its number in
    /// [`CelTerms::lnls`]: a position in [`Pull::pairs`], or [`LONGS`]` + i` for long pair `i`).
    stored_runs: Vec<(u32, u32)>,
}

impl Pull {
    /// The pull step of `k`, if it can take one: the kernel is compiled for AVX-512 or for AVX2
    /// ([`avx2`]), the network's LNL curves evaluate several at a time
    /// ([`ExactCurve::widens`], [`AnyPair::widens`]), those of at most 16 points pad to one point
    /// count ([`ExactPair::padded`]), the pairs do not mix in most rows unless the forces are
    /// stored ([`Pull::stored`]), and there are at least [`PULL_MIN`] MAS.
    pub(super) fn new(k: &Kernel) -> Option<Pull> {
        Pull::build(k, true)
    }

    /// [`Pull::new`], with the LNL forces stored only if `may_store` ([`Pull::stored`]): the
    /// tests take the step's other ways of evaluating curves (the table, runs of one pair)
    /// on networks that would store them.
    fn build(k: &Kernel, may_store: bool) -> Option<Pull> {
        let isa = match k.simd {
            #[cfg(target_arch = "x86_64")]
            Simd::Avx512(cpu) => Isa::Avx512(cpu),
            #[cfg(target_arch = "x86_64")]
            Simd::Avx2 => Isa::Avx2,
            Simd::None => return None,
        };
        if k.n_mas < PULL_MIN || k.nm >= 1 << 28 {
            return None; // (`Row::at` is a 32-bit byte offset)
        }
        let mut law = vec![Law::Ref; k.nl];
        for run in &k.whole.runs {
            law[run.start..run.end].fill(run.law);
        }
        let has_k = |l: Law| matches!(l, Law::Res | Law::Ref | Law::But);
        let has_z = |l: Law| matches!(l, Law::Fro | Law::Ref | Law::But);
        // The distinct pairs of LNL curves, each of which evaluates eight at a time, and the
        // pair of each LNL law (`pair_of`, by index in `k.lnl`).
        let mut pairs: Vec<ExactPair> = Vec::new();
        let mut pair_of = vec![u32::MAX; k.lnl.len()];
        let mut seen: HashMap<Vec<u64>, u32> = HashMap::new();
        let mut longs: Vec<AnyPair> = Vec::new();
        for l in (0..k.nl).filter(|&l| law[l] == Law::Lnl) {
            let i = k.lnl_of[l] as usize;
            if pair_of[i] != u32::MAX {
                continue;
            }
            let pair = match &k.lnl[i] {
                Lnl::Exact(pair) => pair,
                Lnl::Any(any) => {
                    if !any.widens() {
                        return None;
                    }
                    let j = match longs.iter().position(|one| one.same_bits(any)) {
                        Some(j) => j,
                        None if longs.len() < (PARTS - LONGS) as usize => {
                            longs.push((**any).clone());
                            longs.len() - 1
                        }
                        None => return None,
                    };
                    pair_of[i] = LONGS + j as u32;
                    continue;
                }
            };
            if !pair.widens() {
                return None;
            }
            // (the point counts, then the numbers' bits: the same key for the same curves)
            let (a, b) = pair.counts();
            let mut numbers = Vec::new();
            pair.write(&mut numbers);
            let key = [a as u64, b as u64]
                .into_iter()
                .chain(numbers.iter().map(|v| v.to_bits()))
                .collect();
            pair_of[i] = *seen.entry(key).or_insert_with(|| {
                pairs.push(*pair);
                (pairs.len() - 1) as u32
            });
        }
        let lnl_pair = |l: usize| pair_of[k.lnl_of[l] as usize];
        // (the forces stored, but not when the pairs have so few links each that padding their
        // chunks would evaluate more than twice as many)
        let mut per_pair: HashMap<u32, usize> = HashMap::new();
        for l in (0..k.nl).filter(|&l| law[l] == Law::Lnl) {
            *per_pair.entry(lnl_pair(l)).or_default() += 1;
        }
        let links: usize = per_pair.values().sum();
        let padded: usize = per_pair.values().map(|n| LANES * n.div_ceil(LANES)).sum();
        let store = may_store && links > 0 && padded <= 2 * links;
        // Several pairs evaluate as one shape: the smallest that has the most points of any,
        // each padded to it (the long pairs are evaluated as they are). Only rows that evaluate
        // pairs read the table: with the forces stored, it stays empty (but the pairs pad to
        // the shape all the same, so that whether a network takes the step does not change).
        let (a, b) = (pairs.iter().map(ExactPair::counts))
            .fold((0, 0), |(a, b), (x, y)| (a.max(x), b.max(y)));
        let (a, b) = ExactPair::shape(a, b)?;
        let mut table = Vec::new();
        let several = pairs.len() + longs.len() > 1;
        let curves = match &pairs[..] {
            [] if !several => None,
            // (every pair long: the loop's shape is the zero pair's, and the table is empty)
            [] => ExactPair::new(&Curve::zero(), &Curve::zero()),
            [one] if !several => Some(*one),
            [first, ..] => {
                for pair in &pairs {
                    let padded = pair.padded(a, b)?;
                    if !store {
                        padded.write(&mut table);
                    }
                }
                Some(first.padded(a, b)?)
            }
        };
        if table.len() >= LONGS as usize {
            return None; // (`row_curves` are 31-bit positions, and none a long pair's)
        }
        // The terms of mobile material `s`, in summing order: `Ok((other end, link, end 1))`, with
        // whether `s` is end 1, then `Err(input)`.
        let terms = |s: usize| {
            let edges = &k.eidx[k.eoff[s] as usize..k.eoff[s + 1] as usize];
            edges.iter().map(move |&e| {
                let l = (e & !NEG) as usize;
                if l >= k.nl {
                    Err((l - k.nl) as u32)
                } else if e & NEG != 0 {
                    Ok((k.lb[l], l, true)) // the material is end 1
                } else {
                    Ok((k.la[l], l, false))
                }
            })
        };
        // (an LNL lane reads no `K` or `Z`: the rows share theirs when the other links do)
        let kz = |l: usize| (k.lk[l].to_bits(), k.lz[l].to_bits());
        let mut spring_links = (0..k.nl).filter(|&l| law[l] != Law::Lnl);
        let first = spring_links.next();
        let uniform = spring_links.all(|l| Some(kz(l)) == first.map(kz));
        let but = law.contains(&Law::But);
        // (the threshold from the lane's side: `S` where its MAS is end 1, `-S` where end 2)
        let threshold = |l: usize, end1: bool| if end1 { k.ls[l] } else { -k.ls[l] };

        let mut p = Pull {
            isa,
            bounds: vec![0],
            rows: Vec::new(),
            params: Vec::new(),
            enf_bounds: vec![0],
            enf: Vec::new(),
            thresholds: Vec::new(),
            curves,
            pairs,
            longs,
            several,
            masked: law.iter().any(|&l| matches!(l, Law::Res | Law::Fro)),
            table,
            row_curves: Vec::new(),
            parts: Vec::new(),
            runs: Vec::new(),
            full_rows: false,
            cel: CelTerms {
                off: vec![0],
                runs: Vec::new(),
                springs: Vec::new(),
                buts: Vec::new(),
                lnls: Vec::new(),
                inputs: Vec::new(),
            },
            recorded: Vec::new(),
            stored: Vec::new(),
            stored_within: k.nm,
            stored_runs: Vec::new(),
        };
        // (the LNL links' numbers in `stored`, in the order the rows first name them, so that a
        // group's forces are near each other, with each link's pair; `u32::MAX` until named;
        // renumbered pair by pair after the rows)
        let mut stored_at = vec![u32::MAX; if store { k.nl } else { 0 }];
        let mut stored_ends: Vec<([u32; 2], u32)> = Vec::new();
        let forces_at = 16 * k.nm as u64;
        // (each pair's links padded to whole chunks)
        let most = padded as u64 + 2 * LANES as u64;
        if forces_at + 8 * most > u64::from(u32::MAX) {
            return None; // (`Row::at` is a 32-bit byte offset)
        }
        if uniform {
            let (kk, zz) = first.map_or((0.0, 0.0), |l| (k.lk[l], k.lz[l]));
            p.params.push([[kk; LANES], [zz; LANES]]);
        }
        // (with several pairs and the forces not stored: the parts of the rows, and the rows with
        // an LNL lane)
        let mut evaluations = [0, 0];
        for g in 0..k.n_mas.div_ceil(LANES) {
            let lanes = LANES * g..(LANES * (g + 1)).min(k.n_mas);
            let links: Vec<Vec<(u32, usize, bool)>> = lanes
                .clone()
                .map(|s| terms(s).filter_map(Result::ok).collect())
                .collect();
            let depth = links.iter().map(Vec::len).max().unwrap_or(0);
            for r in 0..depth {
                let mut row = Row {
                    at: [0; LANES],
                    k: 0,
                    z: 0,
                    b: 0,
                    flip: 0,
                };
                let mut params = [[0.0; LANES]; 2];
                let mut thresholds = [0.0; LANES];
                // (the row's LNL lanes of each pair, in the order of their first lane; only
                // read with several pairs and the forces not stored)
                let mut parts: Vec<(u32, u8)> = Vec::new();
                for (i, s) in lanes.clone().enumerate() {
                    let mut other = s as u32; // padding: the lane's own MAS, masked off
                    if let Some(&(o, l, end1)) = links[i].get(r) {
                        other = o;
                        row.k |= u8::from(has_k(law[l])) << i;
                        row.z |= u8::from(has_z(law[l])) << i;
                        params[0][i] = k.lk[l];
                        params[1][i] = k.lz[l];
                        if matches!(law[l], Law::But | Law::Lnl) {
                            row.b |= 1 << i;
                            row.flip |= u8::from(!end1) << i;
                        }
                        if law[l] == Law::But {
                            thresholds[i] = threshold(l, end1);
                        }
                        if law[l] == Law::Lnl && p.several && !store {
                            let pair = lnl_pair(l);
                            match parts.iter_mut().find(|(p, _)| *p == pair) {
                                Some((_, lanes)) => *lanes |= 1 << i,
                                None => parts.push((pair, 1 << i)),
                            }
                        }
                    }
                    assert!((other as usize) < k.nm);
                    row.at[i] = 16 * other;
                    if let Some(&(_, l, _)) = links[i].get(r).filter(|_| store) {
                        if law[l] == Law::Lnl {
                            if stored_at[l] == u32::MAX {
                                stored_at[l] = stored_ends.len() as u32;
                                stored_ends.push(([16 * k.la[l], 16 * k.lb[l]], lnl_pair(l)));
                            }
                            // (checked above: below `u32::MAX`)
                            row.at[i] = (forces_at + 8 * u64::from(stored_at[l])) as u32;
                        }
                    }
                }
                p.rows.push(row);
                if p.several && !store {
                    evaluations[0] += parts.len();
                    evaluations[1] += usize::from(!parts.is_empty());
                    let at = |pair: u32| match pair {
                        LONGS.. => pair,
                        _ => pair * (exact_len(a) + exact_len(b)) as u32,
                    };
                    p.row_curves.push(match parts[..] {
                        [] => NO_LNL,
                        [(pair, _)] => at(pair),
                        _ => {
                            let start = p.parts.len() as u32;
                            p.parts
                                .extend(parts.iter().map(|&(pair, lanes)| (at(pair), lanes)));
                            p.parts.push((0, 0));
                            PARTS | start
                        }
                    });
                }
                if !uniform {
                    p.params.push(params);
                }
                if but {
                    p.thresholds.push(thresholds);
                }
            }
            p.bounds.push(p.rows.len() as u32);
            for (i, s) in lanes.enumerate() {
                p.enf
                    .extend(terms(s).filter_map(Result::err).map(|e| (i as u8, e)));
            }
            p.enf_bounds.push(p.enf.len() as u32);
        }
        for s in k.n_mas..k.n_mc {
            let cel = &mut p.cel;
            for t in terms(s) {
                let kind = match t {
                    Ok((other, l, end1)) if law[l] == Law::But => {
                        let but = (other, k.lk[l], k.lz[l], threshold(l, end1), !end1);
                        cel.buts.push(but);
                        CelKind::But
                    }
                    Ok((other, l, end1)) if law[l] == Law::Lnl => {
                        cel.lnls.push((other, !end1, lnl_pair(l)));
                        CelKind::Lnl
                    }
                    Ok((other, l, _)) => {
                        cel.springs.push((other, k.lk[l], k.lz[l]));
                        match law[l] {
                            Law::Res => CelKind::Res,
                            Law::Fro => CelKind::Fro,
                            _ => CelKind::Ref,
                        }
                    }
                    Err(e) => {
                        cel.inputs.push(e);
                        CelKind::Input
                    }
                };
                cel.push(kind);
            }
            cel.off.push(cel.runs.len() as u32);
        }
        // (each part of a row evaluates its pair on the whole row: two pairs in every row ran at
        // 1.4x the gather step on a random network, docs/BENCHMARKS-LOG.md, twenty-eighth session)
        // (with the forces stored, no row evaluates a pair: the parts are empty)
        if p.parts.len() >= PARTS as usize || 2 * evaluations[0] > 5 * evaluations[1] {
            return None;
        }
        // (with LNL links, whether the rows compute their springs and dampers, and BUTs, which
        // have a spring; else whether they compute their BUTs)
        p.full_rows = if p.curves.is_some() || !p.longs.is_empty() {
            Pull::computes_full_rows(&p.rows, |r| (r.k | r.z) != 0)
        } else {
            but && Pull::computes_full_rows(&p.rows, |r| r.b != 0)
        };
        if p.several && !store {
            p.runs = runs(&p.bounds, &p.row_curves);
        }
        p.recorded = k.recorded_links()?;
        // (the stored links pair by pair, in the order of their pairs' first links, each pair's
        // in the order the rows first name them, padded to whole chunks; and the rows' offsets
        // renumbered to match)
        let mut rank: HashMap<u32, usize> = HashMap::new();
        for &(_, pair) in &stored_ends {
            let next = rank.len();
            rank.entry(pair).or_insert(next);
        }
        let mut links: Vec<usize> = (0..stored_ends.len()).collect();
        links.sort_by_key(|&j| rank[&stored_ends[j].1]); // (stable)
        let mut renumbered = vec![u32::MAX; stored_ends.len()];
        for run in links.chunk_by(|&i, &j| stored_ends[i].1 == stored_ends[j].1) {
            for ends in run.chunks(LANES) {
                let mut chunk = [[0; LANES]; 2];
                for (i, &j) in ends.iter().enumerate() {
                    let [a, b] = stored_ends[j].0;
                    // (`stored_within`: unchecked in the step; `a` and `b` are `16` times a
                    // slot)
                    assert!(a < 16 * k.nm as u32 && b < 16 * k.nm as u32);
                    [chunk[0][i], chunk[1][i]] = [a, b];
                    renumbered[j] = (LANES * p.stored.len() + i) as u32;
                }
                p.stored.push(chunk);
            }
            p.stored_runs
                .push((p.stored.len() as u32, stored_ends[run[0]].1));
        }
        assert!(p.stored.len() as u64 * LANES as u64 <= most);
        for row in &mut p.rows {
            for at in row.at.iter_mut().filter(|at| u64::from(**at) >= forces_at) {
                let old = (u64::from(*at) - forces_at) / 8;
                // (checked above: below `u32::MAX`)
                *at = (forces_at + 8 * u64::from(renumbered[old as usize])) as u32;
            }
        }
        // (every 16-byte load of a row within a pair buffer: a pair, or a stored force and the
        // 8 bytes after it)
        let bytes = 16 * p.buffer_len(k.nm);
        assert!(p
            .rows
            .iter()
            .all(|r| r.at.iter().all(|&o| o as usize + 16 <= bytes)));
        let long = |i: u32| (i as usize) < p.longs.len();
        let known =
            |pair: u32| (pair as usize) < p.pairs.len() || (pair >= LONGS && long(pair - LONGS));
        assert!(p.cel.fits(k.nm, k.enf.len(), known));
        assert!(p.cel.off.len() == k.n_mc - k.n_mas + 1);
        assert!(p.enf.iter().all(|&(_, i)| (i as usize) < k.enf.len()));
        Some(p)
    }

    /// Whether every row should compute the kind of terms that the rows that `have` them have,
    /// rather than a branch on each row skip them where it has none: when fewer than half the
    /// rows have none, or when rows with and rows without them alternate in more than one row
    /// in 16. Skipping saves three or four operations of a row's 14 to 34, but a branch
    /// mispredicted costs more, and a loop with the branch is slower in every row (an all-BUT
    /// random network ran at 0.90x with it).
    fn computes_full_rows(rows: &[Row], have: impl Fn(&Row) -> bool) -> bool {
        let without = rows.iter().filter(|r| !have(r)).count();
        let changes = rows
            .windows(2)
            .filter(|w| have(&w[0]) != have(&w[1]))
            .count();
        2 * without < rows.len() || 16 * changes > rows.len()
    }

    /// The BUT thresholds of `rows`, or none when the network has no BUT.
    #[cfg(target_arch = "x86_64")]
    fn row_thresholds(&self, rows: Range<usize>) -> &[[f64; LANES]] {
        if self.thresholds.is_empty() {
            &[]
        } else {
            &self.thresholds[rows]
        }
    }

    /// Calls `f` on each of the [`Pull::runs`] of the groups of `out` (a network of several
    /// pairs), with the run's pair (`None`: the table) and its groups with their slots.
    #[cfg(target_arch = "x86_64")]
    fn by_runs(&self, k: &Kernel, out: Slots, mut f: impl FnMut(Option<u32>, Slots)) {
        let Slots {
            groups: gr,
            mut next,
            mut pn,
        } = out;
        let first = (self.runs).partition_point(|&(end, _)| end as usize <= gr.start);
        let mut start = gr.start;
        for &(end, pair) in &self.runs[first..] {
            if start >= gr.end {
                break;
            }
            let end = gr.end.min(end as usize);
            let slots = |g: usize| (LANES * g).min(k.n_mas);
            let (nx, rest) = std::mem::take(&mut next).split_at_mut(slots(end) - slots(start));
            next = rest;
            let (px, rest) = std::mem::take(&mut pn).split_at_mut(nx.len());
            pn = rest;
            let run = Slots {
                groups: start..end,
                next: nx,
                pn: px,
            };
            f(pair, run);
            start = end;
        }
        assert!(start >= gr.end && next.is_empty() && pn.is_empty());
    }

    /// The force `LK(d) + LZ(dv)` of the pair numbered `pair` (in [`Pull::pairs`], or from
    /// [`LONGS`] in [`Pull::longs`]), one link at a time.
    fn pair_force(&self, pair: u32, d: f64, dv: f64) -> f64 {
        match pair {
            LONGS.. => self.longs[(pair - LONGS) as usize].force(d, dv),
            _ => self.pairs[pair as usize].force(d, dv),
        }
    }

    /// Whether every row computes the terms only some rows may have ([`Pull::full_rows`]).
    #[cfg(test)]
    pub(super) fn has_full_rows(&self) -> bool {
        self.full_rows
    }

    /// Makes the rows compute the terms only some rows may have the other way (every row, or
    /// only those that have one): the same bits either way.
    #[cfg(test)]
    pub(super) fn toggle_full_rows(&mut self) {
        self.full_rows = !self.full_rows;
    }

    /// [`Pull::new`] with the LNL forces not stored ([`Pull::build`]).
    #[cfg(test)]
    pub(super) fn unstored(k: &Kernel) -> Option<Pull> {
        Pull::build(k, false)
    }

    /// The chunks of stored LNL forces ([`Pull::stored`]: the byte offsets of each link's ends'
    /// pairs).
    #[cfg(test)]
    pub(super) fn stored_chunks(&self) -> &[[[u32; LANES]; 2]] {
        &self.stored
    }

    /// The point counts of the pairs of curves of at most 16 points ([`Pull::pairs`]), in order.
    #[cfg(test)]
    pub(super) fn pair_counts(&self) -> Vec<(usize, usize)> {
        self.pairs.iter().map(ExactPair::counts).collect()
    }

    /// How many distinct pairs of LNL curves the network has.
    #[cfg(test)]
    pub(super) fn curve_pairs(&self) -> usize {
        self.pairs.len()
    }

    /// The point counts of the curves the LNL terms are evaluated with (the pair's, or the
    /// table's).
    #[cfg(test)]
    pub(super) fn curve_points(&self) -> Option<(usize, usize)> {
        self.curves.map(|c| c.counts())
    }

    /// How many distinct pairs of LNL curves of more than 16 points the network has
    /// ([`Pull::longs`]).
    #[cfg(test)]
    pub(super) fn long_pairs(&self) -> usize {
        self.longs.len()
    }

    /// How many rows have LNL lanes of one pair, of several (with several pairs).
    #[cfg(test)]
    pub(super) fn rows_of_pairs(&self) -> (usize, usize) {
        let with = |f: fn(u32) -> bool| self.row_curves.iter().filter(|&&r| f(r)).count();
        (
            with(|r| r != NO_LNL && r & PARTS == 0),
            with(|r| r != NO_LNL && r & PARTS != 0),
        )
    }

    /// How many groups are in runs of one pair, and how many read their pairs from the table
    /// ([`Pull::runs`]).
    #[cfg(test)]
    pub(super) fn groups_of_one_pair(&self) -> (usize, usize) {
        let mut counts = [0, 0];
        let mut start = 0;
        for &(end, pair) in &self.runs {
            counts[usize::from(pair.is_none())] += (end - start) as usize;
            start = end;
        }
        (counts[0], counts[1])
    }

    /// How many groups are in runs of a long pair ([`LONGS`]).
    #[cfg(test)]
    pub(super) fn groups_of_long_pairs(&self) -> usize {
        let mut start = 0;
        let mut count = 0;
        for &(end, pair) in &self.runs {
            count += if pair >= Some(LONGS) { end - start } else { 0 } as usize;
            start = end;
        }
        count
    }

    /// Every group reads its pairs from the table, as before runs of one pair: the same bits
    /// either way.
    #[cfg(test)]
    pub(super) fn read_every_pair_from_the_table(&mut self) {
        if let Some(&(end, _)) = self.runs.last() {
            self.runs = vec![(end, None)];
        }
    }

    /// How many rows have BUT lanes and LNL lanes both.
    #[cfg(test)]
    pub(super) fn rows_of_buts_and_curves(&self) -> usize {
        let buts = |r: &Row| r.b & r.k;
        (self.rows.iter())
            .filter(|r| buts(r) != 0 && r.b & !buts(r) != 0)
            .count()
    }

    /// Whether every row has the same `K` and `Z` (one row of parameters for them all).
    #[cfg(test)]
    pub(super) fn shared_params(&self) -> bool {
        self.params.len() == 1
    }

    /// Cuts the work of a step into `threads` shares of about equal cost (consecutive groups),
    /// and each share into chunks of consecutive groups, the units the threads claim
    /// ([`PullJob`]): about [`CHUNK_MAS`] MAS each, at least [`CHUNKS_MIN`] where the groups
    /// allow. The last chunk of the last share also has the CEL and ENX.
    pub(super) fn partition(&self, k: &Kernel, threads: usize) -> Vec<Vec<Share>> {
        let groups = self.bounds.len() - 1;
        let cost = |g: usize| u64::from(self.bounds[g + 1] - self.bounds[g]) + 1;
        let shares = super::split(groups, threads.max(1), cost);
        let last = shares.len() - 1;
        let share = |g: Range<usize>, others: bool| {
            let mas = (LANES * g.start).min(k.n_mas)..(LANES * g.end).min(k.n_mas);
            let end = if others { k.n_mce } else { mas.end };
            Share {
                groups: g,
                slots: mas.start..end,
            }
        };
        (shares.into_iter().enumerate())
            .map(|(t, g)| {
                let chunks = (LANES * g.len() / CHUNK_MAS)
                    .max(CHUNKS_MIN)
                    .min(g.len())
                    .max(1);
                let pieces = super::split(g.len(), chunks, |i| cost(g.start + i));
                let lastc = pieces.len() - 1;
                (pieces.into_iter().enumerate())
                    .map(|(c, r)| {
                        share(g.start + r.start..g.start + r.end, t == last && c == lastc)
                    })
                    .collect()
            })
            .collect()
    }

    /// The length of each pair buffer, in pairs: `nm`, and when the LNL forces are stored
    /// ([`Pull::stored`]), room for them and for the 8 bytes past the last that a row's 16-byte
    /// load of it reads.
    pub(super) fn buffer_len(&self, nm: usize) -> usize {
        match self.stored.len() {
            0 => nm,
            chunks => nm + LANES * chunks / 2 + 1,
        }
    }

    /// Whether the step evaluates each LNL link once a step ([`Pull::stored`]).
    pub(super) fn stores_forces(&self) -> bool {
        !self.stored.is_empty()
    }

    /// The chunks of [`Pull::stored`] thread `t` of `threads` evaluates.
    pub(super) fn stored_share(&self, t: usize, threads: usize) -> Range<usize> {
        let n = self.stored.len();
        n * t / threads..n * (t + 1) / threads
    }

    /// The forces of the LNL links of the chunks `chunks` of [`Pull::stored`], from the `nm`
    /// pairs of step `n` in `pc`, into `forces` (`f64` number `2 nm + 8 chunks.start` of the
    /// buffer on: exactly `8 chunks.len()` of them).
    pub(super) fn store_forces(&self, pc: &[[f64; 2]], chunks: Range<usize>, forces: &mut [f64]) {
        assert!(forces.len() == LANES * chunks.len());
        // (each offset of `stored` is `16 j` for a pair `j < stored_within`, asserted in `build`,
        // so a pair of `pc`: the promise `store_forces_avx2` asks for)
        assert!(pc.len() >= self.stored_within);
        let mut start = 0;
        // (each run of one pair's chunks within `chunks`, with that pair's curves)
        for &(end, pair) in &self.stored_runs {
            let run = start.max(chunks.start)..(end as usize).min(chunks.end);
            start = end as usize;
            if run.is_empty() {
                continue;
            }
            let ends = &self.stored[run.clone()];
            let at = LANES * (run.start - chunks.start)..LANES * (run.end - chunks.start);
            let forces = &mut forces[at];
            // SAFETY (both): every offset of `ends` (chunks of `stored`) is that of a pair of
            // `pc` (above).
            #[cfg(target_arch = "x86_64")]
            match self.isa {
                // SAFETY: the token exists, so the CPU has AVX-512F (see `Avx512::detect`).
                Isa::Avx512(_) => unsafe { self.store_forces_avx512(pc, pair, ends, forces) },
                // SAFETY: `Pull::new` made `Isa::Avx2` from `Simd::Avx2`, which `Simd::detect`
                // returns (and a test asks for) only when the CPU has AVX2.
                Isa::Avx2 => unsafe { self.store_forces_avx2(pc, pair, ends, forces) },
            }
            #[cfg(not(target_arch = "x86_64"))]
            {
                let _ = (pc, pair, ends, forces);
                unreachable!("a pull step needs AVX-512 or AVX2, which exist only on x86-64");
            }
        }
    }

    /// Sets the pairs of step `st.n` (buffer 0) from the positions, and the SOL's (which never
    /// change) in buffer 1 too.
    pub(super) fn prepare(&self, k: &Kernel, st: &mut State) {
        let r = Roles::at(st.c);
        let (x, xp): (&[f64], &[f64]) = (&st.pos[r.cur], &st.pos[r.prev]);
        let [p0, p1] = &mut st.pairs;
        let len = self.buffer_len(k.nm);
        assert!(p0.len() == len && p1.len() == len);
        for ((p, &x), &xp) in p0.iter_mut().zip(x).zip(xp) {
            *p = [x, x - xp];
        }
        p1[k.n_mce..k.nm].copy_from_slice(&p0[k.n_mce..k.nm]);
    }

    /// Steps `frames` times from `st` on the calling thread, writing the outputs into `out` (see
    /// [`super::Engine::process`]).
    pub(super) fn block(&self, k: &Kernel, st: &mut State, frames: usize, out: &mut [f64]) {
        // (the CPU's instructions, not what `CORDIS_SIMD` allows: the tests take the AVX2 step
        // on a CPU that has it whatever the limit, `Engine::new_for`)
        #[cfg(target_arch = "x86_64")]
        debug_assert!(match self.isa {
            Isa::Avx512(cpu) => Some(cpu) == Avx512::detect(),
            Isa::Avx2 => std::is_x86_feature_detected!("avx2"),
        });
        self.prepare(k, st);
        let whole = Share {
            groups: 0..self.bounds.len() - 1,
            slots: 0..k.n_mce,
        };
        let ch = k.channels.len();
        let State {
            n,
            c,
            pos,
            sf,
            pairs,
            ..
        } = st;
        let [p0, p1] = pairs;
        let (nm, chunks) = (k.nm, 0..self.stored.len());
        let mut flip = false;
        for frame in 0..frames {
            let roles = Roles::at(*c);
            let (cur, prev, next) = roles.split(pos);
            let (pc, pn) = if flip {
                (&mut p1[..], &mut p0[..])
            } else {
                (&mut p0[..], &mut p1[..])
            };
            if !chunks.is_empty() {
                let (pairs, rest) = pc.split_at_mut(nm);
                let forces = &mut rest.as_flattened_mut()[..LANES * chunks.len()];
                self.store_forces(pairs, chunks.clone(), forces);
            }
            let pc = &pc[..];
            self.record(k, cur, prev, sf, &mut out[frame * ch..(frame + 1) * ch]);
            let mine = whole.slots.clone();
            let now = Now {
                k,
                n: *n,
                cur,
                prev,
                pc,
            };
            self.step(now, &whole, &mut next[mine.clone()], &mut pn[mine]);
            *n += 1;
            *c = roles.next;
            flip = !flip;
        }
    }

    /// The outputs of a step: the forces of the links they read into `sf`, then `frame`.
    #[inline]
    pub(super) fn record(
        &self,
        k: &Kernel,
        cur: &[f64],
        prev: &[f64],
        sf: &mut [f64],
        frame: &mut [f64],
    ) {
        k.record_with(&self.recorded, cur, prev, sf, frame);
    }

    /// Step `now.n` of `share`: `x(n+1)` of its moving materials into `next` and their pairs
    /// into `pn` (both its `slots`), from `x(n)`, `x(n-1)` and the pairs `pc` of every material.
    fn step(&self, now: Now, share: &Share, next: &mut [f64], pn: &mut [[f64; 2]]) {
        let Now {
            k, cur, prev, pc, ..
        } = now;
        let nm = k.nm;
        assert!(cur.len() == nm && prev.len() == nm && pc.len() == self.buffer_len(nm));
        let slots = share.slots.clone();
        assert!(next.len() == slots.len() && pn.len() == slots.len());
        let mas = slots.end.min(k.n_mas) - slots.start;
        let (next, next_others) = next.split_at_mut(mas);
        let (pn, pn_others) = pn.split_at_mut(mas);
        let out = Slots {
            groups: share.groups.clone(),
            next,
            pn,
        };
        // the MAS, their loop compiled for one row of parameters or one per row
        #[cfg(target_arch = "x86_64")]
        macro_rules! groups {
            ($groups:ident) => {
                if let [one] = &self.params[..] {
                    self.$groups(now, &|_: Range<usize>| std::iter::repeat(one), out)
                } else {
                    self.$groups(now, &|r: Range<usize>| self.params[r].iter(), out)
                }
            };
        }
        #[cfg(target_arch = "x86_64")]
        match self.isa {
            // SAFETY: the token exists, so the CPU has AVX-512F (see `Avx512::detect`).
            Isa::Avx512(_) => unsafe { groups!(groups) },
            // SAFETY: `Pull::new` made `Isa::Avx2` from `Simd::Avx2`, which `Simd::detect`
            // returns (and a test asks for) only when the CPU has AVX2 (an engine does not move
            // to another machine).
            Isa::Avx2 => unsafe { groups!(groups_avx2) },
        }
        #[cfg(not(target_arch = "x86_64"))]
        {
            let _ = out;
            unreachable!("a pull step needs AVX-512 or AVX2, which exist only on x86-64");
        }
        if slots.end > k.n_mas {
            assert!(slots.end == k.n_mce && slots.start <= k.n_mas);
            self.others(now, next_others, pn_others);
        }
    }

    /// The CEL and ENX of step `now.n`: their `x(n+1)` into `next` and pairs into `pn` (slots
    /// `n_mas..n_mce`).
    #[inline]
    fn others(&self, now: Now, next: &mut [f64], pn: &mut [[f64; 2]]) {
        let Now {
            k,
            n,
            cur,
            prev,
            pc,
        } = now;
        assert!(next.len() == k.n_mce - k.n_mas && pn.len() == next.len());
        let t = &self.cel;
        // (where each list's next terms are: the CELs take them in turn)
        let [mut springs, mut buts, mut lnls, mut inputs] = [0; 4];
        for (c, cel) in k.cel.iter().enumerate() {
            let s = k.n_mas + c;
            let (x, xp) = (cur[s], prev[s]);
            let v = x - xp;
            let mut f = 0.0;
            for &(kind, count) in &t.runs[t.off[c] as usize..t.off[c + 1] as usize] {
                match kind {
                    CelKind::Res => {
                        for &(j, kk, _) in take(&t.springs, &mut springs, count) {
                            f -= kk * (x - pc[j as usize][0]);
                        }
                    }
                    CelKind::Fro => {
                        for &(j, _, zz) in take(&t.springs, &mut springs, count) {
                            f -= zz * (v - pc[j as usize][1]);
                        }
                    }
                    CelKind::Ref => {
                        for &(j, kk, zz) in take(&t.springs, &mut springs, count) {
                            let [xj, vj] = pc[j as usize];
                            f -= kk * (x - xj) + zz * (v - vj);
                        }
                    }
                    CelKind::But => {
                        for &(j, kk, zz, s, end2) in take(&t.buts, &mut buts, count) {
                            let [xj, vj] = pc[j as usize];
                            let t = (x - xj) + s;
                            let contact = if end2 { t < 0.0 } else { t > 0.0 };
                            if contact {
                                f -= kk * t + zz * (v - vj);
                            }
                        }
                    }
                    CelKind::Lnl => {
                        for &(j, end2, pair) in take(&t.lnls, &mut lnls, count) {
                            let [xj, vj] = pc[j as usize];
                            // (the reference's `d` and `v` and force, negated from end 2: see
                            // `sum_lnl`)
                            let (d, dv) = (x - xj, v - vj);
                            f -= if end2 {
                                -self.pair_force(pair, -d, -dv)
                            } else {
                                self.pair_force(pair, d, dv)
                            };
                        }
                    }
                    CelKind::Input => {
                        for &i in take(&t.inputs, &mut inputs, count) {
                            f += k.enf[i as usize].at(n);
                        }
                    }
                }
            }
            let xn = cel.next(x, xp, f);
            next[c] = xn;
            pn[c] = [xn, xn - x];
        }
        let n_cel = k.cel.len();
        for (e, sig) in k.enx.iter().enumerate() {
            let xn = sig.at(n + 1);
            next[n_cel + e] = xn;
            pn[n_cel + e] = [xn, xn - cur[k.n_mc + e]];
        }
    }

    /// The MAS, group by group; `params(rows)` are the `(K, Z)` of `rows`, row by row. The
    /// loop is compiled for the kernel's inertias, and for whole groups apart from the last, the
    /// only one that may be partial.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx512f")]
    #[inline]
    fn groups<'p, I: Iterator<Item = &'p [[f64; LANES]; 2]>>(
        &self,
        now: Now,
        params: &impl Fn(Range<usize>) -> I,
        out: Slots,
    ) {
        match &self.curves {
            _ if self.stores_forces() => {
                let stored = Stored {
                    full_rows: self.full_rows,
                };
                self.groups_with(&stored, now, params, out)
            }
            // (no `curves`, so one pair: several have the table's shape, `Pull::new`)
            None if !self.longs.is_empty() => {
                let long = &self.longs[0];
                // SAFETY: this function is compiled with AVX-512F, and a pull step has
                // `Isa::Avx512` (asserted) only with the token, the CPU's proof of it.
                assert!(matches!(self.isa, Isa::Avx512(_)));
                let curves = unsafe { LongCurves::new(long, self.full_rows) };
                self.groups_with(&curves, now, params, out)
            }
            Some(pair) => pair.visit(WithCurves {
                pull: self,
                now,
                params,
                out,
            }),
            None if !self.thresholds.is_empty() && self.full_rows => {
                self.groups_with(&Buts::<false>, now, params, out)
            }
            None if !self.thresholds.is_empty() => {
                self.groups_with(&Buts::<true>, now, params, out)
            }
            None => self.groups_with(&Springs, now, params, out),
        }
    }

    /// [`Pull::groups`] with the group sums of `terms`, a function of its own for each kind of
    /// terms (with all three inlined into `groups`, the BUT network ran 4 % slower).
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx512f")]
    #[inline(never)]
    fn groups_with<'p, I: Iterator<Item = &'p [[f64; LANES]; 2]>, T: Terms>(
        &self,
        terms: &T,
        now: Now,
        params: &impl Fn(Range<usize>) -> I,
        out: Slots,
    ) {
        // (`groups_as` checks each piece against its buffers)
        let [whole, part] = out.split_whole(now.k);
        let none: &[f64] = &[];
        macro_rules! both {
            ($div:literal, $per:literal, $m:expr, $ms:expr) => {{
                self.groups_as::<_, _, $div, $per, true>(terms, now, params, $m, $ms, whole);
                self.groups_as::<_, _, $div, $per, false>(terms, now, params, $m, $ms, part);
            }};
        }
        match &now.k.mas {
            MasLaw::UniformInv(inv) => both!(false, false, inv, none),
            MasLaw::UniformDiv(m) => both!(true, false, m, none),
            MasLaw::Inv(inv) => both!(false, true, &0.0, inv),
            MasLaw::Div(m) => both!(true, true, &0.0, m),
        }
    }

    /// [`Pull::groups`] for the groups of `out`, all whole (`WHOLE`) or the last, partial, one;
    /// `x(n+1) = 2 x(n) - x(n-1) + F(n) / M`, dividing (`DIV`) or multiplying by `1 / M`, `m` for
    /// every MAS or (`PER_MAS`) each MAS's own in `ms` (by storage slot).
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx512f")]
    #[inline]
    fn groups_as<
        'p,
        I: Iterator<Item = &'p [[f64; LANES]; 2]>,
        T: Terms,
        const DIV: bool,
        const PER_MAS: bool,
        const WHOLE: bool,
    >(
        &self,
        terms: &T,
        now: Now,
        params: &impl Fn(Range<usize>) -> I,
        m: &f64,
        ms: &[f64],
        out: Slots,
    ) {
        let Now { k, n, prev, pc, .. } = now;
        let Slots {
            groups: gr,
            next,
            pn,
        } = out;
        // `next` and `pn` are the slots of the MAS of groups `gr`, from `o`
        let o = LANES * gr.start;
        assert!(next.len() == (LANES * gr.end).min(k.n_mas) - o.min(k.n_mas));
        assert!(pn.len() == next.len() && gr.end < self.bounds.len());
        assert!(!PER_MAS || ms.len() == k.n_mas);
        assert!(WHOLE || gr.len() <= 1);
        let base = pc.as_ptr().cast::<u8>();
        // (lanes of the pairs `[x0 v0 x1 v1 x2 v2 x3 v3]`, `[x4 v4 .. x7 v7]`, and back)
        let low = _mm512_set_epi64(11, 3, 10, 2, 9, 1, 8, 0);
        let high = _mm512_set_epi64(15, 7, 14, 6, 13, 5, 12, 4);
        let two = _mm512_set1_pd(2.0);
        let xs = _mm512_set_epi64(14, 12, 10, 8, 6, 4, 2, 0);
        let vs = _mm512_set_epi64(15, 13, 11, 9, 7, 5, 3, 1);
        let n_mas = k.n_mas;
        let groups = (self.bounds[gr.start..=gr.end].windows(2))
            .zip(self.enf_bounds[gr.start..=gr.end].windows(2));
        for (g, (rows, inputs)) in (gr.start..).zip(groups) {
            let s0 = LANES * g;
            let lanes = if WHOLE {
                LANES
            } else {
                (n_mas - s0).min(LANES)
            };
            let mask = if lanes == LANES {
                0xff
            } else {
                ((1u32 << lanes) - 1) as u8
            };
            let (lo, hi) = if lanes == LANES {
                (0xff, 0xff)
            } else {
                let pairs = |l: usize| ((1u32 << (2 * l.min(4))) - 1) as u8;
                (pairs(lanes), pairs(lanes.saturating_sub(4)))
            };
            // `x(n)` and `v(n)` of the lanes from their own pairs (the same bits as `cur` and
            // `cur - prev`); `x(n-1)` is read only after the sum, so that no vector lives across
            // the loop but those it uses (a vector kept across it went to the stack, and loading
            // it back stalled on stack addresses that split a cache line: 20 % of the time).
            // SAFETY: lanes `0..lanes` are the pairs of storage slots `s0..s0 + lanes`, all
            // `< n_mas <= nm`, the length of `pc` (asserted in `step`): `f64` items `2 s0..` of
            // its `2 nm`; masked-off lanes are not read.
            let (x, v) = unsafe {
                let p = base.cast::<f64>().add(2 * s0);
                let (a, b) = if lanes == LANES {
                    (_mm512_loadu_pd(p), _mm512_loadu_pd(p.add(LANES)))
                } else {
                    (
                        _mm512_maskz_loadu_pd(lo, p),
                        _mm512_maskz_loadu_pd(hi, p.add(LANES)),
                    )
                };
                (
                    _mm512_permutex2var_pd(a, xs, b),
                    _mm512_permutex2var_pd(a, vs, b),
                )
            };
            let rows = rows[0] as usize..rows[1] as usize;
            // SAFETY: every row's offset is that of 16 bytes within a buffer of `buffer_len(nm)`
            // pairs (asserted in `new`: a pair `< nm`, or a stored force and the 8 bytes after
            // it), which `pc` has (asserted in `step`); the CPU has AVX-512F, and this function
            // is compiled with it.
            let group = Group::new(rows.clone(), params(rows), base, (x, v), (xs, vs));
            let mut f = unsafe { terms.sum(self, group) };
            let inputs = &self.enf[inputs[0] as usize..inputs[1] as usize];
            if !inputs.is_empty() {
                let mut lanes_f = [0.0; LANES];
                // SAFETY: eight `f64`.
                unsafe { _mm512_storeu_pd(lanes_f.as_mut_ptr(), f) };
                for &(i, e) in inputs {
                    lanes_f[i as usize] += k.enf[e as usize].at(n);
                }
                // SAFETY: as above.
                f = unsafe { _mm512_loadu_pd(lanes_f.as_ptr()) };
            }
            // (`black_box`: the compiler would otherwise hoist this load above the inputs'
            // calls and the loop, and keep its vector on the stack across them)
            let at = black_box(prev.as_ptr()).wrapping_add(s0);
            // SAFETY: as for the pairs, in `prev`, of `nm` items (asserted in `step`).
            let xp = unsafe {
                if lanes == LANES {
                    _mm512_loadu_pd(at)
                } else {
                    _mm512_maskz_loadu_pd(mask, at)
                }
            };
            // 2 x(n) - x(n-1) + F(n) / M, as `by_inv` and `by_div` (a uniform inertia is
            // broadcast here, through `black_box`, for the same reason as `x(n-1)`)
            let m = if PER_MAS {
                // SAFETY: lanes `0..lanes` are MAS `s0..`, within the `n_mas` inertias
                // (asserted above).
                unsafe { _mm512_maskz_loadu_pd(mask, ms.as_ptr().add(s0)) }
            } else {
                _mm512_set1_pd(*black_box(m))
            };
            let acc = if DIV {
                _mm512_div_pd(f, m)
            } else {
                _mm512_mul_pd(f, m)
            };
            let xn = _mm512_add_pd(_mm512_sub_pd(_mm512_mul_pd(two, x), xp), acc);
            let vn = _mm512_sub_pd(xn, x);
            // SAFETY: lanes `0..lanes` are slots `s0..s0 + lanes`, items `s0 - o..` of `next`
            // and of `pn` (asserted above: the groups `gr` cover them), pairs of two `f64`;
            // masked-off lanes are not written.
            unsafe {
                let (a, b) = (
                    _mm512_permutex2var_pd(xn, low, vn),
                    _mm512_permutex2var_pd(xn, high, vn),
                );
                let p = pn.as_mut_ptr().cast::<f64>().add(2 * (s0 - o));
                let x = next.as_mut_ptr().add(s0 - o);
                if lanes == LANES {
                    _mm512_storeu_pd(x, xn);
                    _mm512_storeu_pd(p, a);
                    _mm512_storeu_pd(p.add(LANES), b);
                } else {
                    _mm512_mask_storeu_pd(x, mask, xn);
                    _mm512_mask_storeu_pd(p, lo, a);
                    _mm512_mask_storeu_pd(p.add(LANES), hi, b);
                }
            }
        }
    }
}

/// The `(K, Z)` of a group's rows, row by row (eight lanes each).
#[cfg(target_arch = "x86_64")]
trait Params<'p>: Iterator<Item = &'p [[f64; LANES]; 2]> {}

#[cfg(target_arch = "x86_64")]
impl<'p, I: Iterator<Item = &'p [[f64; LANES]; 2]>> Params<'p> for I {}

/// What a group's sum reads: its rows (`rows` of the pull step's), their parameters `params`,
/// `x(n)` and `v(n)` of the group's eight lanes (`V`: one vector, or two of four lanes on AVX2),
/// and the other ends' pairs in the buffer at `base` (`perm`: on AVX-512, the `xs`, `vs` of
/// [`pairs`]).
#[cfg(target_arch = "x86_64")]
struct Group<P, V, Q = ()> {
    rows: Range<usize>,
    params: P,
    base: *const u8,
    x: V,
    v: V,
    perm: Q,
}

#[cfg(target_arch = "x86_64")]
impl<P, V, Q> Group<P, V, Q> {
    /// The group of `rows`, with `params`, `x(n)`, `v(n)` of its lanes, and the pairs at `base`.
    #[inline(always)]
    fn new(rows: Range<usize>, params: P, base: *const u8, (x, v): (V, V), perm: Q) -> Self {
        Group {
            rows,
            params,
            base,
            x,
            v,
            perm,
        }
    }
}

/// [`Group`] on AVX-512.
#[cfg(target_arch = "x86_64")]
type Group8<P> = Group<P, __m512d, (__m512i, __m512i)>;

/// The kind of terms a network's rows have, and how a group sums them: [`Springs`], [`Buts`]
/// or [`Curves`], chosen once per step ([`Pull::groups`]).
#[cfg(target_arch = "x86_64")]
trait Terms: Copy {
    /// `F(n)` of the eight lanes of a group: from `+0.0`, `F - g` for each of its rows `group.rows`
    /// of `pull` (see [`sum`]).
    ///
    /// # Safety
    /// The CPU has AVX-512F and the calling function is compiled with it; every offset of the
    /// rows is that of 16 bytes within the buffer at `group.base` (a pair, or a stored force and
    /// the 8 bytes after it).
    unsafe fn sum<'p>(&self, pull: &Pull, group: Group8<impl Params<'p>>) -> __m512d;
}

/// RES, FRO and REF terms ([`sum`]).
#[cfg(target_arch = "x86_64")]
#[derive(Clone, Copy)]
struct Springs;

/// RES, FRO, REF and BUT terms ([`sum_but`]; BUTs only in the rows that have one when `SKIP`,
/// that is when not [`Pull::full_rows`]).
#[cfg(target_arch = "x86_64")]
#[derive(Clone, Copy)]
struct Buts<const SKIP: bool>;

/// LNL terms of one pair of curves of `A` and `B` points, and RES, FRO, REF and BUT terms
/// ([`sum_lnl`]; in every row when `full_rows`, else in the rows that have them). `full_rows`
/// is a run-time flag here, unlike [`Buts`]'s `SKIP`, to keep one loop per pair of point counts;
/// the loop tested a flag on each row before it too (whether the network had other links).
#[cfg(target_arch = "x86_64")]
#[derive(Clone, Copy)]
struct Curves<const A: usize, const B: usize> {
    k: WideCurve<V8, A>,
    z: WideCurve<V8, B>,
    full_rows: bool,
}

/// LNL terms of several pairs of curves, each padded to `A` and `B` points ([`Pull::table`]),
/// and RES, FRO, REF and BUT terms ([`sum_lnl`], as [`Curves`]); each row reads its pair, or its
/// parts' pairs ([`RowCurves`]).
#[cfg(target_arch = "x86_64")]
#[derive(Clone, Copy)]
struct CurveTable<'a, const A: usize, const B: usize> {
    full_rows: bool,
    /// The long pairs ([`Pull::longs`]).
    longs: &'a [AnyPair],
}

/// The LNL forces of a row's LNL lanes ([`sum_lnl`]).
#[cfg(target_arch = "x86_64")]
trait LnlForces {
    /// The force `LK(d) + LZ(dv)` of each LNL lane of row `r` (counted from the first row the
    /// sum was given), from the reference's operands `d` and `dv`; any value in the other lanes.
    ///
    /// # Safety
    /// The CPU has AVX-512F and the calling function is compiled with it.
    unsafe fn forces(&self, r: usize, d: __m512d, dv: __m512d) -> __m512d;

    /// Whether the forces were stored before the rows ([`Stored`]): then an LNL lane's load of
    /// its "pair" brings its link's force in the `x` position, and `forces` is not called.
    const STORED: bool = false;
}

/// The forces of the LNL links, stored before the rows ([`Pull::stored`],
/// [`Pull::store_forces_avx512`]), and RES, FRO, REF and BUT terms (as [`Curves`]).
#[cfg(target_arch = "x86_64")]
#[derive(Clone, Copy)]
struct Stored {
    full_rows: bool,
}

#[cfg(target_arch = "x86_64")]
impl LnlForces for Stored {
    const STORED: bool = true;

    unsafe fn forces(&self, _: usize, _: __m512d, _: __m512d) -> __m512d {
        unreachable!("stored forces are read, not evaluated")
    }
}

#[cfg(target_arch = "x86_64")]
impl Terms for Stored {
    #[inline(always)]
    unsafe fn sum<'p>(&self, pull: &Pull, group: Group8<impl Params<'p>>) -> __m512d {
        // SAFETY: the caller's promise.
        unsafe { sum_of_one(self, self.full_rows, pull, group) }
    }
}

#[cfg(target_arch = "x86_64")]
impl<const A: usize, const B: usize> LnlForces for Curves<A, B> {
    #[inline(always)]
    unsafe fn forces(&self, _: usize, d: __m512d, dv: __m512d) -> __m512d {
        // SAFETY: the caller's promise (`V8`).
        unsafe { _mm512_add_pd(self.k.eval(V8(d)).0, self.z.eval(V8(dv)).0) }
    }
}

/// LNL terms of one pair of curves of any number of points ([`Pull::longs`], evaluated by
/// [`WideLong`]), and RES, FRO, REF and BUT terms (as [`Curves`]).
#[cfg(target_arch = "x86_64")]
#[derive(Clone, Copy)]
struct LongCurves<'a> {
    k: WideLong<'a, V8>,
    z: WideLong<'a, V8>,
    full_rows: bool,
}

#[cfg(target_arch = "x86_64")]
impl<'a> LongCurves<'a> {
    /// # Safety
    /// The CPU has AVX-512F (see [`V8`]).
    #[inline(always)]
    unsafe fn new(pair: &'a AnyPair, full_rows: bool) -> Self {
        // SAFETY: the caller's promise.
        unsafe {
            LongCurves {
                k: pair.long.0.wide::<V8>(),
                z: pair.long.1.wide::<V8>(),
                full_rows,
            }
        }
    }
}

#[cfg(target_arch = "x86_64")]
impl LnlForces for LongCurves<'_> {
    #[inline(always)]
    unsafe fn forces(&self, _: usize, d: __m512d, dv: __m512d) -> __m512d {
        // SAFETY: the caller's promise (`V8`).
        unsafe { _mm512_add_pd(self.k.eval(V8(d)).0, self.z.eval(V8(dv)).0) }
    }
}

/// The forces of the long pair `pair` ([`LongCurves`]), for a row that reads its pairs from the
/// table (not inlined into the loop of each shape of the table: one function for them all).
///
/// # Safety
/// The CPU has AVX-512F.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f")]
#[cold]
#[inline(never)]
unsafe fn long_forces(pair: &AnyPair, d: __m512d, dv: __m512d) -> __m512d {
    // SAFETY: the caller's promise.
    unsafe { LongCurves::new(pair, false).forces(0, d, dv) }
}

#[cfg(target_arch = "x86_64")]
impl Terms for LongCurves<'_> {
    #[inline(always)]
    unsafe fn sum<'p>(&self, pull: &Pull, group: Group8<impl Params<'p>>) -> __m512d {
        // SAFETY: the caller's promise.
        unsafe { sum_of_one(self, self.full_rows, pull, group) }
    }
}

/// [`CurveTable`] on the rows of one sum: [`Pull::row_curves`] from its first row, and the
/// pull step's `table` and `parts`.
#[cfg(target_arch = "x86_64")]
struct RowCurves<'t, const A: usize, const B: usize> {
    table: &'t [f64],
    row_curves: &'t [u32],
    parts: &'t [(u32, u8)],
    longs: &'t [AnyPair],
}

#[cfg(target_arch = "x86_64")]
impl<const A: usize, const B: usize> LnlForces for RowCurves<'_, A, B> {
    /// The row's pair evaluated on the whole row, when its LNL lanes share one; else each part's
    /// pair, kept in the part's lanes (the first part's everywhere, then each other part's in
    /// its lanes). Each LNL lane has its own pair's force, as [`Curves`] computes it, from its
    /// curves padded ([`ExactPair::padded`]: the same bits).
    #[inline(always)]
    unsafe fn forces(&self, r: usize, d: __m512d, dv: __m512d) -> __m512d {
        let at = self.row_curves[r];
        // SAFETY (all three): the caller's promise.
        if at == NO_LNL {
            return unsafe { _mm512_setzero_pd() };
        }
        if at & PARTS == 0 {
            return unsafe { self.pair(at, d, dv) };
        }
        let mut f = unsafe { _mm512_setzero_pd() };
        for &(pair, lanes) in &self.parts[(at & !PARTS) as usize..] {
            if lanes == 0 {
                break;
            }
            f = unsafe { _mm512_mask_mov_pd(f, lanes, self.pair(pair, d, dv)) };
        }
        f
    }
}

#[cfg(target_arch = "x86_64")]
impl<const A: usize, const B: usize> RowCurves<'_, A, B> {
    /// The force of the pair at `at` in the table, in every lane (a method, not a closure: a
    /// closure is not compiled with its caller's target features, rust-lang/rust#58279).
    ///
    /// # Safety
    /// As [`LnlForces::forces`].
    #[inline(always)]
    unsafe fn pair(&self, at: u32, d: __m512d, dv: __m512d) -> __m512d {
        if at >= LONGS {
            // SAFETY: the caller's promise.
            return unsafe { long_forces(&self.longs[(at - LONGS) as usize], d, dv) };
        }
        let (k, z) = read_pair::<A, B>(self.table, at);
        // SAFETY: the caller's promise (`V8`).
        unsafe {
            let (k, z) = (k.wide::<V8>(), z.wide::<V8>());
            _mm512_add_pd(k.eval(V8(d)).0, z.eval(V8(dv)).0)
        }
    }
}

#[cfg(target_arch = "x86_64")]
impl Terms for Springs {
    #[inline(always)]
    unsafe fn sum<'p>(&self, pull: &Pull, group: Group8<impl Params<'p>>) -> __m512d {
        // SAFETY: the caller's promise.
        unsafe { sum(&pull.rows[group.rows.clone()], group) }
    }
}

#[cfg(target_arch = "x86_64")]
impl<const SKIP: bool> Terms for Buts<SKIP> {
    #[inline(always)]
    unsafe fn sum<'p>(&self, pull: &Pull, group: Group8<impl Params<'p>>) -> __m512d {
        let rows = group.rows.clone();
        let ts = &pull.thresholds[rows.clone()];
        // SAFETY: the caller's promise; `ts` has a row of thresholds for each row (`new`).
        unsafe { sum_but::<SKIP>(&pull.rows[rows], ts, group) }
    }
}

#[cfg(target_arch = "x86_64")]
impl<const A: usize, const B: usize> Terms for Curves<A, B> {
    #[inline(always)]
    unsafe fn sum<'p>(&self, pull: &Pull, group: Group8<impl Params<'p>>) -> __m512d {
        // SAFETY: the caller's promise.
        unsafe { sum_of_one(self, self.full_rows, pull, group) }
    }
}

#[cfg(target_arch = "x86_64")]
impl<const A: usize, const B: usize> Terms for CurveTable<'_, A, B> {
    #[inline(always)]
    unsafe fn sum<'p>(&self, pull: &Pull, group: Group8<impl Params<'p>>) -> __m512d {
        let rows = group.rows.clone();
        let forces = RowCurves::<A, B> {
            table: &pull.table,
            row_curves: &pull.row_curves[rows.clone()],
            parts: &pull.parts,
            longs: self.longs,
        };
        let ts = pull.row_thresholds(rows.clone());
        // SAFETY: the caller's promise.
        unsafe { sum_lnl(&pull.rows[rows], self.full_rows, &forces, ts, group) }
    }
}

#[cfg(target_arch = "x86_64")]
impl<const A: usize, const B: usize> Curves<A, B> {
    /// The pair `(k, z)` broadcast to eight lanes.
    ///
    /// # Safety
    /// The CPU has AVX-512F (see [`V8`]).
    #[inline(always)]
    unsafe fn new(k: &ExactCurve<A>, z: &ExactCurve<B>, full_rows: bool) -> Self {
        // SAFETY: the caller's promise.
        unsafe {
            Curves {
                k: k.wide::<V8>(),
                z: z.wide::<V8>(),
                full_rows,
            }
        }
    }
}

/// The pair of curves at `at` in `table` ([`Pull::table`]: `A` and `B` points).
#[cfg(target_arch = "x86_64")]
#[inline(always)]
fn read_pair<const A: usize, const B: usize>(
    table: &[f64],
    at: u32,
) -> (ExactCurve<A>, ExactCurve<B>) {
    let t = &table[at as usize..at as usize + ExactCurve::<A>::LEN + ExactCurve::<B>::LEN];
    let (k, z) = t.split_at(ExactCurve::<A>::LEN);
    (ExactCurve::<A>::read(k), ExactCurve::<B>::read(z))
}

/// [`Pull::groups`] for a network of LNL links: [`Pull::groups_with`] with [`Curves`] of the
/// network's point counts (and, with several pairs, [`CurveTable`], in [`Pull::runs`]).
#[cfg(target_arch = "x86_64")]
struct WithCurves<'a, 'b, P> {
    pull: &'a Pull,
    now: Now<'a>,
    params: &'a P,
    out: Slots<'b>,
}

#[cfg(target_arch = "x86_64")]
impl<'p, I: Iterator<Item = &'p [[f64; LANES]; 2]>, P: Fn(Range<usize>) -> I> PairFn
    for WithCurves<'_, '_, P>
{
    type Out = ();

    fn call<const A: usize, const B: usize>(self, k: &ExactCurve<A>, z: &ExactCurve<B>) {
        assert!(matches!(self.pull.isa, Isa::Avx512(_)));
        // SAFETY: a pull step has `Isa::Avx512` only with the token, the CPU's proof of
        // AVX-512F, which `avx512` needs.
        unsafe { self.avx512(k, z) }
    }
}

#[cfg(target_arch = "x86_64")]
impl<'p, I: Iterator<Item = &'p [[f64; LANES]; 2]>, P: Fn(Range<usize>) -> I>
    WithCurves<'_, '_, P>
{
    /// [`PairFn::call`], compiled with AVX-512F, so that the curves' vectors ([`Curves::new`])
    /// are built in registers (in `call` itself, compiled without it, each broadcast was a call
    /// and each vector crossed the stack 16 bytes at a time: 9 % of the time of a network of 64
    /// MAS of LNL links, forty-ninth session).
    ///
    /// # Safety
    /// The CPU has AVX-512F (which `V8` and `groups_with` need).
    #[target_feature(enable = "avx512f")]
    unsafe fn avx512<const A: usize, const B: usize>(self, k: &ExactCurve<A>, z: &ExactCurve<B>) {
        let WithCurves {
            pull,
            now,
            params,
            out,
        } = self;
        // SAFETY: the caller's promise.
        unsafe {
            let full_rows = pull.full_rows;
            if !pull.several {
                let curves = Curves::new(k, z, full_rows);
                pull.groups_with(&curves, now, params, out);
            } else {
                // (each run of the groups: its pair's curves, a long pair's, or the table)
                let table = CurveTable::<A, B> {
                    full_rows,
                    longs: &pull.longs,
                };
                pull.by_runs(now.k, out, |pair, run| match pair {
                    Some(at @ LONGS..) => {
                        let long = &pull.longs[(at - LONGS) as usize];
                        let curves = LongCurves::new(long, full_rows);
                        pull.groups_with(&curves, now, params, run);
                    }
                    Some(at) => {
                        let (k, z) = read_pair::<A, B>(&pull.table, at);
                        let curves = Curves::new(&k, &z, full_rows);
                        pull.groups_with(&curves, now, params, run);
                    }
                    None => pull.groups_with(&table, now, params, run),
                });
            }
        }
    }
}

impl Pull {
    /// [`Pull::store_forces`] on AVX-512: the forces of the LNL links of `ends` (chunks of
    /// [`Pull::stored`], links of one pair of curves, `pair`: a position in `Pull::pairs`, or
    /// [`LONGS`]` + i` for long pair `i`) into `forces`, eight a chunk, from the pairs `pc`.
    ///
    /// # Safety
    /// The CPU has AVX-512F, and every offset of `ends` is that of a pair of `pc`: a multiple of
    /// 16 below `16 pc.len()`.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx512f")]
    unsafe fn store_forces_avx512(
        &self,
        pc: &[[f64; 2]],
        pair: u32,
        ends: &[[[u32; LANES]; 2]],
        forces: &mut [f64],
    ) {
        match pair {
            LONGS.. => {
                // SAFETY: this function is compiled with AVX-512F; the offsets are the caller's
                // promise.
                unsafe {
                    let c = LongCurves::new(&self.longs[(pair - LONGS) as usize], false);
                    store_forces(&c, pc, ends, forces);
                }
            }
            // (the offsets of `ends`: the caller's promise, the invariant of `StoreForces`)
            _ => self.pairs[pair as usize].visit(StoreForces { pc, ends, forces }),
        }
    }
}

/// The forces of the LNL links of `ends` (eight a chunk: the byte offsets in `pc` of the pairs
/// of ends 1 and 2) by `c`, into `forces`, eight a chunk: the reference's `d = x1 - x2` and `v =
/// v1 - v2` (each `v` is `x(n) - x(n-1)`, as the reference's operands, see the module
/// documentation), and `c`'s bits of `LK(d) + LZ(v)`, the reference's force.
///
/// # Safety
/// The CPU has AVX-512F, and every offset of `ends` is that of a pair of `pc`, a multiple of 16
/// below `16 pc.len()` (the reads are not checked, as the AVX2 pass's are not).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f")]
unsafe fn store_forces<C: LnlForces>(
    c: &C,
    pc: &[[f64; 2]],
    ends: &[[[u32; LANES]; 2]],
    forces: &mut [f64],
) {
    assert!(forces.len() == LANES * ends.len());
    let base = pc.as_ptr().cast::<u8>();
    let xs = _mm512_set_epi64(14, 12, 10, 8, 6, 4, 2, 0);
    let vs = _mm512_set_epi64(15, 13, 11, 9, 7, 5, 3, 1);
    for ([a, b], out) in ends.iter().zip(forces.chunks_exact_mut(LANES)) {
        // SAFETY: every offset is that of a pair of `pc` (the caller's promise), the CPU has
        // AVX-512F (this function is compiled with it), and `out` has eight `f64`.
        unsafe {
            let ((xa, va), (xb, vb)) = (pairs(base, a, xs, vs), pairs(base, b, xs, vs));
            let (d, dv) = (_mm512_sub_pd(xa, xb), _mm512_sub_pd(va, vb));
            _mm512_storeu_pd(out.as_mut_ptr(), c.forces(0, d, dv));
        }
    }
}

/// [`store_forces`] with a pair of at most 16 points, at its point counts.
///
/// Invariant: every offset of `ends` is that of a pair of `pc` (its one maker,
/// `Pull::store_forces_avx512`, has the promise from its caller).
#[cfg(target_arch = "x86_64")]
struct StoreForces<'a> {
    pc: &'a [[f64; 2]],
    ends: &'a [[[u32; LANES]; 2]],
    forces: &'a mut [f64],
}

#[cfg(target_arch = "x86_64")]
impl PairFn for StoreForces<'_> {
    type Out = ();

    fn call<const A: usize, const B: usize>(self, k: &ExactCurve<A>, z: &ExactCurve<B>) {
        // SAFETY: `Pull::store_forces` calls `store_forces_avx512` only with `Isa::Avx512`,
        // which exists only with the token, the CPU's proof of AVX-512F; the offsets: the
        // type's invariant.
        unsafe { self.avx512(k, z) }
    }
}

#[cfg(target_arch = "x86_64")]
impl StoreForces<'_> {
    /// [`PairFn::call`], compiled with AVX-512F (the curves' vectors built in registers, as
    /// [`WithCurves::avx512`] builds them).
    ///
    /// # Safety
    /// The CPU has AVX-512F, and the offsets keep the type's invariant.
    #[target_feature(enable = "avx512f")]
    unsafe fn avx512<const A: usize, const B: usize>(self, k: &ExactCurve<A>, z: &ExactCurve<B>) {
        // SAFETY: the caller's promise.
        unsafe { store_forces(&Curves::new(k, z, false), self.pc, self.ends, self.forces) }
    }
}

/// [`sum_lnl`] of the rows `rows` of `pull`, with the forces of one pair of curves `c` (a
/// [`Terms::sum`]).
///
/// # Safety
/// As [`Terms::sum`].
#[cfg(target_arch = "x86_64")]
#[inline(always)]
unsafe fn sum_of_one<'p, C: LnlForces>(
    c: &C,
    full_rows: bool,
    pull: &Pull,
    group: Group8<impl Params<'p>>,
) -> __m512d {
    let rows = group.rows.clone();
    let ts = pull.row_thresholds(rows.clone());
    // SAFETY: the caller's promise.
    unsafe { sum_lnl(&pull.rows[rows], full_rows, c, ts, group) }
}

/// [`sum`] for rows whose lanes `row.b` have LNL terms, their forces from `c` (the network's one
/// pair of curves, or each row's from a table), those of `row.flip` where the lane's MAS is the
/// link's end 2.
///
/// FORMALISM.md's LNL force is `f = LK(x1 - x2) + LZ(v)` (`ExactPair::force`, whose bits
/// `WideCurve::eval` gives lane by lane). From end 1's side `d = x - xj` and `v - vj` are the
/// reference's operands, `g = f`, and `F - g = F + (-f)`. From end 2's side they are the
/// reference's negated (`a - b = -(b - a)` exactly), so the lane negates them (its sign bit
/// flipped, exact), evaluates the curves on the reference's operands, and negates the force: `g
/// = -f`, and `F - g = F + f`. The other lanes of a row are [`sum`]'s terms (a padding lane's
/// `g` is `+0.0`: its curves' value at zero is not used). A row with no spring or damper lane
/// skips them, unless `full_rows`: its other lanes are padding, whose `g` is `+0.0`
/// either way (computed, it is the sum of two masked products, `+0.0 + +0.0`). An LNL lane reads
/// no `K` or `Z`, so the rows of a network share one row of parameters when its other links
/// have the same (`Pull::new`).
///
/// When the forces were stored before the rows ([`Stored`], `C::STORED`), an LNL lane's load
/// brought its link's `f`, evaluated once on the reference's operands (`Pull::store_forces`),
/// where a pair's `x` would be: the lane takes it, negated in `row.flip`, the `g` its own
/// evaluation would give, and the curves are not evaluated in the rows. Its `d` and `dv`, made
/// from that load, are not used: the LNL lanes have no spring, damper or BUT bit.
///
/// A network with BUT links too has a row of thresholds `ts` per row (else `ts` is empty). A
/// row's BUT lanes are those of `row.b` with a spring (`row.k`: every BUT has one, no LNL has).
/// In a row that has one, those lanes compute [`sum_but`]'s terms with the same operations: `t =
/// d + S` (a masked add; `t` is `d` in the other lanes, so the spring lanes' products are
/// `sum`'s), the contact test on `t` with its sign flipped in `row.flip`, `g = K t + Z (v - vj)`
/// set to `+0.0` out of contact; the LNL lanes then take `lnl`. A row without an LNL lane skips
/// the curves (their values would not be used: every lane's `g` is its spring's, damper's or
/// BUT's); in a row with one, a BUT lane evaluates the curves too, a value it does not use.
///
/// Inlined always, and not compiled with AVX-512 as a function of its own: generic in `c`, it was
/// not inlined into `groups_with` for a table, and ran slower (one A/B run: 0.92x).
///
/// # Safety
/// As [`sum`].
#[cfg(target_arch = "x86_64")]
#[inline(always)]
unsafe fn sum_lnl<'p, C: LnlForces>(
    rows: &[Row],
    full_rows: bool,
    c: &C,
    ts: &[[f64; LANES]],
    group: Group8<impl Params<'p>>,
) -> __m512d {
    let (x, v, (xs, vs)) = (group.x, group.v, group.perm);
    let but = !ts.is_empty();
    assert!(!but || ts.len() == rows.len());
    let sign = _mm512_set1_epi64(i64::MIN);
    let zero = _mm512_setzero_pd();
    // (`a` with its sign flipped in lanes `m`)
    let flip = |m: u8, a: __m512d| {
        _mm512_castsi512_pd(_mm512_mask_xor_epi64(
            _mm512_castpd_si512(a),
            m,
            _mm512_castpd_si512(a),
            sign,
        ))
    };
    let mut f = _mm512_setzero_pd();
    for (r, (row, [kr, zr])) in rows.iter().zip(group.params).enumerate() {
        // SAFETY: the caller's promise.
        let (xj, vj) = unsafe { pairs(group.base, &row.at, xs, vs) };
        let d = _mm512_sub_pd(x, xj);
        let dv = _mm512_sub_pd(v, vj);
        // (the row's LNL lanes: those of `row.b` but its BUT lanes, which have a spring; a row
        // without one skips the curves)
        let lnls = if but { row.b & !row.k } else { row.b };
        let lnl = if C::STORED {
            // (the link's force, from the lane's load: see `LnlForces::STORED`)
            flip(row.flip, xj)
        } else if lnls != 0 {
            // SAFETY: the CPU has AVX-512F, and this function is compiled with it.
            flip(row.flip, unsafe {
                c.forces(r, flip(row.flip, d), flip(row.flip, dv))
            })
        } else {
            zero
        };
        let g = if full_rows || (row.k | row.z) != 0 {
            // SAFETY: eight `f64` each.
            let (kk, zz) = unsafe { (_mm512_loadu_pd(kr.as_ptr()), _mm512_loadu_pd(zr.as_ptr())) };
            // (the row's BUT lanes: those of `row.b` with a spring, which no LNL lane has)
            let buts = row.b & row.k;
            if but && buts != 0 {
                // SAFETY: eight `f64`.
                let s = unsafe { _mm512_loadu_pd(ts[r].as_ptr()) };
                let t = _mm512_mask_add_pd(d, buts, d, s);
                // (BUT lanes out of contact: `t`, its sign flipped from end 2, not `> 0`, NaN
                // included)
                let off = _mm512_mask_cmp_pd_mask::<_CMP_NGT_UQ>(buts, flip(row.flip, t), zero);
                let spring = _mm512_maskz_mul_pd(row.k, kk, t);
                let damper = _mm512_maskz_mul_pd(row.z, zz, dv);
                let g = _mm512_mask_mov_pd(_mm512_add_pd(spring, damper), off, zero);
                _mm512_mask_mov_pd(g, lnls, lnl)
            } else {
                let spring = _mm512_maskz_mul_pd(row.k, kk, d);
                let damper = _mm512_maskz_mul_pd(row.z, zz, dv);
                _mm512_mask_mov_pd(_mm512_add_pd(spring, damper), lnls, lnl)
            }
        } else {
            _mm512_maskz_mov_pd(lnls, lnl)
        };
        f = _mm512_sub_pd(f, g);
    }
    f
}

/// [`Pull::runs`] of the groups whose rows are `rows[bounds[g]..bounds[g + 1]]`, of curves
/// `row_curves` ([`Pull::row_curves`]).
fn runs(bounds: &[u32], row_curves: &[u32]) -> Vec<(u32, Option<u32>)> {
    // (each group's pair: `None` when it has no LNL lane, `Some(None)` when its rows have
    // several; consecutive groups of one, and those of none after them, in one run)
    let mut runs: Vec<(u32, Option<u32>)> = Vec::new();
    for (g, rows) in (1..).zip(bounds.windows(2)) {
        let mut pair = None;
        for &at in &row_curves[rows[0] as usize..rows[1] as usize] {
            pair = match (pair, at) {
                (_, NO_LNL) => pair,
                (None, at) if at & PARTS == 0 => Some(Some(at)),
                (Some(one), at) if one == Some(at) => pair,
                _ => Some(None),
            };
        }
        match runs.last_mut() {
            Some(last) if pair.is_none() || pair == Some(last.1) => last.0 = g,
            _ => runs.push((g, pair.flatten())),
        }
    }
    // (short runs of one pair read the table, and runs of the same join)
    let mut joined: Vec<(u32, Option<u32>)> = Vec::new();
    let mut start = 0;
    for (end, pair) in runs {
        let pair = pair.filter(|_| (end - start) as usize >= MIN_RUN);
        start = end;
        match joined.last_mut() {
            Some(last) if last.1 == pair => last.0 = end,
            _ => joined.push((end, pair)),
        }
    }
    joined
}

/// What step `n` reads: the kernel, `x(n)` and `x(n-1)` of every material (`cur`, `prev`, by
/// storage slot) and their pairs `pc` (`(x(n), v(n))`, [`Pull::prepare`]).
#[derive(Clone, Copy)]
struct Now<'a> {
    k: &'a Kernel,
    n: u64,
    cur: &'a [f64],
    prev: &'a [f64],
    pc: &'a [[f64; 2]],
}

/// Groups of a step's MAS, and where their `x(n+1)` and pairs go: `next` and `pn`, the slots of
/// those MAS (from the first group's first).
struct Slots<'b> {
    groups: Range<usize>,
    next: &'b mut [f64],
    pn: &'b mut [[f64; 2]],
}

impl<'b> Slots<'b> {
    /// The whole groups (of eight MAS), and the last, partial, one if there is one (then
    /// `groups.end - 1`; else no group), each with its slots.
    #[cfg(target_arch = "x86_64")]
    fn split_whole(self, k: &Kernel) -> [Slots<'b>; 2] {
        let gr = self.groups;
        let whole = gr.start..gr.end.min(k.n_mas / LANES).max(gr.start);
        let at = LANES * whole.len();
        let (next, next_part) = self.next.split_at_mut(at);
        let (pn, pn_part) = self.pn.split_at_mut(at);
        [
            Slots {
                groups: whole.clone(),
                next,
                pn,
            },
            Slots {
                groups: whole.end..gr.end,
                next: next_part,
                pn: pn_part,
            },
        ]
    }
}

/// `F(n)` of the eight lanes of a group `group`: from `+0.0`, `F - g` for each of its `rows`
/// (the pull step's `group.rows`), with `group.params` (one `(K, Z)` per row), `x(n)` and `v(n)`
/// of the lanes `group.x`, `group.v`, and the other ends' pairs in the buffer at `group.base`
/// (`group.perm`: see [`pairs`]).
///
/// # Safety
/// The CPU has AVX-512F, and every offset of `rows` is that of 16 bytes within the buffer.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f")]
#[inline]
unsafe fn sum<'p>(rows: &[Row], group: Group8<impl Params<'p>>) -> __m512d {
    let (x, v, (xs, vs)) = (group.x, group.v, group.perm);
    let mut f = _mm512_setzero_pd();
    for (row, [kr, zr]) in rows.iter().zip(group.params) {
        // SAFETY: the caller's promise.
        let (xj, vj) = unsafe { pairs(group.base, &row.at, xs, vs) };
        // SAFETY: eight `f64` each.
        let (kk, zz) = unsafe { (_mm512_loadu_pd(kr.as_ptr()), _mm512_loadu_pd(zr.as_ptr())) };
        let spring = _mm512_maskz_mul_pd(row.k, kk, _mm512_sub_pd(x, xj));
        let damper = _mm512_maskz_mul_pd(row.z, zz, _mm512_sub_pd(v, vj));
        f = _mm512_sub_pd(f, _mm512_add_pd(spring, damper));
    }
    f
}

/// [`sum`] for rows that may have BUT terms (lanes `row.b`), a threshold `ts` per row and lane
/// (`S` where the lane's MAS is end 1 of the BUT, `-S` where it is end 2, lanes `row.flip`).
///
/// FORMALISM.md's BUT force is `f = K ((x1 - x2) + S) + Z v` while `x2 - x1 < S`, else `+0.0`
/// (`ButLaw` in `engine.rs`). From end 1's side the lane computes `t = d + S`, with `d = x - xj`
/// the reference's `x1 - x2`, and `g = K t + Z (v - vj)`: the reference's `f`, operand for
/// operand, so `F - g = F + (-f)`. The test `x2 - x1 < S` is `-d < S` (`x2 - x1` is `-(x1 - x2)`
/// exactly), that is `d > -S`, that is `t > 0`: a rounded sum has the sign of the exact one, and is
/// NaN (no contact, as in the reference) where `d` is. From end 2's side, with `d = x - xj = -(x1
/// - x2)` and `v - vj = -v`, the lane computes `t = d + (-S)` and `g = K t + Z (v - vj)`, which
/// is `-f` (negating every operand negates each rounded sum and product), so `F - g = F + f`;
/// the test is `d < S`, `t < 0`, which the lane checks as `-t > 0` (`t` with its sign flipped in
/// the lanes `row.flip`). Out of contact `g` is set to `+0.0`, and `F - (+0.0) = F`, as adding
/// the reference's zero does (`F` is never `-0.0`: see the module documentation). In the other
/// lanes the threshold is not added (a masked add), and the terms are [`sum`]'s. A row with no
/// BUT lane computes only those when `SKIP`: with no lane in `row.b` (nor in
/// `row.flip`, a part of it), `t` is `d`, `off` is empty, and the terms are `sum`'s either way.
///
/// # Safety
/// As [`sum`], and `ts` has an item for each row.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f")]
#[inline]
unsafe fn sum_but<'p, const SKIP: bool>(
    rows: &[Row],
    ts: &[[f64; LANES]],
    group: Group8<impl Params<'p>>,
) -> __m512d {
    let (x, v, (xs, vs)) = (group.x, group.v, group.perm);
    assert!(ts.len() == rows.len());
    let sign = _mm512_set1_epi64(i64::MIN);
    let zero = _mm512_setzero_pd();
    let mut f = _mm512_setzero_pd();
    for ((row, [kr, zr]), s) in rows.iter().zip(group.params).zip(ts) {
        // SAFETY: the caller's promise.
        let (xj, vj) = unsafe { pairs(group.base, &row.at, xs, vs) };
        // SAFETY: eight `f64` each.
        let (kk, zz) = unsafe { (_mm512_loadu_pd(kr.as_ptr()), _mm512_loadu_pd(zr.as_ptr())) };
        let d = _mm512_sub_pd(x, xj);
        if SKIP && row.b == 0 {
            let spring = _mm512_maskz_mul_pd(row.k, kk, d);
            let damper = _mm512_maskz_mul_pd(row.z, zz, _mm512_sub_pd(v, vj));
            f = _mm512_sub_pd(f, _mm512_add_pd(spring, damper));
            continue;
        }
        // SAFETY: eight `f64`.
        let s = unsafe { _mm512_loadu_pd(s.as_ptr()) };
        let t = _mm512_mask_add_pd(d, row.b, d, s);
        let u = _mm512_castsi512_pd(_mm512_mask_xor_epi64(
            _mm512_castpd_si512(t),
            row.flip,
            _mm512_castpd_si512(t),
            sign,
        ));
        // (BUT lanes out of contact: `!(u > 0)`, NaN included)
        let off = _mm512_mask_cmp_pd_mask::<_CMP_NGT_UQ>(row.b, u, zero);
        let spring = _mm512_maskz_mul_pd(row.k, kk, t);
        let damper = _mm512_maskz_mul_pd(row.z, zz, _mm512_sub_pd(v, vj));
        let g = _mm512_mask_mov_pd(_mm512_add_pd(spring, damper), off, zero);
        f = _mm512_sub_pd(f, g);
    }
    f
}

/// The positions and velocities of the pairs at byte offsets `at` of the buffer at `base`
/// (lane `i`: the pair at `base + at[i]`), as two vectors; `xs`, `vs` pick the even and the odd
/// lanes of two vectors.
///
/// # Safety
/// The CPU has AVX-512F, and the 16 bytes at `base + at[i]` are within the buffer for every
/// `i` (a pair, or a stored force and the 8 bytes after it).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f")]
#[inline]
unsafe fn pairs(
    base: *const u8,
    at: &[u32; LANES],
    xs: __m512i,
    vs: __m512i,
) -> (__m512d, __m512d) {
    // (two offsets per 8-byte load, the first in the low half on x86-64: four loads fewer per
    // row, in a loop bound by its loads; measured in docs/BENCHMARKS-LOG.md, sixteenth session)
    // SAFETY: `i < 4`: bytes `8 i..8 i + 8` of the 32 bytes of `at`, read unaligned.
    let w = |i: usize| unsafe { at.as_ptr().cast::<u64>().add(i).read_unaligned() };
    // SAFETY: each 16-byte load reads one pair of the buffer (the caller's promise).
    let p = |o: u64| unsafe { _mm_loadu_pd(base.add(o as u32 as usize).cast::<f64>()) };
    let (w0, w1, w2, w3) = (w(0), w(1), w(2), w(3));
    let (q0, q1, q2, q3) = (p(w0), p(w0 >> 32), p(w1), p(w1 >> 32));
    let (q4, q5, q6, q7) = (p(w2), p(w2 >> 32), p(w3), p(w3 >> 32));
    let a = _mm512_insertf64x4::<1>(
        _mm512_castpd256_pd512(_mm256_insertf128_pd::<1>(_mm256_castpd128_pd256(q0), q1)),
        _mm256_insertf128_pd::<1>(_mm256_castpd128_pd256(q2), q3),
    );
    let b = _mm512_insertf64x4::<1>(
        _mm512_castpd256_pd512(_mm256_insertf128_pd::<1>(_mm256_castpd128_pd256(q4), q5)),
        _mm256_insertf128_pd::<1>(_mm256_castpd128_pd256(q6), q7),
    );
    (
        _mm512_permutex2var_pd(a, xs, b),
        _mm512_permutex2var_pd(a, vs, b),
    )
}

/// One block of the pull step on the pool's threads (see `parallel.rs` for the discipline).
///
/// The work is cut into `shares[t]`, the chunks of thread `t` ([`Pull::partition`]). In each
/// step thread `t` claims the chunks of its own share first, then whatever is left of the
/// others', each to exactly one thread, `claims[q]` counting share `q`'s ([`Claim::claimed`]).
/// Per step `n`, with `cur`, `prev`, `next` the [`Roles`] of step `n`,
/// and `pc`, `pn` the pair buffers of steps `n` and `n + 1` (`pairs[s % 2]` and the other, `s`
/// counting the block's steps):
///
/// | reads (everyone) | writes (thread `t` only) |
/// | --- | --- |
/// | `pos[cur]`, `pos[prev]`, `pc` | the slots of the chunks it claimed in `pos[next]` and in `pn` |
///
/// When the LNL forces are stored ([`Pull::stores_forces`]), each step has a phase before
/// that one, ended by a barrier of its own: every thread reads the `nm` pairs of `pc` and writes
/// the forces of its [`Pull::stored_share`] into `pc`, past them; the phase after reads them.
///
/// Thread 0 also records the outputs: it reads `pos[cur]` and `pos[prev]`, and writes `sf` (the
/// recorded links' forces) and its frame of the output, which no other thread touches. Nothing
/// a step reads is written in it, and the chunks' slots are disjoint (consecutive ranges of the
/// storage slots, from `Pull::partition`). The one barrier after each step orders its writes of
/// `pos[next]` and `pn` before the next step's reads (where they are `cur` and `pc`); the pairs of
/// the first step were set before the job was published (`Pool::run` releases them to the
/// workers).
///
/// Which thread steps a MAS changes no bit: its sum and update read the same values in the same
/// order whoever computes them.
pub(super) struct PullJob<'a> {
    pub(super) k: &'a Kernel,
    pub(super) pull: &'a Pull,
    pub(super) shares: &'a [Vec<Share>],
    /// one counter per share, at 0 when the block starts
    pub(super) claims: &'a [Claim],
    pub(super) pos: [SharedBuf; 3],
    /// the two pair buffers, as `f64` (pair `s` is items `2 s`, `2 s + 1`)
    pub(super) pairs: [SharedBuf; 2],
    pub(super) sf: SharedBuf,
    pub(super) n0: u64,
    /// `n0 % 3`
    pub(super) c0: usize,
    pub(super) frames: usize,
}

impl Task for PullJob<'_> {
    fn run(&self, t: usize, barrier: &SpinBarrier) -> Result<(), Poisoned> {
        self.run_share(t, None, barrier)
    }
}

impl PullJob<'_> {
    /// Thread `t`'s steps; thread 0 passes the output buffer.
    pub(super) fn run_share(
        &self,
        t: usize,
        mut out: Option<&mut [f64]>,
        barrier: &SpinBarrier,
    ) -> Result<(), Poisoned> {
        let k = self.k;
        let threads = self.shares.len();
        assert!(t < threads && self.claims.len() >= threads);
        let ch = k.channels.len();
        let mut c = self.c0;
        for s in 0..self.frames {
            let r = Roles::at(c);
            let (pc, pn) = (&self.pairs[s % 2], &self.pairs[1 - s % 2]);
            if self.pull.stores_forces() {
                let (nm, chunks) = (k.nm, self.pull.stored_share(t, threads));
                let forces = 2 * nm + LANES * chunks.start..2 * nm + LANES * chunks.end;
                // SAFETY: the first phase of the step in the type's documentation: shared reads
                // of the pairs, which nobody writes in it, and exclusive writes to this thread's
                // forces (its chunks, disjoint from every other thread's), both slices dropped
                // before the barrier that ends the phase.
                unsafe {
                    let pairs = pc.read_part(0..2 * nm).as_chunks::<2>().0;
                    self.pull.store_forces(pairs, chunks, pc.write(forces));
                }
                barrier.wait()?;
            }
            // SAFETY: each access follows the table in the type's documentation: shared reads of
            // buffers nobody writes in this step, exclusive writes to the slots of the chunks
            // this thread claimed (or, on thread 0, to `sf`), every slice dropped before the
            // barrier that ends the step.
            unsafe {
                let (cur, prev) = (self.pos[r.cur].read(), self.pos[r.prev].read());
                if let Some(out) = out.as_deref_mut() {
                    let sf = self.sf.write(0..k.sf_len);
                    self.pull
                        .record(k, cur, prev, sf, &mut out[s * ch..(s + 1) * ch]);
                }
                let now = Now {
                    k,
                    n: self.n0 + s as u64,
                    cur,
                    prev,
                    pc: pc.read().as_chunks::<2>().0,
                };
                let chunks = |q: usize| self.shares[q].len();
                for (q, j) in Claim::claimed(&self.claims[..threads], t, s, chunks) {
                    let chunk = &self.shares[q][j];
                    let slots = chunk.slots.clone();
                    let next = self.pos[r.next].write(slots.clone());
                    let pn = pn
                        .write(2 * slots.start..2 * slots.end)
                        .as_chunks_mut::<2>()
                        .0;
                    self.pull.step(now, chunk, next, pn);
                }
            }
            barrier.wait()?;
            c = r.next;
        }
        Ok(())
    }
}
