//! The PNG figure: heat map, axes, colour bar and title, laid out from measured text so that
//! nothing is cut off at any size. Pixels are drawn on our own [`Canvas`]; the PNG
//! backend only encodes the PNG.

use std::path::Path;

use crate::canvas::{Canvas, HAlign, VAlign, INK, PAPER};
use crate::colormap::magma;
use crate::figure::{self, linear_axis, Style, Title};
use crate::stft::Plan;
use crate::ticks;
use crate::{PlotError, Spectrogram, SpectrogramOptions};

/// Draws the figure and writes it to `path` (see [`figure::save`]).
pub(crate) fn write_png(
    spec: &Spectrogram,
    plan: &Plan,
    duration: f64,
    opts: &SpectrogramOptions,
    path: &Path,
) -> Result<(), PlotError> {
    figure::save(path, || draw_figure(spec, plan, duration, opts))
}

/// How a pixel reads the dB matrix along one axis: the maximum over the samples (frames or
/// bins) that fall inside it, or, when none does, linear interpolation between the two nearest.
#[derive(Debug, Clone, Copy)]
enum Pick {
    Max(usize, usize),
    Lerp(usize, usize, f64),
}

impl Pick {
    fn eval(self, get: impl Fn(usize) -> f64) -> f64 {
        match self {
            Pick::Max(a, b) => (a..b).map(get).fold(f64::NEG_INFINITY, f64::max),
            Pick::Lerp(a, b, t) => {
                let (va, vb) = (get(a), get(b));
                va + (vb - va) * t
            }
        }
    }
}

/// One pick per pixel for `n_px` pixels whose edges are `edge(i)` (`edge(0)` lowest, increasing),
/// over sample positions `points` (increasing).
fn picks(points: &[f64], n_px: usize, edge: impl Fn(usize) -> f64) -> Vec<Pick> {
    let last = points.len().saturating_sub(1);
    (0..n_px)
        .map(|i| {
            let (lo, hi) = (edge(i), edge(i + 1));
            let a = points.partition_point(|&p| p < lo);
            let b = points.partition_point(|&p| p < hi);
            if b > a {
                return Pick::Max(a, b);
            }
            let c = 0.5 * (lo + hi);
            let j = points.partition_point(|&p| p < c);
            if j == 0 {
                Pick::Lerp(0, 0, 0.0)
            } else if j > last {
                Pick::Lerp(last, last, 0.0)
            } else {
                let (p0, p1) = (points[j - 1], points[j]);
                let t = if p1 > p0 { (c - p0) / (p1 - p0) } else { 0.0 };
                Pick::Lerp(j - 1, j, t.clamp(0.0, 1.0))
            }
        })
        .collect()
}

