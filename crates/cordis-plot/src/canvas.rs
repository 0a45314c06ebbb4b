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
