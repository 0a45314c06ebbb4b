//! The mode figure: the spectrum of a render with the predicted modes marked on it, above each
//! mode's decay time.

use std::path::Path;

use crate::canvas::{measure, Canvas, HAlign, VAlign};
use crate::chart::{
    arrow_head, check_size, column, decimate, dot_radius, line_width, marker_width, stem_width,
    Chart, Entry, PanelDef, Scale, Swatch, YAxis, PALETTE,
};
use crate::{figure, stft, PlotError};

/// The colour of the spectrum line and of the predicted modes.
const SPECTRUM: [u8; 3] = PALETTE[0];
const MODE: [u8; 3] = PALETTE[1];

/// Largest window accepted by [`spectrum`], in samples.
const MAX_WINDOW: usize = 1 << 24;

/// A magnitude spectrum: a level in dB at each of a list of increasing frequencies, as
/// [`spectrum`] computes it.
#[derive(Debug, Clone, PartialEq)]
pub struct Spectrum {
    /// Frequencies in Hz, increasing.
    pub freqs_hz: Vec<f64>,
    /// The level at each frequency, in dB (any reference; [`spectrum`] uses the loudest bin).
    pub db: Vec<f64>,
}

/// A predicted mode, marked on the spectrum at its frequency.
#[derive(Debug, Clone, PartialEq)]
pub struct ModeMark {
    /// Frequency in Hz (0 or more).
    pub freq_hz: f64,
    /// Time for the mode to decay by 60 dB, in seconds; `f64::INFINITY` for an undamped mode.
    pub t60_s: f64,
    /// A short name written above the marker (such as `"1"` or `"(2,1)"`), when there is room.
    pub label: Option<String>,
}

/// How to draw [`modes_png`] and [`crate::compare_png`]. Start from [`Default`] and change what
/// you need.
#[derive(Debug, Clone, PartialEq)]
pub struct ModesPlotOptions {
    /// Lowest frequency shown, in Hz. Default: the spectrum's first frequency on a linear axis;
    /// on a logarithmic one 20 Hz, or lower to show a lower mode or when the range is narrow.
    pub min_freq: Option<f64>,
    /// Highest frequency shown, in Hz. Default: the spectrum's last frequency.
    pub max_freq: Option<f64>,
    /// Logarithmic frequency axis (then `min_freq` must be above 0 Hz).
    pub log_freq: bool,
    /// Levels drawn below the loudest point shown, in dB; quieter ones sit on the bottom edge.
    /// Default 90 dB.
    pub db_range: f64,
    /// Width of the PNG in pixels, 320 to 16384. Default 1200.
    pub width: u32,
    /// Height of the PNG in pixels, 240 to 16384. Default 700.
    pub height: u32,
    /// Title drawn above the figure.
    pub title: Option<String>,
}

impl Default for ModesPlotOptions {
    fn default() -> Self {
        ModesPlotOptions {
            min_freq: None,
            max_freq: None,
            log_freq: false,
            db_range: 90.0,
            width: 1200,
            height: 700,
            title: None,
        }
    }
}

fn bad(msg: String) -> PlotError {
    PlotError::BadOptions(msg)
}

/// Computes the average magnitude spectrum of `samples` taken at `rate` Hz, in dB relative to
/// its loudest bin (which reads 0 dB; no bin reads below [`crate::FLOOR_DB`]): the power of
/// Hann-windowed frames of `window` samples overlapping by half is averaged (Welch's method),
/// and a signal shorter than the window is padded with zeros. The frequencies are the FFT bins
/// `k * rate / window` from 0 Hz to the Nyquist frequency.
///
/// # Errors
/// [`PlotError::Empty`] for no samples, [`PlotError::NonFinite`] for a NaN or infinite sample
/// (`index` is its position), [`PlotError::BadOptions`] for a rate that is not a positive
/// number or a window outside 16 to 2^24 samples.
pub fn spectrum(samples: &[f64], rate: f64, window: usize) -> Result<Spectrum, PlotError> {
    crate::check_signal(samples, rate)?;
    if !(16..=MAX_WINDOW).contains(&window) {
        return Err(bad(format!(
            "window is {window} samples; it must be between 16 and {MAX_WINDOW} \
             (hint: a longer window resolves closer modes; 8192 or more suits a mode plot)"
        )));
    }
    Ok(stft::average(samples, rate, window))
}