fn draw_figure(
    spec: &Spectrogram,
    plan: &Plan,
    duration: f64,
    opts: &SpectrogramOptions,
) -> Result<Canvas, PlotError> {
    let (w, h) = (opts.width as usize, opts.height as usize);
    // Everything scales with the picture; 1200 x 600 is the reference.
    let st = Style::new(w, h, 1200.0, 600.0)?;
    let Style {
        s,
        tick_size,
        desc_size,
        pad,
        gap,
        tick_len,
        label_h,
        desc_h,
    } = st;
    let bar_gap = (24.0 * s).round();
    let bar_w = (22.0 * s).round();
    let width_of = |t: &str| st.label_w(t);
    let title = Title::fit(opts.title.as_deref(), w, &st)?;
    let title_h = title.as_ref().map_or(0.0, |t| t.height);

    // Vertical layout first: it fixes the plot height, which fixes the y ticks and so the
    // widths of their labels, which fix the horizontal layout.
    let top = (pad + title_h + label_h / 2.0).round();
    let bottom = (tick_len + gap + label_h + gap + desc_h + pad).round();
    let ph = h as f64 - top - bottom;

    let log = plan.log_freq;
    let (y_lo, y_hi) = if log {
        (plan.min_freq.log10(), plan.max_freq.log10())
    } else {
        (plan.min_freq, plan.max_freq)
    };
    let (freq_major, freq_minor) = if log {
        ticks::log_ticks(
            plan.min_freq,
            plan.max_freq,
            ph / (y_hi - y_lo),
            1.8 * label_h,
        )
    } else {
        let (v, _) = linear_axis(
            y_lo,
            y_hi,
            ph,
            1.2 * label_h,
            |v, _| v.to_string(),
            |_| Ok(label_h),
        )?;
        (v, Vec::new())
    };
    let freq_labels: Vec<String> = freq_major.iter().map(|f| ticks::hz(*f)).collect();
    let range = plan.db_range;
    let (db_ticks, db_dec) = linear_axis(
        -range,
        0.0,
        ph,
        1.2 * label_h,
        |v, _| v.to_string(),
        |_| Ok(label_h),
    )?;
    // A true minus sign, as in print.
    let db_labels: Vec<String> = db_ticks
        .iter()
        .map(|v| ticks::trim(*v, db_dec).replace('-', "\u{2212}"))
        .collect();
    let mut freq_label_w = 0.0f64;
    for l in &freq_labels {
        freq_label_w = freq_label_w.max(width_of(l)?);
    }
    let mut db_label_w = 0.0f64;
    for l in &db_labels {
        db_label_w = db_label_w.max(width_of(l)?);
    }

    let left = (pad + desc_h + gap + freq_label_w + gap + tick_len).round();
    let right = (bar_gap + bar_w + tick_len + gap + db_label_w + gap + desc_h + pad).round();
    let pw = w as f64 - left - right;
    if pw < 16.0 || ph < 16.0 {
        return Err(PlotError::Draw(format!(
            "a {w} x {h} picture leaves no room for the plot beside its labels \
             (hint: make it larger)"
        )));
    }
    let (x0, y0, pw_px, ph_px) = (left as i64, top as i64, pw as usize, ph as usize);
    let (x1, y1) = (x0 + pw_px as i64, y0 + ph_px as i64);

    let last_t = spec.times_s.last().copied().unwrap_or(0.0);
    let t_end = duration.max(last_t).max(1e-9);
    let (t_ticks, t_dec) = linear_axis(0.0, t_end, pw, 2.5 * label_h, ticks::trim, width_of)?;

    let mut c = Canvas::new(w, h, PAPER);

    // The heat map, pixel by pixel.
    let to_hz = |u: f64| if log { 10f64.powf(u) } else { u };
    let col_picks = picks(&spec.times_s, pw_px, |i| t_end * i as f64 / pw);
    // Rows are counted from the bottom here, and flipped when drawn.
    let row_picks = picks(&spec.freqs_hz, ph_px, |i| {
        to_hz(y_lo + (y_hi - y_lo) * i as f64 / ph)
    });
    let mut column = vec![0.0; spec.freqs_hz.len()];
    for (x, cp) in col_picks.iter().enumerate() {
        for (k, v) in column.iter_mut().enumerate() {
            *v = cp.eval(|f| spec.db[f][k]);
        }
        for (r, rp) in row_picks.iter().enumerate() {
            let db = rp.eval(|k| column[k]);
            c.set(
                x0 + x as i64,
                y1 - 1 - r as i64,
                magma((db + range) / range),
            );
        }
    }
    c.frame(x0, y0, x1, y1, INK);

    // Frequency axis.
    let y_of = |f: f64| y1 as f64 - (if log { f.log10() } else { f } - y_lo) / (y_hi - y_lo) * ph;
    for (f, label) in freq_major.iter().zip(&freq_labels) {
        let y = y_of(*f).round().min((y1 - 1) as f64) as i64;
        c.fill_rect(x0 - 1 - tick_len as i64, y, x0 - 1, y + 1, INK);
        let ly = y as f64 + 0.5;
        c.text(
            label,
            tick_size,
            left - tick_len - gap,
            ly,
            HAlign::Right,
            VAlign::Center,
            false,
        )?;
    }
    for f in &freq_minor {
        let y = y_of(*f).round().min((y1 - 1) as f64) as i64;
        let len = (tick_len * 0.6).round() as i64;
        c.fill_rect(x0 - 1 - len, y, x0 - 1, y + 1, INK);
    }
    c.text(
        "frequency (Hz)",
        desc_size,
        pad,
        top + ph / 2.0,
        HAlign::Left,
        VAlign::Center,
        true,
    )?;

    // Time axis.
    for t in &t_ticks {
        let x = (x0 as f64 + t / t_end * pw).round().min((x1 - 1) as f64) as i64;
        c.fill_rect(x, y1 + 1, x + 1, y1 + 1 + tick_len as i64, INK);
        let label = ticks::trim(*t, t_dec);
        c.text(
            &label,
            tick_size,
            x as f64 + 0.5,
            y1 as f64 + tick_len + gap,
            HAlign::Center,
            VAlign::Top,
            false,
        )?;
    }
    c.text(
        "time (s)",
        desc_size,
        left + pw / 2.0,
        h as f64 - pad - desc_h,
        HAlign::Center,
        VAlign::Top,
        false,
    )?;

    // Colour bar, level with the plot.
    let bx0 = x1 + bar_gap as i64;
    let bx1 = bx0 + bar_w as i64;
    for r in 0..ph_px {
        let frac = (r as f64 + 0.5) / ph;
        let colour = magma(frac);
        c.fill_rect(bx0, y1 - 1 - r as i64, bx1, y1 - r as i64, colour);
    }
    c.frame(bx0, y0, bx1, y1, INK);
    for (v, label) in db_ticks.iter().zip(&db_labels) {
        let y = (y1 as f64 - (v + range) / range * ph)
            .round()
            .min((y1 - 1) as f64) as i64;
        c.fill_rect(bx1 + 1, y, bx1 + 1 + tick_len as i64, y + 1, INK);
        c.text(
            label,
            tick_size,
            bx1 as f64 + tick_len + gap,
            y as f64 + 0.5,
            HAlign::Left,
            VAlign::Center,
            false,
        )?;
    }
    c.text(
        "level (dB)",
        desc_size,
        w as f64 - pad - desc_h,
        top + ph / 2.0,
        HAlign::Left,
        VAlign::Center,
        true,
    )?;

    if let Some(t) = &title {
        t.draw(&mut c, left, pw, w, &st)?;
    }
    Ok(c)
}
