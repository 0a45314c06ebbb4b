//! An RGB pixel buffer with the few primitives a figure needs, and text in the embedded
//! DejaVu Sans (laid out with kerning and side bearings, anti-aliased).

use std::sync::OnceLock;

use ab_glyph::{point, Font, FontRef, PxScale, ScaleFont};

use crate::PlotError;

/// Colour of text, axes and ticks.
pub(crate) const INK: [u8; 3] = [0, 0, 0];
/// Figure background.
pub(crate) const PAPER: [u8; 3] = [255, 255, 255];

/// The embedded DejaVu Sans, parsed once per process.
fn font() -> Result<&'static FontRef<'static>, PlotError> {
    static FONT: OnceLock<Option<FontRef<'static>>> = OnceLock::new();
    FONT.get_or_init(|| FontRef::try_from_slice(dejavu::sans::regular()).ok())
        .as_ref()
        .ok_or_else(|| PlotError::Draw("the embedded DejaVu Sans font could not be read".into()))
}

/// Horizontal anchor of a text box.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum HAlign {
    Left,
    Center,
    Right,
}

/// Vertical anchor of a text box (the box spans the font's ascent to descent).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum VAlign {
    Top,
    Center,
}

/// A line of text rasterised to coverage values, before placement.
pub(crate) struct TextImage {
    pub width: usize,
    pub height: usize,
    coverage: Vec<f32>,
}

impl TextImage {
    /// Lays out and rasterises `text` at a line height of `size` pixels.
    pub(crate) fn new(text: &str, size: f64) -> Result<TextImage, PlotError> {
        let font = font()?;
        let scaled = font.as_scaled(PxScale::from(size as f32));
        let ascent = scaled.ascent();
        // First pass: pen positions.
        let mut pen = 0.0f32;
        let mut prev = None;
        let mut placed = Vec::with_capacity(text.len());
        for c in text.chars() {
            let id = scaled.glyph_id(c);
            if let Some(p) = prev {
                pen += scaled.kern(p, id);
            }
            placed.push(id.with_scale_and_position(scaled.scale(), point(pen, ascent)));
            pen += scaled.h_advance(id);
            prev = Some(id);
        }
        let width = pen.ceil().max(1.0) as usize + 1;
        let height = (ascent - scaled.descent()).ceil().max(1.0) as usize;
        let mut coverage = vec![0.0f32; width * height];
        for glyph in placed {
            if let Some(outline) = scaled.outline_glyph(glyph) {
                let b = outline.px_bounds();
                outline.draw(|gx, gy, cov| {
                    let x = b.min.x as i64 + i64::from(gx);
                    let y = b.min.y as i64 + i64::from(gy);
                    if (0..width as i64).contains(&x) && (0..height as i64).contains(&y) {
                        let c = &mut coverage[y as usize * width + x as usize];
                        *c = (*c + cov).min(1.0);
                    }
                });
            }
        }
        Ok(TextImage {
            width,
            height,
            coverage,
        })
    }
}

/// Width and height in pixels of `text` at line height `size`.
pub(crate) fn measure(text: &str, size: f64) -> Result<(usize, usize), PlotError> {
    let t = TextImage::new(text, size)?;
    Ok((t.width, t.height))
}

/// An RGB image, row-major, 3 bytes a pixel (the layout a PNG of colour type RGB stores).
pub(crate) struct Canvas {
    pub width: usize,
    pub height: usize,
    pub rgb: Vec<u8>,
}

impl Canvas {
    pub(crate) fn new(width: usize, height: usize, fill: [u8; 3]) -> Canvas {
        let mut rgb = Vec::with_capacity(width * height * 3);
        for _ in 0..width * height {
            rgb.extend_from_slice(&fill);
        }
        Canvas { width, height, rgb }
    }

    /// Sets a pixel; outside the canvas does nothing.
    pub(crate) fn set(&mut self, x: i64, y: i64, c: [u8; 3]) {
        self.blend(x, y, c, 1.0);
    }

    /// Mixes `c` into a pixel with opacity `a` in [0, 1].
    pub(crate) fn blend(&mut self, x: i64, y: i64, c: [u8; 3], a: f32) {
        if x < 0 || y < 0 || x >= self.width as i64 || y >= self.height as i64 || a <= 0.0 {
            return;
        }
        let i = (y as usize * self.width + x as usize) * 3;
        let a = a.min(1.0);
        for (d, s) in self.rgb[i..i + 3].iter_mut().zip(c) {
            *d = (f32::from(*d) * (1.0 - a) + f32::from(s) * a).round() as u8;
        }
    }

