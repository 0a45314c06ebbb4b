//! # cordis-core: the CORDIS-ANIMA engine
//!
//! A 1-D network of material modules (MAS, SOL, CEL, ENX) joined by interactions (RES, FRO, REF,
//! BUT, LNL), driven by force inputs (ENF) and observed by recorders (SOX, SOF), stepped in `f64`
//! exactly as the project's formalism says (see `docs/FORMALISM.md` in the repository).
//!
//! This crate has no parser and no file I/O: it builds for any target, wasm included. Models are
//! written by hand in the `cordis-model` language; this crate only steps them.
//!
//! Two layers, as in rapier:
//! - [`Network`]: what a model *is*, addressed by typed ids ([`MatId`], [`LinkId`]) while it is
//!   being built;
//! - [`Engine`]: the same network compiled once into dense struct-of-arrays state, then stepped
//!   block by block into caller buffers without allocating.
//!
//! A large network can be stepped on several threads ([`Engine::set_threads`]); the output is the
//! same, bit for bit, whatever the number of threads or the block size.
//!
//! ```
//! use cordis_core::{Engine, Interaction, Material, Network, Signal};
//!
//! let mut net = Network::new();
//! let ground = net.add_material(Material::Sol { x0: 0.0 });
//! let mass = net.add_material(Material::Mas { m: 1.0, x0: 0.0, v0: 0.0 });
//! net.add_link(Interaction::Ref { k: 0.01, z: 1e-4 }, ground, mass);
//! net.add_force(mass, Signal::Impulse { at: 0, amp: 1.0 });
//! net.add_position_output(mass);
//!
//! let mut engine = Engine::new(&net);
//! let mut out = vec![0.0; 64 * engine.channels()];
//! engine.process(64, &mut out).expect("a damped oscillator is stable");
//! assert_eq!(out[0], 0.0); // sample 0 of a SOX is X0
//! assert_eq!(out[1], 1.0); // the impulse moved the unit mass by F/M = 1
//! ```
#![warn(missing_docs)]

mod curve;
mod engine;
mod lanes;
mod lines;
mod network;
mod parallel;
mod signal;
mod wide;

pub use curve::{Curve, CurveError};
pub use engine::{BlowUp, Engine, StepView};
pub use lanes::{SimdLimit, SimdLimitError};
pub use network::{ForceInput, Interaction, Link, LinkId, MatId, Material, Network, Output, Probe};
pub use signal::Signal;
