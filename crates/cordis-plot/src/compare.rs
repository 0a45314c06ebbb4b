//! The comparison figure: spectra stacked above one another on one frequency axis, each with its
//! own modes marked, such as a recording above the model designed from it.

use std::path::Path;

use crate::canvas::Canvas;
use crate::chart::{Chart, PanelDef, Scale, PALETTE};
use crate::modes::{
    check_modes, check_options, check_spectrum, freq_range, labelled, level_axis, lowest_mode,
    modes_shown, shown_points, Shown, SpectrumPanel,
};
use crate::{figure, ModeMark, ModesPlotOptions, PlotError, Spectrum};

/// The most panels [`compare_png`] draws.
const MAX_PANELS: usize = 4;

/// The colour of each panel's spectrum line, from the top, and of the mode markers.
const LINES: [[u8; 3]; MAX_PANELS] = [PALETTE[0], PALETTE[2], PALETTE[3], PALETTE[5]];
const MODE: [u8; 3] = PALETTE[1];

/// One panel of [`compare_png`]: a spectrum, the modes marked on it, and the name the legend
/// gives them (such as `"recording"` or `"model"`).
#[derive(Debug, Clone, Copy)]
pub struct ComparePanel<'a> {
    /// The name of the spectrum in the panel's legend (`"panel 2"` and so on when blank).
    pub label: &'a str,
    /// The spectrum drawn as a line.
    pub spectrum: &'a Spectrum,
    /// The modes marked on it (estimated from a recording, or those of a model).
    pub modes: &'a [ModeMark],
}

/// The checked inputs of a comparison figure.
struct Plan {
    min: f64,
    max: f64,
    /// The points shown of each panel's spectrum.
    shown: Vec<Shown>,
}

fn bad(msg: String) -> PlotError {
    PlotError::BadOptions(msg)
}

/// The name of panel `i` (from 0) in its legend and in messages.
fn name(panel: &ComparePanel<'_>, i: usize) -> String {
    match panel.label.trim() {
        "" => format!("panel {}", i + 1),
        l => l.to_string(),
    }
}

fn plan(panels: &[ComparePanel<'_>], opts: &ModesPlotOptions) -> Result<Plan, PlotError> {
    check_options(opts)?;
    if !(1..=MAX_PANELS).contains(&panels.len()) {
        return Err(bad(format!(
            "{} panels were given; a comparison draws 1 to {MAX_PANELS} (hint: one spectrum \
             per panel, such as the recording and the model)",
            panels.len()
        )));
    }
    // A message about the data names the panel it is about.
    let within = |i: usize, p: &ComparePanel<'_>, e: PlotError| match e {
        PlotError::BadOptions(msg) => bad(format!("panel {} ({}): {msg}", i + 1, name(p, i))),
        e => e,
    };
    for (i, p) in panels.iter().enumerate() {
        check_spectrum(p.spectrum).map_err(|e| within(i, p, e))?;
        check_modes(p.modes).map_err(|e| within(i, p, e))?;
    }
    // The union of what the panels hold; every spectrum has a point after the checks above.
    let ends = |p: &ComparePanel<'_>| {
        let f = &p.spectrum.freqs_hz;
        (f[0], f[f.len() - 1])
    };
    let f_first = panels
        .iter()
        .map(|p| ends(p).0)
        .fold(f64::INFINITY, f64::min);
    let f_last = panels
        .iter()
        .map(|p| ends(p).1)
        .fold(f64::NEG_INFINITY, f64::max);
    let lowest = panels
        .iter()
        .map(|p| lowest_mode(p.modes))
        .fold(f64::INFINITY, f64::min);
    let (min, max) = freq_range(f_first, f_last, lowest, opts)?;
    let shown = panels
        .iter()
        .enumerate()
        .map(|(i, p)| {
            shown_points(p.spectrum, min, max, opts.log_freq).map_err(|e| within(i, p, e))
        })
        .collect::<Result<Vec<Shown>, PlotError>>()?;
    Ok(Plan { min, max, shown })
}

