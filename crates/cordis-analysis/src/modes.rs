//! Modal analysis, exact for the discrete scheme.
//!
//! Undamped modes solve `K φ = λ M φ` (symmetric, through `M^-1/2 K M^-1/2`) and ring at
//! `f = (Fs/π) asin(sqrt(λ)/2)`. With damping the poles are those of the state matrix
//! `A_d = [[2I - M^-1(K+R), -I + M^-1 R], [I, 0]]`. Two exact ways to get them:
//!
//! - **decoupled**: when `C = Φᵀ R Φ` is diagonal (R proportional to M and K, the common case of
//!   uniform strings and membranes), each mode `j` is a CEL of its own,
//!   `z² + (λ_j + c_j - 2) z + (1 - c_j) = 0`, and its poles follow in closed form;
//! - **state space**: otherwise, the eigenvalues of the `2n × 2n` matrix `A_d` (dense; slower).
//!
//! A pole `r e^{iθ}` rings at `f = θ Fs / 2π` and decays to 1/e in `τ = -1 / (Fs ln r)`.

use faer::{c64, Mat};

use crate::linear::LinearSystem;
use crate::AnalysisError;

/// What kind of motion a mode is.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ModeKind {
    /// A pair of complex poles: a damped (or undamped) oscillation.
    Oscillating,
    /// Real poles: a decay without oscillation (overdamped), or growth.
    NonOscillating,
    /// `λ = 0` of a free-floating part: the part drifts as a whole.
    Rigid,
}

/// One mode.
#[derive(Clone, Debug, PartialEq)]
pub struct Mode {
    /// Its kind.
    pub kind: ModeKind,
    /// Frequency, Hz (0 for non-oscillating and rigid modes).
    pub freq_hz: f64,
    /// Decay time of the amplitude to 1/e, s (`inf` when undamped; negative when it grows).
    pub tau_s: f64,
    /// Time to decay by 60 dB, s (`tau ln 1000`).
    pub t60_s: f64,
    /// Quality factor `π f τ` (`inf` when undamped).
    pub q: f64,
    /// The pole's radius `r` (> 1: unstable).
    pub radius: f64,
    /// `λ` of the undamped problem (decoupled and undamped methods), else NaN.
    pub lambda: f64,
    /// Amplitude at each output channel (`LinearSystem::outputs`) for the model's initial
    /// conditions and impulses: the envelope at step 0.
    pub amplitudes: Vec<f64>,
    /// The shape over the dofs: `Φᵀ M Φ = I` for undamped and decoupled modes; for state-space
    /// modes the magnitude of the complex shape, scaled to a largest entry of 1.
    pub shape: Vec<f64>,
}

/// How the poles were found.
#[derive(Clone, Debug, PartialEq)]
pub enum Method {
    /// No damping: `K φ = λ M φ`.
    Undamped,
    /// Damping diagonal in the undamped modes: closed-form poles per mode.
    Decoupled,
    /// Eigenvalues of the state matrix; `coupling` is the largest off-diagonal `|C_ij|` relative to
    /// the largest `|C|`, the reason the decoupled method was not exact.
    StateSpace {
        /// Relative size of the damping's off-diagonal part in the undamped modes.
        coupling: f64,
    },
    /// Damping not diagonal in the undamped modes, on a network whose sparse factorisations are
    /// cheap: each pole refined on the full quadratic problem from its mode's own damping, then
    /// certified (see [`ModalAnalysis::compute`]).
    Refined {
        /// As for `StateSpace`.
        coupling: f64,
        /// Sparse complex factorisations used.
        factorisations: usize,
        /// Of their solves, those redone by the sparse LU with partial pivoting (a tiny pivot in
        /// the `L D Lᵀ` without pivoting; each costs several factorisations).
        lu_solves: usize,
        /// Largest relative residual `‖T(z) v‖ / (‖T‖ ‖v‖)` of the poles.
        max_residual: f64,
    },
}

