//! Inverse design: from the sound one wants to a physical model that makes it.
//!
//! - [`cell`]: one damped oscillator from a frequency, a decay time, an amplitude and a phase, in
//!   closed form, exact for the discrete scheme.
//! - [`chain`]: a chain of masses and springs from target frequencies (and amplitudes at its first
//!   mass, and the fundamental's decay time) by inverse Lanczos with full reorthogonalisation.
//! - [`fit`]: any topology, by Levenberg–Marquardt on eigenvalue residuals over a model's `let`
//!   values, with continuation from the model's own frequencies.
//! - [`audio`]: modal parameters (frequency, amplitude, decay time) estimated from a recording.
//!
//! Every design is returned as numbers and as the text of a complete `.cordis` model (the
//! instrumentalist included) that a person can open, render and keep editing.

// `!(x > 0.0)` rejects NaN as well as non-positive values, on purpose, throughout.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

pub mod audio;
pub mod cell;
pub mod chain;
mod error;
pub mod fit;

pub use error::DesignError;