/// Draws spectra one above the other on one frequency axis as a PNG of `opts.width` x
/// `opts.height` pixels at `path`, to compare them: typically the spectrum of a recording with
/// the modes estimated from it, above the spectrum of the model designed from it with the
/// model's modes.
///
/// Each of the 1 to 4 `panels` shows its spectrum as a line (level in dB over frequency in Hz)
/// with a vertical marker at each of its modes, their labels written above the panel where they
/// do not overlap, and a legend naming the spectrum (the panel's `label`) and its modes
/// (`"<label> modes"`). The
/// panels share the frequency axis, linear or logarithmic as `opts.log_freq` says, over
/// `opts.min_freq` to `opts.max_freq`; by default from the lowest to the highest frequency of
/// all the spectra (on a logarithmic axis from 20 Hz, or lower to show a lower mode or when the
/// range is narrow, as [`crate::modes_png`] does). Each panel's level axis spans the same
/// `opts.db_range` below that panel's loudest point shown, so spectra of different loudness
/// compare by shape. Each spectrum is drawn in its own colour (blue, bluish green, reddish
/// purple, sky blue from the top), the modes in vermilion; `opts.title` is written above.
///
/// The file is written beside `path` under a hidden temporary name and renamed only once
/// complete, so a failure never leaves a partial picture.
///
/// # Errors
/// As [`crate::modes_png`], for any panel: [`PlotError::Empty`] for a spectrum without points;
/// [`PlotError::NonFinite`] for a NaN or infinite frequency or level of a spectrum (`index` is
/// the point in its spectrum), or else a NaN frequency or T60 of a mode (`index` is the mode in
/// its panel); [`PlotError::BadOptions`] for no panels or more than 4, an option out of range,
/// frequencies that do not increase, a negative mode frequency or T60, or a range without any
/// point of a spectrum (messages about a panel's data name the panel); [`PlotError::Draw`] when
/// the picture cannot be drawn (too many panels for its height) or written.
pub fn compare_png(
    panels: &[ComparePanel<'_>],
    opts: &ModesPlotOptions,
    path: &Path,
) -> Result<(), PlotError> {
    let plan = plan(panels, opts)?;
    figure::save(path, || draw(panels, opts, &plan))
}

fn draw(
    panels: &[ComparePanel<'_>],
    opts: &ModesPlotOptions,
    plan: &Plan,
) -> Result<Canvas, PlotError> {
    let x = Scale {
        lo: plan.min,
        hi: plan.max,
        log: opts.log_freq,
    };
    let modes: Vec<Vec<&ModeMark>> = panels
        .iter()
        .map(|p| modes_shown(p.modes, plan.min, plan.max))
        .collect();
    let defs: Vec<PanelDef<'_>> = plan
        .shown
        .iter()
        .zip(&modes)
        .map(|(shown, m)| PanelDef {
            weight: 1.0,
            y: level_axis(shown.top, opts.db_range),
            label: "level (dB)",
            inf_band: false,
            strip: labelled(m),
        })
        .collect();
    let chart = Chart::layout(
        opts.width,
        opts.height,
        opts.title.as_deref(),
        x,
        "frequency (Hz)",
        &defs,
    )?;
    let mut c = chart.canvas();
    chart.draw_axes(&mut c)?;
    for (i, ((p, shown), m)) in panels.iter().zip(&plan.shown).zip(&modes).enumerate() {
        let panel = SpectrumPanel {
            spectrum: p.spectrum,
            points: shown,
            modes: m,
            line: LINES[i % LINES.len()],
            mark: MODE,
        };
        panel.draw(&mut c, &chart, i)?;
        let name = name(p, i);
        chart.legend(&mut c, i, &panel.entries(&name, &format!("{name} modes")))?;
    }
    Ok(c)
}
