//! Vectors of `f64` lanes, eight (AVX-512, [`V8`]) or four (AVX2, [`V4`]), behind one trait.
//!
//! The grid step's rows (`engine/grid.rs`) and the LNL curves it evaluates (`curve.rs`'s
//! `WideCurve`) are written once, generic over a [`Vector`], and compiled for each width: a CPU
//! with AVX-512 steps eight MAS at a time, one with AVX2 alone four. Every operation is an IEEE
//! operation lane by lane (no fused multiply-add, no reassociation), the same in both widths, so
//! both give the same bits as the scalar code they stand for.
//!
//! The methods are `#[inline(always)]` and have no target features of their own: they are
//! compiled with those of the function they are inlined into, which must have the width's
//! (`avx512f` for [`V8`], `avx2` for [`V4`]). That is each method's safety condition.

#[cfg(target_arch = "x86_64")]
use std::arch::x86_64::*;

/// `f64` lanes side by side, and the operations of the grid step on them.
///
/// # Safety (every method)
/// The CPU has the width's instructions ([`V8`]: AVX-512F; [`V4`]: AVX2), and the calling
/// function is compiled with them.
#[cfg(target_arch = "x86_64")]
pub(crate) trait Vector: Copy {
    /// Lanes.
    const N: usize;
    /// Whether [`Vector::next1`] is one instruction (else two, across the halves of the vector).
    const SHIFT_IS_ONE: bool;
    /// The most points of a curve whose segment `WideCurve::eval` looks up, in a table of two
    /// vectors at most ([`Vector::pick2`]); 0 where it selects segments whatever the curve.
    const LOOKUP: usize;
    /// The most abscissas of a curve whose segment `WideLong::eval` looks up in vectors
    /// ([`Vector::pick2`] of each two, and selects), rather than gathers.
    const LOOK_MAX: usize;
    /// A set of lanes (the result of a compare).
    type Mask: Copy;
    /// An index into `N` numbers in each lane ([`Vector::pick`]).
    type Index: Copy;

    unsafe fn splat(v: f64) -> Self;
    unsafe fn zero() -> Self;
    /// `N` items from `p` (no alignment needed).
    unsafe fn load(p: *const f64) -> Self;
    /// `N` items to `p`.
    unsafe fn store(self, p: *mut f64);
    /// The first `min(s.len(), N)` items of `s`, `0.0` in the other lanes; nothing outside `s` is
    /// read.
    unsafe fn load_part(s: &[f64]) -> Self;
    /// Lanes `0..min(out.len(), N)` into `out`; nothing else is written.
    unsafe fn store_part(self, out: &mut [f64]);
    unsafe fn add(self, b: Self) -> Self;
    unsafe fn sub(self, b: Self) -> Self;
    unsafe fn mul(self, b: Self) -> Self;
    unsafe fn div(self, b: Self) -> Self;
    /// `if self > b { self } else { b }`, lane by lane (`maxpd`: `b` for a NaN or two zeros).
    unsafe fn max(self, b: Self) -> Self;
    /// `if self < b { self } else { b }`, lane by lane (`minpd`: `b` for a NaN or two zeros).
    unsafe fn min(self, b: Self) -> Self;
    /// The lanes where `self <= b` (false where either is NaN).
    unsafe fn le(self, b: Self) -> Self::Mask;
    /// The lanes where `self < b` (false where either is NaN).
    unsafe fn lt(self, b: Self) -> Self::Mask;
    /// `if m { b } else { self }`, lane by lane.
    unsafe fn select(self, m: Self::Mask, b: Self) -> Self;
    /// `if m { self } else { +0.0 }`, lane by lane.
    unsafe fn keep(self, m: Self::Mask) -> Self;
    /// Lane `i` alone (`i < N`).
    unsafe fn lane(i: usize) -> Self::Mask;
    /// `[self[1], .., self[N-1], b[0]]`: the right neighbours of `N` items from theirs and the
    /// next `N`'s.
    unsafe fn next1(self, b: Self) -> Self;
    /// `[self[N-1], b[0], .., b[N-2]]`: the left neighbours of the `N` items `b` from theirs and
    /// the `N` before's.
    unsafe fn prev1(self, b: Self) -> Self;
    /// Index 0 in every lane.
    unsafe fn first() -> Self::Index;
    /// `i + h` in every lane (`i + h` below `2^31`).
    unsafe fn plus(i: Self::Index, h: usize) -> Self::Index;
    /// `to` in the lanes `m`, `i` in the others.
    unsafe fn moved(i: Self::Index, m: Self::Mask, to: Self::Index) -> Self::Index;
    /// `self[i[j]]` in each lane `j` (each `i[j] < N`).
    unsafe fn pick(self, i: Self::Index) -> Self;
    /// `t[i[j]]` in each lane `j`, where `t` is the `2 N` numbers of `self` then `hi` (each
    /// `i[j] < 2 N`).
    unsafe fn pick2(self, hi: Self, i: Self::Index) -> Self;
    /// `i mod 2 N` in every lane.
    unsafe fn low(i: Self::Index) -> Self::Index;
    /// The lanes where `i >= p`.
    unsafe fn at_least(i: Self::Index, p: usize) -> Self::Mask;
    /// `i << bits` in every lane (`i` times `2^bits`, below `2^31`).
    unsafe fn times(i: Self::Index, bits: u32) -> Self::Index;
    /// Each lane truncated to an index (each lane a number in `-1 < x < 2^31`).
    unsafe fn truncated(self) -> Self::Index;
    /// Each lane's bits as an index (each lane `f64::from_bits(i)` for an index `i < 2^31`).
    unsafe fn index_bits(self) -> Self::Index;
    /// `*p.add(i[j])` in each lane `j` (a gather; each `p.add(i[j])` valid for reads).
    unsafe fn gather(p: *const f64, i: Self::Index) -> Self;
    /// Whether `WideLong::eval` guesses from rows ([`Vector::rows`]) rather than gathers.
    const ROWS: bool;
    /// `[r[0], .., r[5]]` where lane `j` of `r[k]` is `*p.add(8 i + k)`, `i` lane `j` of `self`
    /// truncated: six numbers of a row of eight for each lane (each lane a number in `-1 < x <
    /// 2^25`, each of the numbers valid for reads).
    unsafe fn rows(self, p: *const f64) -> [Self; 6];
}

