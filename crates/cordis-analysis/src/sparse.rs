//! Sparse methods for large networks: the lowest modes, and exact frequency responses.
//!
//! - [`lowest_modes`]: the `count` lowest undamped modes `K φ = λ M φ` by shift-invert block
//!   Lanczos (block size 3, Krylov–Schur thick restarts, full reorthogonalisation, a basis of about
//!   `2 count + 10` vectors) on a sparse Cholesky factor of `K - σ M`, `σ` slightly below 0 so that
//!   rigid modes (`λ = 0`) are found (below the Gershgorin bound when `K` is indefinite). The
//!   eigenvalues are then the Rayleigh–Ritz values of `K` itself (not of the inverted operator),
//!   and every residual `‖K φ - λ M φ‖` is checked. Damping: when `R = α M + β K` (checked entry by
//!   entry to 1e-12 of the largest `|R|`), each pole follows in closed form as in the dense
//!   decoupled method; otherwise the quadratic eigenproblem is projected on the undamped modes
//!   (plus a few more), and each pole is refined on the full `T(z) = M z² + (K + R - 2M) z + (M - R)`
//!   by Rayleigh-functional iteration (`T` is complex symmetric: the left eigenvector is the right
//!   one), one sparse complex factorisation per step, written in `w = z - 1` so that nothing
//!   cancels for poles near 1.
//! - [`receptance_sparse`]: `[(z M + K + R - 2M + z⁻¹ (M - R))⁻¹]_{b,a}` at `z = e^{iω}` by a
//!   direct sparse solve per frequency: exact for the discrete scheme, with no modal truncation.
//!
//! The dynamic stiffness `A(z)` is complex symmetric, so it is factorised as `P A Pᵀ = L D Lᵀ`
//! without pivoting (AMD ordering and supernodes from faer's symbolic Cholesky, dense updates by
//! faer's matrix product, within a supernode too, by panels of 16 columns), about 3 to 6 times
//! faster than faer's sparse LU. Each solve takes one step of iterative refinement, and up to two
//! more while its normwise backward error is above 1e-13; a solve that still fails the check (a
//! tiny pivot) is redone with faer's sparse LU with partial pivoting. After each faer product
//! [`crate::clean_upper`] clears the vector registers' upper bits, which the loops here would
//! otherwise wait on.

// Loops over CSC column ranges index several parallel arrays (rows, K, R, M values) at once.
#![allow(clippy::needless_range_loop)]

use faer::dyn_stack::{MemBuffer, MemStack, StackReq};
use faer::linalg::solvers::Solve;
use faer::sparse::linalg::lu::{factorize_symbolic_lu, NumericLu, SymbolicLu};
use faer::sparse::linalg::solvers::{Llt, SymbolicLlt};
use faer::sparse::{SparseColMatRef, SymbolicSparseColMat};
use faer::{c64, Accum, Conj, Mat, MatRef, Par, Side};

use crate::linear::LinearSystem;
use crate::modes::{finish, modal_amplitudes, mode_from_quadratic, Mode, ModeKind};
use crate::AnalysisError;

/// How [`lowest_modes`] found the poles.
#[derive(Clone, Debug, PartialEq)]
pub enum SparseMethod {
    /// No damping: `K φ = λ M φ`.
    Undamped,
    /// `R = α M + β K`: each mode is a CEL of its own with `c = α + β λ`, poles in closed form.
    Rayleigh {
        /// `α`.
        alpha: f64,
        /// `β`.
        beta: f64,
    },
    /// Damping not proportional: each pole refined on the full quadratic eigenproblem.
    Refined {
        /// Largest off-diagonal `|C_ij|` of `C = Φᵀ R Φ` over the modes found, relative to the
        /// largest `|C|`.
        coupling: f64,
        /// Sparse complex factorisations used by the refinement.
        factorisations: usize,
        /// Of their solves, those redone by the sparse LU (a tiny pivot; see
        /// [`receptance_sparse`]).
        lu_solves: usize,
    },
}

/// The lowest modes of a large network.
#[derive(Clone, Debug)]
pub struct LowestModes {
    /// The modes, sorted as [`crate::ModalAnalysis::modes`] (by frequency, then slowest decay).
    /// `shape` is M-orthonormal for undamped and Rayleigh-damped modes (and for the rigid modes of
    /// undamped free parts); for refined modes it is the magnitude of the complex shape scaled to a
    /// largest entry of 1, and `lambda` is NaN. `amplitudes` are filled for undamped and
    /// Rayleigh-damped modes, empty with refined ones.
    pub modes: Vec<Mode>,
    /// How the poles were found.
    pub method: SparseMethod,
    /// Largest relative residual of the undamped modes, `‖K φ - λ M φ‖_{M⁻¹} / ρ` with `φᵀ M φ = 1`
    /// and `ρ` the Gershgorin bound of `M^-1/2 K M^-1/2`.
    pub max_residual: f64,
    /// For refined modes, the largest relative residual `‖T(z) v‖ / (‖T‖ ‖v‖)`; 0 otherwise.
    pub max_pole_residual: f64,
    /// The shift `σ` of the spectral transformation (NaN when the `count` asked for is so close to
    /// the number of dofs that the dense method was used).
    pub shift: f64,
    /// Applications of `(K - σM)⁻¹` (one per vector).
    pub solves: usize,
}

/// Block size of the Lanczos method: eigenvalues of multiplicity up to this are found.
const BLOCK: usize = 3;
const MAX_RESTARTS: usize = 500;

/// The symmetric pattern shared by K, R and M (diagonal always present), as a full CSC matrix with
/// sorted rows, and the values of each matrix on it.
struct Pattern {
    n: usize,
    symbolic: SymbolicSparseColMat<usize>,
    k: Vec<f64>,
    r: Vec<f64>,
    m: Vec<f64>,
}

impl Pattern {
    fn new(sys: &LinearSystem) -> Result<Pattern, AnalysisError> {
        let n = sys.len();
        if n == 0 {
            return Err(AnalysisError::NoMobileModule);
        }
        for (i, &m) in sys.mass.iter().enumerate() {
            if !(m > 0.0 && m.is_finite()) {
                return Err(AnalysisError::Singular(format!(
                    "the inertia of {} is {m}",
                    sys.names[i]
                )));
            }
        }
        let mut keys: Vec<(usize, usize)> = (0..n).map(|i| (i, i)).collect();
        for &(i, j, _) in sys.k.off.iter().chain(&sys.r.off) {
            if i >= n || j >= n {
                return Err(AnalysisError::Singular(format!(
                    "a matrix entry ({i}, {j}) is outside the {n} dofs"
                )));
            }
            keys.push((j, i));
            keys.push((i, j));
        }
        keys.sort_unstable();
        keys.dedup();
        let mut col_ptr = vec![0usize; n + 1];
        for &(c, _) in &keys {
            col_ptr[c + 1] += 1;
        }
        for c in 0..n {
            col_ptr[c + 1] += col_ptr[c];
        }
        let row_idx: Vec<usize> = keys.iter().map(|&(_, r)| r).collect();
        let nnz = row_idx.len();
        let at = |c: usize, r: usize| -> usize {
            let s = &row_idx[col_ptr[c]..col_ptr[c + 1]];
            col_ptr[c] + s.partition_point(|&x| x < r)
        };
        let (mut k, mut r, mut m) = (vec![0.0; nnz], vec![0.0; nnz], vec![0.0; nnz]);
        for i in 0..n {
            let p = at(i, i);
            k[p] += sys.k.diag[i];
            r[p] += sys.r.diag[i];
            m[p] = sys.mass[i];
        }
        for (vals, off) in [(&mut k, &sys.k.off), (&mut r, &sys.r.off)] {
            for &(i, j, v) in off {
                vals[at(j, i)] += v;
                vals[at(i, j)] += v;
            }
        }
        for (what, vals) in [("K", &k), ("R", &r)] {
            if let Some(p) = vals.iter().position(|v| !v.is_finite()) {
                let c = col_ptr.partition_point(|&x| x <= p) - 1;
                return Err(AnalysisError::Singular(format!(
                    "{what} has a non-finite entry at ({}, {c})",
                    row_idx[p]
                )));
            }
        }
        let symbolic = SymbolicSparseColMat::new_checked(n, n, col_ptr, None, row_idx);
        Ok(Pattern {
            n,
            symbolic,
            k,
            r,
            m,
        })
    }

    fn col_ptr(&self) -> &[usize] {
        self.symbolic.col_ptr()
    }

    fn row_idx(&self) -> &[usize] {
        self.symbolic.row_idx()
    }

    /// `y = A x` for the values `a` on the pattern.
    fn mul<T: Copy + std::ops::Mul<f64, Output = T> + std::ops::AddAssign + Default>(
        &self,
        a: &[f64],
        x: &[T],
        y: &mut [T],
    ) {
        let (cp, ri) = (self.col_ptr(), self.row_idx());
        y.iter_mut().for_each(|v| *v = T::default());
        for c in 0..self.n {
            let xc = x[c];
            for p in cp[c]..cp[c + 1] {
                y[ri[p]] += xc * a[p];
            }
        }
    }

    /// Largest absolute row sum of `M^-1/2 A M^-1/2`, and smallest Gershgorin lower bound.
    fn gershgorin(&self, a: &[f64], mass: &[f64]) -> (f64, f64) {
        let (cp, ri) = (self.col_ptr(), self.row_idx());
        let (mut hi, mut lo) = (0.0f64, f64::INFINITY);
        for c in 0..self.n {
            let (mut diag, mut off) = (0.0, 0.0);
            for p in cp[c]..cp[c + 1] {
                let v = a[p] / (mass[c] * mass[ri[p]]).sqrt();
                if ri[p] == c {
                    diag = v;
                } else {
                    off += v.abs();
                }
            }
            hi = hi.max(diag.abs() + off);
            lo = lo.min(diag - off);
        }
        (hi, lo)
    }

    /// The values of `A(z) = z M + K + R - 2M + z⁻¹ (M - R) = (w² M + w R) / (1 + w) + K`, with
    /// `z = 1 + w` (given as `w`, so that nothing cancels when `z` is near 1).
    fn dynamic(&self, w: c64, out: &mut [c64]) {
        let zi = c64::new(1.0, 0.0) / (w + 1.0);
        let zm = w * w * zi;
        let zr = w * zi;
        for (o, ((k, r), m)) in out.iter_mut().zip(self.k.iter().zip(&self.r).zip(&self.m)) {
            *o = zm * *m + zr * *r + *k;
        }
    }
}

/// A small deterministic generator for start vectors.
struct Lcg(u64);
impl Lcg {
    fn next(&mut self) -> f64 {
        self.0 = self
            .0
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (self.0 >> 11) as f64 / (1u64 << 53) as f64 - 0.5
    }
}

