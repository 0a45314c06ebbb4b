//! One damped oscillator (a CEL) from the sound it should make, in closed form.
//!
//! A CEL of inertia `M`, stiffness `K` and viscosity `Z` (tied to its rest point) rings, left
//! alone, as `x(n) = A r^n cos(θ n + P)`, the poles `r e^{±iθ}` being the roots of
//! `z² + (K/M + Z/M - 2) z + (1 - Z/M) = 0`. Inverting, for a frequency `f`, a decay time `τ` (to
//! 1/e of the amplitude) and a rate `Fs`:
//!
//! ```text
//! θ = 2π f / Fs        r = exp(-1 / (Fs τ))   (r = 1 undamped)
//! Z / M = 1 - r²       K / M = (1 - r)² + 4 r sin²(θ/2)
//! ```
//!
//! computed with `expm1` and the `sin²` form so that low frequencies and long decays keep their
//! digits. The amplitude `A` and phase `P` set the initial conditions of the language
//! (`x(0) = X0`, `x(-1) = X0 - V0`): `X0 = A cos P` and `x(-1) = A r⁻¹ cos(P - θ)`.

// `!(x > 0.0)` rejects NaN along with the out-of-range values: intended.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

use std::f64::consts::TAU;
use std::fmt::Write as _;

use crate::DesignError;

/// What one cell should sound like.
#[derive(Clone, Debug, PartialEq)]
pub struct CellTarget {
    /// Frequency, Hz: `0 < f < rate / 2`.
    pub freq_hz: f64,
    /// Decay time of the amplitude to 1/e, s (`None`: undamped).
    pub decay_s: Option<f64>,
    /// Amplitude `A` of `x(n) = A r^n cos(θ n + P)` (a position: GENESIS length), not 0.
    pub amp: f64,
    /// Phase `P`, radians.
    pub phase_rad: f64,
    /// Sample rate, Hz.
    pub rate: f64,
}

/// What fixes the cell's scale (the frequency and decay fix only the ratios `K/M` and `Z/M`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum CellScale {
    /// The inertia `M` (> 0).
    Mass(f64),
    /// The stiffness `K` (> 0, GENESIS units).
    Stiffness(f64),
}

/// A designed cell: the CEL's parameters in GENESIS units, and its pole.
#[derive(Clone, Debug, PartialEq)]
pub struct Cell {
    /// Inertia `M`.
    pub m: f64,
    /// Stiffness `K` to the rest point.
    pub k: f64,
    /// Viscosity `Z` to the rest point.
    pub z: f64,
    /// Initial position `X0 = x(0)`.
    pub x0: f64,
    /// Initial velocity `V0 = x(0) - x(-1)` (length per sample).
    pub v0: f64,
    /// Pole radius `r` (1 undamped).
    pub radius: f64,
    /// Pole angle `θ = 2π f / Fs`, radians per sample.
    pub theta: f64,
}

/// Checks a rate: finite and positive.
pub(crate) fn check_rate(rate: f64) -> Result<(), DesignError> {
    if !(rate.is_finite() && rate > 0.0) {
        return Err(DesignError::invalid(
            format!("the sample rate {rate} Hz is not a positive number"),
            "give a rate such as 44100",
        ));
    }
    Ok(())
}

/// Checks a decay time, if any: finite and positive.
pub(crate) fn check_decay(decay_s: Option<f64>) -> Result<(), DesignError> {
    if let Some(tau) = decay_s {
        if !(tau.is_finite() && tau > 0.0) {
            return Err(DesignError::invalid(
                format!("the decay time {tau} s is not a positive, finite time"),
                "give a decay time in seconds above 0 (e.g. 1.5), or none for an undamped design",
            ));
        }
    }
    Ok(())
}

/// Checks one frequency against the rate: `0 < f < Fs/2`, finite.
pub(crate) fn check_freq(f: f64, rate: f64) -> Result<(), DesignError> {
    let nyquist = rate / 2.0;
    if !f.is_finite() || f <= 0.0 {
        return Err(DesignError::invalid(
            format!("the frequency {f} Hz is not above 0 Hz"),
            "give frequencies in Hz above 0",
        ));
    }
    if f >= nyquist {
        return Err(DesignError::invalid(
            format!("the frequency {f} Hz is at or above half the sample rate ({nyquist} Hz)"),
            format!("give frequencies below {nyquist} Hz, or raise the rate"),
        ));
    }
    Ok(())
}

