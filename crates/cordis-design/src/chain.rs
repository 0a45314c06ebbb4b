//! A chain of masses and springs from the modes one wants to hear at its first mass: an inverse
//! eigenvalue problem (Gladwell, *Inverse Problems in Vibration*, ch. 4).
//!
//! A chain's stiffness matrix `K` is tridiagonal and its mass matrix `M` diagonal, so
//! `J = M^-1/2 K M^-1/2` is a Jacobi matrix (tridiagonal, negative off-diagonal). A Jacobi matrix
//! is fixed by its eigenvalues `λ_i` and the squared first components `w_i` of its normalised
//! eigenvectors (the *weights*, `Σ w_i = 1`). Here:
//!
//! - `λ_i = 4 sin²(π f_i / Fs)`, the exact discrete-scheme eigenvalue of a mode ringing at `f_i`
//!   (adjusted with damping so that the damped frequencies stay exactly on target, below);
//! - `w_i = m_1 φ_i(1)²` (with `Φᵀ M Φ = I`): for an impulse `F` on the first mass, mode `i` rings at
//!   the first mass with amplitude `(w_i / m_1) F / (r_i sin θ_i)`, so `w_i ∝ A_i r_i sin θ_i` for
//!   target amplitudes `A_i` (equal by default) and pole radii `r_i`.
//!
//! `J` follows from `(λ, w)` by Lanczos on `diag(λ)` started from `sqrt(w)`, **with full
//! reorthogonalisation** (modified Gram–Schmidt, twice, against every earlier vector): plain
//! three-term Lanczos loses orthogonality as soon as a few eigenvalues have converged and its
//! Jacobi matrix then has ghost and missing eigenvalues (hundreds of Hz off with ~40 frequencies;
//! `benches/design.rs` shows it).
//!
//! The chain is then read off `J`. With `s = sqrt(m)` (masses up to scale), `J s = M^-1/2 K 1`,
//! and `K 1` is non-zero only at the masses tied to the ground: every row of `J s = 0` but those.
//! `s` is computed by the three-term recurrence of those rows (a tridiagonal solve done row by
//! row, from the free end inward): each computed row then holds to rounding relative to its own
//! (positive) terms, so the chain rebuilt from the written masses and springs has the designed
//! `J` to a few ulps entry by entry, whatever the spread of the masses. `s > 0` holds in exact
//! arithmetic (`J` is an M-matrix) and is verified. Per boundary:
//!
//! - fixed-free (ground, `k1`, `m1`, `k2`, ..., `mN` free): rows 2..N, from `mN` back to `m1`;
//!   `s ∝ J⁻¹ e_1`; the ground spring `k1 = J_11 m_1 - k_2` closes row 1;
//! - free-fixed (`m1` free, `mN` tied to the ground): rows 1..N-1, from `m1` on; `s ∝ J⁻¹ e_N`;
//! - fixed-fixed: `s = y + t z` with `y = J⁻¹ e_1` and `z = J⁻¹ e_N` (each by its recurrence), and
//!   `t ≥ 0` the root of `t (y_N + t z_N) = ρ (y_1 + t z_1)` that makes the end springs' ratio
//!   `k_{N+1} / k_1 = ρ` (the `end_ratio`);
//! - free-free: a 0 Hz target is added (one more mass than frequencies) with weight `m_1 / Σ m`
//!   (the `rigid_weight`, `1/(N+1)` by default); `s` is the null vector of `J`, computed by the
//!   recurrence from both ends, joined at the mass where the null vector (row 0 of the Lanczos
//!   basis) is largest: there the mismatch of the joined row, which the rebuilt chain absorbs, is
//!   smallest (the twisted factorisation of Dhillon and Parlett).
//!
//! Masses are scaled so that `m_1 = first_mass`; springs are `k_{i+1} = -J_{i,i+1} sqrt(m_i m_{i+1})`.
//!
//! Damping comes from the fundamental's decay time `τ_1` only, in one of two ways that keep every
//! mode a decoupled CEL `z² + (λ + c - 2) z + (1 - c) = 0`, so each `λ_j` can be set to put the
//! damped frequency exactly on target:
//!
//! - [`Damping::Ground`]: a damper `Z = α m_i` from every mass to the ground (`R = α M`, `c = α`):
//!   every mode decays alike, `r² = 1 - α`, `α = 1 - r_1²`, `λ_j = (1 - r)² + 4 r sin²(θ_j / 2)`;
//! - [`Damping::Springs`]: every spring gets `Z = β K` (`R = β K`, `c = β λ`): higher modes decay
//!   faster; `β = (1 - r_1²) / (1 - 2 r_1 cos θ_1 + r_1²)`, and mode `j`'s radius `s_j` solves
//!   `(1 + β) s² - 2 β cos θ_j s - (1 - β) = 0`, `λ_j = (1 - s_j²) / β` (computed in a form free
//!   of cancellation).
//!
//! A decay time is refused when `α` or `β` is not in `(0, 1)` (too short for the fundamental).
//! Within that range every mode is stable and oscillating (`λ_j (1 + 2β) ≤ 4 (1 + 2β) / (1 + β)² <
//! 4`); the per-mode checks stay as guards. With ground damping the 0 Hz mode of a free-free chain
//! becomes a decay without oscillation (the chain's drift is damped), its `λ` stays 0.

