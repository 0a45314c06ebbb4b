//! [`Lines`]: a buffer of `f64` that starts on a 64-byte cache line.
//!
//! A vector load or store of eight `f64` (AVX-512) that does not start on a cache line touches
//! two of them, and costs about two. A `Vec<f64>` starts wherever the allocator puts it (on a
//! 16-byte boundary with glibc), so a row's blocks straddled lines or not by chance: a 100x100
//! membrane ran 1.22–1.34x faster once its buffers started on lines (`docs/BENCHMARKS-LOG.md`,
//! twenty-fourth session). The position buffers and the grid step's row buffers are `Lines`: a
//! `Vec<f64>` seven items longer than asked, used from its first item on a line. Safe code
//! alone: only the offset of that item is computed from the address.

use std::ops::{Deref, DerefMut};

/// Items of a 64-byte cache line.
pub(crate) const LINE: usize = 8;

/// `len` items of `f64`, the first at an address that is a multiple of 64 (see the module).
/// Derefs to `[f64]`; a clone is a new buffer of its own line.
pub(crate) struct Lines {
    buf: Vec<f64>,
    /// The first item used: `buf[off..off + len]`
    off: usize,
    len: usize,
}

impl Lines {
    /// `len` items of `0.0`.
    pub(crate) fn zeros(len: usize) -> Lines {
        let buf = vec![0.0; len + LINE - 1];
        // (at most `LINE - 1` for an `f64` pointer, which is 8-byte aligned; should it ever say
        // otherwise, the buffer starts where it is: slower, never wrong)
        let off = buf.as_ptr().align_offset(LINE * size_of::<f64>());
        let off = if off < LINE { off } else { 0 };
        Lines { buf, off, len }
    }
}

impl Deref for Lines {
    type Target = [f64];

    fn deref(&self) -> &[f64] {
        &self.buf[self.off..self.off + self.len]
    }
}

impl DerefMut for Lines {
    fn deref_mut(&mut self) -> &mut [f64] {
        &mut self.buf[self.off..self.off + self.len]
    }
}

impl Clone for Lines {
    fn clone(&self) -> Lines {
        let mut copy = Lines::zeros(self.len);
        copy.copy_from_slice(self);
        copy
    }
}

impl std::fmt::Debug for Lines {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_list().entries(self.iter()).finish()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every buffer, of every length and clone, starts on a line and holds what was put in it.
    #[test]
    fn starts_on_a_line_and_keeps_its_items() {
        // (allocations of many sizes, kept alive, land at many addresses)
        let mut kept = Vec::new();
        for len in 0..200 {
            let mut b = Lines::zeros(len);
            assert_eq!(b.len(), len);
            assert!(b.iter().all(|&x| x.to_bits() == 0));
            for (i, x) in b.iter_mut().enumerate() {
                *x = i as f64 - 0.5;
            }
            let c = b.clone();
            for l in [&b, &c] {
                assert!((l.as_ptr() as usize).is_multiple_of(64), "len {len}");
                assert!(l.iter().enumerate().all(|(i, &x)| x == i as f64 - 0.5));
            }
            kept.push((b, c));
        }
        assert_eq!(format!("{:?}", kept[2].0), "[-0.5, 0.5]");
    }
}
