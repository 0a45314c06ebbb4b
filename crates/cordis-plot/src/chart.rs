//! Line charts: panels stacked above one another that share a frequency axis, each with its own
//! vertical axis, light grid, ticks and labels, and a legend placed in the emptiest corner.

use crate::canvas::{Canvas, HAlign, Layer, VAlign, INK, PAPER};
use crate::figure::{linear_axis, Style, Title};
use crate::ticks;
use crate::PlotError;

/// The Okabe-Ito colours (distinct for colour-blind readers too), in the order series use them.
pub(crate) const PALETTE: [[u8; 3]; 7] = [
    [0, 114, 178],   // blue
    [213, 94, 0],    // vermilion
    [0, 158, 115],   // bluish green
    [204, 121, 167], // reddish purple
    [230, 159, 0],   // orange
    [86, 180, 233],  // sky blue
    [90, 90, 90],    // grey
];
/// Grid lines at labelled ticks, and at the others.
const GRID: [u8; 3] = [221, 221, 221];
const GRID_MINOR: [u8; 3] = [241, 241, 241];
/// The line under the band of infinite values, and the legend's frame.
const RULE: [u8; 3] = [160, 160, 160];

/// Smallest and largest accepted picture sides for charts, in pixels.
const MIN_WIDTH: u32 = 320;
const MIN_HEIGHT: u32 = 240;
const MAX_SIDE: u32 = 16_384;

/// Checks the picture size of a chart.
pub(crate) fn check_size(width: u32, height: u32) -> Result<(), PlotError> {
    for (name, v, min) in [("width", width, MIN_WIDTH), ("height", height, MIN_HEIGHT)] {
        if !(min..=MAX_SIDE).contains(&v) {
            return Err(PlotError::BadOptions(format!(
                "{name} is {v} pixels; it must be between {min} and {MAX_SIDE} \
                 (the figure needs room for its panels, axes and labels)"
            )));
        }
    }
    Ok(())
}

/// A true minus sign, as in print.
fn minus(s: String) -> String {
    s.replace('-', "\u{2212}")
}

/// A plain number for a log-axis label: `0.05`, `2`, `300`.
fn plain(v: f64) -> String {
    minus(ticks::trim(v, ticks::decimals(v.abs())))
}

/// A mapping from values to `[0, 1]`, linear or logarithmic.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Scale {
    pub lo: f64,
    pub hi: f64,
    pub log: bool,
}

impl Scale {
    pub(crate) fn frac(&self, v: f64) -> f64 {
        if self.log {
            (v.log10() - self.lo.log10()) / (self.hi.log10() - self.lo.log10())
        } else {
            (v - self.lo) / (self.hi - self.lo)
        }
    }
}

/// Pixels `[x0, x1) x [y0, y1)`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Rect {
    pub x0: i64,
    pub y0: i64,
    pub x1: i64,
    pub y1: i64,
}

impl Rect {
    pub(crate) fn w(&self) -> f64 {
        (self.x1 - self.x0) as f64
    }
    pub(crate) fn h(&self) -> f64 {
        (self.y1 - self.y0) as f64
    }
    /// A layer that draws only inside this rectangle.
    pub(crate) fn layer(&self) -> Layer {
        Layer::new(self.x0, self.y0, self.x1, self.y1)
    }
}

/// What a panel's vertical axis shows.
#[derive(Debug, Clone, Copy)]
pub(crate) enum YAxis {
    /// Linear over exactly `[lo, hi]`.
    Linear { lo: f64, hi: f64 },
    /// Linear, widened to the nearest labelled ticks around `[lo, hi]`.
    LinearNice { lo: f64, hi: f64 },
    /// Logarithmic over `[lo, hi]` (both above 0).
    Log { lo: f64, hi: f64 },
    /// Degrees over [-180, 180], ticks every 90.
    Phase,
    /// No ticks (nothing finite to show), over [0, 1].
    Blank,
}

/// A panel to lay out.
pub(crate) struct PanelDef<'a> {
    /// Share of the height given to panels.
    pub weight: f64,
    pub y: YAxis,
    /// The vertical axis description, with its unit.
    pub label: &'a str,
    /// Keep a band at the top for infinite values, labelled ∞.
    pub inf_band: bool,
    /// Keep a strip above the panel for labels of its markers.
    pub strip: bool,
}