// `!(x > 0.0)` rejects NaN along with the out-of-range values: intended.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

use std::f64::consts::TAU;
use std::fmt;
use std::fmt::Write as _;
use std::str::FromStr;

use crate::cell::{check_decay, check_freq, check_rate, num, one_minus_r, preamble};
use crate::DesignError;

/// Most frequencies a chain may be designed for (the reorthogonalised Lanczos costs `4 N³`
/// operations: under a second for 1,000 frequencies, about a minute at this size).
pub const MAX_FREQUENCIES: usize = 4096;

/// How the chain's ends are held. The first mass (`m1`) is the one struck and listened to.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Ends {
    /// `m1` tied to the ground, the last mass free.
    FixedFree,
    /// `m1` free, the last mass tied to the ground.
    FreeFixed,
    /// Both ends tied to the ground.
    FixedFixed,
    /// Neither end tied: the chain has a rigid mode at 0 Hz (added to the targets).
    FreeFree,
}

impl Ends {
    /// Is `m1` tied to the ground?
    pub fn fixed_start(self) -> bool {
        matches!(self, Ends::FixedFree | Ends::FixedFixed)
    }

    /// Is the last mass tied to the ground?
    pub fn fixed_end(self) -> bool {
        matches!(self, Ends::FreeFixed | Ends::FixedFixed)
    }

    /// The name as the command line writes it (`fixed-free`, ...).
    pub fn name(self) -> &'static str {
        match self {
            Ends::FixedFree => "fixed-free",
            Ends::FreeFixed => "free-fixed",
            Ends::FixedFixed => "fixed-fixed",
            Ends::FreeFree => "free-free",
        }
    }
}

impl fmt::Display for Ends {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

impl FromStr for Ends {
    type Err = DesignError;

    /// `fixed-free`, `free-fixed`, `fixed-fixed` or `free-free` (case-insensitive, `_` for `-`).
    fn from_str(s: &str) -> Result<Ends, DesignError> {
        match s.trim().to_ascii_lowercase().replace('_', "-").as_str() {
            "fixed-free" => Ok(Ends::FixedFree),
            "free-fixed" => Ok(Ends::FreeFixed),
            "fixed-fixed" => Ok(Ends::FixedFixed),
            "free-free" => Ok(Ends::FreeFree),
            _ => Err(DesignError::invalid(
                format!("`{s}` is not a way to hold the chain's ends"),
                "use fixed-free, free-fixed, fixed-fixed or free-free (the first word is m1's end)",
            )),
        }
    }
}

/// Where the damping that sets the fundamental's decay time goes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Damping {
    /// Every spring gets a damper proportional to it (`Z = β K`): higher modes decay faster.
    Springs,
    /// Every mass gets a damper to the ground proportional to it (`Z = α m`): every mode decays
    /// alike.
    Ground,
}

impl Damping {
    /// The name as the command line writes it (`springs`, `ground`).
    pub fn name(self) -> &'static str {
        match self {
            Damping::Springs => "springs",
            Damping::Ground => "ground",
        }
    }
}

impl fmt::Display for Damping {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

impl FromStr for Damping {
    type Err = DesignError;