/// Eight lanes: AVX-512F.
#[cfg(target_arch = "x86_64")]
#[derive(Clone, Copy)]
pub(crate) struct V8(pub(crate) __m512d);

/// Four lanes: AVX2.
#[cfg(target_arch = "x86_64")]
#[derive(Clone, Copy)]
pub(crate) struct V4(pub(crate) __m256d);

#[cfg(target_arch = "x86_64")]
impl Vector for V8 {
    const N: usize = 8;
    const SHIFT_IS_ONE: bool = true;
    const LOOKUP: usize = 16;
    const LOOK_MAX: usize = 64;
    type Mask = __mmask8;
    type Index = __m512i;

    #[inline(always)]
    unsafe fn splat(v: f64) -> Self {
        V8(_mm512_set1_pd(v))
    }
    #[inline(always)]
    unsafe fn zero() -> Self {
        V8(_mm512_setzero_pd())
    }
    #[inline(always)]
    unsafe fn load(p: *const f64) -> Self {
        V8(_mm512_loadu_pd(p))
    }
    #[inline(always)]
    unsafe fn store(self, p: *mut f64) {
        _mm512_storeu_pd(p, self.0)
    }
    #[inline(always)]
    unsafe fn load_part(s: &[f64]) -> Self {
        V8(crate::lanes::load8(s))
    }
    #[inline(always)]
    unsafe fn store_part(self, out: &mut [f64]) {
        crate::lanes::store8(out, self.0)
    }
    #[inline(always)]
    unsafe fn add(self, b: Self) -> Self {
        V8(_mm512_add_pd(self.0, b.0))
    }
    #[inline(always)]
    unsafe fn sub(self, b: Self) -> Self {
        V8(_mm512_sub_pd(self.0, b.0))
    }
    #[inline(always)]
    unsafe fn mul(self, b: Self) -> Self {
        V8(_mm512_mul_pd(self.0, b.0))
    }
    #[inline(always)]
    unsafe fn div(self, b: Self) -> Self {
        V8(_mm512_div_pd(self.0, b.0))
    }
    #[inline(always)]
    unsafe fn max(self, b: Self) -> Self {
        V8(_mm512_max_pd(self.0, b.0))
    }
    #[inline(always)]
    unsafe fn min(self, b: Self) -> Self {
        V8(_mm512_min_pd(self.0, b.0))
    }
    #[inline(always)]
    unsafe fn le(self, b: Self) -> __mmask8 {
        _mm512_cmp_pd_mask::<_CMP_LE_OQ>(self.0, b.0)
    }
    #[inline(always)]
    unsafe fn lt(self, b: Self) -> __mmask8 {
        _mm512_cmp_pd_mask::<_CMP_LT_OQ>(self.0, b.0)
    }
    #[inline(always)]
    unsafe fn select(self, m: __mmask8, b: Self) -> Self {
        V8(_mm512_mask_blend_pd(m, self.0, b.0))
    }
    #[inline(always)]
    unsafe fn keep(self, m: __mmask8) -> Self {
        V8(_mm512_maskz_mov_pd(m, self.0))
    }
    #[inline(always)]
    unsafe fn lane(i: usize) -> __mmask8 {
        (1u16 << i) as __mmask8
    }
    /// One `valignq`.
    #[inline(always)]
    unsafe fn next1(self, b: Self) -> Self {
        let (a, b) = (_mm512_castpd_si512(self.0), _mm512_castpd_si512(b.0));
        V8(_mm512_castsi512_pd(_mm512_alignr_epi64::<1>(b, a)))
    }
    /// One `valignq`.
    #[inline(always)]
    unsafe fn prev1(self, b: Self) -> Self {
        let (a, b) = (_mm512_castpd_si512(self.0), _mm512_castpd_si512(b.0));
        V8(_mm512_castsi512_pd(_mm512_alignr_epi64::<7>(b, a)))
    }
    #[inline(always)]
    unsafe fn first() -> __m512i {
        _mm512_setzero_si512()
    }
    #[inline(always)]
    unsafe fn plus(i: __m512i, h: usize) -> __m512i {
        _mm512_add_epi64(i, _mm512_set1_epi64(h as i64))
    }
    /// A masked `vmovdqa64`.
    #[inline(always)]
    unsafe fn moved(i: __m512i, m: __mmask8, to: __m512i) -> __m512i {
        _mm512_mask_mov_epi64(i, m, to)
    }
    /// One `vpermpd`.
    #[inline(always)]
    unsafe fn pick(self, i: __m512i) -> Self {
        V8(_mm512_permutexvar_pd(i, self.0))
    }
    /// One `vpermt2pd` (bit 3 of each index chooses `hi`).
    #[inline(always)]
    unsafe fn pick2(self, hi: Self, i: __m512i) -> Self {
        V8(_mm512_permutex2var_pd(self.0, i, hi.0))
    }
    #[inline(always)]
    unsafe fn low(i: __m512i) -> __m512i {
        _mm512_and_si512(i, _mm512_set1_epi64(15))
    }
    #[inline(always)]
    unsafe fn at_least(i: __m512i, p: usize) -> __mmask8 {
        _mm512_cmpge_epi64_mask(i, _mm512_set1_epi64(p as i64))
    }
    #[inline(always)]
    unsafe fn times(i: __m512i, bits: u32) -> __m512i {
        _mm512_sll_epi64(i, _mm_cvtsi32_si128(bits as i32))
    }
    /// `vcvttpd2dq` then `vpmovsxdq` (AVX-512F has no `f64` to 64-bit conversion).
    #[inline(always)]
    unsafe fn truncated(self) -> __m512i {
        _mm512_cvtepi32_epi64(_mm512_cvttpd_epi32(self.0))
    }
    #[inline(always)]
    unsafe fn index_bits(self) -> __m512i {
        _mm512_castpd_si512(self.0)
    }
    /// One `vgatherqpd`.
    #[inline(always)]
    unsafe fn gather(p: *const f64, i: __m512i) -> Self {
        V8(_mm512_i64gather_pd::<8>(i, p))
    }
    /// (not measured against gathers: no AVX-512 machine since the rows were written)
    const ROWS: bool = false;
    /// Six gathers.
    #[inline(always)]
    unsafe fn rows(self, p: *const f64) -> [Self; 6] {
        let at = Self::times(self.truncated(), 3);
        let mut r = [Self::zero(); 6];
        for (k, r) in r.iter_mut().enumerate() {
            *r = Self::gather(p.add(k), at);
        }
        r
    }
}

