//! The pull step on a CPU with AVX2 but not AVX-512: the same groups and rows as the AVX-512
//! step (see the parent module), each group's eight lanes as two vectors of four.
//!
//! AVX2 has no mask registers, and the pull step's masks (a term's absent spring or damper, a
//! padding term) cost more to build from bits than the term's arithmetic. So this step takes only
//! networks of REF links, where no term lacks a product, and computes the padding terms in full:
//! a padding term names the lane's own MAS, `g = K (x - x) + Z (v - v)`, with the row's `K` and
//! `Z` (those of the network when every link has the same, `0.0` otherwise).
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
//! The last group, which may be partial, is computed one lane at a time, with the masks.

use std::arch::x86_64::*;
use std::hint::black_box;
use std::ops::Range;

use super::{split_whole, Kernel, MasLaw, Pull, Row, LANES};
use crate::engine::{by_div, by_inv};

/// Lanes of an AVX2 vector of `f64`.
const HALF: usize = LANES / 2;

impl Pull {
    /// The MAS, group by group: the whole groups compiled for the kernel's inertias, the last
    /// one, if it is partial, lane by lane.
    #[target_feature(enable = "avx2")]
    #[allow(clippy::too_many_arguments)] // the step's buffers
    #[inline]
    pub(super) fn groups_avx2<'p, I: Iterator<Item = &'p [[f64; LANES]; 2]>>(
        &self,
        k: &Kernel,
        n: u64,
        gr: Range<usize>,
        cur: &[f64],
        prev: &[f64],
        pc: &[[f64; 2]],
        params: impl Fn(Range<usize>) -> I,
        next: &mut [f64],
        pn: &mut [[f64; 2]],
    ) {
        let ([whole, part], (next, next_part), (pn, pn_part)) = split_whole(k, gr, next, pn);
        let none: &[f64] = &[];
        macro_rules! whole {
            ($div:literal, $per:literal, $m:expr, $ms:expr) => {
                self.whole_avx2::<_, $div, $per>(
                    k,
                    n,
                    whole.clone(),
                    cur,
                    prev,
                    pc,
                    &params,
                    $m,
                    $ms,
                    next,
                    pn,
                )
            };
        }
        match &k.mas {
            MasLaw::UniformInv(inv) => whole!(false, false, inv, none),
            MasLaw::UniformDiv(m) => whole!(true, false, m, none),
            MasLaw::Inv(inv) => whole!(false, true, &0.0, inv),
            MasLaw::Div(m) => whole!(true, true, &0.0, m),
        }
        if !part.is_empty() {
            assert!(part.len() == 1);
            self.part(k, n, part.start, cur, prev, pc, params, next_part, pn_part);
        }
    }

