//! The pull step on a CPU with AVX2 but not AVX-512: the same groups and rows as the AVX-512
//! step (see the parent module), each group's eight lanes as two vectors of four.
//!
//! AVX2 has no mask registers, and the pull step's masks (a term's absent spring or damper, a
//! padding term) cost more to build from bits than a REF term's arithmetic. So a network of REF
//! links, where no term lacks a product, and with BUT links ([`Buts4`]), LNL links ([`Curves4`]
//! of one pair, [`CurveTable4`] of several) or both, computes its padding terms in full: a padding
//! term names the lane's own MAS, `g = K (x - x) + Z (v - v)`, with the row's `K` and `Z` (those
//! of the network when every link has the same, `0.0` otherwise). Masks are loaded only where
//! they are needed, each half of a row's lanes of a kind, four bits, from a table of sixteen
//! ([`lanes`]): the BUT or LNL lanes, whose terms cost more than a REF term, and, in a network
//! with RES or FRO links (`MASKED`), the lanes with a spring and those with a damper, whose
//! products are masked as the AVX-512 step masks them (padding lanes then have neither: `+0.0`).
//!
//! **Why the bits are the reference's.** The REF terms are the parent module's, operand for
//! operand. While every position is finite, so is every `x - x`, which is `+0.0`; if `v - v` is
//! too, the padding term is a zero, and subtracting a zero of either sign from a sum started at
//! `+0.0` leaves it as it was (the parent module's argument). `v - v` is not finite only where
//! the lane's own `v(n) = x(n) - x(n-1)` overflowed, between finite positions of opposite signs;
//! then `2 x(n) - x(n-1)`, larger still, overflows too, and the reference's `x(n+1)` of that MAS
//! is not finite either: both steps reach a non-finite position at the same step, where the
//! engine replays the block with the reference's step to report it (`Engine::check_block`).
//!
//! A network of LNL curves stores its links' forces before the rows, one pair's links at a time
//! ([`Stored4`], [`store_forces`]; the parent module's "LNL forces stored"), and its LNL lanes
//! read them. [`CurveTable4`] and the runs of pairs serve the networks that do not store: those
//! of many pairs of few links each, whose chunks would be mostly padding.
//!
//! The last group, which may be partial, is computed as a whole one, on copies of its lanes padded
//! with zeros, and only its lanes are stored (`Pull::groups_avx2_as`): its padding lanes' terms
//! read pair 0 and have no BUT or LNL mask bit, and whatever they compute is dropped. Computed lane
//! by lane until the fifty-first session, it took a quarter of the time of the reconfigurable
//! instrument (60 MAS: seven whole groups and one of four lanes).

use std::arch::x86_64::*;
use std::hint::black_box;
use std::ops::Range;

use super::{
    read_pair, AnyPair, Group, MasLaw, Now, Params, Pull, Row, Slots, LANES, LONGS, NO_LNL, PARTS,
};
use crate::curve::{ExactCurve, WideCurve, WideLong};
use crate::engine::PairFn;
use crate::wide::{Vector, V4};

/// Lanes of an AVX2 vector of `f64`.
const HALF: usize = LANES / 2;

/// Whether the masks of a row's springs and dampers are applied ([`products`]): the network has
/// RES or FRO links.
const MASKED: bool = true;

/// [`Group`] on AVX2: `x(n)` and `v(n)` of a group's lanes as two vectors of four.
type Group4<P> = Group<P, [__m256d; 2]>;

impl Pull {
    /// The MAS, group by group, the loop compiled for the kernel's inertias, and for whole groups
    /// apart from the last, the only one that may be partial.
    #[target_feature(enable = "avx2")]
    #[inline]
    pub(super) fn groups_avx2<'p, I: Iterator<Item = &'p [[f64; LANES]; 2]>>(
        &self,
        now: Now,
        params: &impl Fn(Range<usize>) -> I,
        out: Slots,
    ) {
        match &self.curves {
            _ if self.stores_forces() => {
                let curves = Curves4 {
                    c: Stored4,
                    full_rows: self.full_rows,
                    masked: self.masked,
                };
                self.groups_avx2_with(&curves, now, params, out)
            }
            Some(pair) => pair.visit(WithCurves4 {
                pull: self,
                now,
                params,
                out,
            }),
            // (no `curves`, so one pair: several have the table's shape, `Pull::new`)
            None if !self.longs.is_empty() => {
                // SAFETY: this function is compiled with AVX2.
                let c = unsafe { Long4::new(&self.longs[0]) };
                let curves = Curves4 {
                    c,
                    full_rows: self.full_rows,
                    masked: self.masked,
                };
                self.groups_avx2_with(&curves, now, params, out)
            }
            None => {
                macro_rules! with {
                    ($terms:expr) => {
                        self.groups_avx2_with(&$terms, now, params, out)
                    };
                }
                let buts = !self.thresholds.is_empty();
                match (buts, self.full_rows, self.masked) {
                    (true, true, false) => with!(Buts4::<false, false>),
                    (true, false, false) => with!(Buts4::<true, false>),
                    (true, true, MASKED) => with!(Buts4::<false, MASKED>),
                    (true, false, MASKED) => with!(Buts4::<true, MASKED>),
                    (false, _, false) => with!(Refs::<false>),
                    (false, _, MASKED) => with!(Refs::<MASKED>),
                }
            }
        }
    }

    /// [`Pull::store_forces`]: the forces of the LNL links of `ends` (chunks of
    /// [`Pull::stored`], links of one pair of curves, `pair`: a position in `Pull::pairs`, or
    /// [`LONGS`]` + i` for long pair `i`) into `forces`, eight a chunk, from the pairs `pc`.
    ///
    /// # Safety
    /// The CPU has AVX2, and every offset of `ends` is that of a pair of `pc`: a multiple of 16
    /// below `16 pc.len()`.
    #[target_feature(enable = "avx2")]
    pub(super) unsafe fn store_forces_avx2(
        &self,
        pc: &[[f64; 2]],
        pair: u32,
        ends: &[[[u32; LANES]; 2]],
        forces: &mut [f64],
    ) {
        match pair {
            LONGS.. => {
                // SAFETY: this function is compiled with AVX2; the offsets are the caller's
                // promise.
                unsafe {
                    let c = Long4::new(&self.longs[(pair - LONGS) as usize]);
                    store_forces(&c, pc, ends, forces);
                }
            }
            // (the offsets of `ends`: the caller's promise, the invariant of `StoreForces4`)
            _ => self.pairs[pair as usize].visit(StoreForces4 { pc, ends, forces }),
        }
    }

