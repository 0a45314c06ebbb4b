//! Option checking and the short-time Fourier transform.

use rustfft::num_complex::Complex;
use rustfft::FftPlanner;

use crate::{PlotError, Spectrogram, SpectrogramOptions, Spectrum, FLOOR_DB, MAX_FRAMES};

/// Smallest and largest accepted picture sides, in pixels.
const MIN_WIDTH: u32 = 240;
const MIN_HEIGHT: u32 = 160;
const MAX_SIDE: u32 = 16_384;

/// Checked options, with defaults filled in.
#[derive(Debug, Clone)]
pub(crate) struct Plan {
    pub window: usize,
    pub hop: usize,
    pub min_freq: f64,
    pub max_freq: f64,
    pub log_freq: bool,
    pub db_range: f64,
    /// First and last FFT bins kept.
    pub bin_lo: usize,
    pub bin_hi: usize,
}

fn bad(msg: String) -> PlotError {
    PlotError::BadOptions(msg)
}

impl Plan {
    pub(crate) fn new(
        samples: &[f64],
        rate: f64,
        opts: &SpectrogramOptions,
    ) -> Result<Plan, PlotError> {
        crate::check_signal(samples, rate)?;
        if opts.window < 16 {
            return Err(bad(format!(
                "window is {} samples; it must be at least 16 (hint: 2048 suits most audio, \
                 larger windows resolve close partials better)",
                opts.window
            )));
        }
        if opts.hop == 0 {
            return Err(bad(
                "hop is 0 samples; it must be at least 1 (hint: window / 4)".to_string(),
            ));
        }
        if !(opts.db_range.is_finite() && opts.db_range > 0.0) {
            return Err(bad(format!(
                "db_range is {} dB; it must be a positive number such as 90",
                opts.db_range
            )));
        }
        for (name, v, min) in [
            ("width", opts.width, MIN_WIDTH),
            ("height", opts.height, MIN_HEIGHT),
        ] {
            if !(min..=MAX_SIDE).contains(&v) {
                return Err(bad(format!(
                    "{name} is {v} pixels; it must be between {min} and {MAX_SIDE} \
                     (the figure needs room for its axes, labels and colour bar)"
                )));
            }
        }
        let nyquist = rate / 2.0;
        let max_freq = opts.max_freq.unwrap_or(nyquist);
        if !(max_freq.is_finite() && max_freq > 0.0) {
            return Err(bad(format!(
                "max_freq is {max_freq} Hz; it must be above 0 Hz"
            )));
        }
        if max_freq > nyquist * (1.0 + 1e-12) {
            return Err(bad(format!(
                "max_freq is {max_freq} Hz, above the Nyquist frequency {nyquist} Hz \
                 (half the sample rate {rate} Hz); nothing exists up there (hint: leave it unset)"
            )));
        }
        let max_freq = max_freq.min(nyquist);
        let default_min = if opts.log_freq {
            20f64.min(max_freq / 10.0)
        } else {
            0.0
        };
        let min_freq = opts.min_freq.unwrap_or(default_min);
        crate::check_freq_range(min_freq, max_freq, opts.log_freq)?;
        let df = rate / opts.window as f64;
        let last_bin = opts.window / 2;
        let bin_lo = ((min_freq / df).floor() as usize).min(last_bin);
        let bin_hi = ((max_freq / df).ceil() as usize).min(last_bin);
        let bin_lo = bin_lo.min(bin_hi.saturating_sub(1));
        Ok(Plan {
            window: opts.window,
            hop: opts.hop,
            min_freq,
            max_freq,
            log_freq: opts.log_freq,
            db_range: opts.db_range,
            bin_lo,
            bin_hi,
        })
    }
}

/// The periodic Hann window of `n` samples.
fn hann(n: usize) -> Vec<f64> {
    (0..n)
        .map(|j| 0.5 - 0.5 * (2.0 * std::f64::consts::PI * j as f64 / n as f64).cos())
        .collect()
}

/// Powers in dB relative to `peak`, never below [`FLOOR_DB`] (all of it when `peak` is 0).
fn to_db(power: Vec<f64>, peak: f64) -> Vec<f64> {
    let floor = 10f64.powf(FLOOR_DB / 10.0);
    power
        .into_iter()
        .map(|p| {
            if peak > 0.0 {
                10.0 * (p / peak).max(floor).log10()
            } else {
                FLOOR_DB
            }
        })
        .collect()
}