/// The modes of a network and what the transfer functions need.
#[derive(Clone, Debug)]
pub struct ModalAnalysis {
    /// The modes, by increasing frequency (non-oscillating and rigid modes first).
    pub modes: Vec<Mode>,
    /// How they were found.
    pub method: Method,
    /// The largest pole radius (> 1: the scheme is unstable).
    pub max_radius: f64,
    /// The largest `λ` of `M^-1 K` (stable undamped when < 4), NaN for the state-space method.
    pub lambda_max: f64,
    decomposition: Decomposition,
}

#[derive(Clone, Debug)]
enum Decomposition {
    /// `phi` (n × n, M-orthonormal), `lambda`, `c` (diagonal of Φᵀ R Φ).
    Modal {
        phi: Mat<f64>,
        lambda: Vec<f64>,
        c: Vec<f64>,
    },
    /// `A_d = V diag(mu) V^-1`; `vinv_b` = V^-1 [M^-1; 0] (2n × n), `v_top` = top half of V;
    /// `rigid`: M-orthonormal rigid motions (double poles at 1) kept out of `mu`.
    State {
        mu: Vec<c64>,
        v_top: Mat<c64>,
        vinv_b: Mat<c64>,
        rigid: Vec<Vec<f64>>,
    },
}

const LN_1000: f64 = 6.907_755_278_982_137;

/// Poles of `z² - a z + b = 0`, as a mode (without amplitudes and shape).
pub(crate) fn mode_from_quadratic(a: f64, b: f64, fs: f64) -> (ModeKind, f64, f64, f64) {
    let disc = a * a - 4.0 * b;
    if disc < 0.0 {
        let r = b.sqrt();
        let theta = (a / (2.0 * r)).clamp(-1.0, 1.0).acos();
        (
            ModeKind::Oscillating,
            theta * fs / std::f64::consts::TAU,
            tau(r, fs),
            r,
        )
    } else {
        let s = disc.sqrt();
        let (z1, z2) = ((a + s) / 2.0, (a - s) / 2.0);
        let r = z1.abs().max(z2.abs());
        (ModeKind::NonOscillating, 0.0, tau(r, fs), r)
    }
}

fn tau(r: f64, fs: f64) -> f64 {
    if r == 1.0 {
        f64::INFINITY
    } else {
        -1.0 / (fs * r.ln())
    }
}

pub(crate) fn finish(kind: ModeKind, freq: f64, tau_s: f64, radius: f64, lambda: f64) -> Mode {
    Mode {
        kind,
        freq_hz: freq,
        tau_s,
        t60_s: tau_s * LN_1000,
        q: if tau_s.is_infinite() {
            f64::INFINITY
        } else {
            std::f64::consts::PI * freq * tau_s
        },
        radius,
        lambda,
        amplitudes: Vec::new(),
        shape: Vec::new(),
    }
}

impl ModalAnalysis {
    /// All the modes of a linear system (dense: up to a few thousand dofs).
    ///
    /// Undamped, or with damping diagonal in the undamped modes, the poles follow in closed form.
    /// Otherwise, on a network whose sparse factorisations are cheaper than the dense
    /// eigensolver (chains, strings, membranes: not dense random graphs), each pole is refined on
    /// the full problem ([`Method::Refined`]) and the result certified (every residual at rounding
    /// level, every pole found once, their sum equal to the trace of the state matrix); when the
    /// estimate says dense, or the certification fails, the state matrix's eigenvalues
    /// ([`Method::StateSpace`]).
    pub fn compute(sys: &LinearSystem) -> Result<ModalAnalysis, AnalysisError> {
        Self::compute_with(sys, false)?.ok_or_else(|| {
            AnalysisError::NoConvergence("no method gave the modes of this network".into())
        })
    }

    /// The refined method whatever its cost estimate: `Ok(None)` when the damping does not
    /// couple the undamped modes (the closed forms are exact) or the result cannot be certified.
    /// For checking the refined method against the dense one.
    pub fn compute_refined(sys: &LinearSystem) -> Result<Option<ModalAnalysis>, AnalysisError> {
        Self::compute_with(sys, true)
    }

