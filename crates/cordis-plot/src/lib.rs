//! # cordis-plot: pictures of renders
//!
//! Four figures, each written as a PNG:
//!
//! - Spectrograms of rendered audio, as numbers ([`spectrogram`]) or as a figure
//!   ([`spectrogram_png`]) with a time axis in seconds, a linear or logarithmic frequency axis in
//!   Hz, a perceptual colour map (magma: black for silence, pale yellow for the loudest partial)
//!   and a labelled dB colour bar.
//! - Mode plots ([`modes_png`]): the prediction and the sound seen together, the spectrum of a
//!   render (see [`spectrum`]) with a marker at each predicted mode, above each mode's T60.
//! - Comparison plots ([`compare_png`]): spectra one above the other on one frequency axis, each
//!   with its own modes marked, such as a recording above the model designed from it.
//! - Response plots ([`response_png`]): magnitude and phase of one or more frequency responses
//!   over a logarithmic frequency axis (a Bode plot), with a legend.
//!
//! Text is drawn with DejaVu Sans embedded in the binary, so no system font or fontconfig is
//! needed: a figure renders the same on a fresh machine with only the Rust toolchain.
//!
//! ```no_run
//! use cordis_plot::{spectrogram_png, SpectrogramOptions};
//! let rate = 48_000.0;
//! let tone: Vec<f64> = (0..48_000)
//!     .map(|n| (2.0 * std::f64::consts::PI * 440.0 * n as f64 / rate).sin())
//!     .collect();
//! let opts = SpectrogramOptions { log_freq: true, title: Some("A4".into()), ..Default::default() };
//! spectrogram_png(&tone, rate, &opts, std::path::Path::new("a4.png"))?;
//! # Ok::<(), cordis_plot::PlotError>(())
//! ```
//!
//! ```no_run
//! use cordis_plot::{modes_png, spectrum, ModeMark, ModesPlotOptions};
//! # let samples = vec![0.0; 48_000];
//! let spec = spectrum(&samples, 48_000.0, 8192)?;
//! let modes = [ModeMark { freq_hz: 440.0, t60_s: 2.5, label: Some("1".into()) }];
//! modes_png(&spec, &modes, &ModesPlotOptions::default(), std::path::Path::new("modes.png"))?;
//! # Ok::<(), cordis_plot::PlotError>(())
//! ```
#![warn(missing_docs)]

mod canvas;
mod chart;
mod colormap;
mod compare;
mod draw;
mod figure;
mod modes;
mod response;
mod stft;
mod ticks;

pub use compare::{compare_png, ComparePanel};
pub use modes::{modes_png, spectrum, ModeMark, ModesPlotOptions, Spectrum};
pub use response::{response_png, ResponseCurve, ResponsePlotOptions};

use std::fmt;
use std::path::Path;

/// The most columns (analysis frames) a [`Spectrogram`] keeps.
///
/// A longer signal has its consecutive frames averaged (in power) in groups, so a ten-minute
/// render costs a few megabytes and the figure a fixed number of pixels, whatever the hop.
pub const MAX_FRAMES: usize = 2048;

/// The floor of [`Spectrogram::db`]: bins with no energy at all (silence, zero padding) read this
/// value instead of minus infinity.
pub const FLOOR_DB: f64 = -300.0;

/// How to analyse and draw a spectrogram. Start from [`Default`] and change what you need.
#[derive(Debug, Clone, PartialEq)]
pub struct SpectrogramOptions {
    /// FFT window length in samples (a Hann window); at least 16, any length (a power of two
    /// is fastest). Default 2048.
    pub window: usize,
    /// Hop between frames in samples, at least 1. Default `window / 4` (512).
    pub hop: usize,
    /// Highest frequency shown, in Hz; at most the Nyquist frequency. Default: Nyquist.
    pub max_freq: Option<f64>,
    /// Lowest frequency shown, in Hz. Default 0 Hz on a linear axis, 20 Hz on a logarithmic
    /// one (or a tenth of `max_freq` when that is lower).
    pub min_freq: Option<f64>,
    /// Logarithmic frequency axis (then `min_freq` must be above 0 Hz).
    pub log_freq: bool,
    /// Dynamic range drawn below the peak, in dB: quieter bins are black. Default 90 dB.
    pub db_range: f64,
    /// Width of the PNG in pixels, 240 to 16384. Default 1200.
    pub width: u32,
    /// Height of the PNG in pixels, 160 to 16384. Default 600.
    pub height: u32,
    /// Title drawn above the figure.
    pub title: Option<String>,
}

impl Default for SpectrogramOptions {
    fn default() -> Self {
        SpectrogramOptions {
            window: 2048,
            hop: 512,
            max_freq: None,
            min_freq: None,
            log_freq: false,
            db_range: 90.0,
            width: 1200,
            height: 600,
            title: None,
        }
    }
}