/// The points of a spectrum shown over a frequency range.
pub(crate) struct Shown {
    /// Indices of the spectrum points drawn (with one beyond each end of the range).
    pub first: usize,
    pub last: usize,
    /// The top of the level axis: the loudest point shown.
    pub top: f64,
}

/// The checked inputs of a mode figure.
struct Plan {
    min: f64,
    max: f64,
    shown: Shown,
}

/// Checks the options shared by the mode and comparison figures: the size and the dB range.
pub(crate) fn check_options(opts: &ModesPlotOptions) -> Result<(), PlotError> {
    check_size(opts.width, opts.height)?;
    if !(opts.db_range.is_finite() && opts.db_range > 0.0) {
        return Err(bad(format!(
            "db_range is {} dB; it must be a positive number such as 90",
            opts.db_range
        )));
    }
    Ok(())
}

/// Checks a spectrum to draw: points, one level per frequency, finite, increasing frequencies.
pub(crate) fn check_spectrum(spectrum: &Spectrum) -> Result<(), PlotError> {
    let Spectrum { freqs_hz: f, db } = spectrum;
    if f.is_empty() && db.is_empty() {
        return Err(PlotError::Empty);
    }
    if f.len() != db.len() {
        return Err(bad(format!(
            "the spectrum has {} frequencies but {} levels; it needs one level per frequency",
            f.len(),
            db.len()
        )));
    }
    for (index, (&fi, &di)) in f.iter().zip(db).enumerate() {
        for value in [fi, di] {
            if !value.is_finite() {
                return Err(PlotError::NonFinite { index, value });
            }
        }
    }
    if let Some(i) = f.windows(2).position(|w| w[1] <= w[0]) {
        return Err(bad(format!(
            "the spectrum's frequencies must increase, but point {} is at {} Hz and point {} \
             at {} Hz",
            i,
            f[i],
            i + 1,
            f[i + 1]
        )));
    }
    Ok(())
}

/// Checks modes to mark: finite frequencies of 0 Hz or more, T60s above 0 s (or infinite).
pub(crate) fn check_modes(modes: &[ModeMark]) -> Result<(), PlotError> {
    for (index, m) in modes.iter().enumerate() {
        if !m.freq_hz.is_finite() {
            return Err(PlotError::NonFinite {
                index,
                value: m.freq_hz,
            });
        }
        if m.t60_s.is_nan() || m.t60_s == f64::NEG_INFINITY {
            return Err(PlotError::NonFinite {
                index,
                value: m.t60_s,
            });
        }
        if m.freq_hz < 0.0 {
            return Err(bad(format!(
                "mode {index} is at {} Hz; a frequency must be 0 Hz or more",
                m.freq_hz
            )));
        }
        if m.t60_s <= 0.0 {
            return Err(bad(format!(
                "mode {index} at {} Hz has a T60 of {} s; it must be above 0 s \
                 (hint: f64::INFINITY for an undamped mode)",
                m.freq_hz, m.t60_s
            )));
        }
    }
    Ok(())
}

/// The frequency range shown, `(min, max)`: the options' bounds, or else spectra running from
/// `f_first` to `f_last` Hz with modes as low as `lowest_mode` Hz (above 0 Hz; infinity for
/// none) shown whole.
pub(crate) fn freq_range(
    f_first: f64,
    f_last: f64,
    lowest_mode: f64,
    opts: &ModesPlotOptions,
) -> Result<(f64, f64), PlotError> {
    let max = opts.max_freq.unwrap_or(f_last);
    if !(max.is_finite() && max > 0.0) {
        return Err(bad(format!(
            "max_freq is {max} Hz; it must be above 0 Hz (hint: leave it unset to show the \
             whole spectrum)"
        )));
    }
    let min = match opts.min_freq {
        Some(m) => m,
        None if opts.log_freq => 20f64.min(max / 10.0).min(lowest_mode / 1.25),
        None => f_first.min(max / 2.0),
    };
    crate::check_freq_range(min, max, opts.log_freq)?;
    Ok((min, max))
}