fn norm(x: &[f64]) -> f64 {
    x.iter().map(|v| v * v).sum::<f64>().sqrt()
}

/// Orthogonalises `w` against the orthonormal columns of `v` (classical Gram–Schmidt, twice),
/// adding the coefficients to `h`. Returns the norm of `w` after.
fn orthogonalise(v: MatRef<'_, f64>, w: &mut [f64], h: &mut [f64]) -> f64 {
    let j = v.ncols();
    if j == 0 {
        return norm(w);
    }
    let mut c = Mat::<f64>::zeros(j, 1);
    for _ in 0..2 {
        faer::linalg::matmul::matmul(
            c.as_mut(),
            Accum::Replace,
            v.transpose(),
            MatRef::from_column_major_slice(w, w.len(), 1),
            1.0,
            Par::Seq,
        );
        let n = w.len();
        faer::linalg::matmul::matmul(
            faer::MatMut::from_column_major_slice_mut(w, n, 1),
            Accum::Add,
            v,
            c.as_ref(),
            -1.0,
            Par::Seq,
        );
        crate::clean_upper();
        for (hi, ci) in h.iter_mut().zip(c.col_as_slice(0)) {
            *hi += ci;
        }
    }
    norm(w)
}

/// `y ↦ M^1/2 (K - σM)⁻¹ M^1/2 y`, symmetric: the shift-inverted problem in mass-scaled
/// coordinates.
struct ShiftInvert {
    llt: Llt<usize, f64>,
    sqm: Vec<f64>,
    solves: usize,
}

impl ShiftInvert {
    fn apply(&mut self, y: MatRef<'_, f64>) -> Mat<f64> {
        let mut x = Mat::<f64>::from_fn(y.nrows(), y.ncols(), |i, j| y[(i, j)] * self.sqm[i]);
        self.llt.solve_in_place(x.as_mut());
        crate::clean_upper();
        for j in 0..x.ncols() {
            for (v, s) in x.col_as_slice_mut(j).iter_mut().zip(&self.sqm) {
                *v *= s;
            }
        }
        self.solves += y.ncols();
        x
    }
}

/// Fills column `j` of `v` with a random vector orthonormal to columns `0..j`.
fn random_direction(v: &mut Mat<f64>, j: usize, rng: &mut Lcg) -> Result<(), AnalysisError> {
    let n = v.nrows();
    for _ in 0..8 {
        let mut w: Vec<f64> = (0..n).map(|_| rng.next()).collect();
        let before = norm(&w);
        let mut h = vec![0.0; j];
        let after = orthogonalise(v.as_ref().subcols(0, j), &mut w, &mut h);
        if after > 1e-8 * before {
            for (d, s) in v.col_as_slice_mut(j).iter_mut().zip(&w) {
                *d = s / after;
            }
            return Ok(());
        }
    }
    Err(AnalysisError::NoConvergence(
        "no direction left to explore (the Krylov space spans the whole space)".into(),
    ))
}

/// Orthonormal vectors of the `want` largest eigenvalues of the symmetric operator `op`, by block
/// Krylov–Schur with full reorthogonalisation. `m` is the largest basis size.
fn krylov_schur(
    op: &mut ShiftInvert,
    n: usize,
    want: usize,
    m: usize,
) -> Result<Mat<f64>, AnalysisError> {
    let b = BLOCK.min(n);
    debug_assert!(m > want + 2 * b && m <= n);
    let mut v = Mat::<f64>::zeros(n, m);
    let mut h = Mat::<f64>::zeros(m, m);
    let mut rng = Lcg(0x9e37_79b9_7f4a_7c15);
    for j in 0..b {
        random_direction(&mut v, j, &mut rng)?;
    }
    let (mut p, mut cols) = (0usize, b);
    let mut hcol = vec![0.0; m];
    for _ in 0..MAX_RESTARTS {
        while cols < m {
            let s = b.min(m - cols);
            let w = op.apply(v.as_ref().subcols(p, s));
            for i in 0..s {
                let (c, new) = (p + i, cols);
                let mut wi = w.col_as_slice(i).to_vec();
                let before = norm(&wi);
                hcol[..new].iter_mut().for_each(|x| *x = 0.0);
                let after = orthogonalise(v.as_ref().subcols(0, new), &mut wi, &mut hcol[..new]);
                for (r, &x) in hcol[..new].iter().enumerate() {
                    h[(r, c)] = x;
                }
                if after > 1e-10 * before && after > 0.0 {
                    for (d, x) in v.col_as_slice_mut(new).iter_mut().zip(&wi) {
                        *d = x / after;
                    }
                    h[(new, c)] = after;
                } else {
                    // an invariant subspace: continue from a fresh direction
                    random_direction(&mut v, new, &mut rng)?;
                    h[(new, c)] = 0.0;
                }
                cols += 1;
            }
            p += s;
        }
        // Rayleigh–Ritz on the expanded columns
        let hp = Mat::<f64>::from_fn(p, p, |i, j| 0.5 * (h[(i, j)] + h[(j, i)]));
        let evd = hp
            .self_adjoint_eigen(Side::Lower)
            .map_err(|e| AnalysisError::NoConvergence(format!("{e:?}")))?;
        // descending θ
        let theta: Vec<f64> = (0..p).rev().map(|j| evd.S()[j]).collect();
        let y = Mat::<f64>::from_fn(p, p, |i, j| evd.U()[(i, p - 1 - j)]);
        let tail = Mat::<f64>::from_fn(b, p, |i, j| h[(p + i, j)]);
        let res = &tail * &y;
        let theta_max = theta.iter().fold(0.0f64, |a, t| a.max(t.abs()));
        let converged = (0..want).all(|j| {
            let r = norm(res.col_as_slice(j));
            r <= (1e-12 * theta[j].abs()).max(64.0 * f64::EPSILON * theta_max)
        });
        if converged {
            return Ok(v.as_ref().subcols(0, p) * y.as_ref().subcols(0, want));
        }
        // thick restart: keep the k best Ritz vectors and the trailing block
        let k = (want + (p - want) / 2).min(m - 2 * b).max(want);
        let xk = v.as_ref().subcols(0, p) * y.as_ref().subcols(0, k);
        v.as_mut().subcols_mut(0, k).copy_from(&xk);
        for i in 0..b {
            let src = v.col_as_slice(p + i).to_vec();
            v.col_as_slice_mut(k + i).copy_from_slice(&src);
        }
        h.fill(0.0);
        for i in 0..k {
            h[(i, i)] = theta[i];
            for r in 0..b {
                h[(k + r, i)] = res[(r, i)];
            }
        }
        p = k;
        cols = k + b;
    }
    Err(AnalysisError::NoConvergence(format!(
        "shift-invert Lanczos: the {want} lowest modes did not converge in {MAX_RESTARTS} restarts"
    )))
}

/// `R = α M + β K` entry by entry (to 1e-12 of the largest `|R|`), or `None`.
fn rayleigh(pat: &Pattern) -> Option<(f64, f64)> {
    let (cp, ri) = (pat.col_ptr(), pat.row_idx());
    let (mut kr, mut kk) = (0.0, 0.0);
    for c in 0..pat.n {
        for p in cp[c]..cp[c + 1] {
            if ri[p] != c {
                kr += pat.k[p] * pat.r[p];
                kk += pat.k[p] * pat.k[p];
            }
        }
    }
    let diag: Vec<usize> = (0..pat.n)
        .map(|c| cp[c] + ri[cp[c]..cp[c + 1]].partition_point(|&x| x < c))
        .collect();
    let (alpha, beta) = if kk > 0.0 {
        let beta = kr / kk;
        let (mut num, mut den) = (0.0, 0.0);
        for &p in &diag {
            num += pat.m[p] * (pat.r[p] - beta * pat.k[p]);
            den += pat.m[p] * pat.m[p];
        }
        (num / den, beta)
    } else {
        // no coupling springs: fit the diagonal with both terms (scaled normal equations)
        let (mut smm, mut smk, mut skk, mut smr, mut skr) = (0.0, 0.0, 0.0, 0.0, 0.0);
        for &p in &diag {
            let (m, k, r) = (pat.m[p], pat.k[p], pat.r[p]);
            smm += m * m;
            smk += m * k;
            skk += k * k;
            smr += m * r;
            skr += k * r;
        }
        let det = smm * skk - smk * smk;
        if skk > 0.0 && det > 1e-8 * smm * skk {
            ((smr * skk - skr * smk) / det, (skr * smm - smr * smk) / det)
        } else {
            (smr / smm, 0.0)
        }
    };
    let big = pat.r.iter().fold(0.0f64, |a, r| a.max(r.abs()));
    let tol = 1e-12 * big;
    let fits = (0..pat.n).all(|c| {
        (cp[c]..cp[c + 1]).all(|p| {
            let m = if ri[p] == c { pat.m[p] } else { 0.0 };
            (pat.r[p] - alpha * m - beta * pat.k[p]).abs() <= tol
        })
    });
    fits.then_some((alpha, beta))
}

/// The lowest undamped modes.
struct Undamped {
    /// `λ`, increasing.
    lambda: Vec<f64>,
    /// `Φ` (n × count), M-orthonormal.
    phi: Mat<f64>,
    /// Largest relative residual.
    max_res: f64,
    /// The shift `σ` (NaN when the dense method was used).
    shift: f64,
    /// Applications of the shift-inverted operator.
    solves: usize,
}