/// A magnitude spectrogram in dB relative to its loudest bin.
#[derive(Debug, Clone, PartialEq)]
pub struct Spectrogram {
    /// Centre time of each column in seconds. Frame `i` is centred on sample `i * hop` (the
    /// signal is padded with zeros on both sides); when there are more than [`MAX_FRAMES`]
    /// frames, each column averages a group of consecutive frames and its time is their mean.
    pub times_s: Vec<f64>,
    /// Frequency of each kept bin in Hz (`k * rate / window`), from the bin at or below the
    /// lowest frequency shown to the bin at or above the highest.
    pub freqs_hz: Vec<f64>,
    /// Power in dB, indexed `[column][bin]`, relative to the loudest bin of the whole matrix
    /// (which reads 0 dB); never below [`FLOOR_DB`].
    pub db: Vec<Vec<f64>>,
}

/// Why a figure (or a spectrogram's numbers) could not be computed or drawn.
#[derive(Debug, Clone, PartialEq)]
#[non_exhaustive]
pub enum PlotError {
    /// There is nothing to draw: no samples, no spectrum points, no frequencies or series.
    Empty,
    /// A value is NaN or infinite.
    NonFinite {
        /// Position of the first bad value: the sample, or as each function documents.
        index: usize,
        /// Its value.
        value: f64,
    },
    /// An option (or the sample rate, or the shape of the data) is out of range; the message
    /// says which and why.
    BadOptions(String),
    /// Drawing or writing the PNG failed.
    Draw(String),
}

impl fmt::Display for PlotError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            PlotError::Empty => write!(
                f,
                "nothing to draw: the data is empty (hint: render a duration above zero)"
            ),
            PlotError::NonFinite { index, value } => write!(
                f,
                "value {index} is {value}: a plot needs finite numbers \
                 (hint: if it comes from a render, the model probably blew up; run `cordis check` on it)"
            ),
            PlotError::BadOptions(msg) => write!(f, "bad plot options: {msg}"),
            PlotError::Draw(msg) => write!(f, "cannot draw the plot: {msg}"),
        }
    }
}

impl std::error::Error for PlotError {}

/// Computes the spectrogram of `samples` taken at `rate` Hz: Hann-windowed frames of
/// `opts.window` samples every `opts.hop` samples, power in dB relative to the loudest bin,
/// keeping the bins between `opts.min_freq` and `opts.max_freq`.
///
/// A signal shorter than the window is padded with zeros. Drawing options (`width`, `height`,
/// `title`) are validated too, so that the same options are accepted here and by
/// [`spectrogram_png`].
///
/// # Errors
/// [`PlotError::Empty`] for no samples, [`PlotError::NonFinite`] for a NaN or infinite sample,
/// [`PlotError::BadOptions`] for an option out of range.
pub fn spectrogram(
    samples: &[f64],
    rate: f64,
    opts: &SpectrogramOptions,
) -> Result<Spectrogram, PlotError> {
    let plan = stft::Plan::new(samples, rate, opts)?;
    Ok(stft::analyse(samples, rate, &plan))
}

/// Computes the spectrogram like [`spectrogram`] and draws it as a PNG of
/// `opts.width` x `opts.height` pixels at `path`, returning the numbers too.
///
/// The file is written beside `path` under a hidden temporary name and renamed only once
/// complete, so a failure never leaves a partial picture.
///
/// # Errors
/// Those of [`spectrogram`], and [`PlotError::Draw`] when the picture cannot be drawn or
/// written (for example, the folder does not exist).
pub fn spectrogram_png(
    samples: &[f64],
    rate: f64,
    opts: &SpectrogramOptions,
    path: &Path,
) -> Result<Spectrogram, PlotError> {
    let plan = stft::Plan::new(samples, rate, opts)?;
    let spec = stft::analyse(samples, rate, &plan);
    let duration = samples.len() as f64 / rate;
    draw::write_png(&spec, &plan, duration, opts, path)?;
    Ok(spec)
}

/// Checks a frequency range `[min, max)` for a plot axis (`log`: a logarithmic axis).
pub(crate) fn check_freq_range(min: f64, max: f64, log: bool) -> Result<(), PlotError> {
    let bad = |m: String| Err(PlotError::BadOptions(m));
    if !(min.is_finite() && min >= 0.0) {
        return bad(format!("min_freq is {min} Hz; it must be 0 Hz or more"));
    }
    if log && min <= 0.0 {
        return bad(format!(
            "min_freq is {min} Hz on a logarithmic axis, which cannot reach 0 Hz \
             (hint: 20 Hz, or leave it unset)"
        ));
    }
    if min >= max {
        return bad(format!("min_freq {min} Hz is not below max_freq {max} Hz"));
    }
    Ok(())
}

/// Checks a signal to analyse: not empty, finite samples, a positive rate.
pub(crate) fn check_signal(samples: &[f64], rate: f64) -> Result<(), PlotError> {
    if samples.is_empty() {
        return Err(PlotError::Empty);
    }
    if let Some((index, &value)) = samples.iter().enumerate().find(|(_, v)| !v.is_finite()) {
        return Err(PlotError::NonFinite { index, value });
    }
    if !(rate.is_finite() && rate > 0.0) {
        return Err(PlotError::BadOptions(format!(
            "the sample rate is {rate} Hz; it must be a positive number such as 48000"
        )));
    }
    Ok(())
}