    /// [`Pull::groups_avx2`] with the group sums of `terms`, a function of its own for each kind
    /// of terms (as the AVX-512 step's `groups_with`).
    #[target_feature(enable = "avx2")]
    #[inline(never)]
    fn groups_avx2_with<'p, I: Iterator<Item = &'p [[f64; LANES]; 2]>, T: Terms4>(
        &self,
        terms: &T,
        now: Now,
        params: &impl Fn(Range<usize>) -> I,
        out: Slots,
    ) {
        let [whole, part] = out.split_whole(now.k);
        self.groups_avx2_by::<_, _, true>(terms, now, params, whole);
        if !part.groups.is_empty() {
            self.part_avx2(terms, now, params, part);
        }
    }

    /// [`Pull::groups_avx2_by`] for the last, partial, group, a function of its own (inlined
    /// into `groups_avx2_with`, it changed the whole groups' code: 2 % more instructions on
    /// `random-lnl 10000`, fifty-first session).
    #[target_feature(enable = "avx2")]
    #[inline(never)]
    fn part_avx2<'p, I: Iterator<Item = &'p [[f64; LANES]; 2]>, T: Terms4>(
        &self,
        terms: &T,
        now: Now,
        params: &impl Fn(Range<usize>) -> I,
        part: Slots,
    ) {
        self.groups_avx2_by::<_, _, false>(terms, now, params, part);
    }

    /// [`Pull::groups_avx2_as`] for the kernel's inertia law.
    #[target_feature(enable = "avx2")]
    #[inline]
    fn groups_avx2_by<
        'p,
        I: Iterator<Item = &'p [[f64; LANES]; 2]>,
        T: Terms4,
        const WHOLE: bool,
    >(
        &self,
        terms: &T,
        now: Now,
        params: &impl Fn(Range<usize>) -> I,
        out: Slots,
    ) {
        // (`groups_avx2_as` checks the groups against their buffers)
        let none: &[f64] = &[];
        macro_rules! with {
            ($div:literal, $per:literal, $m:expr, $ms:expr) => {
                self.groups_avx2_as::<_, _, $div, $per, WHOLE>(terms, now, params, $m, $ms, out)
            };
        }
        match &now.k.mas {
            MasLaw::UniformInv(inv) => with!(false, false, inv, none),
            MasLaw::UniformDiv(m) => with!(true, false, m, none),
            MasLaw::Inv(inv) => with!(false, true, &0.0, inv),
            MasLaw::Div(m) => with!(true, true, &0.0, m),
        }
    }

    /// [`Pull::groups_avx2`] for the groups of `out`, all whole (`WHOLE`) or the last, partial,
    /// one: `x(n+1) = 2 x(n) - x(n-1) + F(n) / M`, dividing (`DIV`) or multiplying by `1 / M`, `m`
    /// for every MAS or (`PER_MAS`) each MAS's own in `ms` (by storage slot). A partial group is
    /// computed as a whole one on copies of its lanes padded with zeros (its padding lanes' terms
    /// read pair 0, `Pull::new`; what they compute is not stored), and only its lanes are stored.
    #[target_feature(enable = "avx2")]
    #[inline]
    fn groups_avx2_as<
        'p,
        I: Iterator<Item = &'p [[f64; LANES]; 2]>,
        T: Terms4,
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
        let Now {
            k,
            n,
            cur,
            prev,
            pc,
        } = now;
        let Slots {
            groups: gr,
            next,
            pn,
        } = out;
        // `next` and `pn` are the slots of the MAS of groups `gr`, from `o`: every group whole,
        // or one partial group
        let o = LANES * gr.start;
        assert!(gr.end < self.bounds.len() && (WHOLE || gr.len() <= 1));
        assert!(!WHOLE || gr.is_empty() || LANES * gr.end <= k.n_mas);
        assert!(next.len() == (LANES * gr.end).min(k.n_mas) - o.min(k.n_mas));
        assert!(pn.len() == next.len() && (!PER_MAS || ms.len() == k.n_mas));
        let base = pc.as_ptr().cast::<u8>();
        let two = _mm256_set1_pd(2.0);
        let groups = (self.bounds[gr.start..=gr.end].windows(2))
            .zip(self.enf_bounds[gr.start..=gr.end].windows(2));
        for (g, (rows, inputs)) in (gr.start..).zip(groups) {
            let s0 = LANES * g;
            // (a partial group's `x(n)`, `x(n-1)` and inertias, padded: `[x, xp, m]`)
            let mut padded = [[0.0; LANES]; 3];
            let lanes = if WHOLE { LANES } else { k.n_mas - s0 };
            if !WHOLE {
                assert!(lanes < LANES && next.len() == lanes);
                padded[0][..lanes].copy_from_slice(&cur[s0..s0 + lanes]);
                padded[1][..lanes].copy_from_slice(&prev[s0..s0 + lanes]);
                if PER_MAS {
                    padded[2][..lanes].copy_from_slice(&ms[s0..s0 + lanes]);
                }
            }
            // SAFETY: slots `s0..s0 + 8` of a whole group are MAS (`s0 + 8 <= n_mas`, asserted
            // above), within `cur` and `prev`, of `nm >= n_mas` items (asserted in `step`); a
            // partial group's are eight `f64` of `padded`.
            let (x, xp) = unsafe {
                let (c, p) = if WHOLE {
                    (cur.as_ptr().add(s0), prev.as_ptr().add(s0))
                } else {
                    (padded[0].as_ptr(), padded[1].as_ptr())
                };
                (
                    [_mm256_loadu_pd(c), _mm256_loadu_pd(c.add(HALF))],
                    [_mm256_loadu_pd(p), _mm256_loadu_pd(p.add(HALF))],
                )
            };
            // (the bits of the pairs' `v`: `prepare` and the step before computed them so)
            let v = [_mm256_sub_pd(x[0], xp[0]), _mm256_sub_pd(x[1], xp[1])];
            let rows = rows[0] as usize..rows[1] as usize;
            // SAFETY: every row's 16-byte loads lie within `buffer_len(nm)` pairs (asserted in
            // `new`: a pair `< nm`, or a stored force and the 8 bytes after it), which `pc` has
            // (asserted in `step`).
            let group = Group::new(rows.clone(), params(rows), base, (x, v), ());
            let mut f = unsafe { terms.sum(self, group) };
            let inputs = &self.enf[inputs[0] as usize..inputs[1] as usize];
            if !inputs.is_empty() {
                let mut lanes_f = [0.0; LANES];
                // SAFETY: eight `f64`.
                unsafe {
                    _mm256_storeu_pd(lanes_f.as_mut_ptr(), f[0]);
                    _mm256_storeu_pd(lanes_f.as_mut_ptr().add(HALF), f[1]);
                }
                for &(i, e) in inputs {
                    lanes_f[i as usize] += k.enf[e as usize].at(n);
                }
                // SAFETY: as above.
                f = unsafe {
                    [
                        _mm256_loadu_pd(lanes_f.as_ptr()),
                        _mm256_loadu_pd(lanes_f.as_ptr().add(HALF)),
                    ]
                };
            }
            // (a partial group's `x(n+1)` and `v(n+1)`, all eight lanes, before its lanes are
            // stored)
            let mut done = [[0.0; LANES]; 2];
            for h in 0..2 {
                let s = s0 + HALF * h;
                // 2 x(n) - x(n-1) + F(n) / M, as `by_inv` and `by_div` (a uniform inertia is
                // broadcast here, through `black_box`, so that it is not kept across the loop)
                let m = if PER_MAS && WHOLE {
                    // SAFETY: slots `s..s + 4` are MAS, within the `n_mas` inertias.
                    unsafe { _mm256_loadu_pd(ms.as_ptr().add(s)) }
                } else if PER_MAS {
                    // SAFETY: four of the eight `f64` of `padded[2]`.
                    unsafe { _mm256_loadu_pd(padded[2].as_ptr().add(HALF * h)) }
                } else {
                    _mm256_set1_pd(*black_box(m))
                };
                let acc = if DIV {
                    _mm256_div_pd(f[h], m)
                } else {
                    _mm256_mul_pd(f[h], m)
                };
                let xn = _mm256_add_pd(_mm256_sub_pd(_mm256_mul_pd(two, x[h]), xp[h]), acc);
                let vn = _mm256_sub_pd(xn, x[h]);
                if !WHOLE {
                    // SAFETY: four of the eight `f64` of each of `done`.
                    unsafe {
                        _mm256_storeu_pd(done[0].as_mut_ptr().add(HALF * h), xn);
                        _mm256_storeu_pd(done[1].as_mut_ptr().add(HALF * h), vn);
                    }
                    continue;
                }
                // (`[x0 v0 | x2 v2]` and `[x1 v1 | x3 v3]`, then the pairs in order)
                let (a, b) = (_mm256_unpacklo_pd(xn, vn), _mm256_unpackhi_pd(xn, vn));
                // SAFETY: slots `s..s + 4` are items `s - o..` of `next` and of `pn` (the
                // groups `gr` cover them, asserted above), pairs of two `f64`.
                unsafe {
                    let p = pn.as_mut_ptr().cast::<f64>().add(2 * (s - o));
                    _mm256_storeu_pd(next.as_mut_ptr().add(s - o), xn);
                    _mm256_storeu_pd(p, _mm256_permute2f128_pd::<0x20>(a, b));
                    _mm256_storeu_pd(p.add(HALF), _mm256_permute2f128_pd::<0x31>(a, b));
                }
            }
            if !WHOLE {
                let [xn, vn] = &done;
                next.copy_from_slice(&xn[..lanes]);
                for ((p, &xn), &vn) in pn.iter_mut().zip(xn).zip(vn) {
                    *p = [xn, vn];
                }
            }
        }
    }
}