    /// Fills the rectangle `[x0, x1) x [y0, y1)`.
    pub(crate) fn fill_rect(&mut self, x0: i64, y0: i64, x1: i64, y1: i64, c: [u8; 3]) {
        for y in y0..y1 {
            for x in x0..x1 {
                self.set(x, y, c);
            }
        }
    }

    /// A one-pixel outline just outside the rectangle `[x0, x1) x [y0, y1)`.
    pub(crate) fn frame(&mut self, x0: i64, y0: i64, x1: i64, y1: i64, c: [u8; 3]) {
        self.fill_rect(x0 - 1, y0 - 1, x1 + 1, y0, c);
        self.fill_rect(x0 - 1, y1, x1 + 1, y1 + 1, c);
        self.fill_rect(x0 - 1, y0, x0, y1, c);
        self.fill_rect(x1, y0, x1 + 1, y1, c);
    }

    /// Draws `text` anchored at `(x, y)`; `rotated` turns it a quarter turn anticlockwise (to
    /// read upwards, as a vertical axis label), the anchors then applying to the turned box.
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn text(
        &mut self,
        text: &str,
        size: f64,
        x: f64,
        y: f64,
        h: HAlign,
        v: VAlign,
        rotated: bool,
    ) -> Result<(), PlotError> {
        let img = TextImage::new(text, size)?;
        let (bw, bh) = if rotated {
            (img.height, img.width)
        } else {
            (img.width, img.height)
        };
        let x0 = match h {
            HAlign::Left => x,
            HAlign::Center => x - bw as f64 / 2.0,
            HAlign::Right => x - bw as f64,
        }
        .round() as i64;
        let y0 = match v {
            VAlign::Top => y,
            VAlign::Center => y - bh as f64 / 2.0,
        }
        .round() as i64;
        for ly in 0..img.height {
            for lx in 0..img.width {
                let a = img.coverage[ly * img.width + lx];
                if a <= 0.0 {
                    continue;
                }
                let (dx, dy) = if rotated {
                    (ly, img.width - 1 - lx)
                } else {
                    (lx, ly)
                };
                self.blend(x0 + dx as i64, y0 + dy as i64, INK, a);
            }
        }
        Ok(())
    }
}

/// Anti-aliased coverage over a clip rectangle, painted in one colour once complete, so that the
/// segments of one line do not darken where they meet and nothing spills out of the plot.
pub(crate) struct Layer {
    x0: i64,
    y0: i64,
    width: usize,
    height: usize,
    coverage: Vec<f32>,
}

impl Layer {
    /// An empty layer clipped to `[x0, x1) x [y0, y1)`.
    pub(crate) fn new(x0: i64, y0: i64, x1: i64, y1: i64) -> Layer {
        let width = (x1 - x0).max(0) as usize;
        let height = (y1 - y0).max(0) as usize;
        Layer {
            x0,
            y0,
            width,
            height,
            coverage: vec![0.0; width * height],
        }
    }

    /// Visits the pixels of the layer inside the box `[xa, xb] x [ya, yb]` (continuous
    /// coordinates), calling `cov` with each pixel centre and keeping the largest coverage.
    fn shade(&mut self, xa: f64, ya: f64, xb: f64, yb: f64, cov: impl Fn(f64, f64) -> f64) {
        let (w, h) = (self.width as i64, self.height as i64);
        let px0 = ((xa.floor() as i64) - self.x0).clamp(0, w);
        let px1 = ((xb.ceil() as i64) - self.x0 + 1).clamp(0, w);
        let py0 = ((ya.floor() as i64) - self.y0).clamp(0, h);
        let py1 = ((yb.ceil() as i64) - self.y0 + 1).clamp(0, h);
        for py in py0..py1 {
            let cy = (self.y0 + py) as f64 + 0.5;
            for px in px0..px1 {
                let cx = (self.x0 + px) as f64 + 0.5;
                let a = cov(cx, cy).clamp(0.0, 1.0) as f32;
                let c = &mut self.coverage[py as usize * self.width + px as usize];
                *c = c.max(a);
            }
        }
    }

