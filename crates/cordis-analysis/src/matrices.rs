//! The linear system as dense matrices: `M`, `K`, `R`, the finite-difference form and the state
//! space, as FORMALISM.md writes them.

use faer::Mat;

use crate::LinearSystem;

/// Every matrix of a linear system (GENESIS units), rows and columns in the order of
/// `LinearSystem::names`.
#[derive(Clone, Debug)]
pub struct Matrices {
    /// Inertia (diagonal).
    pub m: Mat<f64>,
    /// Stiffness.
    pub k: Mat<f64>,
    /// Damping.
    pub r: Mat<f64>,
    /// `A1 x(n+1) + A0 x(n) + Am1 x(n-1) = F(n) + b`: `A1 = M`.
    pub a1: Mat<f64>,
    /// `A0 = K + R - 2M`.
    pub a0: Mat<f64>,
    /// `Am1 = M - R`.
    pub am1: Mat<f64>,
    /// State matrix over `s(n) = [x(n); x(n-1)]`: `[[2I - M⁻¹(K+R), -I + M⁻¹R], [I, 0]]`.
    pub ad: Mat<f64>,
    /// Input matrix (a force on every mobile module): `[M⁻¹; 0]`.
    pub bd: Mat<f64>,
    /// Output matrix: the sox channels (`LinearSystem::outputs`) read positions `x(n)`.
    pub cd: Mat<f64>,
    /// Feedthrough: zero.
    pub dd: Mat<f64>,
}

impl LinearSystem {
    /// The dense matrices (size `n²` and `4n²`: meant for small and medium models).
    pub fn matrices(&self) -> Matrices {
        let n = self.len();
        let m = Mat::<f64>::from_fn(n, n, |i, j| if i == j { self.mass[i] } else { 0.0 });
        let (k, r) = (self.k.dense(), self.r.dense());
        let a0 = Mat::<f64>::from_fn(n, n, |i, j| k[(i, j)] + r[(i, j)] - 2.0 * m[(i, j)]);
        let am1 = Mat::<f64>::from_fn(n, n, |i, j| m[(i, j)] - r[(i, j)]);
        let ad = state_matrix(
            n,
            |i, j| (k[(i, j)] + r[(i, j)]) / self.mass[i],
            |i, j| r[(i, j)] / self.mass[i],
        );
        let bd = Mat::<f64>::from_fn(
            2 * n,
            n,
            |i, j| if i == j { 1.0 / self.mass[i] } else { 0.0 },
        );
        let cd = Mat::<f64>::from_fn(self.outputs.len(), 2 * n, |o, j| {
            if j < n {
                self.outputs[o]
                    .1
                    .iter()
                    .filter(|&&(_, d)| d == j)
                    .map(|&(g, _)| g)
                    .sum()
            } else {
                0.0
            }
        });
        let dd = Mat::<f64>::zeros(self.outputs.len(), n);
        Matrices {
            a1: m.clone(),
            m,
            k,
            r,
            a0,
            am1,
            ad,
            bd,
            cd,
            dd,
        }
    }
}

/// The state matrix `[[2I - S, -I + D], [I, 0]]` over `[x(n); x(n-1)]`, where `S(i, j)` is the
/// stiffness-plus-damping term and `D(i, j)` the damping term of row `i` (each already divided by the
/// inertia, or in scaled coordinates).
pub(crate) fn state_matrix(
    n: usize,
    s: impl Fn(usize, usize) -> f64,
    d: impl Fn(usize, usize) -> f64,
) -> Mat<f64> {
    Mat::<f64>::from_fn(2 * n, 2 * n, |i, j| match (i < n, j < n) {
        (true, true) => (if i == j { 2.0 } else { 0.0 }) - s(i, j),
        (true, false) => (if i == j - n { -1.0 } else { 0.0 }) + d(i, j - n),
        (false, true) => f64::from(u8::from(i - n == j)),
        (false, false) => 0.0,
    })
}

/// The rows of a matrix, as nested vectors.
pub fn rows(m: &Mat<f64>) -> Vec<Vec<f64>> {
    (0..m.nrows())
        .map(|i| (0..m.ncols()).map(|j| m[(i, j)]).collect())
        .collect()
}