/// The kind of terms a network's rows have, and how a group sums them with AVX2: [`Refs`],
/// [`Buts4`] or [`Curves4`], chosen once per step ([`Pull::groups_avx2`]).
trait Terms4: Copy {
    /// `F(n)` of the eight lanes of a group, as two vectors: from `+0.0`, `F - g` for each of
    /// its rows `group.rows` of `pull` (see [`sum`]).
    ///
    /// # Safety
    /// The CPU has AVX2 and the calling function is compiled with it; every offset of the rows is
    /// that of 16 bytes within the buffer at `group.base` (a pair or a stored force).
    unsafe fn sum<'p>(&self, pull: &Pull, group: Group4<impl Params<'p>>) -> [__m256d; 2];
}

/// REF terms, or RES, FRO and REF terms when `M` ([`sum`]).
#[derive(Clone, Copy)]
struct Refs<const M: bool>;

impl<const M: bool> Terms4 for Refs<M> {
    #[inline(always)]
    unsafe fn sum<'p>(&self, pull: &Pull, group: Group4<impl Params<'p>>) -> [__m256d; 2] {
        // SAFETY: the caller's promise.
        unsafe { sum::<M>(&pull.rows[group.rows.clone()], group) }
    }
}

/// REF and BUT terms, and RES and FRO terms when `M` ([`sum_but`]; BUTs only in the rows that
/// have one when `SKIP`, that is when not `Pull::full_rows`).
#[derive(Clone, Copy)]
struct Buts4<const SKIP: bool, const M: bool>;

impl<const SKIP: bool, const M: bool> Terms4 for Buts4<SKIP, M> {
    #[inline(always)]
    unsafe fn sum<'p>(&self, pull: &Pull, group: Group4<impl Params<'p>>) -> [__m256d; 2] {
        let rows = group.rows.clone();
        let ts = &pull.thresholds[rows.clone()];
        // SAFETY: the caller's promise; `ts` has a row of thresholds for each row (`Pull::new`).
        unsafe { sum_but::<SKIP, M>(&pull.rows[rows], ts, group) }
    }
}

/// LNL terms of one pair of curves `c`, four lanes at a time, and REF terms, RES and FRO terms
/// when `masked`, BUT terms when the network has them ([`sum_lnl`]; in every row when
/// `full_rows`, else in the rows that have them).
#[derive(Clone, Copy)]
struct Curves4<C: Forces4> {
    c: C,
    full_rows: bool,
    /// `Pull::masked` (a run-time flag, as `full_rows`: one loop per pair of point counts)
    masked: bool,
}

impl<C: Forces4 + Copy> Terms4 for Curves4<C> {
    #[inline(always)]
    unsafe fn sum<'p>(&self, pull: &Pull, group: Group4<impl Params<'p>>) -> [__m256d; 2] {
        let rows = group.rows.clone();
        let ts = pull.row_thresholds(rows.clone());
        // SAFETY: the caller's promise; `ts` is empty or has a row for each row (`Pull::new`).
        unsafe { sum_lnl(self, &pull.rows[rows], ts, group) }
    }
}

/// A pair of LNL curves evaluated four lanes at a time ([`Curves4`]).
trait Forces4 {
    /// The force `LK(d) + LZ(dv)` in each LNL lane of row `r` (counted from the first row the
    /// sum was given), from the reference's operands `d` and `dv` of four of its lanes (the
    /// `ExactPair::force` and `AnyPair::force` bits); any value in the other lanes.
    ///
    /// # Safety
    /// The CPU has AVX2 and the calling function is compiled with it.
    unsafe fn forces(&self, r: usize, h: usize, d: __m256d, dv: __m256d) -> __m256d;

    /// Whether the forces were stored before the rows ([`Stored4`]): then an LNL lane's load
    /// of its "pair" brings its link's force in the `x` position, and `forces` is not called.
    const STORED: bool = false;
}

/// The forces of the LNL links, stored before the rows ([`Pull::stored`], [`store_forces`]).
#[derive(Clone, Copy)]
struct Stored4;

impl Forces4 for Stored4 {
    const STORED: bool = true;

    unsafe fn forces(&self, _: usize, _: usize, _: __m256d, _: __m256d) -> __m256d {
        unreachable!("stored forces are read, not evaluated")
    }
}