    /// `force_refined`: take the refined method whatever its cost, and return `None` rather than
    /// another method.
    fn compute_with(
        sys: &LinearSystem,
        force_refined: bool,
    ) -> Result<Option<ModalAnalysis>, AnalysisError> {
        let n = sys.len();
        if n == 0 {
            return Err(AnalysisError::NoMobileModule);
        }
        if n > DENSE_LIMIT {
            return Err(AnalysisError::TooLarge {
                dofs: n,
                limit: DENSE_LIMIT,
            });
        }
        for (i, &m) in sys.mass.iter().enumerate() {
            if !(m > 0.0 && m.is_finite()) {
                return Err(AnalysisError::Singular(format!(
                    "the inertia of {} is {m}",
                    sys.names[i]
                )));
            }
        }
        let fs = sys.rate;
        let isq: Vec<f64> = sys.mass.iter().map(|m| 1.0 / m.sqrt()).collect();
        let scale = |a: &Mat<f64>| Mat::<f64>::from_fn(n, n, |i, j| a[(i, j)] * isq[i] * isq[j]);
        let ks = scale(&sys.k.dense());
        check_finite(&ks, "K")?;
        let evd = ks
            .self_adjoint_eigen(faer::Side::Lower)
            .map_err(|e| AnalysisError::NoConvergence(format!("{e:?}")))?;
        crate::clean_upper();
        let lambda: Vec<f64> = (0..n).map(|j| evd.S()[j]).collect();
        let v = evd.U();
        // Φ = M^-1/2 V: Φᵀ M Φ = I
        let phi = Mat::<f64>::from_fn(n, n, |i, j| v[(i, j)] * isq[i]);
        let lambda_max = lambda.iter().fold(f64::NEG_INFINITY, |a, &b| a.max(b));
        let scale_l = lambda
            .iter()
            .fold(0.0f64, |a, &b| a.max(b.abs()))
            .max(f64::MIN_POSITIVE);
        let undamped = sys.r.is_zero();
        let rs = scale(&sys.r.dense());
        check_finite(&rs, "R")?;
        let (method, c) = if undamped {
            if force_refined {
                return Ok(None);
            }
            (Method::Undamped, vec![0.0; n])
        } else {
            // C = Φᵀ R Φ (= Vᵀ (M^-1/2 R M^-1/2) V), R sparse
            let mut rphi = Mat::<f64>::zeros(n, n);
            for j in 0..n {
                sys.r.mul(phi.col_as_slice(j), rphi.col_as_slice_mut(j));
            }
            let cm = phi.transpose() * &rphi;
            drop(rphi);
            let big = (0..n)
                .flat_map(|i| (0..n).map(move |j| (i, j)))
                .fold(0.0f64, |a, (i, j)| a.max(cm[(i, j)].abs()));
            let off = (0..n)
                .flat_map(|i| (0..n).map(move |j| (i, j)))
                .filter(|(i, j)| i != j)
                .fold(0.0f64, |a, (i, j)| a.max(cm[(i, j)].abs()));
            let coupling = if big > 0.0 { off / big } else { 0.0 };
            let diag: Vec<f64> = (0..n).map(|j| cm[(j, j)]).collect();
            if coupling <= 1e-12 {
                if force_refined {
                    return Ok(None);
                }
                (Method::Decoupled, diag)
            } else {
                if n >= REFINE_MIN || force_refined {
                    // rigid motions no damper touches (a row of C that is zero)
                    let rigid: Vec<bool> = (0..n)
                        .map(|j| {
                            lambda[j].abs() <= 1e-11 * scale_l
                                && (0..n).all(|i| cm[(i, j)].abs() <= 1e-11 * scale_l)
                        })
                        .collect();
                    if let Some(p) = crate::sparse::all_poles(
                        sys,
                        &lambda,
                        phi.as_ref(),
                        cm.as_ref(),
                        &rigid,
                        force_refined,
                    )? {
                        let xeq = modal_equilibrium(sys, &phi, &lambda, scale_l);
                        let rigid = (0..n)
                            .filter(|&j| rigid[j])
                            .map(|j| phi.col(j).iter().copied().collect())
                            .collect();
                        let method = Method::Refined {
                            coupling,
                            factorisations: p.factorisations,
                            lu_solves: p.lu_solves,
                            max_residual: p.max_residual,
                        };
                        return Ok(Some(from_poles(
                            sys, p.poles, rigid, &xeq, method, lambda_max,
                        )));
                    }
                }
                if force_refined {
                    return Ok(None);
                }
                (Method::StateSpace { coupling }, Vec::new())
            }
        };
        if let Method::StateSpace { .. } = method {
            return state_space(sys, &ks, &rs, &isq, method, lambda_max).map(Some);
        }
        let mut modes = Vec::with_capacity(n);
        let rigid_tol = 1e-11 * scale_l;
        for j in 0..n {
            let (l, cj) = (lambda[j], c[j]);
            let (kind, f, t, r) = if l.abs() <= rigid_tol && cj.abs() <= rigid_tol {
                (ModeKind::Rigid, 0.0, f64::INFINITY, 1.0)
            } else {
                mode_from_quadratic(2.0 - l - cj, 1.0 - cj, fs)
            };
            let mut m = finish(kind, f, t, r, l);
            m.shape = (0..n).map(|i| phi[(i, j)]).collect();
            m.amplitudes = modal_amplitudes(sys, &m, l);
            modes.push(m);
        }
        let decomposition = Decomposition::Modal { phi, lambda, c };
        Ok(Some(ModalAnalysis::assemble(
            modes,
            method,
            lambda_max,
            decomposition,
        )))
    }