/// The `count` lowest undamped modes.
fn undamped_lowest(pat: &Pattern, count: usize) -> Result<Undamped, AnalysisError> {
    let n = pat.n;
    let mass: Vec<f64> = (0..n).map(|i| pat.m[diag_pos(pat, i)]).collect();
    let sqm: Vec<f64> = mass.iter().map(|m| m.sqrt()).collect();
    let (rho, low) = pat.gershgorin(&pat.k, &mass);
    let rho = rho.max(f64::MIN_POSITIVE);
    let b = BLOCK.min(n);
    let m = (2 * count + 10).max(count + 2 * b + 1);
    let (x, sigma, solves) = if m >= n {
        // the Krylov space would be the whole space: dense
        if n > crate::DENSE_LIMIT {
            return Err(AnalysisError::TooLarge {
                dofs: n,
                limit: crate::DENSE_LIMIT,
            });
        }
        let mut ks = Mat::<f64>::zeros(n, n);
        let (cp, ri) = (pat.col_ptr(), pat.row_idx());
        for c in 0..n {
            for p in cp[c]..cp[c + 1] {
                ks[(ri[p], c)] = pat.k[p] / (sqm[ri[p]] * sqm[c]);
            }
        }
        let evd = ks
            .self_adjoint_eigen(Side::Lower)
            .map_err(|e| AnalysisError::NoConvergence(format!("{e:?}")))?;
        (evd.U().subcols(0, count).to_owned(), f64::NAN, 0)
    } else {
        // σ slightly below the lowest eigenvalue: below 0 when K is semi-definite
        let mut sigma = -1e-6 * rho;
        let sym = SymbolicLlt::try_new(pat.symbolic.as_ref(), Side::Lower)
            .map_err(|e| AnalysisError::Singular(format!("{e:?}")))?;
        let factor = |sigma: f64| {
            let vals: Vec<f64> = pat
                .k
                .iter()
                .zip(&pat.m)
                .map(|(k, m)| k - sigma * m)
                .collect();
            Llt::try_new_with_symbolic(
                sym.clone(),
                SparseColMatRef::new(pat.symbolic.as_ref(), &vals),
                Side::Lower,
            )
        };
        let llt = match factor(sigma) {
            Ok(l) => l,
            Err(_) => {
                // K has negative eigenvalues: shift below the Gershgorin bound
                sigma = low - 1e-6 * rho;
                factor(sigma).map_err(|e| {
                    AnalysisError::Singular(format!("K - σM cannot be factorised: {e:?}"))
                })?
            }
        };
        let mut op = ShiftInvert {
            llt,
            sqm: sqm.clone(),
            solves: 0,
        };
        let want = (count + b).min(m - 2 * b - 1);
        let x = krylov_schur(&mut op, n, want, m)?;
        (x, sigma, op.solves)
    };
    // Rayleigh–Ritz on K itself in the span of the Ritz vectors: eigenvalues to the accuracy of K
    let c = x.ncols();
    let mut kx = Mat::<f64>::zeros(n, c);
    let ks_vals: Vec<f64> = {
        let (cp, ri) = (pat.col_ptr(), pat.row_idx());
        let mut v = pat.k.clone();
        for col in 0..n {
            for p in cp[col]..cp[col + 1] {
                v[p] /= sqm[ri[p]] * sqm[col];
            }
        }
        v
    };
    for j in 0..c {
        let (src, dst) = (x.col_as_slice(j), kx.col_as_slice_mut(j));
        pat.mul(&ks_vals, src, dst);
    }
    let proj = x.transpose() * &kx;
    let proj = Mat::<f64>::from_fn(c, c, |i, j| 0.5 * (proj[(i, j)] + proj[(j, i)]));
    let evd = proj
        .self_adjoint_eigen(Side::Lower)
        .map_err(|e| AnalysisError::NoConvergence(format!("{e:?}")))?;
    let lambda: Vec<f64> = (0..count).map(|j| evd.S()[j]).collect();
    let ysub = evd.U().subcols(0, count);
    let xs = &x * ysub;
    let kxs = &kx * ysub;
    let mut max_res = 0.0f64;
    let mut phi = Mat::<f64>::zeros(n, count);
    for j in 0..count {
        let xj = xs.col_as_slice(j);
        let nx = norm(xj);
        let r: f64 = kxs
            .col_as_slice(j)
            .iter()
            .zip(xj)
            .map(|(k, x)| (k - lambda[j] * x) / nx)
            .map(|d| d * d)
            .sum::<f64>()
            .sqrt();
        max_res = max_res.max(r / rho);
        for (i, d) in phi.col_as_slice_mut(j).iter_mut().enumerate() {
            *d = xj[i] / (nx * sqm[i]);
        }
    }
    if !(max_res <= 1e-8) {
        return Err(AnalysisError::NoConvergence(format!(
            "the lowest modes have a relative residual of {max_res:.2e}"
        )));
    }
    Ok(Undamped {
        lambda,
        phi,
        max_res,
        shift: sigma,
        solves,
    })
}

fn diag_pos(pat: &Pattern, c: usize) -> usize {
    let (cp, ri) = (pat.col_ptr(), pat.row_idx());
    cp[c] + ri[cp[c]..cp[c + 1]].partition_point(|&x| x < c)
}

/// The `count` lowest modes of a network (those continuing its `count` lowest undamped modes),
/// exact for the discrete scheme, by sparse methods: for networks too large for
/// [`crate::ModalAnalysis::compute`].
///
/// Undamped modes by shift-invert block Lanczos on a sparse Cholesky factor of `K - σM`; with
/// damping `R = α M + β K` the poles in closed form; with other damping each pole refined on
/// `T(z) = M z² + (K + R - 2M) z + (M - R)` (a sparse complex factorisation per iteration).
/// `count` must be 1 to the number of dofs; when it is so large that the Krylov basis would span
/// everything, the undamped modes come from the dense eigensolver (up to [`crate::DENSE_LIMIT`]
/// dofs).
///
/// Errors: [`AnalysisError::InvalidRequest`] for a bad `count`, [`AnalysisError::Singular`] for
/// a bad inertia or a non-finite matrix entry, [`AnalysisError::NoConvergence`] when a residual
/// check fails (never silently inaccurate modes).
pub fn lowest_modes(sys: &LinearSystem, count: usize) -> Result<LowestModes, AnalysisError> {
    let n = sys.len();
    if n == 0 {
        return Err(AnalysisError::NoMobileModule);
    }
    if count == 0 || count > n {
        return Err(AnalysisError::InvalidRequest(format!(
            "asked for the {count} lowest modes of a network with {n} mobile modules: ask for 1 to {n}"
        )));
    }
    let pat = Pattern::new(sys)?;
    let fs = sys.rate;
    let damped = pat.r.iter().any(|&r| r != 0.0);
    let prop = if damped {
        rayleigh(&pat)
    } else {
        Some((0.0, 0.0))
    };
    let mass: Vec<f64> = (0..n).map(|i| pat.m[diag_pos(&pat, i)]).collect();
    let (rho, _) = pat.gershgorin(&pat.k, &mass);
    let Some((alpha, beta)) = prop else {
        return refined(sys, &pat, count);
    };
    let Undamped {
        lambda,
        phi,
        max_res,
        shift,
        solves,
    } = undamped_lowest(&pat, count)?;
    let rigid_tol = 1e-11 * rho.max(f64::MIN_POSITIVE);
    let mut modes = Vec::with_capacity(count);
    for (j, &l) in lambda.iter().enumerate() {
        let cj = if damped { alpha + beta * l } else { 0.0 };
        let (kind, f, t, r) = if l.abs() <= rigid_tol && cj.abs() <= rigid_tol {
            (ModeKind::Rigid, 0.0, f64::INFINITY, 1.0)
        } else {
            mode_from_quadratic(2.0 - l - cj, 1.0 - cj, fs)
        };
        let mut md = finish(kind, f, t, r, l);
        md.shape = phi.col_as_slice(j).to_vec();
        md.amplitudes = modal_amplitudes(sys, &md, l);
        modes.push(md);
    }
    sort(&mut modes);
    Ok(LowestModes {
        modes,
        method: if damped {
            SparseMethod::Rayleigh { alpha, beta }
        } else {
            SparseMethod::Undamped
        },
        max_residual: max_res,
        max_pole_residual: 0.0,
        shift,
        solves,
    })
}

fn sort(modes: &mut [Mode]) {
    modes.sort_by(|a, b| {
        a.freq_hz
            .total_cmp(&b.freq_hz)
            .then(b.tau_s.total_cmp(&a.tau_s))
    });
}

/// A sparse complex LU (partial pivoting) with its scratch space, reused across factorisations.
struct ComplexLu<'a> {
    pat: &'a Pattern,
    symbolic: &'a SymbolicLu<usize>,
    numeric: NumericLu<usize, c64>,
    mem: MemBuffer,
}

impl<'a> ComplexLu<'a> {
    fn new(pat: &'a Pattern, symbolic: &'a SymbolicLu<usize>) -> Result<Self, AnalysisError> {
        let req = StackReq::any_of(&[
            symbolic.factorize_numeric_lu_scratch::<c64>(Par::Seq, Default::default()),
            symbolic.solve_in_place_scratch::<c64>(1, Par::Seq),
        ]);
        let mem = MemBuffer::try_new(req)
            .map_err(|_| AnalysisError::Singular("out of memory for the sparse LU".into()))?;
        Ok(ComplexLu {
            pat,
            symbolic,
            numeric: NumericLu::new(),
            mem,
        })
    }

    /// Solves `A x = rhs` in place for the values `vals` on the pattern (one step of iterative
    /// refinement). Returns false when the matrix is singular.
    fn solve_values(&mut self, vals: &[c64], rhs: &mut [c64]) -> bool {
        let a = SparseColMatRef::new(self.pat.symbolic.as_ref(), vals);
        let n = rhs.len();
        let Ok(lu) = self.symbolic.factorize_numeric_lu(
            &mut self.numeric,
            a,
            Par::Seq,
            MemStack::new(&mut self.mem),
            Default::default(),
        ) else {
            return false;
        };
        let b = rhs.to_vec();
        lu.solve_in_place_with_conj(
            Conj::No,
            faer::MatMut::from_column_major_slice_mut(rhs, n, 1),
            Par::Seq,
            MemStack::new(&mut self.mem),
        );
        crate::clean_upper();
        // refinement: r = b - A x, x += A⁻¹ r
        let mut r = vec![c64::new(0.0, 0.0); n];
        {
            let (cp, ri) = (self.pat.col_ptr(), self.pat.row_idx());
            for c in 0..n {
                let xc = rhs[c];
                for p in cp[c]..cp[c + 1] {
                    r[ri[p]] += vals[p] * xc;
                }
            }
        }
        for (ri, bi) in r.iter_mut().zip(&b) {
            *ri = *bi - *ri;
        }
        lu.solve_in_place_with_conj(
            Conj::No,
            faer::MatMut::from_column_major_slice_mut(&mut r, n, 1),
            Par::Seq,
            MemStack::new(&mut self.mem),
        );
        crate::clean_upper();
        for (x, d) in rhs.iter_mut().zip(&r) {
            *x += *d;
        }
        rhs.iter().all(|x| x.re.is_finite() && x.im.is_finite())
    }
}

fn symbolic_lu(pat: &Pattern) -> Result<SymbolicLu<usize>, AnalysisError> {
    factorize_symbolic_lu(pat.symbolic.as_ref(), Default::default())
        .map_err(|e| AnalysisError::Singular(format!("sparse LU analysis failed: {e:?}")))
}

