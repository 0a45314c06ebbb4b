//! # cordis-analysis: what a network will sound like, before it sounds
//!
//! The network linearised at its rest state ([`LinearSystem`]), its matrices and state space
//! ([`matrices`]), its modes exactly for the discrete scheme ([`ModalAnalysis`]: frequencies, decay
//! times, shapes, amplitudes at each pickup), and its frequency responses. Built on `faer`.
#![warn(missing_docs)]
// `!(x > 0.0)` rejects NaN along with the out-of-range values: intended.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

mod export;
mod linear;
mod matrices;
mod modes;
mod sparse;

pub use export::{
    graph_dot, parse_spice_ac, spice_netlist, spice_node_names, SpiceAc, SpiceOptions,
};
pub use faer;
pub use linear::{LinearSystem, SymSparse};
pub use matrices::{rows, Matrices};
pub use modes::{
    equilibrium, radius_is_stable, Method, ModalAnalysis, Mode, ModeKind, DENSE_LIMIT,
    STABILITY_MARGIN,
};
pub use sparse::{lowest_modes, receptance_sparse, LowestModes, SparseMethod};

/// Clears the upper bits of the vector registers (`vzeroupper`) where the CPU has AVX; a no-op
/// elsewhere.
///
/// faer's larger products (the `gemm` crate's kernels) can return with those bits dirty, and
/// then every SSE instruction of the code that follows, built for the baseline x86-64, waits to
/// merge them, until something clears them: on a Zen 4 the sparse `L D Lᵀ` solves ran 2.9x slower
/// after a product of 32 × 32 or more than after one of 16 × 16 or less, which returns clean
/// (docs/BENCHMARKS.md, "Analysis"). This crate calls it after each faer call whose caller's own
/// code then runs long; a crate that calls faer itself (through [`faer`], re-exported) may do
/// the same.
#[inline]
pub fn clean_upper() {
    #[cfg(target_arch = "x86_64")]
    {
        #[target_feature(enable = "avx")]
        fn zero_upper() {
            std::arch::x86_64::_mm256_zeroupper();
        }
        if std::arch::is_x86_feature_detected!("avx") {
            // SAFETY: `zero_upper` needs only AVX, which the CPU has (checked just above).
            // `vzeroupper` reads and writes no memory; it zeroes bits 128 and up of the vector
            // registers 0-15, which hold no live value across a call (both x86-64 ABIs make
            // them caller-saved; Windows keeps only the low 128 bits of xmm6-15), and
            // `zero_upper` is a call of its own (a `#[target_feature]` function is not inlined
            // into a caller without the feature), so no caller sees a value change.
            unsafe { zero_upper() }
        }
    }
}

/// Why an analysis could not be done.
#[derive(Clone, Debug, PartialEq)]
#[non_exhaustive]
pub enum AnalysisError {
    /// The model has no MAS or CEL: nothing can move.
    NoMobileModule,
    /// A matrix is singular or has a non-finite entry.
    Singular(String),
    /// An eigenvalue solver did not converge.
    NoConvergence(String),
    /// Too many degrees of freedom for the dense methods.
    TooLarge {
        /// Degrees of freedom of the model.
        dofs: usize,
        /// The limit.
        limit: usize,
    },
    /// A module name that is not a mobile module of the model.
    UnknownModule {
        /// The name given.
        name: String,
        /// A suggestion.
        hint: String,
    },
    /// A request the model cannot satisfy (a mode count of 0 or above the number of dofs, a dof
    /// out of range).
    InvalidRequest(String),
}

impl std::fmt::Display for AnalysisError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            AnalysisError::NoMobileModule => write!(f, "the model has no mobile module (mas or cel): there is nothing to analyse (hint: add a mas or cel)"),
            AnalysisError::Singular(s) => write!(f, "the matrices cannot be analysed: {s}"),
            AnalysisError::NoConvergence(s) => write!(f, "the eigenvalue solver did not converge: {s}"),
            AnalysisError::TooLarge { dofs, limit } => write!(f, "the model has {dofs} mobile modules; the dense analysis handles at most {limit} (hint: ask for the lowest modes only with --count N)"),
            AnalysisError::UnknownModule { name, hint } => write!(f, "`{name}` is not a mobile module of the model ({hint})"),
            AnalysisError::InvalidRequest(s) => write!(f, "{s}"),
        }
    }
}

impl std::error::Error for AnalysisError {}