/// A laid-out panel.
pub(crate) struct Panel {
    /// The whole plotting area (data lines are clipped to it).
    pub rect: Rect,
    /// Where the vertical scale maps: `rect` less the band of infinite values.
    pub data: Rect,
    pub y: Scale,
    yt: Ticks,
    label: String,
    /// The top of the strip of marker labels above the panel, if one was asked for.
    pub strip_y: Option<f64>,
}

impl Panel {
    /// The vertical pixel coordinate of `v` (values outside the scale fall outside `data`).
    pub(crate) fn y_px(&self, v: f64) -> f64 {
        self.data.y1 as f64 - self.y.frac(v) * self.data.h()
    }

    /// The vertical pixel coordinate of the middle of the band of infinite values.
    pub(crate) fn inf_px(&self) -> f64 {
        (self.rect.y0 as f64 + self.data.y0 as f64) / 2.0
    }
}

/// How a legend entry is drawn.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Swatch {
    /// A horizontal line (a series).
    Line,
    /// A vertical line (a marker).
    Marker,
    /// An upward arrow head.
    Arrow,
}

/// One line of a legend.
pub(crate) struct Entry {
    pub label: String,
    pub colour: [u8; 3],
    pub swatch: Swatch,
}

/// A figure of stacked panels sharing a horizontal axis, laid out from measured text.
pub(crate) struct Chart {
    pub st: Style,
    width: usize,
    height: usize,
    pub x: Scale,
    xt: Ticks,
    x_label: String,
    pub panels: Vec<Panel>,
    title: Option<Title>,
}

/// The ticks of an axis: labelled values with their labels, and unlabelled values.
#[derive(Debug, Clone, Default)]
struct Ticks {
    major: Vec<f64>,
    labels: Vec<String>,
    minor: Vec<f64>,
}

/// Ticks of a vertical axis `len_px` long, and its scale.
type YTicks = (Ticks, Scale);

fn y_ticks(axis: YAxis, len_px: f64, st: &Style) -> Result<YTicks, PlotError> {
    let lh = st.label_h;
    let linear = |lo: f64, hi: f64| -> Result<YTicks, PlotError> {
        let (v, dec) = linear_axis(lo, hi, len_px, 1.2 * lh, |v, _| v.to_string(), |_| Ok(lh))?;
        let labels = v.iter().map(|x| minus(ticks::trim(*x, dec))).collect();
        let t = Ticks {
            major: v,
            labels,
            minor: Vec::new(),
        };
        Ok((t, Scale { lo, hi, log: false }))
    };
    match axis {
        YAxis::Linear { lo, hi } => linear(lo, hi),
        YAxis::LinearNice { lo, hi } => {
            let (t, _) = linear(lo, hi)?;
            let step = match t.major.as_slice() {
                [a, b, ..] => b - a,
                _ => ticks::nice_step(hi - lo, 4),
            };
            linear(
                (lo / step + 1e-9).floor() * step,
                (hi / step - 1e-9).ceil() * step,
            )
        }
        YAxis::Log { lo, hi } => {
            let per_decade = len_px / (hi.log10() - lo.log10());
            let (major, minor) = ticks::log_ticks(lo, hi, per_decade, 1.8 * lh);
            let labels = major.iter().map(|v| plain(*v)).collect();
            Ok((
                Ticks {
                    major,
                    labels,
                    minor,
                },
                Scale { lo, hi, log: true },
            ))
        }
        YAxis::Blank => Ok((
            Ticks::default(),
            Scale {
                lo: 0.0,
                hi: 1.0,
                log: false,
            },
        )),
        YAxis::Phase => {
            let v = vec![-180.0, -90.0, 0.0, 90.0, 180.0];
            let labels = v.iter().map(|x| minus(ticks::trim(*x, 0))).collect();
            let minor = if len_px / 8.0 >= 1.2 * lh {
                vec![-135.0, -45.0, 45.0, 135.0]
            } else {
                Vec::new()
            };
            Ok((
                Ticks {
                    major: v,
                    labels,
                    minor,
                },
                Scale {
                    lo: -180.0,
                    hi: 180.0,
                    log: false,
                },
            ))
        }
    }
}