/// The forces of the LNL links of `ends` (eight a chunk: the byte offsets in `pc` of the pairs
/// of ends 1 and 2) by `c`, into `forces`, eight a chunk: the reference's `d = x1 - x2` and `v =
/// v1 - v2` (each `v` is `x(n) - x(n-1)`, as the reference's operands, see the parent module),
/// and `c`'s bits of `LK(d) + LZ(v)`, the reference's force.
///
/// # Safety
/// Every offset of `ends` is that of a pair of `pc`, a multiple of 16 below `16 pc.len()`, so
/// that each 16-byte load reads one pair (the reads are not checked: checked chunk by chunk, this
/// pass ran 1.41x the instructions and 0.95x the speed, sixtieth session).
#[target_feature(enable = "avx2")]
unsafe fn store_forces<C: Forces4>(
    c: &C,
    pc: &[[f64; 2]],
    ends: &[[[u32; LANES]; 2]],
    forces: &mut [f64],
) {
    assert!(forces.len() == LANES * ends.len());
    let base = pc.as_ptr().cast::<u8>();
    for ([a, b], out) in ends.iter().zip(forces.chunks_exact_mut(LANES)) {
        // SAFETY: every offset is that of a pair of `pc` (the caller's promise), and the CPU has
        // AVX2 (this function is compiled with it).
        let ((xa, va), (xb, vb)) = unsafe { (pairs(base, a), pairs(base, b)) };
        for h in 0..2 {
            let (d, dv) = (_mm256_sub_pd(xa[h], xb[h]), _mm256_sub_pd(va[h], vb[h]));
            // SAFETY: as above; four of the eight `f64` of `out`.
            unsafe {
                let f = c.forces(0, h, d, dv);
                _mm256_storeu_pd(out.as_mut_ptr().add(HALF * h), f);
            }
        }
    }
}

/// [`store_forces`] with a pair of at most 16 points, at its point counts.
///
/// Invariant: every offset of `ends` is that of a pair of `pc` (its one maker,
/// `Pull::store_forces_avx2`, has the promise from its caller).
struct StoreForces4<'a> {
    pc: &'a [[f64; 2]],
    ends: &'a [[[u32; LANES]; 2]],
    forces: &'a mut [f64],
}

impl PairFn for StoreForces4<'_> {
    type Out = ();

    fn call<const A: usize, const B: usize>(self, k: &ExactCurve<A>, z: &ExactCurve<B>) {
        // SAFETY: the pull step stores forces only with `Isa::Avx2` (`Pull::new`), made where
        // the CPU has AVX2 (see `Pull::store_forces`); the offsets: the type's invariant.
        unsafe { self.avx2(k, z) }
    }
}

impl StoreForces4<'_> {
    /// [`PairFn::call`], compiled with AVX2.
    ///
    /// # Safety
    /// The CPU has AVX2, and the offsets keep the type's invariant.
    #[target_feature(enable = "avx2")]
    unsafe fn avx2<const A: usize, const B: usize>(self, k: &ExactCurve<A>, z: &ExactCurve<B>) {
        // SAFETY (every block below): the caller's promise (`V4`, and the offsets).
        // (a pair of 2 to 4 points each, or of one count, as one curve of alternate lanes,
        // `store_alternating`; others as two curves, their padding shed where it may be,
        // `store_trimmed`; no closure, which would not have this function's target features)
        if (2..=4).contains(&A) && (2..=4).contains(&B) {
            // (both curves trimmed, `ExactCurve::trimmed`, at the count of the one with more
            // points once trimmed, the fewer padded, at most two selects more in its lanes: a
            // pair of 3 and 3 that several pairs padded to 4 and 4 is a pair of 3 again;
            // `trimmed` is `None` only below a curve's own count)
            let m = k.cut().max(z.cut()) + 1;
            macro_rules! at {
                ($($m:literal)*) => {
                    match m {
                        $($m => {
                            if let (Some(k), Some(z)) = (k.trimmed::<$m>(), z.trimmed::<$m>()) {
                                let c = unsafe { k.wide_alternating::<V4>(&z) };
                                return unsafe {
                                    store_alternating(&c, self.pc, self.ends, self.forces)
                                };
                            }
                        })*
                        _ => {}
                    }
                };
            }
            at!(2 3 4);
        }
        if A == B {
            // (the zero pair, `(8, 8)`, `(16, 16)`: `at_points` copies the viscous curve)
            if let Some(z) = z.at_points::<A>() {
                let c = unsafe { k.wide_alternating::<V4>(&z) };
                return unsafe { store_alternating(&c, self.pc, self.ends, self.forces) };
            }
        }
        if unsafe { store_trimmed(k, z, self.pc, self.ends, self.forces) } {
            return;
        }
        unsafe { store_pair(k, z, self.pc, self.ends, self.forces) }
    }
}

/// [`store_forces`] of the pair `k` and `z` as they are, [`Pair4`].
///
/// # Safety
/// As [`store_forces`].
#[target_feature(enable = "avx2")]
unsafe fn store_pair<const A: usize, const B: usize>(
    k: &ExactCurve<A>,
    z: &ExactCurve<B>,
    pc: &[[f64; 2]],
    ends: &[[[u32; LANES]; 2]],
    forces: &mut [f64],
) {
    // SAFETY: the caller's promise (`V4`, and the offsets).
    unsafe {
        let c = Pair4 {
            k: k.wide::<V4>(),
            z: z.wide::<V4>(),
        };
        store_forces(&c, pc, ends, forces);
    }
}

/// [`store_pair`] of the pair `k` and `z` without the points their padding added
/// ([`ExactCurve::trimmed`]: the same bits), where the stiffness curve has 5 to 16 points and
/// the viscous one at most 4, and one of them sheds a point: false (nothing stored) for other
/// pairs. Each select shed is a compare and three blends of each vector of links: the bench's
/// `drawn` pair, 7 and 3 points kept as 8 and 3 (`ExactPair::new`), makes 6 selects, not 7.
/// (A viscous curve of many points next to a short stiffness curve is rarer, and left as it
/// is: the shapes of `Pair4` this makes are 48 already.)
///
/// # Safety
/// As [`store_forces`].
#[target_feature(enable = "avx2")]
unsafe fn store_trimmed<const A: usize, const B: usize>(
    k: &ExactCurve<A>,
    z: &ExactCurve<B>,
    pc: &[[f64; 2]],
    ends: &[[[u32; LANES]; 2]],
    forces: &mut [f64],
) -> bool {
    // (the zero curve's `cut` is 0: it sheds nothing)
    if A <= 4 || B > 4 || (k.cut() + 1 == A && z.cut() + 1 == B.max(1)) {
        return false;
    }
    // (the viscous curve at each count it may have, `None` below the one it sheds to; the
    // zero curve only at 0, `at_points` refusing to pad it or to drop points)
    let z0 = z.at_points::<0>();
    let z2 = z.trimmed::<2>();
    let z3 = z.trimmed::<3>();
    let z4 = z.trimmed::<4>();
    // SAFETY (every `store_pair`): the caller's promise.
    macro_rules! at {
        ($($m:literal)*) => {
            match k.cut() + 1 {
                $($m => {
                    let Some(k) = k.trimmed::<$m>() else { return false };
                    match (z0, z2, z3, z4) {
                        (Some(z), ..) => unsafe { store_pair(&k, &z, pc, ends, forces) },
                        (_, Some(z), ..) => unsafe { store_pair(&k, &z, pc, ends, forces) },
                        (_, _, Some(z), _) => unsafe { store_pair(&k, &z, pc, ends, forces) },
                        (.., Some(z)) => unsafe { store_pair(&k, &z, pc, ends, forces) },
                        _ => return false,
                    }
                    true
                })*
                _ => false,
            }
        };
    }
    at!(5 6 7 8 9 10 11 12 13 14 15 16)
}