/// The receptance `X_b / F_a` (position at dof `b` per unit force at dof `a`) at each frequency,
/// exact for the discrete scheme: `[(z M + K + R - 2M + z⁻¹ (M - R))⁻¹]_{b,a}` at `z = e^{iω}`,
/// `ω = 2π f / Fs`, by a direct sparse solve per frequency (no modal truncation): complex
/// symmetric `L D Lᵀ`, iterative refinement, backward error checked, sparse LU when the check
/// fails. One symbolic analysis; the frequencies are shared among the available cores.
///
/// Errors: [`AnalysisError::InvalidRequest`] for a dof out of range or a non-finite frequency,
/// [`AnalysisError::Singular`] when the matrix is singular at a frequency (an undamped pole hit
/// exactly).
pub fn receptance_sparse(
    sys: &LinearSystem,
    a: usize,
    b: usize,
    freqs_hz: &[f64],
) -> Result<Vec<c64>, AnalysisError> {
    let n = sys.len();
    if n == 0 {
        return Err(AnalysisError::NoMobileModule);
    }
    if a >= n || b >= n {
        return Err(AnalysisError::InvalidRequest(format!(
            "dof {} is not one of the {n} mobile modules (0 to {})",
            if a >= n { a } else { b },
            n - 1
        )));
    }
    if let Some(f) = freqs_hz.iter().find(|f| !f.is_finite()) {
        return Err(AnalysisError::InvalidRequest(format!(
            "the frequency {f} is not finite"
        )));
    }
    let pat = Pattern::new(sys)?;
    let symbolic = symbolic_lu(&pat)?;
    let fs = sys.rate;
    let mut out = vec![c64::new(0.0, 0.0); freqs_hz.len()];
    let threads = std::thread::available_parallelism()
        .map(|t| t.get())
        .unwrap_or(1)
        .min(freqs_hz.len().div_ceil(4))
        .max(1);
    let chunk = freqs_hz.len().div_ceil(threads).max(1);
    let ldlt = SymLdlt::new(&pat)?;
    let work = |freqs: &[f64], out: &mut [c64]| -> Result<(), AnalysisError> {
        let mut solver = DynamicSolver::new(&pat, &ldlt, &symbolic);
        let mut vals = vec![c64::new(0.0, 0.0); pat.k.len()];
        let mut e = vec![c64::new(0.0, 0.0); n];
        e[a] = c64::new(1.0, 0.0);
        for (&f, o) in freqs.iter().zip(out.iter_mut()) {
            // w = e^{iω} - 1, without cancellation
            let (sn, cs) = (std::f64::consts::PI * f / fs).sin_cos();
            pat.dynamic(c64::new(-2.0 * sn * sn, 2.0 * sn * cs), &mut vals);
            let x = solver.solve(&vals, &e).ok_or_else(|| {
                AnalysisError::Singular(format!(
                    "the dynamic stiffness is singular at {f} Hz (a pole of the network)"
                ))
            })?;
            *o = x[b];
        }
        Ok(())
    };
    if threads == 1 {
        work(freqs_hz, &mut out)?;
    } else {
        let results: Vec<Result<(), AnalysisError>> = std::thread::scope(|s| {
            let handles: Vec<_> = freqs_hz
                .chunks(chunk)
                .zip(out.chunks_mut(chunk))
                .map(|(f, o)| s.spawn(|| work(f, o)))
                .collect();
            handles
                .into_iter()
                .map(|h| {
                    h.join().unwrap_or_else(|_| {
                        Err(AnalysisError::Singular("a worker thread panicked".into()))
                    })
                })
                .collect()
        });
        for r in results {
            r?;
        }
    }
    Ok(out)
}

/// Non-proportional damping: the undamped modes, the quadratic problem projected on them, then
/// each pole refined on the full problem.
fn refined(sys: &LinearSystem, pat: &Pattern, count: usize) -> Result<LowestModes, AnalysisError> {
    let n = pat.n;
    let fs = sys.rate;
    // a few more modes than asked, so that the poles near the last one are well separated
    let extra = (count + BLOCK).min(n);
    let Undamped {
        lambda,
        phi,
        max_res,
        shift,
        solves,
    } = undamped_lowest(pat, extra)?;
    // modes of free-floating parts that no damper touches are exact as they are (z = 1, double)
    let mass: Vec<f64> = (0..n).map(|i| pat.m[diag_pos(pat, i)]).collect();
    let (rho, _) = pat.gershgorin(&pat.k, &mass);
    let rmax = pat.r.iter().fold(0.0f64, |a, r| a.max(r.abs()));
    let mut rigid = Vec::new();
    let mut keep = Vec::new();
    let mut rphi_j = vec![0.0; n];
    for (j, &l) in lambda.iter().enumerate() {
        pat.mul(&pat.r, phi.col_as_slice(j), &mut rphi_j);
        let size = phi
            .col_as_slice(j)
            .iter()
            .fold(0.0f64, |a, x| a.max(x.abs()));
        let damped = rphi_j.iter().any(|x| x.abs() > 1e-12 * rmax * size);
        if l.abs() <= 1e-11 * rho.max(f64::MIN_POSITIVE) && !damped {
            rigid.push(j);
        } else {
            keep.push(j);
        }
    }
    let c = keep.len();
    // C = Φᵀ R Φ over the other modes
    let phik = Mat::<f64>::from_fn(n, c, |i, j| phi[(i, keep[j])]);
    let mut rphi = Mat::<f64>::zeros(n, c);
    for j in 0..c {
        let (src, dst) = (phik.col_as_slice(j), rphi.col_as_slice_mut(j));
        pat.mul(&pat.r, src, dst);
    }
    let cm = phik.transpose() * &rphi;
    let lambda: Vec<f64> = keep.iter().map(|&j| lambda[j]).collect();
    let (mut big, mut off) = (0.0f64, 0.0f64);
    for i in 0..c {
        for j in 0..c {
            big = big.max(cm[(i, j)].abs());
            if i != j {
                off = off.max(cm[(i, j)].abs());
            }
        }
    }
    let coupling = if big > 0.0 { off / big } else { 0.0 };
    // projected state matrix [[2I - Λ - C, -I + C], [I, 0]]
    let sym = |i: usize, j: usize| 0.5 * (cm[(i, j)] + cm[(j, i)]);
    let a = crate::matrices::state_matrix(
        c,
        |i, j| {
            if i == j {
                lambda[i] + sym(i, j)
            } else {
                sym(i, j)
            }
        },
        sym,
    );
    let eig = a
        .eigen()
        .map_err(|e| AnalysisError::NoConvergence(format!("{e:?}")))?;
    let mu: Vec<c64> = (0..2 * c).map(|k| eig.S()[k]).collect();
    // estimates: one per mode (complex poles with Im > 0; real poles in pairs, the larger)
    let mut starts: Vec<(Start, f64)> = rigid.iter().map(|&j| (Start::Rigid(j), 0.0)).collect();
    let mut reals: Vec<usize> = Vec::new();
    for (k, m) in mu.iter().enumerate() {
        if m.im.abs() <= 1e-14 * m.norm().max(1e-300) {
            reals.push(k);
        } else if m.im > 0.0 {
            starts.push((
                Start::Pole(k, ModeKind::Oscillating),
                m.im.atan2(m.re) * fs / std::f64::consts::TAU,
            ));
        }
    }
    reals.sort_by(|&x, &y| mu[y].re.abs().total_cmp(&mu[x].re.abs()));
    for pair in reals.chunks(2) {
        let k = pair[0];
        starts.push((
            Start::Pole(k, ModeKind::NonOscillating),
            if mu[k].re < 0.0 { fs / 2.0 } else { 0.0 },
        ));
    }
    starts.sort_by(|x, y| x.1.total_cmp(&y.1));
    starts.truncate(count);
    let symbolic = symbolic_lu(pat)?;
    let ldlt = SymLdlt::new(pat)?;
    let scales = Scales::new(pat);
    let mut refiner = Refiner::new(pat, &ldlt, &symbolic);
    let mut max_pole_res = 0.0f64;
    let mut found: Vec<(c64, Vec<c64>)> = Vec::new();
    let mut modes = Vec::with_capacity(count);
    let zero = c64::new(0.0, 0.0);
    for &(start, _) in &starts {
        let (k, kind) = match start {
            Start::Rigid(j) => {
                let mut md = finish(ModeKind::Rigid, 0.0, f64::INFINITY, 1.0, 0.0);
                md.shape = phi.col_as_slice(j).to_vec();
                modes.push(md);
                continue;
            }
            Start::Pole(k, kind) => (k, kind),
        };
        // start vector: x = Φ y_top
        let u = eig.U();
        let mut v: Vec<c64> = (0..n)
            .map(|i| {
                (0..c)
                    .map(|j| u[(j, k)] * phik[(i, j)])
                    .fold(zero, |s, t| s + t)
            })
            .collect();
        if v.iter().any(|x| !(x.re.is_finite() && x.im.is_finite())) {
            return Err(AnalysisError::NoConvergence(
                "the projected damped problem has a non-finite eigenvector".into(),
            ));
        }
        let w = refiner.refine(mu[k] - 1.0, &mut v, &scales);
        let res = scales.residual(pat, w, &v);
        let z = w + 1.0;
        let hz = |z: c64| z.im.abs().atan2(z.re) * fs / std::f64::consts::TAU;
        max_pole_res = max_pole_res.max(res);
        if !(res <= POLE_RESIDUAL) {
            return Err(AnalysisError::NoConvergence(format!(
                "a damped pole near {:.6} Hz did not converge (relative residual {res:.2e})",
                hz(z)
            )));
        }
        for (w2, v2) in &found {
            if (*w2 - w).norm() <= 1e-10 * z.norm() {
                let dot = v
                    .iter()
                    .zip(v2)
                    .map(|(a, b)| a.conj() * *b)
                    .fold(zero, |s, t| s + t)
                    .norm();
                if dot > 1.0 - 1e-6 {
                    return Err(AnalysisError::NoConvergence(format!(
                        "two damped modes converged to the same pole near {:.6} Hz",
                        hz(z)
                    )));
                }
            }
        }
        // ln r = ln |1 + w| without cancellation
        let ln_r = 0.5 * (2.0 * w.re + w.norm_sqr()).ln_1p();
        // within a few ulps of the unit circle the decay is not resolved: undamped
        let (tau_s, r) = if ln_r.abs() <= 4.0 * f64::EPSILON {
            (f64::INFINITY, 1.0)
        } else {
            (-1.0 / (fs * ln_r), ln_r.exp())
        };
        let mut md = match kind {
            ModeKind::Oscillating if z.im.abs() > 0.0 => {
                finish(ModeKind::Oscillating, hz(z), tau_s, r, f64::NAN)
            }
            _ => finish(
                ModeKind::NonOscillating,
                if z.re < 0.0 { fs / 2.0 } else { 0.0 },
                tau_s,
                r,
                f64::NAN,
            ),
        };
        let peak = v.iter().fold(0.0f64, |a, x| a.max(x.norm()));
        md.shape = v
            .iter()
            .map(|x| x.norm() / peak.max(f64::MIN_POSITIVE))
            .collect();
        found.push((w, v));
        modes.push(md);
    }
    sort(&mut modes);
    Ok(LowestModes {
        modes,
        method: SparseMethod::Refined {
            coupling,
            factorisations: refiner.factorisations,
            lu_solves: refiner.solver.fallbacks,
        },
        max_residual: max_res,
        max_pole_residual: max_pole_res,
        shift,
        solves,
    })
}