    /// `springs` or `ground` (case-insensitive).
    fn from_str(s: &str) -> Result<Damping, DesignError> {
        match s.trim().to_ascii_lowercase().as_str() {
            "springs" | "spring" => Ok(Damping::Springs),
            "ground" => Ok(Damping::Ground),
            _ => Err(DesignError::invalid(
                format!("`{s}` is not a damping strategy"),
                "use springs (higher modes decay faster) or ground (every mode decays alike)",
            )),
        }
    }
}

/// What the chain should sound like at its first mass.
#[derive(Clone, Debug, PartialEq)]
pub struct ChainSpec {
    /// Target frequencies, Hz, strictly increasing, in `(0, rate/2)`.
    pub freqs_hz: Vec<f64>,
    /// Relative amplitude of each mode at the first mass for a strike there (`None`: equal).
    pub amps: Option<Vec<f64>>,
    /// Decay time of the fundamental to 1/e, s (`None`: undamped).
    pub decay_s: Option<f64>,
    /// Where the damping goes (used only with `decay_s`).
    pub damping: Damping,
    /// How the ends are held.
    pub ends: Ends,
    /// Sample rate, Hz.
    pub rate: f64,
    /// Inertia of the first mass (the scale of the whole chain).
    pub first_mass: f64,
    /// Fixed-fixed only: the ratio of the last ground spring to the first, `k_{N+1} / k_1` (> 0).
    pub end_ratio: f64,
    /// Free-free only: the weight of the 0 Hz mode, which is `m_1 / Σ m` (in `(0, 1)`; `None`:
    /// `1 / (N + 1)`).
    pub rigid_weight: Option<f64>,
}

impl ChainSpec {
    /// A spec with the defaults: equal amplitudes, undamped (springs damping if a decay is set
    /// later), first mass 1, end ratio 1, default rigid weight.
    pub fn new(freqs_hz: Vec<f64>, ends: Ends, rate: f64) -> ChainSpec {
        ChainSpec {
            freqs_hz,
            amps: None,
            decay_s: None,
            damping: Damping::Springs,
            ends,
            rate,
            first_mass: 1.0,
            end_ratio: 1.0,
            rigid_weight: None,
        }
    }
}

/// One spring (and its damper) of a chain.
#[derive(Clone, Debug, PartialEq)]
pub struct Spring {
    /// End 1: a mass index (0 is `m1`), or `None` for the ground.
    pub from: Option<usize>,
    /// End 2: a mass index, or `None` for the ground.
    pub to: Option<usize>,
    /// Stiffness (GENESIS units).
    pub k: f64,
    /// Viscosity in parallel (GENESIS units, 0 if none).
    pub z: f64,
}

/// A designed chain.
#[derive(Clone, Debug, PartialEq)]
pub struct Chain {
    /// How its ends are held.
    pub ends: Ends,
    /// The inertias, `m1` first.
    pub masses: Vec<f64>,
    /// The springs in chain order: the ground spring of a fixed start, then `m1`–`m2`, ..., then
    /// the ground spring of a fixed end.
    pub springs: Vec<Spring>,
    /// Viscosity to the ground of each mass ([`Damping::Ground`]); empty if none.
    pub ground_dampers: Vec<f64>,
    /// The eigenvalues of `M⁻¹ K` the chain was built for, ascending (0 first for free-free);
    /// with damping, adjusted so that the damped frequencies are the targets.
    pub lambdas: Vec<f64>,
    /// The weights `w_i = m_1 φ_i(m1)²` (squared first components of the eigenvectors of `J`),
    /// summing to 1, in the order of `lambdas`.
    pub weights: Vec<f64>,
    /// The damping strategy and its coefficient (`β` for springs, `α` for ground), if damped.
    pub damping: Option<(Damping, f64)>,
}

/// A symmetric tridiagonal (Jacobi) matrix `J = tridiag(-off, diag, -off)`: the off-diagonal is
/// stored positive, as the Lanczos recurrence gives it; the chain's `J` has it negative.
#[derive(Clone, Debug, PartialEq)]
pub struct Jacobi {
    /// `J_ii`.
    pub diag: Vec<f64>,
    /// `-J_{i,i+1}` (one fewer than `diag`).
    pub off: Vec<f64>,
}

/// Dot product with four partial sums (so that it vectorises).
fn dot(a: &[f64], b: &[f64]) -> f64 {
    let mut acc = [0.0f64; 4];
    let (ca, cb) = (a.chunks_exact(4), b.chunks_exact(4));
    let (ra, rb) = (ca.remainder(), cb.remainder());
    for (x, y) in ca.zip(cb) {
        for i in 0..4 {
            acc[i] += x[i] * y[i];
        }
    }
    let tail: f64 = ra.iter().zip(rb).map(|(x, y)| x * y).sum();
    (acc[0] + acc[1]) + (acc[2] + acc[3]) + tail
}

/// Lanczos on `diag(lambdas)` from `sqrt(weights)` (normalised): the Jacobi matrix whose
/// eigenvalues are `lambdas` and whose eigenvectors' squared first components are the weights.
/// Returns it and row 0 of the Lanczos basis (`q_k[0]` for each `k`: the components of the
/// eigenvector of `lambdas[0]`, up to the signs `(-1)^k`).
fn lanczos_with_row0(
    lambdas: &[f64],
    weights: &[f64],
    reorthogonalise: bool,
) -> Result<(Jacobi, Vec<f64>), DesignError> {
    let n = lambdas.len();
    if n == 0 || weights.len() != n {
        return Err(DesignError::invalid(
            format!(
                "Lanczos needs as many weights as eigenvalues (got {} and {})",
                weights.len(),
                n
            ),
            "give one weight per eigenvalue",
        ));
    }
    if let Some(w) = weights.iter().find(|w| !(w.is_finite() && **w > 0.0)) {
        return Err(DesignError::invalid(
            format!("the weight {w} is not positive"),
            "every weight must be above 0",
        ));
    }
    if let Some(l) = lambdas.iter().find(|l| !l.is_finite()) {
        return Err(DesignError::invalid(
            format!("the eigenvalue {l} is not finite"),
            "give finite eigenvalues",
        ));
    }
    let norm = weights.iter().sum::<f64>().sqrt();
    // the basis, one vector of length n after another (only the last two without
    // reorthogonalisation)
    let keep = if reorthogonalise { n } else { 2.min(n) };
    let mut q = vec![0.0f64; keep * n];
    for (qi, w) in q[..n].iter_mut().zip(weights) {
        *qi = w.sqrt() / norm;
    }
    let mut diag = Vec::with_capacity(n);
    let mut off: Vec<f64> = Vec::with_capacity(n.saturating_sub(1));
    let mut row0 = Vec::with_capacity(n);
    let mut v = vec![0.0f64; n];
    for k in 0..n {
        let slot = if reorthogonalise { k } else { k % 2 };
        let prev = if reorthogonalise {
            k.wrapping_sub(1)
        } else {
            (k + 1) % 2
        };
        let (qk, qprev) = {
            let qk = &q[slot * n..(slot + 1) * n];
            let qprev = if k > 0 {
                Some(&q[prev * n..(prev + 1) * n])
            } else {
                None
            };
            (qk, qprev)
        };
        row0.push(qk[0]);
        let mut alpha = 0.0;
        for ((vi, &qi), &l) in v.iter_mut().zip(qk).zip(lambdas) {
            *vi = l * qi;
            alpha += l * qi * qi;
        }
        for (vi, &qi) in v.iter_mut().zip(qk) {
            *vi -= alpha * qi;
        }
        if let (Some(qp), Some(&b)) = (qprev, off.last()) {
            for (vi, &qi) in v.iter_mut().zip(qp) {
                *vi -= b * qi;
            }
        }
        if reorthogonalise {
            // modified Gram–Schmidt against q_0..q_k, twice ("twice is enough"): each q_j is
            // read once per pass for its product and its update, while it is in cache
            for pass in 0..2 {
                for j in 0..=k {
                    let qj = &q[j * n..(j + 1) * n];
                    let hj = dot(qj, &v);
                    for (vi, &qi) in v.iter_mut().zip(qj) {
                        *vi -= hj * qi;
                    }
                    if pass == 0 && j == k {
                        alpha += hj;
                    }
                }
            }
        }
        diag.push(alpha);
        if k + 1 == n {
            break;
        }
        let beta = dot(&v, &v).sqrt();
        if !(beta.is_finite() && beta > 0.0) {
            return Err(DesignError::Numerical(format!(
                "Lanczos broke down at step {} of {n} (the remaining spectrum is not reachable from the weights)",
                k + 1
            )));
        }
        off.push(beta);
        let next = if reorthogonalise { k + 1 } else { (k + 1) % 2 };
        for (qi, &vi) in q[next * n..(next + 1) * n].iter_mut().zip(&v) {
            *qi = vi / beta;
        }
    }
    Ok((Jacobi { diag, off }, row0))
}

/// Lanczos on `diag(lambdas)` started from `sqrt(weights)` (normalised to unit length): the
/// Jacobi matrix with these eigenvalues and these squared first eigenvector components.
///
/// With `reorthogonalise` (what [`design_chain`] uses) every new vector is orthogonalised twice
/// against all the earlier ones: `4 N³` operations, exact to rounding. Without, the plain
/// three-term recurrence (`O(N²)`), which loses orthogonality and with it the spectrum for more
/// than a few tens of eigenvalues; public for the benchmark that shows it.
pub fn lanczos(
    lambdas: &[f64],
    weights: &[f64],
    reorthogonalise: bool,
) -> Result<Jacobi, DesignError> {
    lanczos_with_row0(lambdas, weights, reorthogonalise).map(|(j, _)| j)
}

const RESCALE_ABOVE: f64 = 1e150;

fn positivity(i: usize, value: f64) -> DesignError {
    DesignError::Numerical(format!(
        "lost positivity rebuilding the chain: sqrt(m{}) came out {value:e} (the targets ask for masses beyond what double precision can hold; try fewer or less crowded frequencies)",
        i + 1
    ))
}

/// `s[0] = 1` and rows `0..last` of `J s = 0` forward: `s[0..=last]`, rescaled to stay finite.
fn forward(j: &Jacobi, last: usize) -> Result<Vec<f64>, DesignError> {
    let mut s = vec![0.0; last + 1];
    s[0] = 1.0;
    for k in 0..last {
        let mut t = j.diag[k] * s[k];
        if k > 0 {
            t -= j.off[k - 1] * s[k - 1];
        }
        let x = t / j.off[k];
        if !(x.is_finite() && x > 0.0) {
            return Err(positivity(k + 1, x));
        }
        s[k + 1] = x;
        if x > RESCALE_ABOVE {
            for v in &mut s[..=k + 1] {
                *v /= RESCALE_ABOVE;
            }
        }
    }
    Ok(s)
}

/// `s[n-1] = 1` and rows `n-1` down to `first + 1` of `J s = 0` backward: `s[first..n]` (the
/// entries below `first` are 0), rescaled to stay finite.
fn backward(j: &Jacobi, first: usize) -> Result<Vec<f64>, DesignError> {
    let n = j.diag.len();
    let mut s = vec![0.0; n];
    s[n - 1] = 1.0;
    for k in (first + 1..n).rev() {
        let mut t = j.diag[k] * s[k];
        if k + 1 < n {
            t -= j.off[k] * s[k + 1];
        }
        let x = t / j.off[k - 1];
        if !(x.is_finite() && x > 0.0) {
            return Err(positivity(k - 1, x));
        }
        s[k - 1] = x;
        if x > RESCALE_ABOVE {
            for v in &mut s[k - 1..] {
                *v /= RESCALE_ABOVE;
            }
        }
    }
    Ok(s)
}

/// `(J s)_k`.
fn row(j: &Jacobi, s: &[f64], k: usize) -> f64 {
    let mut t = j.diag[k] * s[k];
    if k > 0 {
        t -= j.off[k - 1] * s[k - 1];
    }
    if k + 1 < s.len() {
        t -= j.off[k] * s[k + 1];
    }
    t
}

/// `sqrt(m)` up to scale for the chain's ends (see the module documentation).
fn square_root_masses(
    j: &Jacobi,
    ends: Ends,
    end_ratio: f64,
    row0: &[f64],
) -> Result<Vec<f64>, DesignError> {
    let n = j.diag.len();
    if n == 1 {
        return Ok(vec![1.0]);
    }
    match ends {
        Ends::FixedFree => backward(j, 0),
        Ends::FreeFixed => forward(j, n - 1),
        Ends::FixedFixed => {
            let mut y = backward(j, 0)?;
            let mut z = forward(j, n - 1)?;
            let (g, h) = (row(j, &y, 0), row(j, &z, n - 1));
            if !(g > 0.0 && h > 0.0) {
                return Err(positivity(if g > 0.0 { n - 1 } else { 0 }, g.min(h)));
            }
            y.iter_mut().for_each(|v| *v /= g);
            z.iter_mut().for_each(|v| *v /= h);
            // t (y_N + t z_N) = ρ (y_1 + t z_1): z_N t² + (y_N - ρ z_1) t - ρ y_1 = 0
            let (a, b, c) = (z[n - 1], y[n - 1] - end_ratio * z[0], end_ratio * y[0]);
            let d = (b * b + 4.0 * a * c).sqrt();
            let t = if b >= 0.0 {
                2.0 * c / (b + d)
            } else {
                (d - b) / (2.0 * a)
            };
            if !(t.is_finite() && t > 0.0) {
                return Err(DesignError::Numerical(format!(
                    "no positive end weight gives the end ratio {end_ratio} (got {t:e})"
                )));
            }
            Ok(y.iter().zip(&z).map(|(y, z)| y + t * z).collect())
        }
        Ends::FreeFree => {
            // join the two recurrences where the null vector is largest
            let p = row0
                .iter()
                .enumerate()
                .fold((0, 0.0f64), |best, (i, v)| {
                    if v.abs() > best.1 {
                        (i, v.abs())
                    } else {
                        best
                    }
                })
                .0;
            let f = forward(j, p)?;
            let b = backward(j, p)?;
            let (fp, bp) = (f[p], b[p]);
            Ok((0..n)
                .map(|i| if i <= p { f[i] / fp } else { b[i] / bp })
                .collect())
        }
    }
}

/// The eigenvalue and pole radius of each target mode, and the damping coefficient.
fn targets(spec: &ChainSpec, thetas: &[f64]) -> Result<(Vec<f64>, Vec<f64>, f64), DesignError> {
    let half_sin2 = |t: f64| {
        let s = (t / 2.0).sin();
        s * s
    };
    let Some(tau) = spec.decay_s else {
        let l = thetas.iter().map(|&t| 4.0 * half_sin2(t)).collect();
        return Ok((l, vec![1.0; thetas.len()], 0.0));
    };
    let (omr, omr2) = one_minus_r(Some(tau), spec.rate);
    let r1 = 1.0 - omr;
    let too_short = |what: &str| {
        DesignError::invalid(
            format!("the decay time {tau} s cannot be met with {what} damping"),
            "give a longer decay time (a few periods of the fundamental at least), or the other damping strategy",
        )
    };
    match spec.damping {
        Damping::Ground => {
            let alpha = omr2;
            if !(alpha > 0.0 && alpha < 1.0) {
                return Err(too_short("ground"));
            }
            let mut l = Vec::with_capacity(thetas.len());
            for &t in thetas {
                let lj = omr * omr + 4.0 * r1 * half_sin2(t);
                if !(lj > 0.0 && lj + 2.0 * alpha < 4.0) {
                    return Err(too_short("ground"));
                }
                l.push(lj);
            }
            Ok((l, vec![r1; thetas.len()], alpha))
        }
        Damping::Springs => {
            let l1 = omr * omr + 4.0 * r1 * half_sin2(thetas[0]);
            let beta = omr2 / l1;
            if !(beta > 0.0 && beta < 1.0) {
                return Err(too_short("spring"));
            }
            let (mut l, mut r) = (Vec::new(), Vec::new());
            for (i, &t) in thetas.iter().enumerate() {
                let (s, c) = t.sin_cos();
                let root = 1.0 - beta * beta * s * s;
                if !(root > 0.0) {
                    return Err(DesignError::invalid(
                        format!(
                            "with spring damping set by a decay time of {tau} s, the mode at {} Hz would be overdamped",
                            spec.freqs_hz[i]
                        ),
                        "give a longer decay time, or use ground damping (every mode decays alike)",
                    ));
                }
                let q = root.sqrt();
                // the root of (1+β)² λ² - 4 (1 + β sin²θ) λ + 4 sin²θ = 0 with s_j > 0
                let lj = if c >= 0.0 {
                    2.0 * s * s / ((1.0 + beta * s * s) + c * q)
                } else {
                    2.0 * ((1.0 + beta * s * s) - c * q) / ((1.0 + beta) * (1.0 + beta))
                };
                let c_j = beta * lj;
                if !(lj > 0.0 && c_j < 1.0 && lj + 2.0 * c_j < 4.0) {
                    return Err(DesignError::invalid(
                        format!(
                            "with spring damping set by a decay time of {tau} s, the mode at {} Hz would be unstable",
                            spec.freqs_hz[i]
                        ),
                        "give a longer decay time, lower frequencies, or use ground damping",
                    ));
                }
                l.push(lj);
                r.push((1.0 - c_j).sqrt());
            }
            Ok((l, r, beta))
        }
    }
}

fn validate(spec: &ChainSpec) -> Result<(), DesignError> {
    check_rate(spec.rate)?;
    let f = &spec.freqs_hz;
    if f.is_empty() {
        return Err(DesignError::invalid(
            "no frequency to design a chain for",
            "give at least one frequency, e.g. 150,300,450",
        ));
    }
    if f.len() > MAX_FREQUENCIES {
        return Err(DesignError::invalid(
            format!("{} frequencies are too many for one chain", f.len()),
            format!("give at most {MAX_FREQUENCIES}"),
        ));
    }
    for &x in f {
        if x == 0.0 && spec.ends == Ends::FreeFree {
            return Err(DesignError::invalid(
                "0 Hz is among the targets",
                "leave 0 Hz out: a free-free chain has its rigid mode at 0 Hz already (its weight is set by the rigid weight)",
            ));
        }
        if x == 0.0 {
            return Err(DesignError::invalid(
                format!("0 Hz is among the targets of a {} chain", spec.ends),
                "a chain with a fixed end has no mode at 0 Hz: leave it out, or use free-free ends",
            ));
        }
        check_freq(x, spec.rate)?;
    }
    for (i, w) in f.windows(2).enumerate() {
        if w[1] == w[0] {
            return Err(DesignError::invalid(
                format!("{} Hz is given twice", w[0]),
                "give each frequency once: the modes of a chain heard at its end all differ",
            ));
        }
        if w[1] < w[0] {
            return Err(DesignError::invalid(
                format!(
                    "the frequencies are not in increasing order: {} Hz (number {}) comes after {} Hz",
                    w[1],
                    i + 2,
                    w[0]
                ),
                "sort the frequencies from low to high",
            ));
        }
    }
    if let Some(a) = &spec.amps {
        if a.len() != f.len() {
            return Err(DesignError::invalid(
                format!("{} amplitudes for {} frequencies", a.len(), f.len()),
                "give one amplitude per frequency, in the same order",
            ));
        }
        if let Some((i, x)) = a
            .iter()
            .enumerate()
            .find(|(_, x)| !(x.is_finite() && **x > 0.0))
        {
            return Err(DesignError::invalid(
                format!("the amplitude {x} (for {} Hz) is not above 0", f[i]),
                "give positive amplitudes (relative values: only their ratios matter)",
            ));
        }
    }
    check_decay(spec.decay_s)?;
    if !(spec.first_mass.is_finite() && spec.first_mass > 0.0) {
        return Err(DesignError::invalid(
            format!(
                "the first mass {} is not a positive number",
                spec.first_mass
            ),
            "give the inertia of m1, above 0 (e.g. 1)",
        ));
    }
    if spec.ends == Ends::FixedFixed && !(spec.end_ratio.is_finite() && spec.end_ratio > 0.0) {
        return Err(DesignError::invalid(
            format!("the end ratio {} is not a positive number", spec.end_ratio),
            "give the ratio of the last ground spring to the first, above 0 (1 for a symmetric hold); for no spring at the far end use fixed-free",
        ));
    }
    if let Some(w) = spec.rigid_weight {
        if spec.ends != Ends::FreeFree {
            return Err(DesignError::invalid(
                format!("a rigid weight is given for a {} chain", spec.ends),
                "the rigid weight is the 0 Hz mode's: it applies to free-free chains only",
            ));
        }
        if !(w.is_finite() && w > 0.0 && w < 1.0) {
            return Err(DesignError::invalid(
                format!("the rigid weight {w} is not between 0 and 1"),
                "give m1's share of the total mass, strictly between 0 and 1",
            ));
        }
    }
    Ok(())
}

/// Designs the chain whose modes, heard at its first mass, ring at the target frequencies (and
/// with the target relative amplitudes for a strike there, and the fundamental's decay time),
/// exactly for the discrete scheme.
///
/// Errors: [`DesignError::Invalid`] for a request that cannot be met (no frequency, unsorted or
/// repeated frequencies, one at or below 0 Hz or at or above half the rate, an amplitude not
/// positive, amplitudes not one per frequency, a decay time not positive or that cannot be met,
/// a first mass, end ratio or rigid weight out of range); [`DesignError::Numerical`] when the
/// reconstruction loses positivity (masses or springs beyond what double precision can hold).
pub fn design_chain(spec: &ChainSpec) -> Result<Chain, DesignError> {
    validate(spec)?;
    let thetas: Vec<f64> = spec.freqs_hz.iter().map(|f| TAU * f / spec.rate).collect();
    let (mut lambdas, radii, coef) = targets(spec, &thetas)?;
    let mut weights: Vec<f64> = thetas
        .iter()
        .zip(&radii)
        .enumerate()
        .map(|(i, (t, r))| spec.amps.as_ref().map_or(1.0, |a| a[i]) * r * t.sin())
        .collect();
    let total: f64 = weights.iter().sum();
    weights.iter_mut().for_each(|w| *w /= total);
    if spec.ends == Ends::FreeFree {
        let n = spec.freqs_hz.len();
        let w0 = spec.rigid_weight.unwrap_or(1.0 / (n as f64 + 1.0));
        weights.iter_mut().for_each(|w| *w *= 1.0 - w0);
        weights.insert(0, w0);
        lambdas.insert(0, 0.0);
    }
    if let Some(w) = weights.iter().find(|w| !(w.is_finite() && **w > 0.0)) {
        return Err(DesignError::invalid(
            format!("a mode's weight at the first mass came out {w:e}"),
            "give amplitudes of less extreme ratios",
        ));
    }
    let (j, row0) = lanczos_with_row0(&lambdas, &weights, true)?;
    let n = lambdas.len();
    let s = square_root_masses(&j, spec.ends, spec.end_ratio, &row0)?;
    if let Some((i, v)) = s
        .iter()
        .enumerate()
        .find(|(_, v)| !(v.is_finite() && **v > 0.0))
    {
        return Err(DesignError::Numerical(format!(
            "the square root of m{} came out {v:e}: the chain's masses span more than double precision holds (try fewer or less crowded frequencies, or other ends)",
            i + 1
        )));
    }
    let m1 = spec.first_mass;
    let sigma: Vec<f64> = s.iter().map(|v| v / s[0]).collect();
    let masses: Vec<f64> = sigma.iter().map(|v| m1 * v * v).collect();
    for (i, &m) in masses.iter().enumerate() {
        if !(m.is_finite() && m >= f64::MIN_POSITIVE) {
            return Err(DesignError::Numerical(format!(
                "the mass m{} came out {m:e}: the chain's masses span more than double precision holds (try fewer or less crowded frequencies, or other ends)",
                i + 1
            )));
        }
    }
    let inner: Vec<f64> = (0..n - 1)
        .map(|i| j.off[i] * m1 * sigma[i] * sigma[i + 1])
        .collect();
    let mut springs = Vec::with_capacity(n + 1);
    let (fixed_start, fixed_end) = (spec.ends.fixed_start(), spec.ends.fixed_end());
    let (k_start, k_end) = if n == 1 {
        let total = j.diag[0] * masses[0];
        match spec.ends {
            Ends::FixedFixed => {
                let a = total / (1.0 + spec.end_ratio);
                (a, total - a)
            }
            _ => (total, total),
        }
    } else {
        (
            j.diag[0] * masses[0] - inner[0],
            j.diag[n - 1] * masses[n - 1] - inner[n - 2],
        )
    };
    if fixed_start {
        springs.push(Spring {
            from: None,
            to: Some(0),
            k: k_start,
            z: 0.0,
        });
    }
    for (i, &k) in inner.iter().enumerate() {
        springs.push(Spring {
            from: Some(i),
            to: Some(i + 1),
            k,
            z: 0.0,
        });
    }
    if fixed_end {
        springs.push(Spring {
            from: Some(n - 1),
            to: None,
            k: k_end,
            z: 0.0,
        });
    }
    for sp in &springs {
        if !(sp.k.is_finite() && sp.k > 0.0) {
            return Err(DesignError::Numerical(format!(
                "lost positivity rebuilding the chain: the spring {} came out {:e} (try fewer or less crowded frequencies, or other ends)",
                spring_name(sp, n),
                sp.k
            )));
        }
    }
    let mut ground_dampers = Vec::new();
    let damping = spec.decay_s.map(|_| (spec.damping, coef));
    match damping {
        Some((Damping::Springs, beta)) => springs.iter_mut().for_each(|sp| sp.z = beta * sp.k),
        Some((Damping::Ground, alpha)) => {
            ground_dampers = masses.iter().map(|m| alpha * m).collect()
        }
        None => {}
    }
    Ok(Chain {
        ends: spec.ends,
        masses,
        springs,
        ground_dampers,
        lambdas,
        weights,
        damping,
    })
}

/// `k{i+1}` for the spring between `m{i}` and `m{i+1}`, `k1` for a fixed start, `k{N+1}` for a
/// fixed end.
fn spring_name(sp: &Spring, n: usize) -> String {
    match (sp.from, sp.to) {
        (Some(a), Some(b)) => format!("k{}", a.max(b) + 1),
        (None, Some(_)) => "k1".into(),
        _ => format!("k{}", n + 1),
    }
}

fn mass_name(i: Option<usize>) -> String {
    match i {
        Some(i) => format!("m{}", i + 1),
        None => "ground".into(),
    }
}

/// The instrumentalist of a written chain: a light mass falling on `m1` through a contact.
#[derive(Clone, Debug, PartialEq)]
pub struct Hammer {
    /// Inertia of the hammer.
    pub mass: f64,
    /// Speed at which it falls on `m1` (length per sample).
    pub velocity: f64,
    /// Stiffness of the contact (a `but`).
    pub stiffness: f64,
    /// Viscosity of the contact.
    pub damping: f64,
}

impl Hammer {
    /// A hammer for a chain: 1 % of `m1`, falling at `1e-3` per sample, with a contact stiffness
    /// of half its mass (a contact a few samples long), lowered if needed so that the chain in
    /// contact stays stable (`λ_max + 2c + K (1/m_h + 1/m_1)` at most halfway from the chain's
    /// largest `λ + 2c` to 4), no contact damping.
    pub fn for_chain(chain: &Chain) -> Hammer {
        let m1 = chain.masses.first().copied().unwrap_or(1.0);
        let mass = 0.01 * m1;
        let c = |l: f64| match chain.damping {
            Some((Damping::Springs, beta)) => beta * l,
            Some((Damping::Ground, alpha)) => alpha,
            None => 0.0,
        };
        let top = chain
            .lambdas
            .iter()
            .map(|&l| l + 2.0 * c(l))
            .fold(0.0f64, f64::max);
        let room = 0.5 * (4.0 - top).max(0.0) / (1.0 / mass + 1.0 / m1);
        Hammer {
            mass,
            velocity: 1e-3,
            stiffness: (0.5 * mass).min(room),
            damping: 0.0,
        }
    }
}

impl Chain {
    /// The chain as a complete `.cordis` model: `rate`, `duration`, the header as comments (each
    /// line prefixed `# `), `sol ground` if anything is tied to it, `mas m1` ... `mas mN`, the
    /// springs as `ref` (`k1` between the ground and `m1` for a fixed start, `k{i+1}` between
    /// `m{i}` and `m{i+1}`, `k{N+1}` between `mN` and the ground for a fixed end; `Z=` only when
    /// damped), ground dampers as `fro d{i} ground m{i}`, the hammer (`mas hammer`, one step above
    /// `m1` and falling, and `but strike m1 hammer`), and `sox out m1`. Numbers have 17
    /// significant digits: read back, the model is this chain exactly.
    pub fn to_cordis(&self, header: &str, hammer: &Hammer, rate: f64, duration_s: f64) -> String {
        let n = self.masses.len();
        let mut s = String::new();
        preamble(&mut s, header, rate, duration_s);
        let grounded = self
            .springs
            .iter()
            .any(|sp| sp.from.is_none() || sp.to.is_none())
            || !self.ground_dampers.is_empty();
        if grounded {
            let _ = writeln!(s, "sol ground");
        }
        for (i, m) in self.masses.iter().enumerate() {
            let _ = writeln!(s, "mas m{} M={}", i + 1, num(*m));
        }
        for sp in &self.springs {
            let _ = write!(
                s,
                "ref {} {} {} K={}",
                spring_name(sp, n),
                mass_name(sp.from),
                mass_name(sp.to),
                num(sp.k)
            );
            if sp.z != 0.0 {
                let _ = write!(s, " Z={}", num(sp.z));
            }
            s.push('\n');
        }
        for (i, z) in self.ground_dampers.iter().enumerate() {
            let _ = writeln!(s, "fro d{} ground m{} Z={}", i + 1, i + 1, num(*z));
        }
        let v = hammer.velocity;
        let _ = writeln!(
            s,
            "mas hammer M={} X0={} V0={}",
            num(hammer.mass),
            num(v),
            num(-v)
        );
        let _ = writeln!(
            s,
            "but strike m1 hammer K={} Z={} S=0",
            num(hammer.stiffness),
            num(hammer.damping)
        );
        let _ = writeln!(s, "sox out m1");
        s
    }

