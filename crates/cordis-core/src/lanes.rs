//! Blocks of eight `f64` lanes for the last items of the stepping loops.
//!
//! A vector loop over `n` items leaves `n % 8` of them to a scalar loop, which on a membrane's
//! 100-mass rows is a tenth of the work done one lane at a time. With AVX-512 those items are one
//! block instead: loaded with masked loads (the lanes past the end read as `0.0`, and no memory
//! past the end is touched), computed lane by lane on arrays the compiler keeps in vector
//! registers, stored with a masked store (nothing past the end is written). Each lane computes the
//! same IEEE operations on the same values as the scalar loop would: the same bits.

#[cfg(target_arch = "x86_64")]
use std::arch::x86_64::{__m512d, _mm512_mask_storeu_pd, _mm512_maskz_loadu_pd};

/// Lanes of a block.
pub(crate) const LANES: usize = 8;

/// The widest vector instructions an [`Engine`](crate::Engine) may use, whatever the CPU has.
///
/// Every width computes the same IEEE operations on the same values, so the output is the same,
/// bit for bit, under every limit; only the speed changes. The limit is read once per process
/// from the environment variable `CORDIS_SIMD` ([`SimdLimit::VAR`]): `avx512` (the default),
/// `avx2` or `none`. It is there to time or test, on one machine, what a CPU without AVX-512 (or
/// without vector units) gets; a value the engine does not know sets no limit (the `cordis` CLI
/// refuses it with [`SimdLimit::from_env`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum SimdLimit {
    /// No vector instructions beyond the target's baseline (SSE2 on x86-64).
    None,
    /// Up to AVX2 (four `f64` lanes).
    Avx2,
    /// Up to AVX-512 (eight `f64` lanes): no limit.
    Avx512,
}

impl SimdLimit {
    /// The environment variable that sets the limit.
    pub const VAR: &'static str = "CORDIS_SIMD";
    const NAMES: [(&'static str, SimdLimit); 3] = [
        ("avx512", SimdLimit::Avx512),
        ("avx2", SimdLimit::Avx2),
        ("none", SimdLimit::None),
    ];

    /// The limit [`SimdLimit::VAR`] sets: `Ok(None)` when it is unset, an error naming the
    /// values it may take when it is set to anything else.
    pub fn from_env() -> Result<Option<SimdLimit>, SimdLimitError> {
        match std::env::var(Self::VAR) {
            Err(std::env::VarError::NotPresent) => Ok(None),
            Err(std::env::VarError::NotUnicode(v)) => Err(SimdLimitError {
                value: v.to_string_lossy().into_owned(),
            }),
            Ok(v) => v.parse().map(Some),
        }
    }

    /// The limit of this process: [`SimdLimit::from_env`], read once; no limit when it is unset
    /// or not understood.
    pub fn current() -> SimdLimit {
        static LIMIT: std::sync::OnceLock<SimdLimit> = std::sync::OnceLock::new();
        *LIMIT.get_or_init(|| Self::from_env().ok().flatten().unwrap_or(SimdLimit::Avx512))
    }
}

impl std::str::FromStr for SimdLimit {
    type Err = SimdLimitError;

    /// `avx512`, `avx2` or `none`, in any case.
    fn from_str(s: &str) -> Result<SimdLimit, SimdLimitError> {
        let t = s.trim().to_ascii_lowercase();
        (Self::NAMES.iter().find(|(name, _)| *name == t))
            .map(|&(_, limit)| limit)
            .ok_or_else(|| SimdLimitError {
                value: s.to_owned(),
            })
    }
}

/// A value of `CORDIS_SIMD` that is not `avx512`, `avx2` or `none`.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct SimdLimitError {
    /// The value as it was set.
    pub value: String,
}

impl std::fmt::Display for SimdLimitError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "{} is {:?}: it may be avx512 (the default), avx2 or none",
            SimdLimit::VAR,
            self.value
        )?;
        let t: String = (self.value.chars())
            .filter(char::is_ascii_alphanumeric)
            .map(|c| c.to_ascii_lowercase())
            .collect();
        let near = (SimdLimit::NAMES.iter().map(|(name, _)| *name))
            .find(|name| !t.is_empty() && (name.starts_with(&t) || t.starts_with(name)));
        if let Some(name) = near {
            write!(f, " (did you mean {name}?)")?;
        }
        Ok(())
    }
}