/// The lowest frequency above 0 Hz of `modes`, or infinity.
pub(crate) fn lowest_mode(modes: &[ModeMark]) -> f64 {
    modes
        .iter()
        .map(|m| m.freq_hz)
        .filter(|&m| m > 0.0)
        .fold(f64::INFINITY, f64::min)
}

/// The points of a checked `spectrum` shown between `min` and `max` Hz.
pub(crate) fn shown_points(
    spectrum: &Spectrum,
    min: f64,
    max: f64,
    log: bool,
) -> Result<Shown, PlotError> {
    let Spectrum { freqs_hz: f, db } = spectrum;
    let inside: Vec<usize> = (0..f.len())
        .filter(|&i| f[i] >= min && f[i] <= max)
        .collect();
    let (Some(&a), Some(&b)) = (inside.first(), inside.last()) else {
        return Err(bad(format!(
            "no point of the spectrum ({} to {} Hz) lies between min_freq {min} Hz \
             and max_freq {max} Hz",
            f[0],
            f[f.len() - 1]
        )));
    };
    let top = inside
        .iter()
        .map(|&i| db[i])
        .fold(f64::NEG_INFINITY, f64::max);
    // One point beyond each end, so that the line runs to the edges (a log axis cannot show
    // 0 Hz).
    let first = if a > 0 && (!log || f[a - 1] > 0.0) {
        a - 1
    } else {
        a
    };
    let last = (b + 1).min(f.len() - 1);
    Ok(Shown { first, last, top })
}

fn plan(
    spectrum: &Spectrum,
    modes: &[ModeMark],
    opts: &ModesPlotOptions,
) -> Result<Plan, PlotError> {
    check_options(opts)?;
    check_spectrum(spectrum)?;
    check_modes(modes)?;
    let f = &spectrum.freqs_hz;
    let (min, max) = freq_range(f[0], f[f.len() - 1], lowest_mode(modes), opts)?;
    let shown = shown_points(spectrum, min, max, opts.log_freq)?;
    Ok(Plan { min, max, shown })
}

/// Draws "the prediction and the sound seen together" as a PNG of `opts.width` x
/// `opts.height` pixels at `path`: above, `spectrum` as a line (level in dB over frequency in Hz,
/// on a linear or logarithmic axis) with a vertical marker at each of `modes`; below, on the
/// same frequency axis, each mode's T60 in seconds as a stem (on a logarithmic axis when the
/// T60s shown span more than a decade). Undamped modes (infinite T60) reach a band at the top
/// of the lower panel, labelled ∞, with an arrow head. Modes outside the frequency range are
/// left out; labels of modes are written above the markers where they do not overlap.
///
/// The file is written beside `path` under a hidden temporary name and renamed only once
/// complete, so a failure never leaves a partial picture.
///
/// # Errors
/// [`PlotError::Empty`] for a spectrum without points; [`PlotError::NonFinite`] for a NaN or
/// infinite frequency or level of the spectrum (`index` is the point), or else a NaN
/// frequency or T60 of a mode (`index` is the mode); [`PlotError::BadOptions`] for an option
/// out of range, frequencies that do not increase, a negative mode frequency or T60, or a
/// range without any point of the spectrum; [`PlotError::Draw`] when the picture cannot be
/// drawn or written.
pub fn modes_png(
    spectrum: &Spectrum,
    modes: &[ModeMark],
    opts: &ModesPlotOptions,
    path: &Path,
) -> Result<(), PlotError> {
    let plan = plan(spectrum, modes, opts)?;
    figure::save(path, || draw(spectrum, modes, opts, &plan))
}