/// [`store_forces`] for a pair of curves in alternate lanes of one, `c` (the stiffness curve in
/// lanes 0 and 2, the viscous one in 1 and 3, [`ExactCurve::wide_alternating`]): each link's
/// `[d, v]` is its end 1's pair less its end 2's, `[x1 - x2, v1 - v2]`, the reference's operands
/// side by side, two links a vector, so that its `c` is `[LK(d), LZ(v)]` for each; the forces are
/// their sums, the reference's `LK(d) + LZ(v)`. With the curves' constants in one set of vectors,
/// not two, the pass keeps them in registers (two pairs of 3 points: 8 vectors, not 16).
///
/// # Safety
/// As [`store_forces`].
#[target_feature(enable = "avx2")]
unsafe fn store_alternating<const N: usize>(
    c: &WideCurve<V4, N>,
    pc: &[[f64; 2]],
    ends: &[[[u32; LANES]; 2]],
    forces: &mut [f64],
) {
    assert!(forces.len() == LANES * ends.len());
    let base = pc.as_ptr().cast::<u8>();
    for ([a, b], out) in ends.iter().zip(forces.chunks_exact_mut(LANES)) {
        for h in 0..2 {
            let i = HALF * h;
            // (links `i` and `i + 2` in one vector, `i + 1` and `i + 3` in the other, so that
            // the low and high halves of the two interleave to the four in order)
            // SAFETY: every offset is that of a pair of `pc` (the caller's promise), and the
            // CPU has AVX2 (this function is compiled with it); four of the eight `f64` of `out`.
            unsafe {
                let e0 = c.eval(V4(links(base, a, b, i, i + 2))).0;
                let e1 = c.eval(V4(links(base, a, b, i + 1, i + 3))).0;
                let f = _mm256_add_pd(_mm256_unpacklo_pd(e0, e1), _mm256_unpackhi_pd(e0, e1));
                _mm256_storeu_pd(out.as_mut_ptr().add(i), f);
            }
        }
    }
}

/// `[d, v]` of links `i` and `j` of a chunk whose ends' pairs are at byte offsets `a` and `b`
/// of the buffer at `base`: each link's end 1 pair less its end 2 pair, `[x1 - x2, v1 - v2]`.
///
/// # Safety
/// The CPU has AVX2, and the 16 bytes at `base + a[i]`, `base + a[j]`, `base + b[i]` and `base +
/// b[j]` are within the buffer.
#[target_feature(enable = "avx2")]
#[inline]
unsafe fn links(
    base: *const u8,
    a: &[u32; LANES],
    b: &[u32; LANES],
    i: usize,
    j: usize,
) -> __m256d {
    // SAFETY: the caller's promise.
    unsafe {
        let p = |o: u32| _mm_loadu_pd(base.add(o as usize).cast::<f64>());
        let two =
            |lo: __m128d, hi: __m128d| _mm256_insertf128_pd::<1>(_mm256_castpd128_pd256(lo), hi);
        _mm256_sub_pd(two(p(a[i]), p(a[j])), two(p(b[i]), p(b[j])))
    }
}

/// A pair of at most 16 points, of `A` and `B` (the network's `Pull::curves`).
#[derive(Clone, Copy)]
struct Pair4<const A: usize, const B: usize> {
    k: WideCurve<V4, A>,
    z: WideCurve<V4, B>,
}

impl<const A: usize, const B: usize> Forces4 for Pair4<A, B> {
    #[inline(always)]
    unsafe fn forces(&self, _: usize, _: usize, d: __m256d, dv: __m256d) -> __m256d {
        // SAFETY: the caller's promise (`V4`).
        unsafe { self.k.eval(V4(d)).add(self.z.eval(V4(dv))).0 }
    }
}

/// A pair of more than 16 points (one of `Pull::longs`: the network's pair when it is the only
/// one; among others, in its runs of groups, or by [`long_forces4`]), as the AVX-512 step's
/// `LongCurves` evaluates it.
#[derive(Clone, Copy)]
struct Long4<'a> {
    k: WideLong<'a, V4>,
    z: WideLong<'a, V4>,
}

impl Forces4 for Long4<'_> {
    #[inline(always)]
    unsafe fn forces(&self, _: usize, _: usize, d: __m256d, dv: __m256d) -> __m256d {
        // SAFETY: the caller's promise (`V4`).
        unsafe { self.k.eval(V4(d)).add(self.z.eval(V4(dv))).0 }
    }
}

impl<'a> Long4<'a> {
    /// # Safety
    /// The CPU has AVX2 (see [`V4`]).
    #[inline(always)]
    unsafe fn new(pair: &'a AnyPair) -> Self {
        // SAFETY: the caller's promise.
        unsafe {
            Long4 {
                k: pair.long.0.wide::<V4>(),
                z: pair.long.1.wide::<V4>(),
            }
        }
    }
}

/// LNL terms of several pairs of curves, each padded to `A` and `B` points (`Pull::table`), and
/// the other terms, as [`Curves4`] sums them: the AVX-512 step's `CurveTable`, each row reading
/// its pair, or its parts' pairs ([`RowCurves4`]).
#[derive(Clone, Copy)]
struct CurveTable4<'a, const A: usize, const B: usize> {
    full_rows: bool,
    masked: bool,
    /// `Pull::longs`
    longs: &'a [AnyPair],
}

impl<const A: usize, const B: usize> Terms4 for CurveTable4<'_, A, B> {
    #[inline(always)]
    unsafe fn sum<'p>(&self, pull: &Pull, group: Group4<impl Params<'p>>) -> [__m256d; 2] {
        let rows = group.rows.clone();
        let curves = Curves4 {
            c: RowCurves4::<A, B> {
                table: &pull.table,
                row_curves: &pull.row_curves[rows.clone()],
                parts: &pull.parts,
                longs: self.longs,
            },
            full_rows: self.full_rows,
            masked: self.masked,
        };
        let ts = pull.row_thresholds(rows.clone());
        // SAFETY: the caller's promise; `ts` is empty or has a row for each row (`Pull::new`).
        unsafe { sum_lnl(&curves, &pull.rows[rows], ts, group) }
    }
}