/// `[x[k] x[k+1] y[k] y[k+1]]` (a function, not a closure, so that it has the caller's target
/// features).
///
/// # Safety
/// The CPU has AVX2 (see [`Vector`]), and the four numbers are valid for reads.
#[cfg(target_arch = "x86_64")]
#[inline(always)]
unsafe fn halves(x: *const f64, y: *const f64, k: usize) -> __m256d {
    let low = _mm256_castpd128_pd256(_mm_loadu_pd(x.add(k)));
    _mm256_insertf128_pd::<1>(low, _mm_loadu_pd(y.add(k)))
}

/// The lanes `0..n` of four as an AVX2 mask (all ones in a lane that is set).
#[cfg(target_arch = "x86_64")]
#[inline(always)]
unsafe fn mask4(n: usize) -> __m256i {
    _mm256_cmpgt_epi64(_mm256_set1_epi64x(n as i64), _mm256_set_epi64x(3, 2, 1, 0))
}

#[cfg(target_arch = "x86_64")]
impl Vector for V4 {
    const N: usize = 4;
    const SHIFT_IS_ONE: bool = false;
    /// (an index costs four integer operations before each `vpermd`, two `vpermd` and a blend
    /// for two vectors: no fewer than the selects)
    const LOOKUP: usize = 0;
    /// (a 33-point curve's table of 32 numbers, one `vgatherqpd` a fetch, ran 1.5x faster on
    /// Zen 3 than looked up; a 17-point one's 16 as fast: fifty-third session)
    const LOOK_MAX: usize = 16;
    type Mask = __m256d;
    type Index = __m256i;