/// Every pole of a damped network, each refined on the full quadratic problem from its decoupled
/// estimate (see [`all_poles`]).
pub(crate) struct AllPoles {
    /// One entry per pole with `Im z ≥ 0` (complex poles stand for their conjugate pair too): the
    /// pole and its vector `v` (`T(z) v = 0`, unit 2-norm).
    pub poles: Vec<(c64, Vec<c64>)>,
    /// Sparse complex factorisations used.
    pub factorisations: usize,
    /// Of their solves, those redone by the sparse LU.
    pub lu_solves: usize,
    /// Largest relative residual `‖T(z) v‖ / (‖T‖ ‖v‖)`.
    pub max_residual: f64,
}

/// All the poles of `T(z) = M z² + (K + R - 2M) z + (M - R)` by refining, one by one on the sparse
/// problem, the poles of each undamped mode with only its own damping `c_j = φ_jᵀ R φ_j`
/// (`w² + (λ_j + c_jj) w + λ_j = 0` in `w = z - 1`), starting from `φ_j`; modes that the damping
/// couples strongly (`|w_j C_ij|` above 5 % of `|d_i(w_j)|`, `d_i` mode `i`'s own quadratic) are
/// grouped, and each group's poles start from the quadratic problem projected on its modes.
/// `lambda`, `phi` (M-orthonormal columns) are the dense undamped modes, `c = Φᵀ R Φ`; `rigid[j]`
/// marks the modes left out (rigid motions no damper touches).
///
/// `Ok(None)` when the sparse factorisations would cost more than the dense eigensolver (unless
/// `force`), or when
/// the result cannot be certified: every pole must converge (relative residual ≤ 1e-9), keep its
/// kind (complex or real), and be distinct from the others (two starts that reach the same pole
/// leave another unfound; poles closer than 1e-7 must have `T'`-orthogonal vectors), and the poles
/// must sum to the trace of the state matrix. The caller then uses the dense method.
pub(crate) fn all_poles(
    sys: &LinearSystem,
    lambda: &[f64],
    phi: MatRef<'_, f64>,
    c: MatRef<'_, f64>,
    rigid: &[bool],
    force: bool,
) -> Result<Option<AllPoles>, AnalysisError> {
    let pat = Pattern::new(sys)?;
    let n = pat.n;
    let ldlt = SymLdlt::new(&pat)?;
    // estimated seconds: two factorisations per pole (each about 1e-10 s per flop of the
    // estimate plus 5e-7 s per dof of overhead), against the dense eigensolver's 5.5e-10 (2n)³
    // (measured: 35 s for n = 2000); the sparse method must win by 2 (a failed certification
    // costs both)
    let nf = n as f64;
    let sparse = 2.0 * nf * (1e-10 * ldlt.flops() + 5e-7 * nf);
    let dense = 5.5e-10 * (2.0 * nf).powi(3);
    if !force && sparse > 0.5 * dense {
        return Ok(None);
    }
    let starts = match cluster_starts(lambda, phi, c, rigid) {
        Some(s) => s,
        None => return Ok(None),
    };
    let symbolic = symbolic_lu(&pat)?;
    let scales = Scales::new(&pat);
    let threads = std::thread::available_parallelism()
        .map(|t| t.get())
        .unwrap_or(1)
        .min(starts.len().div_ceil(16))
        .max(1);
    let chunk = starts.len().div_ceil(threads).max(1);
    /// (the poles, the factorisations and the solves redone by the LU)
    type Refined = (Vec<(c64, Vec<c64>, f64)>, usize, usize);
    let work = |part: &[PoleStart]| -> Refined {
        // (after the dense eigensolver on this thread, or none on a new one)
        crate::clean_upper();
        let mut refiner = Refiner::new(&pat, &ldlt, &symbolic);
        let out = part
            .iter()
            .map(|st| {
                let mut v: Vec<c64> = match &st.v {
                    StartVector::Mode(j) => phi.col(*j).iter().map(|&x| c64::new(x, 0.0)).collect(),
                    StartVector::Given(v) => v.clone(),
                };
                let w = refiner.refine(st.w, &mut v, &scales);
                let res = scales.residual(&pat, w, &v);
                (w, v, res)
            })
            .collect();
        (out, refiner.factorisations, refiner.solver.fallbacks)
    };
    let parts: Vec<Refined> = if threads == 1 {
        vec![work(&starts)]
    } else {
        std::thread::scope(|s| {
            let handles: Vec<_> = starts
                .chunks(chunk)
                .map(|part| s.spawn(|| work(part)))
                .collect();
            handles
                .into_iter()
                .map(|h| h.join().unwrap_or_else(|_| (Vec::new(), 0, 0)))
                .collect()
        })
    };
    let factorisations = parts.iter().map(|p| p.1).sum();
    let lu_solves = parts.iter().map(|p| p.2).sum();
    let refined: Vec<(c64, Vec<c64>, f64)> = parts.into_iter().flat_map(|p| p.0).collect();
    if refined.len() != starts.len() {
        return Ok(None); // a worker panicked
    }
    let mut max_residual = 0.0f64;
    let mut poles: Vec<(c64, Vec<c64>)> = Vec::with_capacity(refined.len());
    let mut sum = c64::new(0.0, 0.0);
    let mut size = 0.0;
    for ((w, mut v, res), st) in refined.into_iter().zip(&starts) {
        let complex = st.complex;
        max_residual = max_residual.max(res);
        let z = w + 1.0;
        let is_complex = z.im.abs() > 1e-14 * z.norm();
        if !(res <= POLE_RESIDUAL) || is_complex != complex {
            return Ok(None);
        }
        if complex {
            sum += c64::new(2.0 * w.re, 0.0);
            size += 2.0 * w.norm();
        } else {
            sum += c64::new(w.re, 0.0);
            size += w.norm();
        }
        let w = if complex && w.im < 0.0 {
            v.iter_mut().for_each(|x| *x = x.conj());
            w.conj()
        } else if complex {
            w
        } else {
            v.iter_mut().for_each(|x| *x = c64::new(x.re, 0.0));
            c64::new(w.re, 0.0)
        };
        poles.push((w, v));
    }
    // the poles sum to the trace of the state matrix: Σ w = -Σ (K_ii + R_ii) / M_ii (rigid
    // modes add w = 0)
    let trace: f64 = (0..n)
        .map(|i| {
            let p = diag_pos(&pat, i);
            -(pat.k[p] + pat.r[p]) / pat.m[p]
        })
        .sum();
    if (sum.re - trace).abs() > 1e-9 * size.max(trace.abs()) + 1e-300 {
        return Ok(None);
    }
    // distinct: poles closer than 1e-7 need T'-orthogonal vectors
    let mut order: Vec<usize> = (0..poles.len()).collect();
    order.sort_by(|&a, &b| poles[a].0.re.total_cmp(&poles[b].0.re));
    let tprime = |w: c64, v: &[c64]| -> Vec<c64> {
        let (mv, krv, _) = products(&pat, v);
        mv.iter()
            .zip(&krv)
            .map(|(m, kr)| w * 2.0 * *m + *kr)
            .collect()
    };
    for (a, &i) in order.iter().enumerate() {
        for &j in &order[a + 1..] {
            let (wi, wj) = (poles[i].0, poles[j].0);
            let tol = 1e-7 * (wi + 1.0).norm().max((wj + 1.0).norm());
            if wj.re - wi.re > tol {
                break;
            }
            if (wi - wj).norm() > tol {
                continue;
            }
            let (vi, vj) = (&poles[i].1, &poles[j].1);
            let ti = tprime(wi, vi);
            let cross = dot(vj, &ti).norm();
            let own = dot(vi, &ti).norm() * dot(vj, &tprime(wj, vj)).norm();
            if cross > 1e-6 * own.sqrt() {
                return Ok(None);
            }
        }
    }
    Ok(Some(AllPoles {
        poles,
        factorisations,
        lu_solves,
        max_residual,
    }))
}

/// Where the refinement of one pole starts.
struct PoleStart {
    /// The estimate of `w = z - 1`.
    w: c64,
    v: StartVector,
    /// Whether the pole is complex (it stands for its conjugate too) or real.
    complex: bool,
}

enum StartVector {
    /// An undamped mode's shape.
    Mode(usize),
    /// A vector from a group's projected problem.
    Given(Vec<c64>),
}

/// The starts of [`all_poles`]: one per complex pole with `Im z > 0`, one per real pole. `None`
/// when a group's projected problem fails.
fn cluster_starts(
    lambda: &[f64],
    phi: MatRef<'_, f64>,
    c: MatRef<'_, f64>,
    rigid: &[bool],
) -> Option<Vec<PoleStart>> {
    let n = lambda.len();
    let modes: Vec<usize> = (0..n).filter(|&j| !rigid[j]).collect();
    // each mode's own poles: w² + (λ + c) w + λ = 0
    let own = |j: usize| -> (c64, c64) {
        let (l, cj) = (lambda[j], c[(j, j)]);
        let b = l + cj;
        let disc = b * b - 4.0 * l;
        if disc < 0.0 {
            let w = c64::new(-0.5 * b, 0.5 * (-disc).sqrt());
            (w, w.conj())
        } else {
            // the larger root in magnitude without cancellation, the other from the product
            let q = -0.5 * (b + b.signum() * disc.sqrt());
            let (w1, w2) = if q != 0.0 { (q, l / q) } else { (0.0, 0.0) };
            (c64::new(w1, 0.0), c64::new(w2, 0.0))
        }
    };
    let d = |i: usize, w: c64| w * w + w * (lambda[i] + c[(i, i)]) + lambda[i];
    // groups: union-find over strongly coupled pairs
    let mut parent: Vec<usize> = (0..n).collect();
    fn find(p: &mut [usize], mut i: usize) -> usize {
        while p[i] != i {
            p[i] = p[p[i]];
            i = p[i];
        }
        i
    }
    let firsts: Vec<c64> = (0..n).map(|j| own(j).0).collect();
    for (a, &i) in modes.iter().enumerate() {
        for &j in &modes[a + 1..] {
            let cij = c[(i, j)].abs();
            if cij == 0.0 {
                continue;
            }
            let strong = |p: usize, q: usize| {
                let w = firsts[p];
                w.norm() * cij > 0.05 * d(q, w).norm()
            };
            if strong(i, j) || strong(j, i) {
                let (ri, rj) = (find(&mut parent, i), find(&mut parent, j));
                if ri != rj {
                    parent[ri] = rj;
                }
            }
        }
    }
    let mut groups: std::collections::BTreeMap<usize, Vec<usize>> = Default::default();
    for &j in &modes {
        let r = find(&mut parent, j);
        groups.entry(r).or_default().push(j);
    }
    let mut starts = Vec::with_capacity(n);
    for group in groups.values() {
        if let [j] = group[..] {
            let (w1, w2) = own(j);
            if w1.im != 0.0 {
                starts.push(PoleStart {
                    w: w1,
                    v: StartVector::Mode(j),
                    complex: true,
                });
            } else {
                for w in [w1, w2] {
                    starts.push(PoleStart {
                        w,
                        v: StartVector::Mode(j),
                        complex: false,
                    });
                }
            }
            continue;
        }
        // the quadratic problem projected on the group's modes: [[2I - Λ - C, -I + C], [I, 0]]
        let k = group.len();
        let sym = |a: usize, b: usize| 0.5 * (c[(group[a], group[b])] + c[(group[b], group[a])]);
        let a = crate::matrices::state_matrix(
            k,
            |a, b| {
                if a == b {
                    lambda[group[a]] + sym(a, b)
                } else {
                    sym(a, b)
                }
            },
            sym,
        );
        let eig = a.eigen().ok()?;
        let u = eig.U();
        for q in 0..2 * k {
            let mu = eig.S()[q];
            let complex = mu.im.abs() > 1e-14 * mu.norm();
            if complex && mu.im < 0.0 {
                continue;
            }
            let v: Vec<c64> = (0..phi.nrows())
                .map(|i| {
                    (0..k).fold(c64::new(0.0, 0.0), |s, b| {
                        s + u[(b, q)] * phi[(i, group[b])]
                    })
                })
                .collect();
            if v.iter().any(|x| !(x.re.is_finite() && x.im.is_finite())) {
                return None;
            }
            starts.push(PoleStart {
                w: mu - 1.0,
                v: StartVector::Given(v),
                complex,
            });
        }
    }
    Some(starts)
}