/// [`CurveTable4`] on the rows of one sum: `Pull::row_curves` from its first row, and the pull
/// step's `table` and `parts` (the AVX-512 step's `RowCurves`).
struct RowCurves4<'t, const A: usize, const B: usize> {
    table: &'t [f64],
    row_curves: &'t [u32],
    parts: &'t [(u32, u8)],
    longs: &'t [AnyPair],
}

impl<const A: usize, const B: usize> Forces4 for RowCurves4<'_, A, B> {
    /// The row's pair, when its LNL lanes share one; else each part's pair kept in the part's
    /// lanes of the four (the first part's everywhere, then each other part's in its lanes, a
    /// part with none of them skipped). Each LNL lane has its own pair's force, as [`Pair4`] or
    /// [`Long4`] computes it, from its curves padded (`ExactPair::padded`: the same bits).
    #[inline(always)]
    unsafe fn forces(&self, r: usize, h: usize, d: __m256d, dv: __m256d) -> __m256d {
        let at = self.row_curves[r];
        // SAFETY (all three): the caller's promise.
        if at == NO_LNL {
            return unsafe { _mm256_setzero_pd() };
        }
        if at & PARTS == 0 {
            return unsafe { self.pair(at, d, dv) };
        }
        let mut f = unsafe { _mm256_setzero_pd() };
        for &(pair, bits) in &self.parts[(at & !PARTS) as usize..] {
            if bits == 0 {
                break;
            }
            if (bits >> (HALF * h)) & 15 != 0 {
                f = unsafe { _mm256_blendv_pd(f, self.pair(pair, d, dv), lanes(bits, h)) };
            }
        }
        f
    }
}

impl<const A: usize, const B: usize> RowCurves4<'_, A, B> {
    /// The force of the pair at `at` in the table, or of the long pair `at` numbers, in every
    /// lane (a method, not a closure: a closure is not compiled with its caller's target
    /// features, rust-lang/rust#58279).
    ///
    /// # Safety
    /// As [`Forces4::forces`].
    #[inline(always)]
    unsafe fn pair(&self, at: u32, d: __m256d, dv: __m256d) -> __m256d {
        if at >= LONGS {
            // SAFETY: the caller's promise.
            return unsafe { long_forces4(&self.longs[(at - LONGS) as usize], d, dv) };
        }
        let (k, z) = read_pair::<A, B>(self.table, at);
        // SAFETY: the caller's promise (`V4`).
        unsafe {
            Pair4 {
                k: k.wide::<V4>(),
                z: z.wide::<V4>(),
            }
            .forces(0, 0, d, dv)
        }
    }
}

/// The forces of the long pair `pair` ([`Long4`]), for a row that reads its pairs from the
/// table (cold, and not inlined into the loop of each shape of the table, as the AVX-512 step's
/// `long_forces`).
///
/// # Safety
/// The CPU has AVX2.
#[target_feature(enable = "avx2")]
#[cold]
#[inline(never)]
unsafe fn long_forces4(pair: &AnyPair, d: __m256d, dv: __m256d) -> __m256d {
    // SAFETY: the caller's promise.
    unsafe { Long4::new(pair).forces(0, 0, d, dv) }
}

/// [`Pull::groups_avx2`] for a network of LNL links of one pair of at most 16 points:
/// [`Pull::groups_avx2_with`] with [`Curves4`] of the pair's point counts.
struct WithCurves4<'a, 'b, P> {
    pull: &'a Pull,
    now: Now<'a>,
    params: &'a P,
    out: Slots<'b>,
}

impl<'p, I: Iterator<Item = &'p [[f64; LANES]; 2]>, P: Fn(Range<usize>) -> I> PairFn
    for WithCurves4<'_, '_, P>
{
    type Out = ();

    fn call<const A: usize, const B: usize>(self, k: &ExactCurve<A>, z: &ExactCurve<B>) {
        // SAFETY: this step runs only where `Simd::detect` found AVX2 (see `Pull::step`), which
        // `avx2` needs.
        unsafe { self.avx2(k, z) }
    }
}

impl<'p, I: Iterator<Item = &'p [[f64; LANES]; 2]>, P: Fn(Range<usize>) -> I>
    WithCurves4<'_, '_, P>
{
    /// [`PairFn::call`], compiled with AVX2 (as the AVX-512 step's `WithCurves::avx512`: the
    /// curves' vectors built in registers).
    ///
    /// # Safety
    /// The CPU has AVX2 (which `V4` and `groups_avx2_with` need).
    #[target_feature(enable = "avx2")]
    unsafe fn avx2<const A: usize, const B: usize>(self, k: &ExactCurve<A>, z: &ExactCurve<B>) {
        let WithCurves4 {
            pull,
            now,
            params,
            out,
        } = self;
        // SAFETY: the caller's promise.
        unsafe {
            let (full_rows, masked) = (pull.full_rows, pull.masked);
            let pair4 = |k: &ExactCurve<A>, z: &ExactCurve<B>| Curves4 {
                c: Pair4 {
                    k: k.wide::<V4>(),
                    z: z.wide::<V4>(),
                },
                full_rows,
                masked,
            };
            if !pull.several {
                let curves = pair4(k, z);
                pull.groups_avx2_with(&curves, now, params, out);
            } else {
                // (each run of the groups: its pair's curves, a long pair's, or the table)
                let table = CurveTable4::<A, B> {
                    full_rows,
                    masked,
                    longs: &pull.longs,
                };
                pull.by_runs(now.k, out, |pair, run| match pair {
                    Some(at @ LONGS..) => {
                        let c = Long4::new(&pull.longs[(at - LONGS) as usize]);
                        let curves = Curves4 {
                            c,
                            full_rows,
                            masked,
                        };
                        pull.groups_avx2_with(&curves, now, params, run);
                    }
                    Some(at) => {
                        let (k, z) = read_pair::<A, B>(&pull.table, at);
                        let curves = pair4(&k, &z);
                        pull.groups_avx2_with(&curves, now, params, run);
                    }
                    None => pull.groups_avx2_with(&table, now, params, run),
                });
            }
        }
    }
}

/// Masks of four lanes: item `m` is all ones in lane `j` where bit `j` of `m` is set, else
/// zeros (aligned: each item is one aligned 32-byte load).
#[repr(align(32))]
struct Nibbles([[u64; HALF]; 16]);

static NIBBLES: Nibbles = Nibbles({
    let mut t = [[0; HALF]; 16];
    let mut m = 0;
    while m < 16 {
        let mut j = 0;
        while j < HALF {
            if (m >> j) & 1 == 1 {
                t[m][j] = u64::MAX;
            }
            j += 1;
        }
        m += 1;
    }
    t
});