    #[inline(always)]
    unsafe fn splat(v: f64) -> Self {
        V4(_mm256_set1_pd(v))
    }
    #[inline(always)]
    unsafe fn zero() -> Self {
        V4(_mm256_setzero_pd())
    }
    #[inline(always)]
    unsafe fn load(p: *const f64) -> Self {
        V4(_mm256_loadu_pd(p))
    }
    #[inline(always)]
    unsafe fn store(self, p: *mut f64) {
        _mm256_storeu_pd(p, self.0)
    }
    /// `vmaskmovpd`: masked-off lanes read as `0.0`, and are not accessed (no fault; Intel SDM,
    /// VMASKMOV: "faults ... are suppressed" for masked-off elements).
    #[inline(always)]
    unsafe fn load_part(s: &[f64]) -> Self {
        V4(_mm256_maskload_pd(s.as_ptr(), mask4(s.len().min(4))))
    }
    /// `vmaskmovpd`: masked-off lanes are not written (and do not fault).
    #[inline(always)]
    unsafe fn store_part(self, out: &mut [f64]) {
        _mm256_maskstore_pd(out.as_mut_ptr(), mask4(out.len().min(4)), self.0)
    }
    #[inline(always)]
    unsafe fn add(self, b: Self) -> Self {
        V4(_mm256_add_pd(self.0, b.0))
    }
    #[inline(always)]
    unsafe fn sub(self, b: Self) -> Self {
        V4(_mm256_sub_pd(self.0, b.0))
    }
    #[inline(always)]
    unsafe fn mul(self, b: Self) -> Self {
        V4(_mm256_mul_pd(self.0, b.0))
    }
    #[inline(always)]
    unsafe fn div(self, b: Self) -> Self {
        V4(_mm256_div_pd(self.0, b.0))
    }
    #[inline(always)]
    unsafe fn max(self, b: Self) -> Self {
        V4(_mm256_max_pd(self.0, b.0))
    }
    #[inline(always)]
    unsafe fn min(self, b: Self) -> Self {
        V4(_mm256_min_pd(self.0, b.0))
    }
    #[inline(always)]
    unsafe fn le(self, b: Self) -> __m256d {
        _mm256_cmp_pd::<_CMP_LE_OQ>(self.0, b.0)
    }
    #[inline(always)]
    unsafe fn lt(self, b: Self) -> __m256d {
        _mm256_cmp_pd::<_CMP_LT_OQ>(self.0, b.0)
    }
    /// `vblendvpd`, by the sign bit of each lane of `m` (all ones or all zeros here).
    #[inline(always)]
    unsafe fn select(self, m: __m256d, b: Self) -> Self {
        V4(_mm256_blendv_pd(self.0, b.0, m))
    }
    /// `vandpd`: the lane's bits, or all zeros (`+0.0`).
    #[inline(always)]
    unsafe fn keep(self, m: __m256d) -> Self {
        V4(_mm256_and_pd(m, self.0))
    }
    #[inline(always)]
    unsafe fn lane(i: usize) -> __m256d {
        let i = _mm256_set1_epi64x(i as i64);
        _mm256_castsi256_pd(_mm256_cmpeq_epi64(i, _mm256_set_epi64x(3, 2, 1, 0)))
    }
    /// `[a1 a2 a3 b0]`: the middle two lanes of `a` and `b` (`vperm2f128`), then `vshufpd`.
    #[inline(always)]
    unsafe fn next1(self, b: Self) -> Self {
        let mid = _mm256_permute2f128_pd::<0x21>(self.0, b.0); // [a2 a3 b0 b1]
        V4(_mm256_shuffle_pd::<0b0101>(self.0, mid))
    }
    /// `[a3 b0 b1 b2]`, as `next1`.
    #[inline(always)]
    unsafe fn prev1(self, b: Self) -> Self {
        let mid = _mm256_permute2f128_pd::<0x21>(self.0, b.0); // [a2 a3 b0 b1]
        V4(_mm256_shuffle_pd::<0b0101>(mid, b.0))
    }
    #[inline(always)]
    unsafe fn first() -> __m256i {
        _mm256_setzero_si256()
    }
    #[inline(always)]
    unsafe fn plus(i: __m256i, h: usize) -> __m256i {
        _mm256_add_epi64(i, _mm256_set1_epi64x(h as i64))
    }
    /// `vblendvpd`, by the sign bit of each lane of `m` (all ones or all zeros).
    #[inline(always)]
    unsafe fn moved(i: __m256i, m: __m256d, to: __m256i) -> __m256i {
        let (i, to) = (_mm256_castsi256_pd(i), _mm256_castsi256_pd(to));
        _mm256_castpd_si256(_mm256_blendv_pd(i, to, m))
    }
    /// `vpermd` of the 32-bit halves: lane `j` takes halves `2 i[j]` and `2 i[j] + 1`, modulo
    /// 8 (`vpermd` reads the low 3 bits of each index), so an index `4 + k` reads lane `k`.
    #[inline(always)]
    unsafe fn pick(self, i: __m256i) -> Self {
        let low = _mm256_slli_epi64::<1>(i);
        let high = _mm256_slli_epi64::<32>(_mm256_add_epi64(low, _mm256_set1_epi64x(1)));
        let halves = _mm256_or_si256(low, high);
        let t = _mm256_castpd_si256(self.0);
        V4(_mm256_castsi256_pd(_mm256_permutevar8x32_epi32(t, halves)))
    }
    /// Lane `i[j] mod 4` of `self` and of `hi` ([`V4::pick`]), `hi`'s where `i[j] > 3`.
    #[inline(always)]
    unsafe fn pick2(self, hi: Self, i: __m256i) -> Self {
        let high = _mm256_castsi256_pd(_mm256_cmpgt_epi64(i, _mm256_set1_epi64x(3)));
        V4(_mm256_blendv_pd(self.pick(i).0, hi.pick(i).0, high))
    }
    #[inline(always)]
    unsafe fn low(i: __m256i) -> __m256i {
        _mm256_and_si256(i, _mm256_set1_epi64x(7))
    }
    /// All ones where `i > p - 1` (`p >= 1` here).
    #[inline(always)]
    unsafe fn at_least(i: __m256i, p: usize) -> __m256d {
        let m = _mm256_cmpgt_epi64(i, _mm256_set1_epi64x(p as i64 - 1));
        _mm256_castsi256_pd(m)
    }
    #[inline(always)]
    unsafe fn times(i: __m256i, bits: u32) -> __m256i {
        _mm256_sll_epi64(i, _mm_cvtsi32_si128(bits as i32))
    }
    /// `vcvttpd2dq` then `vpmovsxdq`.
    #[inline(always)]
    unsafe fn truncated(self) -> __m256i {
        _mm256_cvtepi32_epi64(_mm256_cvttpd_epi32(self.0))
    }
    #[inline(always)]
    unsafe fn index_bits(self) -> __m256i {
        _mm256_castpd_si256(self.0)
    }
    /// One `vgatherqpd`.
    #[inline(always)]
    unsafe fn gather(p: *const f64, i: __m256i) -> Self {
        V4(_mm256_i64gather_pd::<8>(p, i))
    }
    const ROWS: bool = true;
    /// The lanes' rows `a`, `b`, `c`, `d`: numbers 0 to 3 of each read whole (a row is 64-byte
    /// aligned) and transposed (`vunpcklpd`/`vunpckhpd` of `a`, `b` and of `c`, `d`, then
    /// `vperm2f128` of their halves); numbers 4 and 5 read in halves, `[a4 a5 c4 c5]` and `[b4 b5
    /// d4 d5]` (a load and a `vinsertf128` each), `vunpcklpd` of them `[a4 b4 c4 d4]`, `vunpckhpd`
    /// `[a5 b5 c5 d5]`. Eight loads, where gathers are six `vgatherqpd`. The rows' byte offsets
    /// are computed in 32-bit lanes (`vcvttpd2dq`, `vpslld` by 6: below `2^31`) and taken out
    /// one by one (`vmovd`, `vpextrd`), with no widening to 64-bit lanes.
    #[inline(always)]
    unsafe fn rows(self, p: *const f64) -> [Self; 6] {
        let at = _mm_slli_epi32::<6>(_mm256_cvttpd_epi32(self.0));
        let p: *const u8 = p.cast();
        let [a, b, c, d] = [
            _mm_cvtsi128_si32(at),
            _mm_extract_epi32::<1>(at),
            _mm_extract_epi32::<2>(at),
            _mm_extract_epi32::<3>(at),
        ]
        .map(|j| p.add(j as u32 as usize).cast::<f64>());
        let [ra, rb, rc, rd] = [a, b, c, d].map(|r| _mm256_loadu_pd(r));
        let (ab0, ab1) = (_mm256_unpacklo_pd(ra, rb), _mm256_unpackhi_pd(ra, rb));
        let (cd0, cd1) = (_mm256_unpacklo_pd(rc, rd), _mm256_unpackhi_pd(rc, rd));
        let (ac, bd) = (halves(a, c, 4), halves(b, d, 4));
        [
            _mm256_permute2f128_pd::<0x20>(ab0, cd0),
            _mm256_permute2f128_pd::<0x20>(ab1, cd1),
            _mm256_permute2f128_pd::<0x31>(ab0, cd0),
            _mm256_permute2f128_pd::<0x31>(ab1, cd1),
            _mm256_unpacklo_pd(ac, bd),
            _mm256_unpackhi_pd(ac, bd),
        ]
        .map(V4)
    }
}

