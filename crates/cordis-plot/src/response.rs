//! The response figure (a Bode plot): magnitude in dB above phase in degrees, over a
//! logarithmic frequency axis, for one or more curves.

use std::path::Path;

use crate::canvas::Canvas;
use crate::chart::{
    check_size, decimate, line_width, Chart, Entry, PanelDef, Scale, Swatch, YAxis, PALETTE,
};
use crate::{figure, PlotError};

/// The widest level range drawn when [`ResponsePlotOptions::db_range`] is unset, in dB: lower
/// magnitudes (zeros among them) sit on the bottom edge.
const AUTO_RANGE_DB: f64 = 200.0;

/// Frequency responses sampled at common frequencies: each series is a named curve, such as
/// `"receptance"` or `"mobility"`.
#[derive(Debug, Clone, PartialEq)]
pub struct ResponseCurve {
    /// Frequencies in Hz, above 0 and increasing; at least two.
    pub freqs_hz: Vec<f64>,
    /// Each curve's name and, at each frequency, its magnitude (linear, 0 or more) and phase
    /// (radians, any value: it is wrapped to [-180, 180] degrees when drawn).
    pub series: Vec<(String, Vec<(f64, f64)>)>,
}

/// How to draw [`response_png`]. Start from [`Default`] and change what you need.
#[derive(Debug, Clone, PartialEq)]
pub struct ResponsePlotOptions {
    /// Width of the PNG in pixels, 320 to 16384. Default 1200.
    pub width: u32,
    /// Height of the PNG in pixels, 240 to 16384. Default 700.
    pub height: u32,
    /// Title drawn above the figure.
    pub title: Option<String>,
    /// Levels drawn below the loudest point, in dB; quieter ones sit on the bottom edge.
    /// Default: the range of the data (at most 200 dB), widened to whole ticks.
    pub db_range: Option<f64>,
}

impl Default for ResponsePlotOptions {
    fn default() -> Self {
        ResponsePlotOptions {
            width: 1200,
            height: 700,
            title: None,
            db_range: None,
        }
    }
}

fn bad(msg: String) -> PlotError {
    PlotError::BadOptions(msg)
}

fn check(resp: &ResponseCurve, opts: &ResponsePlotOptions) -> Result<(), PlotError> {
    check_size(opts.width, opts.height)?;
    if let Some(r) = opts.db_range {
        if !(r.is_finite() && r > 0.0) {
            return Err(bad(format!(
                "db_range is {r} dB; it must be a positive number such as 120 \
                 (hint: leave it unset to fit the data)"
            )));
        }
    }
    let f = &resp.freqs_hz;
    if f.is_empty() || resp.series.is_empty() {
        return Err(PlotError::Empty);
    }
    if let Some((index, &value)) = f.iter().enumerate().find(|(_, v)| !v.is_finite()) {
        return Err(PlotError::NonFinite { index, value });
    }
    if f.len() < 2 {
        return Err(bad(format!(
            "a response needs at least two frequencies to draw a curve; it has {}",
            f.len()
        )));
    }
    if let Some((i, v)) = f.iter().enumerate().find(|(_, v)| **v <= 0.0) {
        return Err(bad(format!(
            "frequency {i} is {v} Hz; a logarithmic frequency axis needs frequencies above 0 Hz"
        )));
    }
    if let Some(i) = f.windows(2).position(|w| w[1] <= w[0]) {
        return Err(bad(format!(
            "the frequencies must increase, but frequency {} is {} Hz and frequency {} is {} Hz",
            i,
            f[i],
            i + 1,
            f[i + 1]
        )));
    }
    for (name, values) in &resp.series {
        if values.len() != f.len() {
            return Err(bad(format!(
                "series \"{name}\" has {} values for {} frequencies; it needs one per frequency",
                values.len(),
                f.len()
            )));
        }
        for (index, &(mag, phase)) in values.iter().enumerate() {
            for value in [mag, phase] {
                if !value.is_finite() {
                    return Err(PlotError::NonFinite { index, value });
                }
            }
            if mag < 0.0 {
                return Err(bad(format!(
                    "series \"{name}\" has magnitude {mag} at {} Hz; a magnitude is 0 or more \
                     (hint: put the sign in the phase)",
                    f[index]
                )));
            }
        }
    }
    Ok(())
}

/// `d` degrees wrapped to [-180, 180).
fn wrap(d: f64) -> f64 {
    d - 360.0 * ((d + 180.0) / 360.0).floor()
}

/// The phase curve in degrees as pieces, broken where it wraps: each piece runs past the edge
/// where the curve leaves, and the next one comes in from the other edge.
fn phase_pieces(freqs: &[f64], phases: &[f64]) -> Vec<Vec<(f64, f64)>> {
    let mut pieces = Vec::new();
    let mut piece: Vec<(f64, f64)> = Vec::new();
    let mut prev: Option<(f64, f64)> = None;
    for (&f, &rad) in freqs.iter().zip(phases) {
        let p = wrap(rad.to_degrees());
        if let Some((f0, p0)) = prev {
            let d = wrap(p - p0);
            let reached = p0 + d;
            if (-180.0..=180.0).contains(&reached) {
                piece.push((f, p));
            } else {
                piece.push((f, reached));
                pieces.push(std::mem::take(&mut piece));
                piece.push((f0, p - d));
                piece.push((f, p));
            }
        } else {
            piece.push((f, p));
        }
        prev = Some((f, p));
    }
    pieces.push(piece);
    pieces
}