    /// The Jacobi matrix `M^-1/2 K M^-1/2` of the chain as it stands (rebuilt from its masses and
    /// springs, as an analysis of the written model sees it).
    pub fn jacobi(&self) -> Jacobi {
        let n = self.masses.len();
        let mut diag = vec![0.0; n];
        let mut off = vec![0.0; n.saturating_sub(1)];
        // springs to masses the chain does not have (a hand-made chain) are left out
        let inside = |i: Option<usize>| i.filter(|&i| i < n);
        for sp in &self.springs {
            match (inside(sp.from), inside(sp.to)) {
                (Some(a), Some(b)) => {
                    diag[a] += sp.k;
                    diag[b] += sp.k;
                    if a.abs_diff(b) == 1 {
                        off[a.min(b)] = sp.k / (self.masses[a].sqrt() * self.masses[b].sqrt());
                    }
                }
                (Some(a), None) | (None, Some(a)) => diag[a] += sp.k,
                (None, None) => {}
            }
        }
        for (d, m) in diag.iter_mut().zip(&self.masses) {
            *d /= m;
        }
        Jacobi { diag, off }
    }

    /// Largest mass over smallest.
    pub fn mass_spread(&self) -> f64 {
        spread(self.masses.iter().copied())
    }

    /// Largest spring stiffness over smallest.
    pub fn stiffness_spread(&self) -> f64 {
        spread(self.springs.iter().map(|s| s.k))
    }