    /// A straight line from `a` to `b`, `width` pixels thick, with round ends.
    pub(crate) fn segment(&mut self, a: (f64, f64), b: (f64, f64), width: f64) {
        let hw = width / 2.0;
        let (dx, dy) = (b.0 - a.0, b.1 - a.1);
        let len2 = dx * dx + dy * dy;
        let reach = hw + 1.0;
        self.shade(
            a.0.min(b.0) - reach,
            a.1.min(b.1) - reach,
            a.0.max(b.0) + reach,
            a.1.max(b.1) + reach,
            |x, y| {
                let t = if len2 > 0.0 {
                    (((x - a.0) * dx + (y - a.1) * dy) / len2).clamp(0.0, 1.0)
                } else {
                    0.0
                };
                let (ex, ey) = (x - a.0 - t * dx, y - a.1 - t * dy);
                hw + 0.5 - (ex * ex + ey * ey).sqrt()
            },
        );
    }

    /// Connected segments through `points`.
    pub(crate) fn polyline(&mut self, points: &[(f64, f64)], width: f64) {
        if let [p] = points {
            self.segment(*p, *p, width);
        }
        for pair in points.windows(2) {
            self.segment(pair[0], pair[1], width);
        }
    }

    /// A filled disc.
    pub(crate) fn disc(&mut self, centre: (f64, f64), radius: f64) {
        let (cx, cy) = centre;
        let reach = radius + 1.0;
        self.shade(cx - reach, cy - reach, cx + reach, cy + reach, |x, y| {
            radius + 0.5 - ((x - cx).powi(2) + (y - cy).powi(2)).sqrt()
        });
    }

    /// A filled triangle (any winding).
    pub(crate) fn triangle(&mut self, p: [(f64, f64); 3]) {
        let area = (p[1].0 - p[0].0) * (p[2].1 - p[0].1) - (p[2].0 - p[0].0) * (p[1].1 - p[0].1);
        if area == 0.0 {
            return;
        }
        let sign = area.signum();
        // Outward distance from each edge; the largest is the distance outside the shape.
        let edges: Vec<(f64, f64, f64)> = (0..3)
            .map(|i| {
                let (a, b) = (p[i], p[(i + 1) % 3]);
                let (nx, ny) = (sign * (b.1 - a.1), -sign * (b.0 - a.0));
                let n = (nx * nx + ny * ny).sqrt();
                (nx / n, ny / n, -(nx * a.0 + ny * a.1) / n)
            })
            .collect();
        let xs = p.iter().map(|q| q.0);
        let ys = p.iter().map(|q| q.1);
        let (xa, xb) = (
            xs.clone().fold(f64::MAX, f64::min),
            xs.fold(f64::MIN, f64::max),
        );
        let (ya, yb) = (
            ys.clone().fold(f64::MAX, f64::min),
            ys.fold(f64::MIN, f64::max),
        );
        self.shade(xa - 1.0, ya - 1.0, xb + 1.0, yb + 1.0, |x, y| {
            let outside = edges
                .iter()
                .map(|(nx, ny, c)| nx * x + ny * y + c)
                .fold(f64::MIN, f64::max);
            0.5 - outside
        });
    }

    /// Blends the layer into `canvas` in colour `c`.
    pub(crate) fn paint(&self, canvas: &mut Canvas, c: [u8; 3]) {
        for (i, &a) in self.coverage.iter().enumerate() {
            if a > 0.0 {
                let (px, py) = (i % self.width, i / self.width);
                canvas.blend(self.x0 + px as i64, self.y0 + py as i64, c, a);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn text_has_ink_and_sensible_size() {
        let t = TextImage::new("time (s)", 16.0).expect("font");
        assert!(t.width > 40 && t.width < 90, "width {}", t.width);
        assert!(t.height >= 15 && t.height <= 17, "height {}", t.height);
        let ink: f32 = t.coverage.iter().sum();
        assert!(ink > 50.0);
        let mut c = Canvas::new(100, 40, PAPER);
        c.text("Hz", 16.0, 50.0, 20.0, HAlign::Center, VAlign::Center, true)
            .expect("draw");
        assert!(c.rgb.iter().any(|&b| b < 128));
    }
}