#[cfg(all(test, target_arch = "x86_64"))]
mod tests {
    use super::*;

    /// Every operation of both widths against its scalar meaning, on values that tell the lanes
    /// apart, partial loads and stores at every length, NaNs and zeros of both signs.
    #[test]
    fn both_widths_do_what_their_scalar_meaning_says() {
        if std::is_x86_feature_detected!("avx512f") {
            // SAFETY: the CPU has AVX-512F, and `check` is compiled with it.
            unsafe { check_avx512() };
        }
        if std::is_x86_feature_detected!("avx2") {
            // SAFETY: the CPU has AVX2, and `check` is compiled with it.
            unsafe { check_avx2() };
        }
    }

    #[target_feature(enable = "avx512f")]
    unsafe fn check_avx512() {
        check::<V8>();
    }

    #[target_feature(enable = "avx2")]
    unsafe fn check_avx2() {
        check::<V4>();
    }

    /// The lanes of `v`.
    #[inline(always)]
    unsafe fn lanes<V: Vector>(v: V) -> Vec<f64> {
        let mut out = vec![0.0; V::N];
        v.store(out.as_mut_ptr());
        out
    }

    #[inline(always)]
    unsafe fn check<V: Vector>() {
        let n = V::N;
        let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<u64>>();
        let a: Vec<f64> = (0..n).map(|i| 1.5 + i as f64).collect();
        let b: Vec<f64> = (0..n).map(|i| -10.0 - i as f64).collect();
        let (va, vb) = (V::load(a.as_ptr()), V::load(b.as_ptr()));
        assert_eq!(lanes(va), a);
        let each = |f: fn(f64, f64) -> f64| {
            a.iter()
                .zip(&b)
                .map(|(&x, &y)| f(x, y))
                .collect::<Vec<f64>>()
        };
        assert_eq!(lanes(va.add(vb)), each(|x, y| x + y));
        assert_eq!(lanes(va.sub(vb)), each(|x, y| x - y));
        assert_eq!(lanes(va.mul(vb)), each(|x, y| x * y));
        assert_eq!(lanes(va.div(vb)), each(|x, y| x / y));
        // shifts by a lane
        let mut next = a[1..].to_vec();
        next.push(b[0]);
        assert_eq!(lanes(va.next1(vb)), next);
        let mut prev = vec![a[n - 1]];
        prev.extend_from_slice(&b[..n - 1]);
        assert_eq!(lanes(va.prev1(vb)), prev);
        // compares, selects, masks: NaN and zeros of both signs
        let odd = [
            0.0,
            -0.0,
            f64::NAN,
            2.0,
            -f64::NAN,
            1.0,
            f64::INFINITY,
            -0.0,
        ];
        let x: Vec<f64> = odd[..n].to_vec();
        let y: Vec<f64> = (0..n).map(|i| [-0.0, 0.0, 1.0, f64::NAN][i % 4]).collect();
        let (vx, vy) = (V::load(x.as_ptr()), V::load(y.as_ptr()));
        let max: Vec<f64> = (x.iter().zip(&y))
            .map(|(&p, &q)| if p > q { p } else { q })
            .collect();
        assert_eq!(bits(&lanes(vx.max(vy))), bits(&max));
        let min: Vec<f64> = (x.iter().zip(&y))
            .map(|(&p, &q)| if p < q { p } else { q })
            .collect();
        assert_eq!(bits(&lanes(vx.min(vy))), bits(&min));
        for (m, want) in [
            (
                vx.le(vy),
                x.iter().zip(&y).map(|(p, q)| p <= q).collect::<Vec<_>>(),
            ),
            (vx.lt(vy), x.iter().zip(&y).map(|(p, q)| p < q).collect()),
        ] {
            let picked: Vec<f64> = (0..n).map(|i| if want[i] { b[i] } else { a[i] }).collect();
            assert_eq!(lanes(va.select(m, vb)), picked);
            let kept: Vec<f64> = (0..n).map(|i| if want[i] { a[i] } else { 0.0 }).collect();
            assert_eq!(bits(&lanes(va.keep(m))), bits(&kept));
        }
        for i in 0..n {
            let one: Vec<f64> = (0..n).map(|j| if j == i { b[j] } else { a[j] }).collect();
            assert_eq!(lanes(va.select(V::lane(i), vb)), one);
        }
        assert_eq!(bits(&lanes(V::zero())), bits(&vec![0.0; n]));
        assert_eq!(lanes(V::splat(-3.25)), vec![-3.25; n]);
        // partial loads and stores touch their slice alone, to the end of an allocation
        for len in 0..=n + 2 {
            let items: Box<[f64]> = (0..len).map(|i| i as f64 + 0.5).collect();
            let v = V::load_part(&items);
            let want: Vec<f64> = (0..n)
                .map(|j| if j < len { j as f64 + 0.5 } else { 0.0 })
                .collect();
            assert_eq!(bits(&lanes(v)), bits(&want), "len {len}");
            let mut buf = [-1.0; 20];
            va.store_part(&mut buf[4..4 + len]);
            for (i, &got) in buf.iter().enumerate() {
                let want = if (4..4 + len.min(n)).contains(&i) {
                    a[i - 4]
                } else {
                    -1.0
                };
                assert_eq!(got, want, "len {len}, item {i}");
            }
            let mut exact: Box<[f64]> = vec![0.0; len].into_boxed_slice();
            va.store_part(&mut exact[..]);
            assert!(exact.iter().zip(&a).all(|(&p, &q)| p == q));
        }
        let mut out = vec![0.0; n];
        vb.store(out.as_mut_ptr());
        assert_eq!(out, b);
        // indexes: moved lane by lane, then picking from a table of one vector or two (NaN
        // bits included)
        let table: Vec<f64> = (0..2 * n)
            .map(|i| odd[(3 * i + 2) % 8] + i as f64)
            .collect();
        let (lo, hi) = (V::load(table.as_ptr()), V::load(table[n..].as_ptr()));
        let mut i = V::first();
        let mut index = vec![0; n];
        let moves = [vx.le(vy), vx.lt(vy), V::lane(n - 1), V::lane(0), V::lane(1)];
        for (step, m) in moves.into_iter().enumerate() {
            let to = V::plus(i, step + 1);
            i = V::moved(i, m, to);
            let set = lanes(V::zero().select(m, V::splat(1.0)));
            for (c, s) in index.iter_mut().zip(set) {
                *c += if s == 1.0 { step + 1 } else { 0 };
            }
            if index.iter().all(|&c| c < n) {
                let want: Vec<f64> = index.iter().map(|&c| table[c]).collect();
                assert_eq!(bits(&lanes(lo.pick(i))), bits(&want), "{index:?}");
            }
            if index.iter().all(|&c| c < 2 * n) {
                let want: Vec<f64> = index.iter().map(|&c| table[c]).collect();
                assert_eq!(bits(&lanes(lo.pick2(hi, i))), bits(&want), "{index:?}");
            }
        }
        assert!(index.iter().any(|&c| c >= 5), "{index:?}");
        // every index of two vectors in every lane
        for (k, &t) in table.iter().enumerate() {
            let ks = V::plus(V::first(), k);
            assert_eq!(bits(&lanes(lo.pick2(hi, ks))), bits(&vec![t; n]), "{k}");
            if k < n {
                assert_eq!(bits(&lanes(lo.pick(ks))), bits(&vec![t; n]), "{k}");
            }
        }
        // the indexes above times a power of two: gathered from a longer table, their low bits
        // picked from the table of two vectors, compared
        let long: Vec<f64> = (0..64 * n).map(|k| odd[k % 8] * 0.5 + k as f64).collect();
        for shift in 0..4 {
            let scaled = V::times(i, shift);
            let at: Vec<usize> = index.iter().map(|&c| c << shift).collect();
            let want: Vec<f64> = at.iter().map(|&c| long[c]).collect();
            let got = lanes(V::gather(long.as_ptr(), scaled));
            assert_eq!(bits(&got), bits(&want), "{at:?}");
            // (and rows of eight from them, from the indexes as numbers and a fraction: `8 * 30 +
            // 5` within the table's `64 n`)
            if shift < 2 {
                let near: Vec<f64> = at.iter().map(|&c| c as f64 + 0.75).collect();
                let rows = V::load(near.as_ptr()).rows(long.as_ptr());
                for (k, got) in rows.into_iter().enumerate() {
                    let want: Vec<f64> = at.iter().map(|&c| long[8 * c + k]).collect();
                    assert_eq!(bits(&lanes(got)), bits(&want), "{at:?} {k}");
                }
            }
            let want: Vec<f64> = at.iter().map(|&c| table[c % (2 * n)]).collect();
            let got = lanes(lo.pick2(hi, V::low(scaled)));
            assert_eq!(bits(&got), bits(&want), "{at:?}");
            for p in [1, 3, 8, 16, 40] {
                let got = lanes(V::zero().select(V::at_least(scaled, p), V::splat(1.0)));
                let want: Vec<f64> = at.iter().map(|&c| f64::from(u8::from(c >= p))).collect();
                assert_eq!(got, want, "{at:?} >= {p}");
            }
        }
        // indexes from numbers: truncated (zeros of both signs, just below an integer, the
        // largest), and from an index's bits: their low bits picked, their size compared
        let near: [f64; 8] = [
            0.0,
            -0.0,
            0.999_999_999,
            1.0,
            6.5,
            -0.75,
            2_147_483_647.0,
            31.0f64.next_down(),
        ];
        let back: Vec<f64> = (0..n).map(|j| f64::from_bits(j as u64 * 5 + 1)).collect();
        let made = [
            V::load(near.as_ptr()).truncated(),
            V::load(back.as_ptr()).index_bits(),
        ];
        for (k, i) in made.into_iter().enumerate() {
            let at: Vec<usize> = (0..n)
                .map(|j| if k == 0 { near[j] as usize } else { j * 5 + 1 })
                .collect();
            let want: Vec<f64> = at.iter().map(|&c| table[c % (2 * n)]).collect();
            assert_eq!(bits(&lanes(lo.pick2(hi, V::low(i)))), bits(&want), "{at:?}");
            for p in [1, 6, 7, 30, 31, 1 << 30, (1 << 31) - 1] {
                let got = lanes(V::zero().select(V::at_least(i, p), V::splat(1.0)));
                let want: Vec<f64> = at.iter().map(|&c| f64::from(u8::from(c >= p))).collect();
                assert_eq!(got, want, "{at:?} >= {p}");
            }
        }
    }
}