    /// The modes from the state matrix even when the damping is decoupled (for checking the two
    /// exact methods against each other).
    pub fn compute_state_space(sys: &LinearSystem) -> Result<ModalAnalysis, AnalysisError> {
        let n = sys.len();
        if n == 0 {
            return Err(AnalysisError::NoMobileModule);
        }
        let isq: Vec<f64> = sys.mass.iter().map(|m| 1.0 / m.sqrt()).collect();
        let scale = |a: &Mat<f64>| Mat::<f64>::from_fn(n, n, |i, j| a[(i, j)] * isq[i] * isq[j]);
        let (ks, rs) = (scale(&sys.k.dense()), scale(&sys.r.dense()));
        state_space(
            sys,
            &ks,
            &rs,
            &isq,
            Method::StateSpace { coupling: f64::NAN },
            f64::NAN,
        )
    }

    /// The analysis from its modes (sorted here), with the largest radius.
    fn assemble(
        modes: Vec<Mode>,
        method: Method,
        lambda_max: f64,
        decomposition: Decomposition,
    ) -> ModalAnalysis {
        let mut ma = ModalAnalysis {
            max_radius: modes.iter().fold(0.0f64, |a, m| a.max(m.radius)),
            modes,
            method,
            lambda_max,
            decomposition,
        };
        ma.sort();
        ma
    }

    fn sort(&mut self) {
        self.modes.sort_by(|a, b| {
            a.freq_hz
                .total_cmp(&b.freq_hz)
                .then(b.tau_s.total_cmp(&a.tau_s))
        });
    }