/// Draws a Bode plot of `resp` as a PNG of `opts.width` x `opts.height` pixels at `path`:
/// magnitude in dB (20 log10 of the magnitude, zero magnitudes on the bottom edge) above phase
/// in degrees wrapped to [-180, 180], over a logarithmic frequency axis in Hz; each series in
/// its own colour, named in a legend when there are several.
///
/// The file is written beside `path` under a hidden temporary name and renamed only once
/// complete, so a failure never leaves a partial picture.
///
/// # Errors
/// [`PlotError::Empty`] without frequencies or series; [`PlotError::NonFinite`] for a NaN or
/// infinite frequency, magnitude or phase (`index` is the frequency's position);
/// [`PlotError::BadOptions`] for an option out of range, fewer than two frequencies,
/// frequencies that are not above 0 Hz and increasing, a series of the wrong length or a
/// negative magnitude; [`PlotError::Draw`] when the picture cannot be drawn or written.
pub fn response_png(
    resp: &ResponseCurve,
    opts: &ResponsePlotOptions,
    path: &Path,
) -> Result<(), PlotError> {
    check(resp, opts)?;
    figure::save(path, || draw(resp, opts))
}

fn draw(resp: &ResponseCurve, opts: &ResponsePlotOptions) -> Result<Canvas, PlotError> {
    let f = &resp.freqs_hz;
    let db: Vec<Vec<f64>> = resp
        .series
        .iter()
        .map(|(_, v)| v.iter().map(|(m, _)| 20.0 * m.log10()).collect())
        .collect();
    let finite = db.iter().flatten().copied().filter(|v| v.is_finite());
    let top = finite.clone().fold(f64::NEG_INFINITY, f64::max);
    let low = finite.fold(f64::INFINITY, f64::min);
    let top = if top.is_finite() { top } else { 0.0 };
    let level = match opts.db_range {
        Some(r) => YAxis::Linear {
            lo: top - r,
            hi: top + 0.05 * r,
        },
        None => {
            let low = if low.is_finite() {
                low.max(top - AUTO_RANGE_DB)
            } else {
                top - 60.0
            };
            let span = (top - low).max(10.0);
            let mid = (top + low) / 2.0;
            YAxis::LinearNice {
                lo: mid - 0.55 * span,
                hi: mid + 0.55 * span,
            }
        }
    };
    let x = Scale {
        lo: f[0],
        hi: f[f.len() - 1],
        log: true,
    };
    let chart = Chart::layout(
        opts.width,
        opts.height,
        opts.title.as_deref(),
        x,
        "frequency (Hz)",
        &[
            PanelDef {
                weight: 0.55,
                y: level,
                label: "level (dB)",
                inf_band: false,
                strip: false,
            },
            PanelDef {
                weight: 0.45,
                y: YAxis::Phase,
                label: "phase (deg)",
                inf_band: false,
                strip: false,
            },
        ],
    )?;
    let mut c = chart.canvas();
    chart.draw_axes(&mut c)?;
    let (mag_panel, phase_panel) = (&chart.panels[0], &chart.panels[1]);
    let floor = mag_panel.y.lo;
    let lw = line_width(&chart.st);
    let mut entries = Vec::new();
    for (k, ((name, values), levels)) in resp.series.iter().zip(&db).enumerate() {
        let colour = PALETTE[k % PALETTE.len()];
        let points: Vec<(f64, f64)> = f
            .iter()
            .zip(levels)
            .map(|(&fi, &l)| (chart.x_px(fi), mag_panel.y_px(l.max(floor))))
            .collect();
        let mut layer = mag_panel.rect.layer();
        layer.polyline(&decimate(&points), lw);
        layer.paint(&mut c, colour);

        let phases: Vec<f64> = values.iter().map(|(_, p)| *p).collect();
        let mut layer = phase_panel.rect.layer();
        for piece in phase_pieces(f, &phases) {
            let points: Vec<(f64, f64)> = piece
                .iter()
                .map(|&(fi, p)| (chart.x_px(fi), phase_panel.y_px(p)))
                .collect();
            layer.polyline(&decimate(&points), lw);
        }
        layer.paint(&mut c, colour);
        let name = name.trim();
        entries.push(Entry {
            label: if name.is_empty() {
                format!("series {}", k + 1)
            } else {
                name.to_string()
            },
            colour,
            swatch: Swatch::Line,
        });
    }
    if entries.len() > 1 {
        chart.legend(&mut c, 0, &entries)?;
    }
    Ok(c)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn phase_wraps_and_breaks_at_the_edges() {
        assert_eq!(wrap(190.0), -170.0);
        assert_eq!(wrap(-190.0), 170.0);
        assert_eq!(wrap(540.0), -180.0);
        let deg = |d: f64| d.to_radians();
        let pieces = phase_pieces(&[1.0, 2.0, 3.0], &[deg(170.0), deg(-170.0), deg(-160.0)]);
        assert_eq!(pieces.len(), 2);
        // The first piece leaves through the top edge, the second comes in from the bottom.
        assert!((pieces[0][1].1 - 190.0).abs() < 1e-9);
        assert!((pieces[1][0].1 + 190.0).abs() < 1e-9);
        assert_eq!(pieces[1].len(), 3);
        let smooth = phase_pieces(&[1.0, 2.0], &[deg(-10.0), deg(-100.0)]);
        assert_eq!(smooth.len(), 1);
    }
}