/// Largest relative residual `‖T(z) v‖ / ((|w|² ‖M‖ + |w| ‖K + R‖ + ‖K‖) ‖v‖)` accepted for a
/// refined pole.
const POLE_RESIDUAL: f64 = 1e-9;

/// A relative residual at the rounding level: the refinement stops there.
const CONVERGED: f64 = 1e-14;

/// Norms of `M`, `K + R` and `K` (largest absolute column sums) that scale the residual of
/// `T(1 + w) = M w² + (K + R) w + K`.
struct Scales {
    nm: f64,
    nkr: f64,
    nk: f64,
}

impl Scales {
    fn new(pat: &Pattern) -> Scales {
        let cp = pat.col_ptr();
        let abs_sum = |f: &dyn Fn(usize) -> f64| -> f64 {
            (0..pat.n)
                .map(|col| (cp[col]..cp[col + 1]).map(|p| f(p).abs()).sum::<f64>())
                .fold(0.0, f64::max)
        };
        Scales {
            nm: abs_sum(&|p| pat.m[p]),
            nkr: abs_sum(&|p| pat.k[p] + pat.r[p]),
            nk: abs_sum(&|p| pat.k[p]),
        }
    }

    /// The relative residual of the pole `1 + w` with vector `v`.
    fn residual(&self, pat: &Pattern, w: c64, v: &[c64]) -> f64 {
        let (a, b, c) = products(pat, v);
        self.relative(w, &a, &b, &c, v)
    }

    /// The relative residual from the products `(M v, (K + R) v, K v)`.
    fn relative(&self, w: c64, mv: &[c64], krv: &[c64], kv: &[c64], v: &[c64]) -> f64 {
        let tv = mv
            .iter()
            .zip(krv)
            .zip(kv)
            .map(|((a, b), c)| (w * w * *a + w * *b + *c).norm_sqr())
            .sum::<f64>()
            .sqrt();
        let nv = v.iter().map(|x| x.norm_sqr()).sum::<f64>().sqrt();
        tv / ((w.norm_sqr() * self.nm + w.norm() * self.nkr + self.nk) * nv)
    }
}

/// Rayleigh-functional iteration on `T(1 + w) = M w² + (K + R) w + K`, in `w = z - 1` so that
/// nothing cancels for poles near 1.
struct Refiner<'a> {
    pat: &'a Pattern,
    solver: DynamicSolver<'a>,
    vals: Vec<c64>,
    tmp: Vec<c64>,
    /// Sparse complex factorisations so far.
    factorisations: usize,
}

impl<'a> Refiner<'a> {
    fn new(pat: &'a Pattern, ldlt: &'a SymLdlt, symbolic: &'a SymbolicLu<usize>) -> Self {
        Refiner {
            pat,
            solver: DynamicSolver::new(pat, ldlt, symbolic),
            vals: vec![c64::new(0.0, 0.0); pat.k.len()],
            tmp: vec![c64::new(0.0, 0.0); pat.n],
            factorisations: 0,
        }
    }

    /// Refines the estimate `w` (pole `1 + w`) and its vector `v` (normalised in place); returns
    /// the refined `w`. Stops when the residual reaches the rounding level (checked at each
    /// Rayleigh-functional update, at the cost of a product), or when a step no longer shrinks.
    fn refine(&mut self, mut w: c64, v: &mut [c64], scales: &Scales) -> c64 {
        let pat = self.pat;
        let mut last_step = f64::INFINITY;
        for it in 0..30 {
            // Rayleigh functional: the root of vᵀ T(w) v = 0 nearest w (transposes, no conjugates:
            // T is complex symmetric, so v is its left eigenvector too)
            let (mv, krv, kv) = products(pat, v);
            let wnew = nearest_root(dot(v, &mv), dot(v, &krv), dot(v, &kv), w);
            let step = (wnew - w).norm();
            w = wnew;
            // after at least one inverse iteration: done when the residual is at rounding level
            if it >= 1 && scales.relative(w, &mv, &krv, &kv, v) <= CONVERGED {
                break;
            }
            if it >= 2 && (step <= 4.0 * f64::EPSILON * w.norm() || step >= last_step) {
                break;
            }
            if it >= 1 {
                last_step = step;
            }
            // inverse iteration: v ← A⁻¹ T'(w) v, T'(w) = 2 w M + K + R (A = T / (1 + w))
            for (t, (m, kr)) in self.tmp.iter_mut().zip(mv.iter().zip(&krv)) {
                *t = w * 2.0 * *m + *kr;
            }
            self.factorisations += 1;
            pat.dynamic(w, &mut self.vals);
            let Some(x) = self.solver.solve(&self.vals, &self.tmp) else {
                break; // exactly singular: w is the pole
            };
            self.tmp.copy_from_slice(x);
            let nv = self.tmp.iter().map(|x| x.norm_sqr()).sum::<f64>().sqrt();
            if !(nv > 0.0 && nv.is_finite()) {
                break;
            }
            for (vi, ti) in v.iter_mut().zip(&self.tmp) {
                *vi = *ti / nv;
            }
        }
        w
    }
}

#[derive(Clone, Copy)]
enum Start {
    /// An undamped rigid mode (its index among the undamped modes).
    Rigid(usize),
    /// A pole of the projected problem (its index) and its kind.
    Pole(usize, ModeKind),
}

/// `(M v, (K + R) v, K v)`.
fn products(pat: &Pattern, v: &[c64]) -> (Vec<c64>, Vec<c64>, Vec<c64>) {
    let n = v.len();
    let zero = c64::new(0.0, 0.0);
    let (mut a, mut b, mut c) = (vec![zero; n], vec![zero; n], vec![zero; n]);
    let (cp, ri) = (pat.col_ptr(), pat.row_idx());
    for col in 0..n {
        let x = v[col];
        for p in cp[col]..cp[col + 1] {
            let (m, k, r) = (pat.m[p], pat.k[p], pat.r[p]);
            let i = ri[p];
            a[i] += x * m;
            b[i] += x * (k + r);
            c[i] += x * k;
        }
    }
    (a, b, c)
}

/// `xᵀ y` (no conjugate).
fn dot(x: &[c64], y: &[c64]) -> c64 {
    x.iter()
        .zip(y)
        .fold(c64::new(0.0, 0.0), |s, (a, b)| s + *a * *b)
}

/// The root of `a z² + b z + c = 0` nearest `near`.
fn nearest_root(a: c64, b: c64, c: c64, near: c64) -> c64 {
    if a.norm() == 0.0 {
        return if b.norm() == 0.0 { near } else { -c / b };
    }
    let d = (b * b - a * c * 4.0).sqrt();
    // the root of larger magnitude without cancellation, the other from the product c / a
    let q = if (b.conj() * d).re >= 0.0 {
        (b + d) * -0.5
    } else {
        (b - d) * -0.5
    };
    let z1 = q / a;
    let z2 = if q.norm() > 0.0 { c / q } else { z1 };
    if (z1 - near).norm() <= (z2 - near).norm() {
        z1
    } else {
        z2
    }
}

/// The symbolic part of a supernodal `L D Lᵀ` factorisation of complex symmetric matrices on the
/// pattern (fill-reducing AMD ordering and supernodes from faer's symbolic Cholesky).
struct SymLdlt {
    n: usize,
    /// `perm[new] = old`.
    perm: Vec<usize>,
    begin: Vec<usize>,
    /// Row pattern (below the diagonal block) of each supernode: `rows[rp[s]..rp[s + 1]]`.
    rp: Vec<usize>,
    rows: Vec<usize>,
    /// Value offsets: supernode `s` is a column-major `(ncols + pattern) × ncols` block at
    /// `vp[s]`.
    vp: Vec<usize>,
    /// The supernodes whose pattern reaches each supernode's columns (left-looking updates).
    updaters: Vec<Vec<usize>>,
    /// For each permuted column `j`, the lower entries `(permuted row, index into the pattern's
    /// values)`.
    acol: Vec<usize>,
    aent: Vec<(usize, usize)>,
}

impl SymLdlt {
    /// An estimate of the flops of one numeric factorisation: `Σ width · height²` over the
    /// supernodes.
    fn flops(&self) -> f64 {
        (0..self.begin.len() - 1)
            .map(|s| {
                let w = (self.begin[s + 1] - self.begin[s]) as f64;
                let h = w + (self.rp[s + 1] - self.rp[s]) as f64;
                w * h * h
            })
            .sum()
    }