impl std::error::Error for SimdLimitError {}

/// Proof that the CPU has AVX-512F: only [`Avx512::detect`] makes one, so the blocks it loads
/// and stores are safe to use wherever one is at hand.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) struct Avx512(());

impl Avx512 {
    /// `Some` when this CPU has AVX-512F and [`SimdLimit::current`] allows it.
    pub(crate) fn detect() -> Option<Avx512> {
        #[cfg(target_arch = "x86_64")]
        if SimdLimit::current() >= SimdLimit::Avx512 && std::is_x86_feature_detected!("avx512f") {
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
    // SAFETY: `__m512d` is 64 bytes of eight `f64`, as `[f64; 8]`; every bit pattern is valid;
    // the CPU has AVX-512F, as `load8` needs.
    unsafe { std::mem::transmute::<__m512d, [f64; LANES]>(load8(s)) }
}

/// [`load`] into a vector.
///
/// # Safety
/// The CPU has AVX-512F.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f")]
#[inline]
pub(crate) unsafe fn load8(s: &[f64]) -> __m512d {
    // SAFETY: the mask selects lanes `0..min(s.len(), 8)`, each an item of `s`; a masked load
    // does not access the lanes its mask clears (Intel SDM, "memory faults are suppressed" on
    // masked-off elements), so nothing outside `s` is read. The pointer needs no alignment.
    unsafe { _mm512_maskz_loadu_pd(mask(s.len()), s.as_ptr()) }
}

/// Writes lanes `0..min(out.len(), 8)` of `v` into `out`; nothing else is written.
///
/// # Safety
/// The CPU has AVX-512F.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f")]
#[inline]
pub(crate) unsafe fn store(out: &mut [f64], v: [f64; LANES]) {
    // SAFETY: as in `load`: same size, every bit pattern valid; the CPU has AVX-512F.
    unsafe { store8(out, std::mem::transmute::<[f64; LANES], __m512d>(v)) }
}

/// [`store`] from a vector.
///
/// # Safety
/// The CPU has AVX-512F.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f")]
#[inline]
pub(crate) unsafe fn store8(out: &mut [f64], v: __m512d) {
    // SAFETY: the mask selects lanes `0..min(out.len(), 8)`, each an item of `out`, which we
    // borrow mutably; a masked store does not write (or fault on) the lanes its mask clears.
    unsafe { _mm512_mask_storeu_pd(out.as_mut_ptr(), mask(out.len()), v) }
}

/// The mask of lanes `0..min(len, 8)`.
#[cfg(target_arch = "x86_64")]
#[inline(always)]
pub(crate) fn mask(len: usize) -> u8 {
    ((1u16 << len.min(LANES)) - 1) as u8
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The limit's names parse in any case, widest last in order; others are refused with the
    /// values they may be and, when one is near, which.
    #[test]
    fn simd_limits_parse_and_a_wrong_one_names_the_right_ones() {
        assert_eq!("avx512".parse(), Ok(SimdLimit::Avx512));
        assert_eq!(" AVX2 ".parse(), Ok(SimdLimit::Avx2));
        assert_eq!("None".parse(), Ok(SimdLimit::None));
        assert!(SimdLimit::None < SimdLimit::Avx2 && SimdLimit::Avx2 < SimdLimit::Avx512);
        for (value, hint) in [
            ("avx-512", Some("avx512")),
            ("avx2x", Some("avx2")),
            ("no", Some("none")),
            ("sse", None),
            ("", None),
        ] {
            let e = value.parse::<SimdLimit>().unwrap_err();
            let text = e.to_string();
            assert!(text.starts_with("CORDIS_SIMD is "), "{text}");
            assert!(
                text.contains("avx512 (the default), avx2 or none"),
                "{text}"
            );
            match hint {
                Some(h) => assert!(text.ends_with(&format!("(did you mean {h}?)")), "{text}"),
                None => assert!(!text.contains("did you mean"), "{text}"),
            }
        }
    }

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