    /// [`Pull::groups_avx2`] for the whole groups `gr`: `x(n+1) = 2 x(n) - x(n-1) + F(n) / M`,
    /// dividing (`DIV`) or multiplying by `1 / M`, `m` for every MAS or (`PER_MAS`) each MAS's
    /// own in `ms` (by storage slot).
    #[target_feature(enable = "avx2")]
    #[allow(clippy::too_many_arguments)] // the step's buffers
    #[inline]
    fn whole_avx2<
        'p,
        I: Iterator<Item = &'p [[f64; LANES]; 2]>,
        const DIV: bool,
        const PER_MAS: bool,
    >(
        &self,
        k: &Kernel,
        n: u64,
        gr: Range<usize>,
        cur: &[f64],
        prev: &[f64],
        pc: &[[f64; 2]],
        params: &impl Fn(Range<usize>) -> I,
        m: &f64,
        ms: &[f64],
        next: &mut [f64],
        pn: &mut [[f64; 2]],
    ) {
        // `next` and `pn` are the slots of the MAS of groups `gr`, from `o`, every group whole
        let o = LANES * gr.start;
        assert!((gr.is_empty() || LANES * gr.end <= k.n_mas) && gr.end < self.bounds.len());
        assert!(next.len() == LANES * gr.len() && pn.len() == next.len());
        assert!(!PER_MAS || ms.len() == k.n_mas);
        let base = pc.as_ptr().cast::<u8>();
        let two = _mm256_set1_pd(2.0);
        let groups = (self.bounds[gr.start..=gr.end].windows(2))
            .zip(self.enf_bounds[gr.start..=gr.end].windows(2));
        for (g, (rows, inputs)) in (gr.start..).zip(groups) {
            let s0 = LANES * g;
            // SAFETY: slots `s0..s0 + 8` are MAS (`s0 + 8 <= n_mas`, asserted above), within
            // `cur` and `prev`, of `nm >= n_mas` items (asserted in `step`).
            let (x, xp) = unsafe {
                let (c, p) = (cur.as_ptr().add(s0), prev.as_ptr().add(s0));
                (
                    [_mm256_loadu_pd(c), _mm256_loadu_pd(c.add(HALF))],
                    [_mm256_loadu_pd(p), _mm256_loadu_pd(p.add(HALF))],
                )
            };
            // (the bits of the pairs' `v`: `prepare` and the step before computed them so)
            let v = [_mm256_sub_pd(x[0], xp[0]), _mm256_sub_pd(x[1], xp[1])];
            let rows = rows[0] as usize..rows[1] as usize;
            // SAFETY: every row's offsets are those of pairs `< nm` (asserted in `new`), and `pc`
            // has `nm` pairs (asserted in `step`).
            let mut f = unsafe { sum(&self.rows[rows.clone()], params(rows), base, x, v) };
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
            for h in 0..2 {
                let s = s0 + HALF * h;
                // 2 x(n) - x(n-1) + F(n) / M, as `by_inv` and `by_div` (a uniform inertia is
                // broadcast here, through `black_box`, so that it is not kept across the loop)
                let m = if PER_MAS {
                    // SAFETY: slots `s..s + 4` are MAS, within the `n_mas` inertias.
                    unsafe { _mm256_loadu_pd(ms.as_ptr().add(s)) }
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
        }
    }

    /// The partial group `g` (the last), lane by lane: the REF terms of the lane's rows (those
    /// its mask bits name; the others are padding, skipped), then its ENF inputs, with the
    /// reference's expressions.
    #[allow(clippy::too_many_arguments)] // the step's buffers
    fn part<'p, I: Iterator<Item = &'p [[f64; LANES]; 2]>>(
        &self,
        k: &Kernel,
        n: u64,
        g: usize,
        cur: &[f64],
        prev: &[f64],
        pc: &[[f64; 2]],
        params: impl Fn(Range<usize>) -> I,
        next: &mut [f64],
        pn: &mut [[f64; 2]],
    ) {
        let s0 = LANES * g;
        let lanes = k.n_mas - s0;
        assert!(lanes < LANES && next.len() == lanes && pn.len() == lanes);
        let rows = self.bounds[g] as usize..self.bounds[g + 1] as usize;
        let inputs = &self.enf[self.enf_bounds[g] as usize..self.enf_bounds[g + 1] as usize];
        for i in 0..lanes {
            let s = s0 + i;
            let (x, xp) = (cur[s], prev[s]);
            let v = x - xp;
            let mut f = 0.0;
            for (row, [kr, zr]) in self.rows[rows.clone()].iter().zip(params(rows.clone())) {
                if row.k & (1 << i) == 0 {
                    continue; // (padding: every term of this step's networks is a REF)
                }
                let [xj, vj] = pc[row.at[i] as usize / 16];
                f -= kr[i] * (x - xj) + zr[i] * (v - vj);
            }
            for &(_, e) in inputs.iter().filter(|&&(l, _)| l as usize == i) {
                f += k.enf[e as usize].at(n);
            }
            let xn = match &k.mas {
                MasLaw::UniformInv(inv) => by_inv(x, xp, f, *inv),
                MasLaw::UniformDiv(m) => by_div(x, xp, f, *m),
                MasLaw::Inv(inv) => by_inv(x, xp, f, inv[s]),
                MasLaw::Div(m) => by_div(x, xp, f, m[s]),
            };
            next[i] = xn;
            pn[i] = [xn, xn - x];
        }
    }
}

/// `F(n)` of the eight lanes of a group, as two vectors: from `+0.0`, `F - g` for each of its
/// `rows`, with `params` (one `(K, Z)` per row), `x(n)` and `v(n)` of the lanes `x`, `v`, and
/// the other ends' pairs in the buffer at `base`.
///
/// # Safety
/// The CPU has AVX2, and every offset of `rows` is that of a pair within the buffer.
#[target_feature(enable = "avx2")]
#[inline]
unsafe fn sum<'p>(
    rows: &[Row],
    params: impl Iterator<Item = &'p [[f64; LANES]; 2]>,
    base: *const u8,
    x: [__m256d; 2],
    v: [__m256d; 2],
) -> [__m256d; 2] {
    let mut f = [_mm256_setzero_pd(); 2];
    for (row, [kr, zr]) in rows.iter().zip(params) {
        // SAFETY: the caller's promise.
        let (xj, vj) = unsafe { pairs(base, &row.at) };
        for h in 0..2 {
            // SAFETY: four `f64` each, lanes `4 h..4 h + 4` of eight.
            let (kk, zz) = unsafe {
                (
                    _mm256_loadu_pd(kr.as_ptr().add(HALF * h)),
                    _mm256_loadu_pd(zr.as_ptr().add(HALF * h)),
                )
            };
            let spring = _mm256_mul_pd(kk, _mm256_sub_pd(x[h], xj[h]));
            let damper = _mm256_mul_pd(zz, _mm256_sub_pd(v[h], vj[h]));
            f[h] = _mm256_sub_pd(f[h], _mm256_add_pd(spring, damper));
        }
    }
    f
}

/// The positions and velocities of the pairs at byte offsets `at` of the buffer at `base` (lane
/// `i`: the pair at `base + at[i]`), as two vectors of four lanes each.
///
/// # Safety
/// The CPU has AVX2, and `base + at[i]` is a pair of the buffer for every `i`.
#[target_feature(enable = "avx2")]
#[inline]
unsafe fn pairs(base: *const u8, at: &[u32; LANES]) -> ([__m256d; 2], [__m256d; 2]) {
    // (two offsets per 8-byte load, as the AVX-512 step's `pairs`)
    // SAFETY: `i < 4`: bytes `8 i..8 i + 8` of the 32 bytes of `at`, read unaligned.
    let w = |i: usize| unsafe { at.as_ptr().cast::<u64>().add(i).read_unaligned() };
    // SAFETY: each 16-byte load reads one pair of the buffer (the caller's promise).
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