    fn new(pat: &Pattern) -> Result<SymLdlt, AnalysisError> {
        use faer::sparse::linalg::cholesky::{
            factorize_symbolic_cholesky, CholeskySymbolicParams, SymbolicCholeskyRaw,
            SymmetricOrdering,
        };
        use faer::sparse::linalg::SupernodalThreshold;
        let n = pat.n;
        let sym = factorize_symbolic_cholesky(
            pat.symbolic.as_ref(),
            Side::Lower,
            SymmetricOrdering::Amd,
            CholeskySymbolicParams {
                supernodal_flop_ratio_threshold: SupernodalThreshold::FORCE_SUPERNODAL,
                ..Default::default()
            },
        )
        .map_err(|e| AnalysisError::Singular(format!("sparse analysis failed: {e:?}")))?;
        let perm: Vec<usize> = match sym.perm() {
            Some(p) => p.arrays().0.to_vec(),
            None => (0..n).collect(),
        };
        let SymbolicCholeskyRaw::Supernodal(s) = sym.raw() else {
            return Err(AnalysisError::Singular(
                "sparse analysis: no supernodal structure".into(),
            ));
        };
        let ns = s.n_supernodes();
        let mut begin = s.supernode_begin().to_vec();
        begin.push(n);
        let rp = s.col_ptr_for_row_idx()[..=ns].to_vec();
        let rows = s.row_idx()[..rp[ns]].to_vec();
        let vp = s.col_ptr_for_val()[..=ns].to_vec();
        let mut col_super = vec![0usize; n];
        for k in 0..ns {
            col_super[begin[k]..begin[k + 1]]
                .iter_mut()
                .for_each(|c| *c = k);
        }
        let mut updaters: Vec<Vec<usize>> = vec![Vec::new(); ns];
        for d in 0..ns {
            let mut last = usize::MAX;
            for &r in &rows[rp[d]..rp[d + 1]] {
                let t = col_super[r];
                if t != last {
                    updaters[t].push(d);
                    last = t;
                }
            }
        }
        let mut inv = vec![0usize; n];
        for (new, &old) in perm.iter().enumerate() {
            inv[old] = new;
        }
        let (cp, ri) = (pat.col_ptr(), pat.row_idx());
        let mut ent: Vec<(usize, usize, usize)> = Vec::new();
        for c in 0..n {
            for p in cp[c]..cp[c + 1] {
                let (i, j) = (inv[ri[p]], inv[c]);
                if i >= j {
                    ent.push((j, i, p));
                }
            }
        }
        ent.sort_unstable();
        let mut acol = vec![0usize; n + 1];
        for &(j, _, _) in &ent {
            acol[j + 1] += 1;
        }
        for j in 0..n {
            acol[j + 1] += acol[j];
        }
        let aent = ent.iter().map(|&(_, i, p)| (i, p)).collect();
        Ok(SymLdlt {
            n,
            perm,
            begin,
            rp,
            rows,
            vp,
            updaters,
            acol,
            aent,
        })
    }
}

/// How many columns of a supernode [`NumLdlt::factor`] eliminates one by one before it updates
/// the rest by a product.
const PANEL: usize = 16;

/// `work (bot × mid) = lb (lb[..mid] D)ᵀ` for a panel `lb` of `bot` rows and `nb` columns, its
/// pivots `d` (`nb`): the update `L D Lᵀ` a panel makes on the `mid` columns its first rows
/// stand for. `scaled` and `work` must hold `mid × nb` and `bot × mid` numbers.
fn outer(lb: MatRef<'_, c64>, d: &[c64], mid: usize, scaled: &mut [c64], work: &mut [c64]) {
    let (bot, nb) = (lb.nrows(), lb.ncols());
    debug_assert!(d.len() == nb && mid <= bot);
    // scaled = (lb[..mid] D) as (mid × nb), column-major
    for (k, &dk) in d.iter().enumerate() {
        for t in 0..mid {
            scaled[k * mid + t] = lb[(t, k)] * dk;
        }
    }
    let sc = faer::MatRef::from_column_major_slice(&scaled[..mid * nb], mid, nb);
    let wk = faer::MatMut::from_column_major_slice_mut(&mut work[..bot * mid], bot, mid);
    faer::linalg::matmul::matmul(
        wk,
        Accum::Replace,
        lb,
        sc.transpose(),
        c64::new(1.0, 0.0),
        Par::Seq,
    );
    crate::clean_upper();
}

/// The numeric part: `P A Pᵀ = L D Lᵀ`, no pivoting, with its work space.
struct NumLdlt<'a> {
    sym: &'a SymLdlt,
    l: Vec<c64>,
    d: Vec<c64>,
    local: Vec<usize>,
    work: Vec<c64>,
    scaled: Vec<c64>,
}

impl<'a> NumLdlt<'a> {
    fn new(sym: &'a SymLdlt) -> NumLdlt<'a> {
        let zero = c64::new(0.0, 0.0);
        let ns = sym.begin.len() - 1;
        let (mut wmax, mut hmax) = (0usize, 0usize);
        for s in 0..ns {
            wmax = wmax.max(sym.begin[s + 1] - sym.begin[s]);
            hmax = hmax.max(sym.rp[s + 1] - sym.rp[s] + sym.begin[s + 1] - sym.begin[s]);
        }
        NumLdlt {
            sym,
            l: vec![zero; sym.vp[ns]],
            d: vec![zero; sym.n],
            local: vec![0; sym.n],
            work: vec![zero; hmax * hmax.max(1)],
            scaled: vec![zero; hmax * wmax.max(1)],
        }
    }

    /// Factorises the matrix with values `vals` on the pattern. False on a zero pivot.
    fn factor(&mut self, vals: &[c64]) -> bool {
        let sym = self.sym;
        let zero = c64::new(0.0, 0.0);
        self.l.iter_mut().for_each(|x| *x = zero);
        let ns = sym.begin.len() - 1;
        for s in 0..ns {
            let (s0, s1) = (sym.begin[s], sym.begin[s + 1]);
            let w = s1 - s0;
            let pattern = &sym.rows[sym.rp[s]..sym.rp[s + 1]];
            let h = w + pattern.len();
            for (i, &r) in pattern.iter().enumerate() {
                self.local[r] = w + i;
            }
            let (head, tail) = self.l.split_at_mut(sym.vp[s]);
            let ls = &mut tail[..h * w];
            // A's lower entries
            for j in s0..s1 {
                for &(i, p) in &sym.aent[sym.acol[j]..sym.acol[j + 1]] {
                    let li = if i < s1 { i - s0 } else { self.local[i] };
                    ls[(j - s0) * h + li] += vals[p];
                }
            }
            // updates from the supernodes below
            for &d in &sym.updaters[s] {
                let (d0, d1) = (sym.begin[d], sym.begin[d + 1]);
                let dw = d1 - d0;
                let dpat = &sym.rows[sym.rp[d]..sym.rp[d + 1]];
                let dh = dw + dpat.len();
                let ld = &head[sym.vp[d]..sym.vp[d] + dh * dw];
                let start = dpat.partition_point(|&r| r < s0);
                let mid = dpat[start..].partition_point(|&r| r < s1);
                let bot = dpat.len() - start;
                let lbot = faer::MatRef::from_column_major_slice_with_stride(
                    &ld[dw + start..],
                    bot,
                    dw,
                    dh,
                );
                let ddw = &self.d[d0..d1];
                outer(lbot, ddw, mid, &mut self.scaled, &mut self.work);
                for t in 0..mid {
                    let col = dpat[start + t] - s0;
                    let dst = &mut ls[col * h..(col + 1) * h];
                    let src = &self.work[t * bot..(t + 1) * bot];
                    for (q, &x) in src.iter().enumerate().skip(t) {
                        let g = dpat[start + q];
                        let li = if g < s1 { g - s0 } else { self.local[g] };
                        dst[li] -= x;
                    }
                }
            }
            // dense L D Lᵀ of the diagonal block, and the rows below, by blocks of `PANEL`
            // columns: each column within its block by rank-1 updates, the columns after the
            // block by one product
            for k0 in (0..w).step_by(PANEL) {
                let k1 = (k0 + PANEL).min(w);
                for k in k0..k1 {
                    let dk = ls[k * h + k];
                    // (a zero pivot: `dk.norm() > 0.0` fails, without its `hypot`)
                    if (dk.re == 0.0 && dk.im == 0.0) || !dk.re.is_finite() || !dk.im.is_finite() {
                        return false;
                    }
                    self.d[s0 + k] = dk;
                    let inv = c64::new(1.0, 0.0) / dk;
                    ls[k * h + k] = c64::new(1.0, 0.0);
                    for x in &mut ls[k * h + k + 1..(k + 1) * h] {
                        *x *= inv;
                    }
                    // update of the block's columns k+1..k1, rows j..h
                    let (left, right) = ls.split_at_mut((k + 1) * h);
                    let lk = &left[k * h..];
                    for j in k + 1..k1 {
                        let f = lk[j] * dk;
                        let col = &mut right[(j - k - 1) * h..(j - k) * h];
                        for i in j..h {
                            col[i] -= lk[i] * f;
                        }
                    }
                }
                if k1 == w {
                    break;
                }
                // update of columns k1..w, rows j..h, by the block's columns
                let (left, right) = ls.split_at_mut(k1 * h);
                let lb = faer::MatRef::from_column_major_slice_with_stride(
                    &left[k0 * h + k1..],
                    h - k1,
                    k1 - k0,
                    h,
                );
                let (m, bot) = (w - k1, h - k1);
                outer(
                    lb,
                    &self.d[s0 + k0..s0 + k1],
                    m,
                    &mut self.scaled,
                    &mut self.work,
                );
                for t in 0..m {
                    let col = &mut right[t * h + k1..(t + 1) * h];
                    let src = &self.work[t * bot..(t + 1) * bot];
                    for (x, &u) in col.iter_mut().zip(src).skip(t) {
                        *x -= u;
                    }
                }
            }
        }
        true
    }

    /// Solves `A x = b` in place (`b` in the original order).
    fn solve(&self, b: &mut [c64], y: &mut [c64]) {
        let sym = self.sym;
        for (yi, &p) in y.iter_mut().zip(&sym.perm) {
            *yi = b[p];
        }
        let ns = sym.begin.len() - 1;
        for s in 0..ns {
            let (s0, s1) = (sym.begin[s], sym.begin[s + 1]);
            let w = s1 - s0;
            let pattern = &sym.rows[sym.rp[s]..sym.rp[s + 1]];
            let h = w + pattern.len();
            let ls = &self.l[sym.vp[s]..sym.vp[s] + h * w];
            for k in 0..w {
                let xk = y[s0 + k];
                let col = &ls[k * h..(k + 1) * h];
                for i in k + 1..w {
                    y[s0 + i] -= col[i] * xk;
                }
                for (q, &r) in pattern.iter().enumerate() {
                    y[r] -= col[w + q] * xk;
                }
            }
        }
        for (yi, di) in y.iter_mut().zip(&self.d) {
            *yi /= *di;
        }
        for s in (0..ns).rev() {
            let (s0, s1) = (sym.begin[s], sym.begin[s + 1]);
            let w = s1 - s0;
            let pattern = &sym.rows[sym.rp[s]..sym.rp[s + 1]];
            let h = w + pattern.len();
            let ls = &self.l[sym.vp[s]..sym.vp[s] + h * w];
            for k in (0..w).rev() {
                let col = &ls[k * h..(k + 1) * h];
                let mut acc = y[s0 + k];
                for (q, &r) in pattern.iter().enumerate() {
                    acc -= col[w + q] * y[r];
                }
                for i in k + 1..w {
                    acc -= col[i] * y[s0 + i];
                }
                y[s0 + k] = acc;
            }
        }
        for (yi, &p) in y.iter().zip(&sym.perm) {
            b[p] = *yi;
        }
    }
}

/// Solves `A x = e_a` for dynamic stiffnesses on one pattern: `L D Lᵀ` without pivoting, one step
/// of iterative refinement and up to two more until the backward error passes its check; the LU
/// with partial pivoting when it never does (a tiny pivot). The two more steps took the membrane
/// of the analysis bench's `refined` case from 60 LU solves (each about 13 ms) to 26 of its 4,005
/// (the bench prints them: docs/BENCHMARKS.md, "Analysis").
struct DynamicSolver<'a> {
    pat: &'a Pattern,
    num: NumLdlt<'a>,
    symbolic: &'a SymbolicLu<usize>,
    lu: Option<ComplexLu<'a>>,
    x: Vec<c64>,
    y: Vec<c64>,
    r: Vec<c64>,
    /// Solves that needed the LU.
    fallbacks: usize,
}

