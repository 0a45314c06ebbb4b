//! Input signals for ENF (force) and ENX (position) modules.

use std::sync::Arc;

use crate::Curve;

/// A signal: one `f64` per step, a pure function of the step index `n`.
///
/// Being a pure function of `n` makes renders independent of block size and lets the engine replay
/// a block exactly (to find where a simulation blew up). Times are in samples and frequencies in
/// cycles per sample: the model language converts units before it builds a signal.
#[derive(Clone, Debug, PartialEq)]
pub enum Signal {
    /// `value` at every step.
    Constant(f64),
    /// `amp` at step `at`, 0 elsewhere.
    Impulse {
        /// Step of the impulse.
        at: u64,
        /// Its value.
        amp: f64,
    },
    /// 0 before step `at`, `amp` from it on.
    Step {
        /// First step at `amp`.
        at: u64,
        /// Value from `at` on.
        amp: f64,
    },
    /// `amp * sin(2 pi freq n + phase)`.
    Sine {
        /// Frequency in cycles per sample (Hz / Fs).
        freq: f64,
        /// Peak value.
        amp: f64,
        /// Phase at step 0, radians.
        phase: f64,
    },
    /// White noise, uniform in `[-amp, amp)`, from a seeded hash of the step index.
    Noise {
        /// Seed: the same seed gives the same noise.
        seed: u64,
        /// Peak value.
        amp: f64,
    },
    /// A piecewise-linear envelope over the step index (see [`Curve`] for the rules).
    Envelope(Curve),
    /// Recorded samples (from a file), times `gain`; 0 after the last sample.
    Samples {
        /// The samples, one per step from step 0.
        data: Arc<[f64]>,
        /// Multiplier applied to every sample.
        gain: f64,
    },
}

impl Signal {
    /// The signal's value at step `n`.
    #[inline]
    pub fn at(&self, n: u64) -> f64 {
        match self {
            Signal::Constant(v) => *v,
            Signal::Impulse { at, amp } => {
                if n == *at {
                    *amp
                } else {
                    0.0
                }
            }
            Signal::Step { at, amp } => {
                if n >= *at {
                    *amp
                } else {
                    0.0
                }
            }
            Signal::Sine { freq, amp, phase } => {
                amp * (std::f64::consts::TAU * freq * n as f64 + phase).sin()
            }
            Signal::Noise { seed, amp } => {
                let h = splitmix64(seed ^ n.wrapping_mul(0x9E37_79B9_7F4A_7C15));
                // 53 random bits -> [0, 1) -> [-1, 1)
                let u = (h >> 11) as f64 * (1.0 / (1u64 << 53) as f64);
                amp * (2.0 * u - 1.0)
            }
            Signal::Envelope(curve) => curve.eval(n as f64),
            Signal::Samples { data, gain } => {
                match usize::try_from(n).ok().and_then(|i| data.get(i)) {
                    Some(v) => v * gain,
                    None => 0.0,
                }
            }
        }
    }

    /// True when every value of the signal is finite (checked once, before stepping).
    pub fn is_finite(&self) -> bool {
        match self {
            Signal::Constant(v) => v.is_finite(),
            Signal::Impulse { amp, .. } | Signal::Step { amp, .. } | Signal::Noise { amp, .. } => {
                amp.is_finite()
            }
            Signal::Sine { freq, amp, phase } => {
                freq.is_finite() && amp.is_finite() && phase.is_finite()
            }
            Signal::Envelope(c) => c.points().all(|(x, y)| x.is_finite() && y.is_finite()),
            Signal::Samples { data, gain } => {
                gain.is_finite() && data.iter().all(|v| v.is_finite())
            }
        }
    }
}

/// SplitMix64 finaliser: a bijective hash of 64 bits with good avalanche.
#[inline]
fn splitmix64(mut z: u64) -> u64 {
    z = z.wrapping_add(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn impulse_and_step() {
        let i = Signal::Impulse { at: 3, amp: 2.0 };
        assert_eq!(
            (0..5).map(|n| i.at(n)).collect::<Vec<_>>(),
            [0.0, 0.0, 0.0, 2.0, 0.0]
        );
        let s = Signal::Step { at: 2, amp: -1.0 };
        assert_eq!(
            (0..4).map(|n| s.at(n)).collect::<Vec<_>>(),
            [0.0, 0.0, -1.0, -1.0]
        );
    }

    #[test]
    fn noise_is_seeded_bounded_and_roughly_centred() {
        let a = Signal::Noise { seed: 7, amp: 0.5 };
        let b = Signal::Noise { seed: 8, amp: 0.5 };
        let va: Vec<f64> = (0..20000).map(|n| a.at(n)).collect();
        assert!(va.iter().all(|v| (-0.5..0.5).contains(v)));
        assert_eq!(va[123], a.at(123));
        assert_ne!(va[123], b.at(123));
        let mean = va.iter().sum::<f64>() / va.len() as f64;
        assert!(mean.abs() < 0.01, "mean {mean}");
    }

    #[test]
    fn samples_end_in_silence() {
        let s = Signal::Samples {
            data: vec![1.0, 2.0].into(),
            gain: 0.5,
        };
        assert_eq!([s.at(0), s.at(1), s.at(2)], [0.5, 1.0, 0.0]);
    }
}