    /// The receptance `X_b / F_a` (position at dof `b` per unit force at dof `a`) at `freq_hz`,
    /// exact for the discrete scheme: `(z M + K + R - 2M + z⁻¹ (M - R))⁻¹` at `z = e^{iω}`.
    pub fn receptance(&self, a: usize, b: usize, freq_hz: f64, fs: f64) -> c64 {
        let w = std::f64::consts::TAU * freq_hz / fs;
        let z = c64::new(w.cos(), w.sin());
        let zi = c64::new(1.0, 0.0) / z;
        match &self.decomposition {
            Decomposition::Modal { phi, lambda, c } => {
                let mut h = c64::new(0.0, 0.0);
                for j in 0..lambda.len() {
                    let den = z + (lambda[j] + c[j] - 2.0) + zi * (1.0 - c[j]);
                    h += c64::new(phi[(b, j)] * phi[(a, j)], 0.0) / den;
                }
                h
            }
            Decomposition::State {
                mu,
                v_top,
                vinv_b,
                rigid,
            } => {
                // X(z) = V_top (zI - diag(mu))^-1 V^-1 B F, with x(n) the top half of the state
                let mut h = c64::new(0.0, 0.0);
                for (k, &m) in mu.iter().enumerate() {
                    h += v_top[(b, k)] * vinv_b[(k, a)] / (z - m);
                }
                // a rigid motion: φ_b φ_a / (z - 2 + 1/z)
                for phi in rigid {
                    h += c64::new(phi[b] * phi[a], 0.0) / (z - 2.0 + zi);
                }
                h
            }
        }
    }
}

/// Amplitudes at the outputs of a decoupled mode (its `shape` M-orthonormal, `lambda` its
/// undamped eigenvalue), for the initial state and the impulses: the envelope at step 0.
/// In modal coordinates `q = φᵀ M x - φᵀ b / λ`, and `q(n) = A z^n + conj`.
pub(crate) fn modal_amplitudes(sys: &LinearSystem, mode: &Mode, lambda: f64) -> Vec<f64> {
    let col = &mode.shape;
    let fs = sys.rate;
    let pb: f64 = col.iter().zip(&sys.b).map(|(p, b)| p * b).sum();
    let eq = if mode.kind == ModeKind::Rigid {
        0.0
    } else {
        pb / lambda
    };
    let proj = |x: &[f64]| -> f64 {
        col.iter()
            .zip(&sys.mass)
            .zip(x)
            .map(|((p, m), x)| p * m * x)
            .sum::<f64>()
            - eq
    };
    let (q0, qm1) = (proj(&sys.x0), proj(&sys.xm1));
    let envelope = match mode.kind {
        ModeKind::Oscillating => {
            let theta = mode.freq_hz * std::f64::consts::TAU / fs;
            let z = c64::new(mode.radius * theta.cos(), mode.radius * theta.sin());
            let w = c64::new(1.0, 0.0) / z;
            let u = q0 / 2.0;
            let v = (u * w.re - qm1 / 2.0) / w.im;
            let mut a = c64::new(u, v);
            for &(at, d, f) in &sys.impulses {
                let g = col[d] * f;
                let za = z.powf(at as f64);
                a += c64::new(0.0, -g / (2.0 * z.im)) / za;
            }
            2.0 * a.norm()
        }
        _ => q0.abs().max(qm1.abs()),
    };
    sys.outputs
        .iter()
        .map(|(_, terms)| envelope * terms.iter().map(|&(g, d)| g * col[d]).sum::<f64>().abs())
        .collect()
}

/// How far above 1 a pole radius may read and still count as stable: the eigensolvers' rounding
/// on undamped modes (exactly `r = 1`) reaches about 1e-12 on models with a wide range of inertias
/// (the reconfigurable instrument's 1e10 bridges). A radius of `1 + 1e-9` would grow an amplitude by
/// 3 % over ten minutes at 44.1 kHz: not an instability worth the name.
pub const STABILITY_MARGIN: f64 = 1e-9;

/// True when a pole of this radius does not grow (within [`STABILITY_MARGIN`]).
pub fn radius_is_stable(radius: f64) -> bool {
    radius <= 1.0 + STABILITY_MARGIN
}

/// Largest number of dofs the dense methods accept.
pub const DENSE_LIMIT: usize = 4000;

/// Networks with fewer dofs always take the dense state-space method when damping couples modes.
const REFINE_MIN: usize = 200;