/// The average power spectrum of `samples` (already checked) in dB relative to its loudest
/// bin: Hann-windowed frames of `window` samples overlapping by half, the last one aligned
/// with the end of the signal; a signal shorter than the window is padded with zeros.
pub(crate) fn average(samples: &[f64], rate: f64, window: usize) -> Spectrum {
    let n = samples.len();
    let hop = (window / 2).max(1);
    let mut starts: Vec<usize> = (0..=n.saturating_sub(window)).step_by(hop).collect();
    if n > window && starts.last().is_some_and(|&s| s + window < n) {
        starts.push(n - window);
    }
    let fft = FftPlanner::<f64>::new().plan_fft_forward(window);
    let mut scratch = vec![Complex::new(0.0, 0.0); fft.get_inplace_scratch_len()];
    let mut buf = vec![Complex::new(0.0, 0.0); window];
    let hann = hann(window);
    let n_bins = window / 2 + 1;
    let mut power = vec![0.0f64; n_bins];
    for &start in &starts {
        for (j, (b, w)) in buf.iter_mut().zip(&hann).enumerate() {
            let x = samples.get(start + j).copied().unwrap_or(0.0);
            *b = Complex::new(x * w, 0.0);
        }
        fft.process_with_scratch(&mut buf, &mut scratch);
        for (a, z) in power.iter_mut().zip(&buf) {
            *a += z.norm_sqr();
        }
    }
    let peak = power.iter().copied().fold(0.0f64, f64::max);
    let df = rate / window as f64;
    Spectrum {
        freqs_hz: (0..n_bins).map(|k| k as f64 * df).collect(),
        db: to_db(power, peak),
    }
}

/// The STFT of `samples` under `plan`, frames centred on `i * hop`, grouped into at most
/// [`MAX_FRAMES`] columns, in dB relative to the loudest bin.
pub(crate) fn analyse(samples: &[f64], rate: f64, plan: &Plan) -> Spectrogram {
    let n = samples.len();
    let (window, hop) = (plan.window, plan.hop);
    let n_frames = n / hop + 1;
    let group = n_frames.div_ceil(MAX_FRAMES);
    let n_cols = n_frames.div_ceil(group);
    let n_bins = plan.bin_hi - plan.bin_lo + 1;

    let fft = FftPlanner::<f64>::new().plan_fft_forward(window);
    let mut scratch = vec![Complex::new(0.0, 0.0); fft.get_inplace_scratch_len()];
    let mut buf = vec![Complex::new(0.0, 0.0); window];
    let hann = hann(window);
    let half = window / 2;

    let mut power = vec![vec![0.0f64; n_bins]; n_cols];
    let mut times = Vec::with_capacity(n_cols);
    for (col, acc) in power.iter_mut().enumerate() {
        let first = col * group;
        let last = ((col + 1) * group).min(n_frames);
        let mut t_sum = 0.0;
        for frame in first..last {
            let centre = frame * hop;
            t_sum += centre as f64 / rate;
            // Window j covers sample centre - half + j.
            for (j, (b, w)) in buf.iter_mut().zip(&hann).enumerate() {
                let x = (centre + j)
                    .checked_sub(half)
                    .and_then(|i| samples.get(i))
                    .copied()
                    .unwrap_or(0.0);
                *b = Complex::new(x * w, 0.0);
            }
            fft.process_with_scratch(&mut buf, &mut scratch);
            for (a, z) in acc.iter_mut().zip(&buf[plan.bin_lo..=plan.bin_hi]) {
                *a += z.norm_sqr();
            }
        }
        let count = (last - first) as f64;
        for a in acc.iter_mut() {
            *a /= count;
        }
        times.push(t_sum / count);
    }

    let peak = power
        .iter()
        .flat_map(|c| c.iter().copied())
        .fold(0.0f64, f64::max);
    let db = power.into_iter().map(|col| to_db(col, peak)).collect();
    let df = rate / window as f64;
    let freqs_hz = (plan.bin_lo..=plan.bin_hi).map(|k| k as f64 * df).collect();
    Spectrogram {
        times_s: times,
        freqs_hz,
        db,
    }
}
