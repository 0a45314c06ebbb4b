//! # cordis-plot: pictures of renders
//!
//! Placeholder: being written.
#![warn(missing_docs)]