fn check_finite(m: &Mat<f64>, what: &str) -> Result<(), AnalysisError> {
    for j in 0..m.ncols() {
        for i in 0..m.nrows() {
            if !m[(i, j)].is_finite() {
                return Err(AnalysisError::Singular(format!(
                    "{what} has a non-finite entry at ({i}, {j})"
                )));
            }
        }
    }
    Ok(())
}

fn state_space(
    sys: &LinearSystem,
    ks: &Mat<f64>,
    rs: &Mat<f64>,
    isq: &[f64],
    method: Method,
    lambda_max: f64,
) -> Result<ModalAnalysis, AnalysisError> {
    let n = sys.len();
    // in the scaled coordinates y = M^1/2 x: A = [[2I - Ks - Rs, -I + Rs], [I, 0]]
    let a = crate::matrices::state_matrix(n, |i, j| ks[(i, j)] + rs[(i, j)], |i, j| rs[(i, j)]);
    let eig = a
        .eigen()
        .map_err(|e| AnalysisError::NoConvergence(format!("{e:?}")))?;
    let vv = eig.U().to_owned();
    let mu: Vec<c64> = (0..2 * n).map(|k| eig.S()[k]).collect();
    let lu = vv.partial_piv_lu();
    crate::clean_upper();
    use faer::linalg::solvers::Solve;
    // B in scaled coordinates: force F on x gives M^-1/2 F on y → input matrix [M^-1/2; 0]
    let bmat = Mat::<c64>::from_fn(2 * n, n, |i, j| {
        if i == j {
            c64::new(isq[j], 0.0)
        } else {
            c64::new(0.0, 0.0)
        }
    });
    let vinv_b = lu.solve(&bmat);
    // back to x = M^-1/2 y for the output half
    let v_top = Mat::<c64>::from_fn(n, 2 * n, |i, k| vv[(i, k)] * isq[i]);
    // initial deviation state, scaled: s0 = M^1/2 [x0 - xeq; xm1 - xeq]
    let kd = sys.k.dense();
    let xeq = equilibrium(&kd, &sys.b);
    let s0 = Mat::<c64>::from_fn(2 * n, 1, |i, _| {
        let (x, d) = if i < n {
            (sys.x0[i], i)
        } else {
            (sys.xm1[i - n], i - n)
        };
        c64::new((x - xeq[d]) / isq[d], 0.0)
    });
    let coeff = lu.solve(&s0);
    let mut coeff: Vec<c64> = (0..2 * n).map(|k| coeff[(k, 0)]).collect();
    for &(at, d, f) in &sys.impulses {
        for k in 0..2 * n {
            let step = mu[k].powf((at + 1) as f64);
            coeff[k] += vinv_b[(k, d)] * f / step;
        }
    }
    let modes = eigen_modes(sys, &mu, &v_top, &coeff, 2 * sys.free_parts.len());
    let decomposition = Decomposition::State {
        mu,
        v_top,
        vinv_b,
        rigid: Vec::new(),
    };
    let ma = ModalAnalysis::assemble(modes, method, lambda_max, decomposition);
    Ok(ma)
}

