//! Blocks of eight `f64` lanes for the last items of the stepping loops.
//!
//! A vector loop over `n` items leaves `n % 8` of them to a scalar loop, which on a membrane's
//! 100-mass rows is a tenth of the work done one lane at a time. With AVX-512 those items are one
//! block instead: loaded with masked loads (the lanes past the end read as `0.0`, and no memory
//! past the end is touched), computed lane by lane on arrays the compiler keeps in vector
//! registers, stored with a masked store (nothing past the end is written). Each lane computes the
//! same IEEE operations on the same values as the scalar loop would: the same bits.

/// Lanes of a block.
pub(crate) const LANES: usize = 8;

/// Proof that the CPU has AVX-512F: only [`Avx512::detect`] makes one, so the blocks it loads
/// and stores are safe to use wherever one is at hand.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) struct Avx512(());

impl Avx512 {
    /// `Some` when this CPU has AVX-512F.
    pub(crate) fn detect() -> Option<Avx512> {
        #[cfg(target_arch = "x86_64")]
        if std::is_x86_feature_detected!("avx512f") {
            return Some(Avx512(()));
        }
        None
    }

    /// [`load`]: the lanes of `s`'s first `min(s.len(), 8)` items, `0.0` in the others.
    #[inline(always)]
    pub(crate) fn load(self, s: &[f64]) -> [f64; LANES] {
        #[cfg(target_arch = "x86_64")]
        // SAFETY: `self` exists, so `detect` found AVX-512F on this CPU.
        return unsafe { load(s) };
        #[cfg(not(target_arch = "x86_64"))]
        {
            let mut v = [0.0; LANES];
            let n = s.len().min(LANES);
            v[..n].copy_from_slice(&s[..n]);
            v
        }
    }

    /// [`store`]: lanes `0..min(out.len(), 8)` of `v` into `out`, nothing else written.
    #[inline(always)]
    pub(crate) fn store(self, out: &mut [f64], v: [f64; LANES]) {
        #[cfg(target_arch = "x86_64")]
        // SAFETY: as in `load`.
        unsafe {
            store(out, v)
        };
        #[cfg(not(target_arch = "x86_64"))]
        {
            let n = out.len().min(LANES);
            out[..n].copy_from_slice(&v[..n]);
        }
    }
}

/// The lanes of `s`'s first `min(s.len(), 8)` items, `0.0` in the others.
///
/// # Safety
/// The CPU has AVX-512F (`is_x86_feature_detected!("avx512f")`).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f")]
#[inline]
pub(crate) unsafe fn load(s: &[f64]) -> [f64; LANES] {
    use std::arch::x86_64::{__m512d, _mm512_maskz_loadu_pd};
    // SAFETY: the mask selects lanes `0..min(s.len(), 8)`, each an item of `s`; a masked load
    // does not access the lanes its mask clears (Intel SDM, "memory faults are suppressed" on
    // masked-off elements), so nothing outside `s` is read. The pointer needs no alignment.
    let v = unsafe { _mm512_maskz_loadu_pd(mask(s.len()), s.as_ptr()) };
    // SAFETY: `__m512d` is 64 bytes of eight `f64`, as `[f64; 8]`; every bit pattern is valid.
    unsafe { std::mem::transmute::<__m512d, [f64; LANES]>(v) }
}

/// Writes lanes `0..min(out.len(), 8)` of `v` into `out`; nothing else is written.
///
/// # Safety
/// The CPU has AVX-512F.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f")]
#[inline]
pub(crate) unsafe fn store(out: &mut [f64], v: [f64; LANES]) {
    use std::arch::x86_64::{__m512d, _mm512_mask_storeu_pd};
    // SAFETY: as in `load`: same size, every bit pattern valid.
    let v = unsafe { std::mem::transmute::<[f64; LANES], __m512d>(v) };
    // SAFETY: the mask selects lanes `0..min(out.len(), 8)`, each an item of `out`, which we
    // borrow mutably; a masked store does not write (or fault on) the lanes its mask clears.
    unsafe { _mm512_mask_storeu_pd(out.as_mut_ptr(), mask(out.len()), v) }
}

/// The mask of lanes `0..min(len, 8)`.
#[cfg(target_arch = "x86_64")]
#[inline(always)]
fn mask(len: usize) -> u8 {
    ((1u16 << len.min(LANES)) - 1) as u8
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Loads and stores touch exactly the items of their slice, at the very end of an
    /// allocation too (a boxed slice has no spare capacity after it), for every length.
    #[test]
    fn masked_lanes_touch_only_their_slice() {
        let Some(cpu) = Avx512::detect() else {
            // (an `Avx512`, and so a call of these functions, needs a CPU with AVX-512F)
            return;
        };
        for len in 0..=LANES + 2 {
            let items: Box<[f64]> = (0..len).map(|i| i as f64 + 0.5).collect();
            let v = cpu.load(&items);
            for (j, &lane) in v.iter().enumerate() {
                let want = if j < len { j as f64 + 0.5 } else { 0.0 };
                assert_eq!(lane.to_bits(), want.to_bits(), "len {len}, lane {j}");
            }
            let mut buf = [-1.0; 20];
            let block: [f64; LANES] = std::array::from_fn(|j| 100.0 + j as f64);
            cpu.store(&mut buf[4..4 + len], block);
            for (i, &b) in buf.iter().enumerate() {
                let want = if (4..4 + len.min(LANES)).contains(&i) {
                    100.0 + (i - 4) as f64
                } else {
                    -1.0
                };
                assert_eq!(b, want, "len {len}, item {i}");
            }
            // the last items of an exact-length allocation
            let mut exact: Box<[f64]> = vec![0.0; len].into_boxed_slice();
            let tail = len.saturating_sub(3);
            cpu.store(&mut exact[tail..], block);
            assert!(exact[tail..].iter().zip(block).all(|(&a, b)| a == b));
        }
    }
}