/// `1 - r` and `1 - r²` for `r = exp(-1 / (Fs τ))`, without cancellation (0 and 0 undamped).
pub(crate) fn one_minus_r(decay_s: Option<f64>, rate: f64) -> (f64, f64) {
    match decay_s {
        None => (0.0, 0.0),
        Some(tau) => {
            let a = 1.0 / (rate * tau);
            (-(-a).exp_m1(), -(-2.0 * a).exp_m1())
        }
    }
}

/// Designs a cell: the CEL whose free response is `A r^n cos(θ n + P)` with the target's
/// frequency, decay time, amplitude and phase, exactly for the discrete scheme.
///
/// Errors ([`DesignError::Invalid`]): a frequency not in `(0, rate/2)`, a decay time not positive
/// and finite, an amplitude of 0 or not finite, a phase not finite, a rate not positive, a mass or
/// stiffness not positive and finite.
pub fn design_cell(target: &CellTarget, scale: CellScale) -> Result<Cell, DesignError> {
    check_rate(target.rate)?;
    check_freq(target.freq_hz, target.rate)?;
    check_decay(target.decay_s)?;
    if !target.amp.is_finite() || target.amp == 0.0 {
        return Err(DesignError::invalid(
            format!("the amplitude {} is not a non-zero number", target.amp),
            "give the amplitude of the oscillation (a length, e.g. 0.001); its sign may be folded into the phase",
        ));
    }
    if !target.phase_rad.is_finite() {
        return Err(DesignError::invalid(
            format!("the phase {} is not a number", target.phase_rad),
            "give the phase in radians (e.g. 0, or 1.5708 for a sine)",
        ));
    }
    let (value, what) = match scale {
        CellScale::Mass(m) => (m, "mass"),
        CellScale::Stiffness(k) => (k, "stiffness"),
    };
    if !(value.is_finite() && value > 0.0) {
        return Err(DesignError::invalid(
            format!("the {what} {value} is not a positive number"),
            format!("give a {what} above 0"),
        ));
    }
    let theta = TAU * target.freq_hz / target.rate;
    let (omr, omr2) = one_minus_r(target.decay_s, target.rate);
    let r = 1.0 - omr;
    let half = (theta / 2.0).sin();
    let k_over_m = omr * omr + 4.0 * r * half * half;
    let z_over_m = omr2;
    let (m, k) = match scale {
        CellScale::Mass(m) => (m, m * k_over_m),
        CellScale::Stiffness(k) => (k / k_over_m, k),
    };
    let z = m * z_over_m;
    if !(m.is_finite() && k.is_finite() && z.is_finite() && m > 0.0 && k > 0.0) {
        return Err(DesignError::invalid(
            format!("the cell's parameters are out of range (M = {m:e}, K = {k:e}, Z = {z:e})"),
            format!("choose a {what} nearer 1"),
        ));
    }
    let (a, p) = (target.amp, target.phase_rad);
    let x0 = a * p.cos();
    let xm1 = a / r * (p - theta).cos();
    Ok(Cell {
        m,
        k,
        z,
        x0,
        v0: x0 - xm1,
        radius: r,
        theta,
    })
}

/// A number with 17 significant digits: read back, it is the same `f64`.
pub(crate) fn num(x: f64) -> String {
    format!("{x:.16e}")
}

/// A rate as the language reads it (a whole number when it is one).
pub(crate) fn rate_text(rate: f64) -> String {
    if rate.fract() == 0.0 && rate.abs() < 1e15 {
        format!("{rate:.0}")
    } else {
        num(rate)
    }
}

/// The `rate`, `duration` and header comment lines of a written model.
pub(crate) fn preamble(out: &mut String, header: &str, rate: f64, duration_s: f64) {
    for line in header.lines() {
        let _ = writeln!(out, "# {line}");
    }
    let _ = writeln!(out, "rate {}", rate_text(rate));
    let _ = writeln!(out, "duration {}s", num(duration_s));
}

impl Cell {
    /// The cell as a complete `.cordis` model: `rate`, `duration`, the header as comments (each
    /// line prefixed `# `), `cel cell M=.. K=.. Z=.. X0=.. V0=..` and `sox out cell`. Numbers are
    /// written with 17 significant digits, so the model read back is this cell exactly.
    pub fn to_cordis(&self, header: &str, rate: f64, duration_s: f64) -> String {
        let mut s = String::new();
        preamble(&mut s, header, rate, duration_s);
        let _ = writeln!(
            s,
            "cel cell M={} K={} Z={} X0={} V0={}",
            num(self.m),
            num(self.k),
            num(self.z),
            num(self.x0),
            num(self.v0)
        );
        let _ = writeln!(s, "sox out cell");
        s
    }
}