/// The modes of an eigendecomposition of the state matrix: `mu` the poles, `v_top` the position
/// half of their vectors, `coeff` each pole's coefficient for the model's excitation. The
/// `rigid_poles` poles nearest to 1 (within 1e-6) are rigid motions.
fn eigen_modes(
    sys: &LinearSystem,
    mu: &[c64],
    v_top: &Mat<c64>,
    coeff: &[c64],
    rigid_poles: usize,
) -> Vec<Mode> {
    let n = sys.len();
    let fs = sys.rate;
    let mut modes = Vec::new();
    let mut reals: Vec<usize> = Vec::new();
    // Each free-floating part has a double pole at z = 1 (its rigid motion). A double root is
    // perturbed by about sqrt(eps) in floating point, which could read as a radius above 1: the
    // 2 poles per part nearest to 1 are the rigid modes, exactly.
    let mut rigid: Vec<usize> = (0..mu.len())
        .filter(|&k| (mu[k] - c64::new(1.0, 0.0)).norm() < 1e-6)
        .collect();
    rigid.sort_by(|&a, &b| {
        (mu[a] - c64::new(1.0, 0.0))
            .norm()
            .total_cmp(&(mu[b] - c64::new(1.0, 0.0)).norm())
    });
    rigid.truncate(rigid_poles);
    for _ in 0..rigid.len() / 2 {
        let mut mode = finish(ModeKind::Rigid, 0.0, f64::INFINITY, 1.0, 0.0);
        mode.amplitudes = vec![0.0; sys.outputs.len()];
        mode.shape = vec![0.0; n];
        modes.push(mode);
    }
    for k in 0..mu.len() {
        if rigid.contains(&k) {
            continue;
        }
        let m = mu[k];
        if m.im.abs() <= 1e-14 * m.norm().max(1e-300) {
            reals.push(k);
            continue;
        }
        if m.im < 0.0 {
            continue;
        }
        let r = m.norm();
        let theta = m.im.atan2(m.re);
        let mut mode = finish(
            ModeKind::Oscillating,
            theta * fs / std::f64::consts::TAU,
            tau(r, fs),
            r,
            f64::NAN,
        );
        let shape: Vec<f64> = (0..n).map(|i| v_top[(i, k)].norm()).collect();
        let peak = shape
            .iter()
            .fold(0.0f64, |a, &b| a.max(b))
            .max(f64::MIN_POSITIVE);
        mode.shape = shape.iter().map(|s| s / peak).collect();
        mode.amplitudes = sys
            .outputs
            .iter()
            .map(|(_, terms)| {
                let y: c64 = terms.iter().map(|&(g, d)| v_top[(d, k)] * g).sum();
                2.0 * (coeff[k] * y).norm()
            })
            .collect();
        modes.push(mode);
    }
    reals.sort_by(|&a, &b| mu[b].re.abs().total_cmp(&mu[a].re.abs()));
    for pair in reals.chunks(2) {
        let k = pair[0];
        let r = mu[k].norm();
        let mut mode = finish(
            ModeKind::NonOscillating,
            if mu[k].re < 0.0 { fs / 2.0 } else { 0.0 },
            tau(r, fs),
            r,
            f64::NAN,
        );
        mode.shape = (0..n).map(|i| v_top[(i, k)].norm()).collect();
        mode.amplitudes = sys
            .outputs
            .iter()
            .map(|(_, terms)| {
                pair.iter()
                    .map(|&k| {
                        (coeff[k] * terms.iter().map(|&(g, d)| v_top[(d, k)] * g).sum::<c64>())
                            .norm()
                    })
                    .sum()
            })
            .collect();
        modes.push(mode);
    }
    modes
}