fn draw(
    spectrum: &Spectrum,
    modes: &[ModeMark],
    opts: &ModesPlotOptions,
    plan: &Plan,
) -> Result<Canvas, PlotError> {
    let x = Scale {
        lo: plan.min,
        hi: plan.max,
        log: opts.log_freq,
    };
    let shown = modes_shown(modes, plan.min, plan.max);
    let finite: Vec<f64> = shown
        .iter()
        .map(|m| m.t60_s)
        .filter(|t| t.is_finite())
        .collect();
    let undamped = shown.iter().any(|m| m.t60_s.is_infinite());
    let t_lo = finite.iter().copied().fold(f64::INFINITY, f64::min);
    let t_hi = finite.iter().copied().fold(0.0f64, f64::max);
    let t_axis = if finite.is_empty() {
        YAxis::Blank
    } else if t_hi > 10.0 * t_lo {
        YAxis::Log {
            lo: t_lo / 1.5,
            hi: t_hi * 1.5,
        }
    } else {
        YAxis::LinearNice {
            lo: 0.0,
            hi: t_hi * 1.08,
        }
    };
    let range = opts.db_range;
    let chart = Chart::layout(
        opts.width,
        opts.height,
        opts.title.as_deref(),
        x,
        "frequency (Hz)",
        &[
            PanelDef {
                weight: 0.62,
                y: level_axis(plan.shown.top, range),
                label: "level (dB)",
                inf_band: false,
                strip: labelled(&shown),
            },
            PanelDef {
                weight: 0.38,
                y: t_axis,
                label: "T60 (s)",
                inf_band: undamped,
                strip: false,
            },
        ],
    )?;
    let mut c = chart.canvas();
    chart.draw_axes(&mut c)?;
    let st = chart.st;
    let bottom = &chart.panels[1];

    let top = SpectrumPanel {
        spectrum,
        points: &plan.shown,
        modes: &shown,
        line: SPECTRUM,
        mark: MODE,
    };
    let cols = top.draw(&mut c, &chart, 0)?;

    // Decay times.
    let mut stems = bottom.rect.layer();
    let (sw, r) = (stem_width(&st), dot_radius(&st));
    let base = bottom.data.y1 as f64;
    for (m, &col) in shown.iter().zip(&cols) {
        let xc = col as f64 + 0.5;
        if m.t60_s.is_finite() {
            let y = bottom
                .y_px(m.t60_s)
                .clamp(bottom.data.y0 as f64, bottom.data.y1 as f64);
            stems.segment((xc, base), (xc, y), sw);
            stems.disc((xc, y), r);
        } else {
            let tip = bottom.rect.y0 as f64 + (2.0 * st.s).max(1.0);
            stems.segment((xc, base), (xc, tip + 4.0 * st.s), sw);
            arrow_head(&mut stems, xc, tip, &st);
        }
    }
    stems.paint(&mut c, MODE);
    if shown.is_empty() {
        let r = bottom.rect;
        c.text(
            "no predicted mode in this frequency range",
            st.tick_size,
            (r.x0 + r.x1) as f64 / 2.0,
            (r.y0 + r.y1) as f64 / 2.0,
            HAlign::Center,
            VAlign::Center,
            false,
        )?;
    }

    chart.legend(&mut c, 0, &top.entries("spectrum", "predicted mode"))?;
    if undamped {
        let entries = [Entry {
            label: "undamped (T60 = \u{221e})".into(),
            colour: MODE,
            swatch: Swatch::Arrow,
        }];
        chart.legend(&mut c, 1, &entries)?;
    }
    Ok(c)
}

/// The modes of `modes` between `min` and `max` Hz, by increasing frequency.
pub(crate) fn modes_shown(modes: &[ModeMark], min: f64, max: f64) -> Vec<&ModeMark> {
    let mut shown: Vec<&ModeMark> = modes
        .iter()
        .filter(|m| m.freq_hz >= min && m.freq_hz <= max)
        .collect();
    shown.sort_by(|a, b| a.freq_hz.total_cmp(&b.freq_hz));
    shown
}