impl<'a> DynamicSolver<'a> {
    fn new(pat: &'a Pattern, ldlt: &'a SymLdlt, symbolic: &'a SymbolicLu<usize>) -> Self {
        let zero = c64::new(0.0, 0.0);
        DynamicSolver {
            pat,
            num: NumLdlt::new(ldlt),
            symbolic,
            lu: None,
            x: vec![zero; pat.n],
            y: vec![zero; pat.n],
            r: vec![zero; pat.n],
            fallbacks: 0,
        }
    }

    /// `A⁻¹ b` for the values `vals` on the pattern; `None` when `A` is singular.
    fn solve(&mut self, vals: &[c64], b: &[c64]) -> Option<&[c64]> {
        let pat = self.pat;
        let mut ok = self.num.factor(vals);
        if ok {
            self.x.copy_from_slice(b);
            self.num.solve(&mut self.x, &mut self.y);
            // iterative refinement: one step, and up to two more where the backward error is
            // still above 1e-13 (each far cheaper than the LU)
            for _ in 0..3 {
                residual(pat, vals, b, &self.x, &mut self.r);
                self.num.solve(&mut self.r, &mut self.y);
                for (xi, ri) in self.x.iter_mut().zip(&self.r) {
                    *xi += *ri;
                }
                ok = backward_error(pat, vals, b, &self.x, &mut self.r) <= 1e-13;
                if ok {
                    break;
                }
            }
        }
        if !ok {
            self.fallbacks += 1;
            if self.lu.is_none() {
                self.lu = ComplexLu::new(pat, self.symbolic).ok();
            }
            let lu = self.lu.as_mut()?;
            self.x.copy_from_slice(b);
            if !lu.solve_values(vals, &mut self.x) {
                return None;
            }
        }
        Some(&self.x)
    }
}

/// `|z|` as `sqrt(re² + im²)`: within an ulp or two of `z.norm()`, libm's `hypot`, which took a
/// seventh of the refined method's time (docs/BENCHMARKS.md, "Analysis"); `hypot` itself where
/// the squares overflow or fall below the normal numbers (zero, NaN and infinities included).
fn modulus(z: c64) -> f64 {
    let s = z.re * z.re + z.im * z.im;
    if s.is_finite() && s >= f64::MIN_POSITIVE {
        s.sqrt()
    } else {
        z.norm()
    }
}

/// `r = b - A x` for the values `vals` on the pattern.
fn residual(pat: &Pattern, vals: &[c64], b: &[c64], x: &[c64], r: &mut [c64]) {
    let (cp, ri) = (pat.col_ptr(), pat.row_idx());
    r.copy_from_slice(b);
    for c in 0..pat.n {
        let xc = x[c];
        for p in cp[c]..cp[c + 1] {
            r[ri[p]] -= vals[p] * xc;
        }
    }
}

/// The normwise backward error of `x` as a solution of `A x = b`: `‖b - A x‖∞ / (‖A‖∞ ‖x‖∞ +
/// ‖b‖∞)`.
fn backward_error(pat: &Pattern, vals: &[c64], b: &[c64], x: &[c64], r: &mut [c64]) -> f64 {
    residual(pat, vals, b, x, r);
    let cp = pat.col_ptr();
    // A is symmetric: its largest absolute column sum is its largest row sum
    let anorm = (0..pat.n)
        .map(|c| (cp[c]..cp[c + 1]).map(|p| modulus(vals[p])).sum::<f64>())
        .fold(0.0, f64::max);
    let inf = |v: &[c64]| v.iter().fold(0.0f64, |m, v| m.max(modulus(*v)));
    let e = inf(r) / (anorm * inf(x) + inf(b));
    if e.is_finite() {
        e
    } else {
        f64::INFINITY
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn two_masses() -> LinearSystem {
        load("sol g\nmas a M=1\nmas b M=1\nref ga g a K=1\nref gb g b K=1\nref ab a b K=1\n")
    }

    fn load(text: &str) -> LinearSystem {
        let model = match cordis_model::load_str(
            "t.cordis".as_ref(),
            text,
            &cordis_model::Options::default(),
        ) {
            Ok(m) => m,
            Err(e) => panic!("{e}"),
        };
        match LinearSystem::from_model(&model) {
            Ok(s) => s,
            Err(e) => panic!("{e}"),
        }
    }

    #[test]
    fn supernodes_wider_than_a_panel_solve_as_the_lu_does() {
        // a membrane with dampers to the ground: its top separators make supernodes of more
        // than `PANEL` columns, which `NumLdlt::factor` updates by products
        let sys = load(
            "membrane mem rows=24 cols=24 M=1 K=0.1 Z=1e-4 border=fixed\n\
             sol g\nfro d1 g mem[3,5] Z=5e-3\nfro d2 g mem[12,12] Z=2e-3\n",
        );
        let pat = Pattern::new(&sys).expect("pattern");
        let ldlt = SymLdlt::new(&pat).expect("ldlt");
        let widest = (0..ldlt.begin.len() - 1)
            .map(|s| ldlt.begin[s + 1] - ldlt.begin[s])
            .max()
            .unwrap_or(0);
        assert!(widest > 2 * PANEL, "widest supernode {widest}");
        let lu = symbolic_lu(&pat).expect("lu");
        let mut solver = DynamicSolver::new(&pat, &ldlt, &lu);
        let mut exact = ComplexLu::new(&pat, &lu).expect("lu");
        let mut rng = Lcg(7);
        let mut vals = vec![c64::new(0.0, 0.0); pat.k.len()];
        // near a pole and far from one
        for w in [c64::new(-2e-3, 0.05), c64::new(-0.5, 0.8)] {
            pat.dynamic(w, &mut vals);
            let b: Vec<c64> = (0..pat.n)
                .map(|_| c64::new(rng.next(), rng.next()))
                .collect();
            let x = solver.solve(&vals, &b).expect("regular").to_vec();
            let mut y = b.clone();
            assert!(exact.solve_values(&vals, &mut y));
            let peak = y.iter().fold(0.0f64, |m, v| m.max(v.norm()));
            let far = x
                .iter()
                .zip(&y)
                .fold(0.0f64, |m, (a, b)| m.max((*a - *b).norm()));
            assert!(far <= 1e-10 * peak, "w {w}: {far:e} of {peak:e}");
            let mut r = vec![c64::new(0.0, 0.0); pat.n];
            assert!(backward_error(&pat, &vals, &b, &x, &mut r) <= 1e-13);
        }
        assert_eq!(solver.fallbacks, 0);
    }

    #[test]
    fn modulus_is_hypot_to_an_ulp_or_two() {
        let cases = [
            c64::new(3.0, 4.0),
            c64::new(-1e-3, 2.5e-7),
            c64::new(1e200, 1e200),
            c64::new(1e-170, -3e-171),
            c64::new(0.0, -0.0),
            c64::new(f64::INFINITY, 1.0),
        ];
        for z in cases {
            let (m, h) = (modulus(z), z.norm());
            assert!(
                m == h || ((m - h) / h).abs() <= 4.0 * f64::EPSILON,
                "{z}: {m:e} against {h:e}"
            );
        }
        assert!(modulus(c64::new(f64::NAN, 1.0)).is_nan());
    }

    #[test]
    fn clean_upper_keeps_every_value() {
        // a product large enough for faer's `gemm` kernels first, then values held across
        let m = Mat::<f64>::from_fn(64, 64, |i, j| (i + 2 * j) as f64 * 0.25);
        let p = &m * &m;
        let held: Vec<f64> = (0..64).map(|i| p[(i, 3)]).collect();
        let sum: f64 = held.iter().sum();
        crate::clean_upper();
        assert_eq!(sum.to_bits(), held.iter().sum::<f64>().to_bits());
        let direct: f64 = (0..64)
            .map(|k| (5 + 2 * k) as f64 * 0.25 * (k + 6) as f64 * 0.25)
            .sum();
        assert_eq!(p[(5, 3)], direct);
    }

    #[test]
    fn a_zero_pivot_falls_back_to_the_lu() {
        let sys = two_masses();
        let pat = Pattern::new(&sys).expect("pattern");
        let ldlt = SymLdlt::new(&pat).expect("ldlt");
        let lu = symbolic_lu(&pat).expect("lu");
        // [[0, -1], [-1, 0]]: regular, with zero diagonal
        let c = |x: f64| c64::new(x, 0.0);
        let vals = vec![c(0.0), c(-1.0), c(-1.0), c(0.0)];
        let mut solver = DynamicSolver::new(&pat, &ldlt, &lu);
        let e =
            |i: usize| -> Vec<c64> { (0..2).map(|j| c(if i == j { 1.0 } else { 0.0 })).collect() };
        let x = solver.solve(&vals, &e(0)).expect("regular").to_vec();
        assert_eq!(solver.fallbacks, 1);
        assert!(
            (x[0] - c(0.0)).norm() < 1e-15 && (x[1] - c(-1.0)).norm() < 1e-15,
            "{x:?}"
        );
        // and a regular diagonal needs no fallback
        let vals = vec![c(3.0), c(-1.0), c(-1.0), c(2.0)];
        let x = solver.solve(&vals, &e(1)).expect("regular").to_vec();
        assert_eq!(solver.fallbacks, 1);
        assert!(
            (x[0] - c(0.2)).norm() < 1e-15 && (x[1] - c(0.6)).norm() < 1e-15,
            "{x:?}"
        );
        // singular: refused
        let vals = vec![c(1.0), c(1.0), c(1.0), c(1.0)];
        assert!(solver.solve(&vals, &e(0)).is_none());
    }
}