/// Lanes `4 h..4 h + 4` of the eight of `bits` as a mask of four lanes ([`Nibbles`]).
#[target_feature(enable = "avx2")]
#[inline]
fn lanes(bits: u8, h: usize) -> __m256d {
    let m = &NIBBLES.0[usize::from(bits >> (HALF * h)) & 15];
    // SAFETY: four `u64`, 32-byte aligned (`Nibbles` is, and each item is 32 bytes).
    unsafe { _mm256_load_pd(m.as_ptr().cast::<f64>()) }
}

/// [`sum`] for rows whose lanes `row.b` have BUT terms, with a threshold `ts` per row and lane
/// (`S` where the lane's MAS is end 1 of the BUT, `-S` where it is end 2, lanes `row.flip`; `0.0`
/// in the other lanes): the AVX-512 step's `sum_but` (which proves the bits) four lanes at a
/// time, its masked operations by the masks of [`lanes`].
///
/// In each half of a row: `t = d + S`, `g = K t + Z (v - vj)`, set to `+0.0` (`vandnpd`) in the
/// BUT lanes out of contact: where `t`, its sign flipped in the lanes of `row.flip`, is not `> 0`
/// (NaN included). The add is not masked: in the other lanes `S` is `+0.0`, and `d + 0.0` is `d`
/// but where `d` is `-0.0`, whose `+0.0` changes the sign of a zero product `K d` at most; then
/// `g` is the damper's product (the same bits) or a zero, and subtracting a zero of either sign
/// from `F` leaves it as it was (`F` is never `-0.0`: the module documentation). A row with no
/// BUT lane computes [`sum`]'s terms when `SKIP` (the same bits: `t` would be `d` again, and no
/// lane out of contact). Every lane of this step's networks has a spring and a damper (a REF,
/// a BUT, or padding, whose `g` is a zero: the module documentation).
///
/// # Safety
/// As [`sum`], and `ts` has an item for each row.
#[target_feature(enable = "avx2")]
#[inline]
unsafe fn sum_but<'p, const SKIP: bool, const M: bool>(
    rows: &[Row],
    ts: &[[f64; LANES]],
    group: Group4<impl Params<'p>>,
) -> [__m256d; 2] {
    let (x, v) = (group.x, group.v);
    assert!(ts.len() == rows.len());
    let sign = _mm256_set1_pd(-0.0);
    let zero = _mm256_setzero_pd();
    let mut f = [_mm256_setzero_pd(); 2];
    for ((row, [kr, zr]), s) in rows.iter().zip(group.params).zip(ts) {
        // SAFETY: the caller's promise.
        let (xj, vj) = unsafe { pairs(group.base, &row.at) };
        for h in 0..2 {
            // SAFETY: four `f64` each, lanes `4 h..4 h + 4` of eight.
            let (kk, zz, s) = unsafe {
                (
                    _mm256_loadu_pd(kr.as_ptr().add(HALF * h)),
                    _mm256_loadu_pd(zr.as_ptr().add(HALF * h)),
                    _mm256_loadu_pd(s.as_ptr().add(HALF * h)),
                )
            };
            let d = _mm256_sub_pd(x[h], xj[h]);
            let dv = _mm256_sub_pd(v[h], vj[h]);
            let g = if SKIP && row.b == 0 {
                products::<M>(row, h, kk, d, zz, dv)
            } else {
                let t = _mm256_add_pd(d, s);
                let u = _mm256_xor_pd(t, _mm256_and_pd(lanes(row.flip, h), sign));
                let off = _mm256_and_pd(_mm256_cmp_pd::<_CMP_NGT_UQ>(u, zero), lanes(row.b, h));
                _mm256_andnot_pd(off, products::<M>(row, h, kk, t, zz, dv))
            };
            f[h] = _mm256_sub_pd(f[h], g);
        }
    }
    f
}

/// [`sum`] for rows whose lanes `row.b` have LNL terms of the pair `c.c`, or BUT terms where they
/// have a spring (`row.k`: every BUT has one, no LNL has), with a threshold `ts` per row and lane
/// when the network has BUTs (else `ts` is empty), those of `row.flip` where the lane's MAS is the
/// link's end 2: the AVX-512 step's `sum_lnl` (which proves the bits) four lanes at a time, its
/// masked moves `vblendvpd` and `vandpd` by the masks of [`lanes`].
///
/// In each half of a row: `d = x - xj`, `dv = v - vj`; where the half has an LNL lane, the
/// curves' force `LK(d) + LZ(dv)` of the operands with their sign flipped in the lanes of
/// `row.flip` (`vxorpd` with the mask's sign bits), flipped back; `g` is that force in the LNL
/// lanes, and elsewhere the REF term `K d + Z dv` (a padding lane's is a zero, the module
/// documentation's argument), or `+0.0` in a row with no REF lane unless `full_rows` (a padding
/// lane's `g` is `+0.0`: `vandpd` of the force with the LNL lanes' mask); `F - g`. A row's LNL
/// lanes read no `K` or `Z` (whatever the row holds there, the force replaces the product). A
/// half with a BUT lane computes [`sum_but`]'s terms, with its operations and its argument (the
/// threshold added without a mask), before the LNL lanes take their force.
///
/// Inlined always, and not compiled with AVX2 as a function of its own (as the AVX-512 step's
/// `sum_lnl`): generic in `C`, it was not inlined into `groups_avx2_with`, and the random LNL
/// network ran at 0.81x (five A/B rounds).
///
/// # Safety
/// As [`sum`], and `ts` is empty or has an item for each row.
#[inline(always)]
unsafe fn sum_lnl<'p, C: Forces4>(
    c: &Curves4<C>,
    rows: &[Row],
    ts: &[[f64; LANES]],
    group: Group4<impl Params<'p>>,
) -> [__m256d; 2] {
    let (x, v) = (group.x, group.v);
    let but = !ts.is_empty();
    assert!(!but || ts.len() == rows.len());
    let sign = _mm256_set1_pd(-0.0);
    let zero = _mm256_setzero_pd();
    let mut f = [zero; 2];
    for (r, (row, [kr, zr])) in rows.iter().zip(group.params).enumerate() {
        // SAFETY: the caller's promise.
        let (xj, vj) = unsafe { pairs(group.base, &row.at) };
        let full = c.full_rows || (row.k | row.z) != 0;
        // (the row's LNL lanes: those of `row.b` but its BUT lanes)
        let (lnls, buts) = if but {
            (row.b & !row.k, row.b & row.k)
        } else {
            (row.b, 0)
        };
        let has = |bits: u8, h: usize| (bits >> (HALF * h)) & 15 != 0;
        for h in 0..2 {
            let d = _mm256_sub_pd(x[h], xj[h]);
            let dv = _mm256_sub_pd(v[h], vj[h]);
            let lnl_lanes = lanes(lnls, h);
            let lnl = if C::STORED {
                // (the link's force, from the lane's load: see `Forces4::STORED`)
                _mm256_xor_pd(xj[h], _mm256_and_pd(lanes(row.flip, h), sign))
            } else if has(lnls, h) {
                let flip = _mm256_and_pd(lanes(row.flip, h), sign);
                let (d, dv) = (_mm256_xor_pd(d, flip), _mm256_xor_pd(dv, flip));
                // SAFETY: the CPU has AVX2 (the caller's promise).
                _mm256_xor_pd(unsafe { c.c.forces(r, h, d, dv) }, flip)
            } else {
                zero
            };
            let g = if full {
                // SAFETY: four `f64` each, lanes `4 h..4 h + 4` of eight.
                let (kk, zz) = unsafe {
                    (
                        _mm256_loadu_pd(kr.as_ptr().add(HALF * h)),
                        _mm256_loadu_pd(zr.as_ptr().add(HALF * h)),
                    )
                };
                let terms = if has(buts, h) {
                    // SAFETY: four `f64`, lanes `4 h..4 h + 4` of eight (`ts` has row `r`).
                    let s = unsafe { _mm256_loadu_pd(ts[r].as_ptr().add(HALF * h)) };
                    let t = _mm256_add_pd(d, s);
                    let u = _mm256_xor_pd(t, _mm256_and_pd(lanes(row.flip, h), sign));
                    let off = _mm256_and_pd(_mm256_cmp_pd::<_CMP_NGT_UQ>(u, zero), lanes(buts, h));
                    _mm256_andnot_pd(off, products_if(c.masked, row, h, kk, t, zz, dv))
                } else {
                    products_if(c.masked, row, h, kk, d, zz, dv)
                };
                _mm256_blendv_pd(terms, lnl, lnl_lanes)
            } else {
                _mm256_and_pd(lnl, lnl_lanes)
            };
            f[h] = _mm256_sub_pd(f[h], g);
        }
    }
    f
}