/// Modes from poles refined one by one ([`crate::sparse::all_poles`]): each `(z, v)` with
/// `T(z) v = 0` stands for `z` and, when complex, its conjugate. For the symmetric `T`, the left
/// eigenvector of the state matrix for `z` is `[M v; (R - M) v / z]` and its right one `[z v; v]`,
/// with the product `vᵀ T'(z) v`, `T'(z) = 2 z M + K + R - 2M`: the coefficients of the initial
/// state and of the impulses follow without inverting anything.
fn from_poles(
    sys: &LinearSystem,
    poles: Vec<(c64, Vec<c64>)>,
    rigid: Vec<Vec<f64>>,
    xeq: &[f64],
    method: Method,
    lambda_max: f64,
) -> ModalAnalysis {
    let n = sys.len();
    let zero = c64::new(0.0, 0.0);
    let mut mu = Vec::with_capacity(2 * n);
    let mut vecs: Vec<Vec<c64>> = Vec::with_capacity(2 * n);
    for (w, v) in poles {
        let z = w + 1.0;
        if z.im != 0.0 {
            mu.push(z.conj());
            vecs.push(v.iter().map(|x| x.conj()).collect());
        }
        mu.push(z);
        vecs.push(v);
    }
    let m = mu.len();
    let (k, r) = (&sys.k, &sys.r);
    let mut v_top = Mat::<c64>::zeros(n, m);
    let mut vinv_b = Mat::<c64>::zeros(m, n);
    let mut coeff = vec![zero; m];
    let d0: Vec<f64> = sys.x0.iter().zip(xeq).map(|(x, e)| x - e).collect();
    let d1: Vec<f64> = sys.xm1.iter().zip(xeq).map(|(x, e)| x - e).collect();
    let (mut kv, mut rv, mut rd1) = (vec![zero; n], vec![zero; n], vec![0.0; n]);
    r.mul(&d1, &mut rd1);
    for (c, (&z, v)) in mu.iter().zip(&vecs).enumerate() {
        k.mul(v, &mut kv);
        r.mul(v, &mut rv);
        // vᵀ T'(z) v = Σ v_i [(2z - 2) m_i v_i + (K v)_i + (R v)_i]
        let mut tp = zero;
        let (mut top, mut back) = (zero, zero);
        for i in 0..n {
            let mi = sys.mass[i];
            tp += v[i] * ((z * 2.0 - 2.0) * mi * v[i] + kv[i] + rv[i]);
            top += v[i] * (mi * d0[i]);
            back += v[i] * (rd1[i] - mi * d1[i]);
        }
        for i in 0..n {
            v_top[(i, c)] = z * v[i];
            vinv_b[(c, i)] = v[i] / tp;
        }
        coeff[c] = (top + back / z) / tp;
        for &(at, d, f) in &sys.impulses {
            coeff[c] += vinv_b[(c, d)] * f / z.powf((at + 1) as f64);
        }
    }
    let mut modes = eigen_modes(sys, &mu, &v_top, &coeff, 0);
    for phi in &rigid {
        let mut mode = finish(ModeKind::Rigid, 0.0, f64::INFINITY, 1.0, 0.0);
        mode.amplitudes = vec![0.0; sys.outputs.len()];
        mode.shape = phi.clone();
        modes.push(mode);
    }
    let decomposition = Decomposition::State {
        mu,
        v_top,
        vinv_b,
        rigid,
    };
    ModalAnalysis::assemble(modes, method, lambda_max, decomposition)
}

/// The static equilibrium `K x = b` from the undamped modes (`Φ` M-orthonormal): `Σ φ_j (φ_jᵀ b)
/// / λ_j` over the modes with `λ_j` above the rigid threshold.
fn modal_equilibrium(sys: &LinearSystem, phi: &Mat<f64>, lambda: &[f64], scale_l: f64) -> Vec<f64> {
    let n = sys.len();
    let mut x = vec![0.0; n];
    if sys.b.iter().all(|&b| b == 0.0) {
        return x;
    }
    for (j, &l) in lambda.iter().enumerate() {
        if l.abs() > 1e-11 * scale_l {
            let p: f64 = (0..n).map(|i| phi[(i, j)] * sys.b[i]).sum::<f64>() / l;
            for (i, xi) in x.iter_mut().enumerate() {
                *xi += p * phi[(i, j)];
            }
        }
    }
    x
}

/// The static equilibrium `K x = b` (least squares on free-floating parts: their rigid motion is
/// left as it is).
pub fn equilibrium(k: &Mat<f64>, b: &[f64]) -> Vec<f64> {
    let n = b.len();
    let evd = match k.self_adjoint_eigen(faer::Side::Lower) {
        Ok(e) => e,
        Err(_) => return vec![0.0; n],
    };
    crate::clean_upper();
    let (u, s) = (evd.U(), evd.S());
    let smax = (0..n).fold(0.0f64, |a, j| a.max(s[j].abs()));
    let mut x = vec![0.0; n];
    for j in 0..n {
        if s[j].abs() > 1e-12 * smax {
            let p: f64 = (0..n).map(|i| u[(i, j)] * b[i]).sum::<f64>() / s[j];
            for (i, xi) in x.iter_mut().enumerate() {
                *xi += p * u[(i, j)];
            }
        }
    }
    x
}