/// Whether any of `modes` has a label to write.
pub(crate) fn labelled(modes: &[&ModeMark]) -> bool {
    modes.iter().any(|m| label(m).is_some())
}

fn label(m: &ModeMark) -> Option<&str> {
    m.label.as_deref().map(str::trim).filter(|l| !l.is_empty())
}

/// The level axis of a spectrum panel: `range` dB below the loudest point shown, `top`, with
/// a little room above it.
pub(crate) fn level_axis(top: f64, range: f64) -> YAxis {
    YAxis::Linear {
        lo: top - range,
        hi: top + 0.05 * range,
    }
}

/// A spectrum with modes marked on it, drawn in a panel whose axis is [`level_axis`].
pub(crate) struct SpectrumPanel<'a> {
    pub spectrum: &'a Spectrum,
    pub points: &'a Shown,
    /// The modes in the frequency range, by increasing frequency (see [`modes_shown`]).
    pub modes: &'a [&'a ModeMark],
    /// Colours of the spectrum line and of the mode markers.
    pub line: [u8; 3],
    pub mark: [u8; 3],
}

impl SpectrumPanel<'_> {
    /// Draws into panel `panel` of `chart` a vertical marker at each mode, the spectrum line over
    /// them (levels below the axis sit on the bottom edge), and the labels of the modes in the
    /// panel's strip, skipping any that would overlap the one before. Returns the pixel column
    /// of each mode.
    pub(crate) fn draw(
        &self,
        c: &mut Canvas,
        chart: &Chart,
        panel: usize,
    ) -> Result<Vec<i64>, PlotError> {
        let st = chart.st;
        let Some(p) = chart.panels.get(panel) else {
            return Ok(Vec::new());
        };
        // Markers first, so that the spectrum stays readable over them.
        let mw = marker_width(&st);
        let cols: Vec<i64> = self
            .modes
            .iter()
            .map(|m| column(chart.x_px(m.freq_hz), &p.rect))
            .collect();
        for &col in &cols {
            let x0 = (col - (mw - 1) / 2).clamp(p.rect.x0, p.rect.x1 - mw);
            c.fill_rect(x0, p.rect.y0, x0 + mw, p.rect.y1, self.mark);
        }
        let floor = p.y.lo;
        let (f, db) = (&self.spectrum.freqs_hz, &self.spectrum.db);
        let points: Vec<(f64, f64)> = (self.points.first..=self.points.last)
            .map(|i| (chart.x_px(f[i]), p.y_px(db[i].max(floor))))
            .collect();
        let mut layer = p.rect.layer();
        layer.polyline(&decimate(&points), line_width(&st));
        layer.paint(c, self.line);

        if let Some(y) = p.strip_y {
            let mut free_from = st.pad;
            let right_edge = c.width as f64 - st.pad;
            for (m, &col) in self.modes.iter().zip(&cols) {
                let Some(label) = label(m) else {
                    continue;
                };
                let (lw, _) = measure(label, st.tick_size)?;
                let lw = lw as f64;
                let x = (col as f64 + 0.5 - lw / 2.0).max(st.pad);
                if x < free_from || x + lw > right_edge {
                    continue;
                }
                c.text(label, st.tick_size, x, y, HAlign::Left, VAlign::Top, false)?;
                free_from = x + lw + st.gap;
            }
        }
        Ok(cols)
    }

    /// Legend entries: the spectrum line as `line_label`, and the markers as `mark_label` when
    /// any mode is shown.
    pub(crate) fn entries(&self, line_label: &str, mark_label: &str) -> Vec<Entry> {
        let mut entries = vec![Entry {
            label: line_label.into(),
            colour: self.line,
            swatch: Swatch::Line,
        }];
        if !self.modes.is_empty() {
            entries.push(Entry {
                label: mark_label.into(),
                colour: self.mark,
                swatch: Swatch::Marker,
            });
        }
        entries
    }
}