/// `K d + Z dv` in half `h` of `row` (lanes `4 h..4 h + 4`), each product set to `+0.0` (`vandpd`)
/// in the lanes without a spring (`row.k`) or a damper (`row.z`) when `M`: the AVX-512 step's
/// `maskz_mul`s, the same bits (and no `0 x inf` where the reference has no such product).
#[target_feature(enable = "avx2")]
#[inline]
fn products<const M: bool>(
    row: &Row,
    h: usize,
    kk: __m256d,
    d: __m256d,
    zz: __m256d,
    dv: __m256d,
) -> __m256d {
    let (spring, damper) = (_mm256_mul_pd(kk, d), _mm256_mul_pd(zz, dv));
    if M {
        let spring = _mm256_and_pd(spring, lanes(row.k, h));
        _mm256_add_pd(spring, _mm256_and_pd(damper, lanes(row.z, h)))
    } else {
        _mm256_add_pd(spring, damper)
    }
}

/// [`products`], masked or not (a run-time flag).
#[target_feature(enable = "avx2")]
#[inline]
fn products_if(
    masked: bool,
    row: &Row,
    h: usize,
    kk: __m256d,
    d: __m256d,
    zz: __m256d,
    dv: __m256d,
) -> __m256d {
    if masked {
        products::<MASKED>(row, h, kk, d, zz, dv)
    } else {
        products::<false>(row, h, kk, d, zz, dv)
    }
}

/// `F(n)` of the eight lanes of a group `group`, as two vectors: from `+0.0`, `F - g` for each
/// of its `rows` (the pull step's `group.rows`), with `group.params` (one `(K, Z)` per row), `x(n)`
/// and `v(n)` of the lanes `group.x`, `group.v`, and the other ends' pairs in the buffer at
/// `group.base`.
///
/// # Safety
/// The CPU has AVX2, and every offset of `rows` is that of 16 bytes within the buffer.
#[target_feature(enable = "avx2")]
#[inline]
unsafe fn sum<'p, const M: bool>(rows: &[Row], group: Group4<impl Params<'p>>) -> [__m256d; 2] {
    let (x, v) = (group.x, group.v);
    let mut f = [_mm256_setzero_pd(); 2];
    for (row, [kr, zr]) in rows.iter().zip(group.params) {
        // SAFETY: the caller's promise.
        let (xj, vj) = unsafe { pairs(group.base, &row.at) };
        for h in 0..2 {
            // SAFETY: four `f64` each, lanes `4 h..4 h + 4` of eight.
            let (kk, zz) = unsafe {
                (
                    _mm256_loadu_pd(kr.as_ptr().add(HALF * h)),
                    _mm256_loadu_pd(zr.as_ptr().add(HALF * h)),
                )
            };
            let (d, dv) = (_mm256_sub_pd(x[h], xj[h]), _mm256_sub_pd(v[h], vj[h]));
            f[h] = _mm256_sub_pd(f[h], products::<M>(row, h, kk, d, zz, dv));
        }
    }
    f
}

/// The positions and velocities of the pairs at byte offsets `at` of the buffer at `base` (lane
/// `i`: the pair at `base + at[i]`), as two vectors of four lanes each.
///
/// # Safety
/// The CPU has AVX2, and the 16 bytes at `base + at[i]` are within the buffer for every `i`.
#[target_feature(enable = "avx2")]
#[inline]
unsafe fn pairs(base: *const u8, at: &[u32; LANES]) -> ([__m256d; 2], [__m256d; 2]) {
    // (two offsets per 8-byte load, as the AVX-512 step's `pairs`)
    // SAFETY: `i < 4`: bytes `8 i..8 i + 8` of the 32 bytes of `at`, read unaligned.
    let w = |i: usize| unsafe { at.as_ptr().cast::<u64>().add(i).read_unaligned() };
    // SAFETY: each 16-byte load reads 16 bytes of the buffer (the caller's promise).
    let p = |o: u64| unsafe { _mm_loadu_pd(base.add(o as u32 as usize).cast::<f64>()) };
    let two = |lo: __m128d, hi: __m128d| _mm256_insertf128_pd::<1>(_mm256_castpd128_pd256(lo), hi);
    let (w0, w1, w2, w3) = (w(0), w(1), w(2), w(3));
    // lanes 0, 2 in one vector, 1, 3 in the other: `[x0 v0 | x2 v2]`, `[x1 v1 | x3 v3]`, whose
    // low and high halves interleave to `[x0 x1 x2 x3]` and `[v0 v1 v2 v3]`
    let (a0, b0) = (two(p(w0), p(w1)), two(p(w0 >> 32), p(w1 >> 32)));
    let (a1, b1) = (two(p(w2), p(w3)), two(p(w2 >> 32), p(w3 >> 32)));
    (
        [_mm256_unpacklo_pd(a0, b0), _mm256_unpacklo_pd(a1, b1)],
        [_mm256_unpackhi_pd(a0, b0), _mm256_unpackhi_pd(a1, b1)],
    )
}