/// Ticks of the horizontal frequency axis over `len_px` pixels: values, labels, minor values.
fn x_ticks(x: Scale, len_px: f64, st: &Style) -> Result<Ticks, PlotError> {
    let lh = st.label_h;
    if x.log {
        let per_decade = len_px / (x.hi.log10() - x.lo.log10());
        let mut gap = 2.0 * lh;
        loop {
            let (major, minor) = ticks::log_ticks(x.lo, x.hi, per_decade, gap);
            let labels: Vec<String> = major.iter().map(|f| ticks::hz(*f)).collect();
            let mut widest = 0.0f64;
            for l in &labels {
                widest = widest.max(st.label_w(l)?);
            }
            let need = widest + lh;
            if gap >= need {
                return Ok(Ticks {
                    major,
                    labels,
                    minor,
                });
            }
            gap = need;
        }
    } else {
        let (major, _) = linear_axis(
            x.lo,
            x.hi,
            len_px,
            2.5 * lh,
            |v, _| ticks::hz(v),
            |t| st.label_w(t),
        )?;
        let labels = major.iter().map(|f| minus(ticks::hz(*f))).collect();
        Ok(Ticks {
            major,
            labels,
            minor: Vec::new(),
        })
    }
}

/// The pixel column nearest to continuous coordinate `x`, kept inside `r`.
pub(crate) fn column(x: f64, r: &Rect) -> i64 {
    ((x - 0.5).round() as i64).clamp(r.x0, r.x1 - 1)
}

/// The pixel row nearest to continuous coordinate `y`, kept inside `r`.
fn row(y: f64, r: &Rect) -> i64 {
    ((y - 0.5).round() as i64).clamp(r.y0, r.y1 - 1)
}

