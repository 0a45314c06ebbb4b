//! # cordis-model: the cordis model language
//!
//! Turns a `*.cordis` text into a checked [`Model`], in named stages (STYLE.md practice 4):
//!
//! 1. **parse** ([`syntax`]): text → statements, with byte spans;
//! 2. **resolve**: `let` values and units evaluated at the model's rate, generators expanded,
//!    names bound to typed ids (did-you-mean on every unknown name);
//! 3. **validate**: ranges (M > 0, frequencies below Nyquist...), curves, signal files, limits;
//! 4. **compile** ([`Model::compile`]): into a `cordis_core::Engine`.
//!
//! Errors are typed [`Diagnostic`]s with file, line and column; rendering them is the caller's
//! business. The language is documented in `docs/LANGUAGE.md`.
//!
//! ```
//! use cordis_model::{load_str, Options};
//! let text = "cel c M=1 f=441Hz tau=0.5s X0=1\nsox out c\n";
//! let model = load_str("bell.cordis".as_ref(), text, &Options::default()).unwrap();
//! assert_eq!(model.network.materials.len(), 1);
//! let mut engine = model.compile();
//! let mut out = vec![0.0; 4];
//! engine.process(4, &mut out).unwrap();
//! assert_eq!(out[0], 1.0);
//! ```
#![warn(missing_docs)]
// `!(x > 0.0)` is how this crate rejects NaN along with the out-of-range values: intended.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

mod devices;
mod error;
pub mod eval;
mod model;
mod names;
mod observe;
mod signals;
pub use signals::read_wav_channel;
pub mod stability;
pub mod syntax;

pub use devices::{critical_z1, sticking_curve, Activity, Device, DeviceKind, Tracked};
pub use error::{did_you_mean, Diagnostic, ErrorKind, LoadError, Severity, Span};
pub use model::{
    cel_from_modal, cel_modal, eval_text, load_file, load_str, Limits, Model, Named, Options,
};
pub use observe::{EnergyMeter, EnergyRow, Event, EventLog};