    /// What to know before using the chain: a spread of masses or stiffnesses above `1e6` makes
    /// it fragile (a small edit of a written value moves the modes a lot), and a spring or mass
    /// that is not positive (which [`design_chain`] never returns) makes it unphysical.
    pub fn warnings(&self) -> Vec<String> {
        let mut w = Vec::new();
        let n = self.masses.len();
        let ms = self.mass_spread();
        if !(ms <= 1e6) {
            w.push(format!(
                "fragile: the masses span a ratio of {ms:.3e} (above 1e6): edits of single masses or rounding of the written values move the modes far more than they would in an even chain"
            ));
        }
        let ks = self.stiffness_spread();
        if !(ks <= 1e6) {
            w.push(format!(
                "fragile: the springs span a ratio of {ks:.3e} (above 1e6): edits of single springs or rounding of the written values move the modes far more than they would in an even chain"
            ));
        }
        for sp in &self.springs {
            if !(sp.k > 0.0) {
                w.push(format!(
                    "the spring {} has stiffness {:e}: not a physical chain",
                    spring_name(sp, n),
                    sp.k
                ));
            }
        }
        for (i, m) in self.masses.iter().enumerate() {
            if !(*m > 0.0) {
                w.push(format!(
                    "the mass m{} is {m:e}: not a physical chain",
                    i + 1
                ));
            }
        }
        w
    }
}

fn spread(values: impl Iterator<Item = f64>) -> f64 {
    let (lo, hi) = values.fold((f64::INFINITY, 0.0f64), |(lo, hi), v| {
        (lo.min(v.abs()), hi.max(v.abs()))
    });
    if hi == 0.0 {
        1.0
    } else {
        hi / lo
    }
}