impl Chart {
    /// Lays out a `width` x `height` figure: the title, the panels from top to bottom (each
    /// with an optional strip of marker labels above it), the shared horizontal axis `x`
    /// described by `x_label`.
    pub(crate) fn layout(
        width: u32,
        height: u32,
        title: Option<&str>,
        x: Scale,
        x_label: &str,
        defs: &[PanelDef<'_>],
    ) -> Result<Chart, PlotError> {
        let (w, h) = (width as usize, height as usize);
        // 1200 x 700 is the reference size.
        let st = Style::new(w, h, 1200.0, 700.0)?;
        let title = Title::fit(title, w, &st)?;
        let title_h = title.as_ref().map_or(0.0, |t| t.height);
        let strip_h = st.label_h + st.gap;
        let first_strip = defs.first().is_some_and(|d| d.strip);
        let no_room = || {
            PlotError::Draw(format!(
                "a {w} x {h} picture leaves no room for the plot beside its labels \
                 (hint: make it larger)"
            ))
        };

        // Vertical layout first: panel heights fix the vertical ticks, whose label widths fix
        // the left margin.
        let top =
            (st.pad + title_h + if first_strip { strip_h } else { 0.0 } + st.label_h / 2.0).round();
        let bottom = (st.tick_len + st.gap + st.label_h + st.gap + st.desc_h + st.pad).round();
        let between = (st.label_h + 2.0 * st.gap).round();
        let n = defs.len().max(1) as f64;
        // Strips above the lower panels sit below the gap between panels.
        let lower_strips = defs.iter().skip(1).filter(|d| d.strip).count() as f64;
        let avail = h as f64 - top - bottom - between * (n - 1.0) - strip_h * lower_strips;
        let band = (2.0 * st.label_h).round();
        let total: f64 = defs.iter().map(|d| d.weight).sum();
        let mut y = top;
        let mut placed = Vec::with_capacity(defs.len());
        let mut widest = 0.0f64;
        for (i, d) in defs.iter().enumerate() {
            let strip_y = match (d.strip, i) {
                (false, _) => None,
                (true, 0) => Some((st.pad + title_h).round()),
                (true, _) => {
                    // The strip follows the gap under the panel above; as above the first
                    // panel, its text starts half a label above the strip.
                    let strip_y = (y - st.label_h / 2.0).round();
                    y += strip_h;
                    Some(strip_y)
                }
            };
            let ph = if i + 1 == defs.len() {
                h as f64 - bottom - y
            } else {
                (avail * d.weight / total).round()
            };
            let dh = ph - if d.inf_band { band } else { 0.0 };
            let (desc_w, _) = crate::canvas::measure(d.label, st.desc_size)?;
            if dh < 24.0 || ph < desc_w as f64 {
                return Err(no_room());
            }
            let (yt, scale) = y_ticks(d.y, dh, &st)?;
            for l in &yt.labels {
                widest = widest.max(st.label_w(l)?);
            }
            if d.inf_band {
                widest = widest.max(st.label_w("\u{221e}")?);
            }
            placed.push((y, ph, dh, yt, scale, d.label, strip_y));
            y += ph + between;
        }
        let left = (st.pad + st.desc_h + st.gap + widest + st.gap + st.tick_len).round();

        // The right margin holds half of the last frequency label.
        let mut right = st.pad + 2.0 * st.label_h;
        let mut xt = x_ticks(x, w as f64 - left - right, &st)?;
        for _ in 0..2 {
            let mut half = 0.0f64;
            for l in &xt.labels {
                half = half.max(st.label_w(l)? / 2.0);
            }
            right = (st.pad + half).round();
            xt = x_ticks(x, w as f64 - left - right, &st)?;
        }
        let pw = w as f64 - left - right;
        if pw < 32.0 {
            return Err(no_room());
        }
        let (x0, x1) = (left as i64, (left + pw) as i64);
        let panels = placed
            .into_iter()
            .map(|(y, ph, dh, yt, scale, label, strip_y)| {
                let (y0, y1) = (y as i64, (y + ph) as i64);
                Panel {
                    rect: Rect { x0, y0, x1, y1 },
                    data: Rect {
                        x0,
                        y0: y1 - dh as i64,
                        x1,
                        y1,
                    },
                    y: scale,
                    yt,
                    label: label.to_string(),
                    strip_y,
                }
            })
            .collect();
        Ok(Chart {
            st,
            width: w,
            height: h,
            x,
            xt,
            x_label: x_label.to_string(),
            panels,
            title,
        })
    }

    /// A blank canvas of the figure's size.
    pub(crate) fn canvas(&self) -> Canvas {
        Canvas::new(self.width, self.height, PAPER)
    }

    /// The horizontal pixel coordinate of `v` (continuous; outside the panels when `v` is out of
    /// range).
    pub(crate) fn x_px(&self, v: f64) -> f64 {
        let r = match self.panels.first() {
            Some(p) => p.rect,
            None => return 0.0,
        };
        r.x0 as f64 + self.x.frac(v) * r.w()
    }

    /// Grids, frames, ticks, labels and title: everything but the data.
    pub(crate) fn draw_axes(&self, c: &mut Canvas) -> Result<(), PlotError> {
        let st = &self.st;
        let tick = st.tick_len as i64;
        let minor_tick = (st.tick_len * 0.6).round() as i64;
        for p in &self.panels {
            let r = p.rect;
            // Grid: minor lines first so that the labelled ones stay on top.
            for (values, colour) in [(&self.xt.minor, GRID_MINOR), (&self.xt.major, GRID)] {
                for v in values {
                    let x = column(self.x_px(*v), &r);
                    c.fill_rect(x, r.y0, x + 1, r.y1, colour);
                }
            }
            for (values, colour) in [(&p.yt.minor, GRID_MINOR), (&p.yt.major, GRID)] {
                for v in values {
                    let y = row(p.y_px(*v), &p.data);
                    c.fill_rect(r.x0, y, r.x1, y + 1, colour);
                }
            }
            c.frame(r.x0, r.y0, r.x1, r.y1, INK);
            // Frequency ticks under every panel; labels under the last one only.
            for (values, len) in [(&self.xt.major, tick), (&self.xt.minor, minor_tick)] {
                for v in values {
                    let x = column(self.x_px(*v), &r);
                    c.fill_rect(x, r.y1 + 1, x + 1, r.y1 + 1 + len, INK);
                }
            }
            for (values, len) in [(&p.yt.major, tick), (&p.yt.minor, minor_tick)] {
                for v in values {
                    let y = row(p.y_px(*v), &p.data);
                    c.fill_rect(r.x0 - 1 - len, y, r.x0 - 1, y + 1, INK);
                }
            }
            for (v, label) in p.yt.major.iter().zip(&p.yt.labels) {
                let y = row(p.y_px(*v), &p.data);
                c.text(
                    label,
                    st.tick_size,
                    r.x0 as f64 - st.tick_len - st.gap,
                    y as f64 + 0.5,
                    HAlign::Right,
                    VAlign::Center,
                    false,
                )?;
            }
            if p.data.y0 > r.y0 {
                // The band of infinite values, under a dashed rule.
                let y = p.data.y0 - 1;
                let dash = (4.0 * st.s).round().max(2.0) as i64;
                let mut x = r.x0;
                while x < r.x1 {
                    c.fill_rect(x, y, (x + dash).min(r.x1), y + 1, RULE);
                    x += 2 * dash;
                }
                let yi = row(p.inf_px(), &r);
                c.fill_rect(r.x0 - 1 - tick, yi, r.x0 - 1, yi + 1, INK);
                c.text(
                    "\u{221e}",
                    st.tick_size,
                    r.x0 as f64 - st.tick_len - st.gap,
                    yi as f64 + 0.5,
                    HAlign::Right,
                    VAlign::Center,
                    false,
                )?;
            }
            c.text(
                &p.label,
                st.desc_size,
                st.pad,
                (r.y0 + r.y1) as f64 / 2.0,
                HAlign::Left,
                VAlign::Center,
                true,
            )?;
        }
        let Some(last) = self.panels.last() else {
            return Ok(());
        };
        let r = last.rect;
        // Frequency labels, skipping any that would touch the one before.
        let mut free_from = f64::NEG_INFINITY;
        for (v, label) in self.xt.major.iter().zip(&self.xt.labels) {
            let x = column(self.x_px(*v), &r) as f64 + 0.5;
            let lw = st.label_w(label)?;
            if x - lw / 2.0 < free_from {
                continue;
            }
            free_from = x + lw / 2.0 + st.gap;
            c.text(
                label,
                st.tick_size,
                x,
                r.y1 as f64 + st.tick_len + st.gap,
                HAlign::Center,
                VAlign::Top,
                false,
            )?;
        }
        c.text(
            &self.x_label,
            st.desc_size,
            (r.x0 + r.x1) as f64 / 2.0,
            self.height as f64 - st.pad - st.desc_h,
            HAlign::Center,
            VAlign::Top,
            false,
        )?;
        if let Some(t) = &self.title {
            t.draw(c, r.x0 as f64, r.w(), self.width, st)?;
        }
        Ok(())
    }

    /// Draws a legend inside panel `panel`, in whichever corner covers the least of what is
    /// already drawn there. A legend too large for the panel is left out.
    pub(crate) fn legend(
        &self,
        c: &mut Canvas,
        panel: usize,
        entries: &[Entry],
    ) -> Result<(), PlotError> {
        let (Some(p), false) = (self.panels.get(panel), entries.is_empty()) else {
            return Ok(());
        };
        let st = &self.st;
        let inset = (8.0 * st.s).round();
        let row_h = (1.35 * st.label_h).round();
        let sw = (30.0 * st.s).round();
        let mut text_w = 0.0f64;
        for e in entries {
            text_w = text_w.max(st.label_w(&e.label)?);
        }
        let bw = (inset + sw + st.gap + text_w + inset).round() as i64;
        let bh = (inset * 2.0 + row_h * entries.len() as f64).round() as i64;
        let r = p.rect;
        let margin = (st.gap + 2.0).round() as i64;
        if bw + 2 * margin > r.x1 - r.x0 || bh + 2 * margin > r.y1 - r.y0 {
            return Ok(());
        }
        let (left, right) = (r.x0 + margin, r.x1 - margin - bw);
        let (upper, lower) = (r.y0 + margin, r.y1 - margin - bh);
        let corners = [(right, upper), (left, upper), (right, lower), (left, lower)];
        let busy = |bx: i64, by: i64| {
            let mut n = 0usize;
            for y in by - 1..by + bh + 1 {
                for x in bx - 1..bx + bw + 1 {
                    let i = (y as usize * c.width + x as usize) * 3;
                    let px = [c.rgb[i], c.rgb[i + 1], c.rgb[i + 2]];
                    if px != PAPER && px != GRID && px != GRID_MINOR && px != RULE {
                        n += 1;
                    }
                }
            }
            n
        };
        let mut best = corners[0];
        let mut best_n = usize::MAX;
        for (bx, by) in corners {
            let n = busy(bx, by);
            if n < best_n {
                (best, best_n) = ((bx, by), n);
            }
        }
        let (bx, by) = best;
        c.fill_rect(bx, by, bx + bw, by + bh, PAPER);
        c.frame(bx, by, bx + bw, by + bh, RULE);
        let lw = line_width(st);
        for (i, e) in entries.iter().enumerate() {
            let cy = by as f64 + inset + row_h * (i as f64 + 0.5);
            let sx0 = bx as f64 + inset;
            let sx1 = sx0 + sw;
            let mut layer = Layer::new(bx, by, bx + bw, by + bh);
            let half = row_h * 0.4;
            match e.swatch {
                Swatch::Line => layer.segment((sx0, cy), (sx1, cy), lw),
                Swatch::Marker => {
                    let x = ((sx0 + sx1) / 2.0).floor();
                    let mw = marker_width(st) as f64;
                    c.fill_rect(
                        x as i64,
                        (cy - half) as i64,
                        (x + mw) as i64,
                        (cy + half) as i64,
                        e.colour,
                    );
                }
                Swatch::Arrow => {
                    let x = ((sx0 + sx1) / 2.0).floor() + 0.5;
                    layer.segment((x, cy + half), (x, cy - half * 0.5), stem_width(st));
                    arrow_head(&mut layer, x, cy - half, st);
                }
            }
            layer.paint(c, e.colour);
            c.text(
                &e.label,
                st.tick_size,
                sx1 + st.gap,
                cy,
                HAlign::Left,
                VAlign::Center,
                false,
            )?;
        }
        Ok(())
    }
}

/// Width of a data line in pixels.
pub(crate) fn line_width(st: &Style) -> f64 {
    (1.6 * st.s).max(1.25)
}

/// Width of a marker line in whole pixels.
pub(crate) fn marker_width(st: &Style) -> i64 {
    st.s.round().max(1.0) as i64
}

/// Width of a stem, and the radius of the dot on top.
pub(crate) fn stem_width(st: &Style) -> f64 {
    (2.0 * st.s).max(1.0)
}
pub(crate) fn dot_radius(st: &Style) -> f64 {
    (4.0 * st.s).max(2.0)
}

/// An upward arrow head with its tip at `(x, tip)`.
pub(crate) fn arrow_head(layer: &mut Layer, x: f64, tip: f64, st: &Style) {
    let (hw, hh) = (5.0 * st.s, 9.0 * st.s);
    layer.triangle([(x, tip), (x - hw, tip + hh), (x + hw, tip + hh)]);
}

/// Keeps at most four points per pixel column (the first, lowest, highest and last, in order),
/// which draws the same line as all of them; `points` are in pixels, by increasing x.
pub(crate) fn decimate(points: &[(f64, f64)]) -> Vec<(f64, f64)> {
    let mut out = Vec::with_capacity(points.len().min(8192));
    let mut i = 0;
    while i < points.len() {
        let col = points[i].0.floor();
        let mut j = i;
        while j < points.len() && points[j].0.floor() == col {
            j += 1;
        }
        let group = &points[i..j];
        if group.len() <= 4 {
            out.extend_from_slice(group);
        } else {
            let (mut lo, mut hi) = (0, 0);
            for (k, p) in group.iter().enumerate() {
                if p.1 < group[lo].1 {
                    lo = k;
                }
                if p.1 > group[hi].1 {
                    hi = k;
                }
            }
            let mut keep = [0, lo.min(hi), lo.max(hi), group.len() - 1];
            keep.sort_unstable();
            let mut last = usize::MAX;
            for k in keep {
                if k != last {
                    out.push(group[k]);
                    last = k;
                }
            }
        }
        i = j;
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn decimation_keeps_extremes_in_order() {
        let pts: Vec<(f64, f64)> = (0..100)
            .map(|i| (10.0 + i as f64 / 100.0, ((i * 37) % 11) as f64))
            .collect();
        let d = decimate(&pts);
        assert!(d.len() <= 4);
        assert_eq!(d[0], pts[0]);
        assert_eq!(*d.last().unwrap_or(&(0.0, 0.0)), pts[99]);
        assert!(d.iter().any(|p| p.1 == 0.0) && d.iter().any(|p| p.1 == 10.0));
        let sparse = [(1.0, 1.0), (2.5, 3.0)];
        assert_eq!(decimate(&sparse), sparse.to_vec());
    }

    #[test]
    fn layers_clip_and_cover() {
        let mut layer = Layer::new(10, 10, 20, 20);
        layer.segment((0.0, 15.0), (30.0, 15.0), 2.0);
        let mut c = Canvas::new(30, 30, PAPER);
        layer.paint(&mut c, INK);
        let at = |c: &Canvas, x: usize, y: usize| c.rgb[(y * 30 + x) * 3];
        assert_eq!(at(&c, 15, 15), 0, "inside the line");
        assert_eq!(at(&c, 5, 15), 255, "clipped");
        assert_eq!(at(&c, 15, 12), 255, "off the line");
    }
}
