//! What every figure shares: text sizes and spacing scaled to the picture, the title, linear
//! tick selection from measured labels, and writing the PNG safely.

use std::fs;
use std::path::{Path, PathBuf};

use crate::canvas::{measure, Canvas, HAlign, VAlign};
use crate::ticks;
use crate::PlotError;

/// Text sizes and spacing in pixels, scaled with the picture.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Style {
    /// The scale factor (1 at the figure's reference size).
    pub s: f64,
    /// Tick labels and legends.
    pub tick_size: f64,
    /// Axis descriptions.
    pub desc_size: f64,
    pub pad: f64,
    pub gap: f64,
    pub tick_len: f64,
    /// Heights of a line of tick-label and description text.
    pub label_h: f64,
    pub desc_h: f64,
}

impl Style {
    /// The style of a `w` x `h` picture whose reference size is `ref_w` x `ref_h`.
    pub(crate) fn new(w: usize, h: usize, ref_w: f64, ref_h: f64) -> Result<Style, PlotError> {
        let s = (w as f64 / ref_w).min(h as f64 / ref_h).clamp(0.5, 4.0);
        let tick_size = 16.0 * s;
        let desc_size = 18.0 * s;
        Ok(Style {
            s,
            tick_size,
            desc_size,
            pad: (10.0 * s).round(),
            gap: (6.0 * s).round(),
            tick_len: (6.0 * s).round().max(2.0),
            label_h: measure("0123456789", tick_size)?.1 as f64,
            desc_h: measure("time (s)", desc_size)?.1 as f64,
        })
    }

    /// Width in pixels of a tick label.
    pub(crate) fn label_w(&self, text: &str) -> Result<f64, PlotError> {
        Ok(measure(text, self.tick_size)?.0 as f64)
    }
}

/// A title fitted to the picture's width.
#[derive(Debug, Clone)]
pub(crate) struct Title {
    text: String,
    size: f64,
    width: f64,
    /// Height taken above the plot, including the gap below the text.
    pub height: f64,
}

impl Title {
    /// The trimmed title, if any, set smaller when too long for a `w`-pixel picture rather than
    /// cut.
    pub(crate) fn fit(
        title: Option<&str>,
        w: usize,
        st: &Style,
    ) -> Result<Option<Title>, PlotError> {
        let Some(text) = title.map(str::trim).filter(|t| !t.is_empty()) else {
            return Ok(None);
        };
        let mut size = 21.0 * st.s;
        let room = w as f64 - 2.0 * st.pad;
        let tw = measure(text, size)?.0 as f64;
        if tw > room {
            size = (size * room / tw).max(6.0);
        }
        let (width, height) = measure(text, size)?;
        Ok(Some(Title {
            text: text.to_string(),
            size,
            width: width as f64,
            height: height as f64 + st.gap,
        }))
    }

    /// Draws the title at the top: centred over the plot (from `left`, `pw` wide) when it fits
    /// there, else over the whole `w`-pixel picture.
    pub(crate) fn draw(
        &self,
        c: &mut Canvas,
        left: f64,
        pw: f64,
        w: usize,
        st: &Style,
    ) -> Result<(), PlotError> {
        let centre = if self.width < pw {
            left + pw / 2.0
        } else {
            w as f64 / 2.0
        };
        c.text(
            &self.text,
            self.size,
            centre,
            st.pad,
            HAlign::Center,
            VAlign::Top,
            false,
        )
    }
}

/// Linear ticks over `[lo, hi]` drawn on `len_px` pixels: the finest 1-2-5 step whose labels
/// (from `label`) keep `min_gap_px` plus their own extent (`extent`) apart.
pub(crate) fn linear_axis(
    lo: f64,
    hi: f64,
    len_px: f64,
    min_gap_px: f64,
    label: impl Fn(f64, usize) -> String,
    extent: impl Fn(&str) -> Result<f64, PlotError>,
) -> Result<(Vec<f64>, usize), PlotError> {
    let span = hi - lo;
    let mut target = ((len_px / min_gap_px).floor() as usize).max(1);
    loop {
        let step = ticks::nice_step(span, target);
        let dec = ticks::decimals(step);
        let values = ticks::linear_ticks(lo, hi, step);
        let mut widest = 0.0f64;
        for v in &values {
            widest = widest.max(extent(&label(*v, dec))?);
        }
        let spacing = step / span * len_px;
        if spacing >= widest + min_gap_px || target == 1 {
            return Ok((values, dec));
        }
        target -= 1;
    }
}

/// Checks that `path` names a file in an existing folder, draws the figure, and writes it into
/// a hidden temporary beside `path` that is renamed into place once complete (a device, pipe or
/// other special file that already exists is written in place instead).
pub(crate) fn save(
    path: &Path,
    draw: impl FnOnce() -> Result<Canvas, PlotError>,
) -> Result<(), PlotError> {
    let name = path.file_name().ok_or_else(|| {
        PlotError::Draw(format!(
            "{} names no file (hint: give a path such as figure.png)",
            path.display()
        ))
    })?;
    let dir = match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
        _ => PathBuf::from("."),
    };
    if !dir.is_dir() {
        return Err(PlotError::Draw(format!(
            "cannot write {}: the folder {} does not exist (hint: create it first)",
            path.display(),
            dir.display()
        )));
    }
    let canvas = draw()?;
    // A device, pipe or other special file (`/dev/stdout`) is written in place: renaming a
    // temporary over it would replace it.
    if fs::metadata(path).is_ok_and(|m| !m.is_file()) {
        return encode(&canvas, path);
    }
    let tmp = dir.join(format!(
        ".{}.{}.partial.png",
        name.to_string_lossy(),
        std::process::id()
    ));
    let written = encode(&canvas, &tmp).and_then(|()| {
        fs::rename(&tmp, path).map_err(|e| {
            PlotError::Draw(format!(
                "cannot write {}: {e} (hint: check the folder is writable)",
                path.display()
            ))
        })
    });
    if written.is_err() {
        let _ = fs::remove_file(&tmp);
    }
    written
}

fn encode(canvas: &Canvas, file: &Path) -> Result<(), PlotError> {
    let fail = |e: &dyn std::fmt::Display| {
        PlotError::Draw(format!(
            "cannot write {}: {e} (hint: check the folder is writable)",
            file.display()
        ))
    };
    let out = fs::File::create(file).map_err(|e| fail(&e))?;
    let mut encoder = png::Encoder::new(
        std::io::BufWriter::new(out),
        canvas.width as u32,
        canvas.height as u32,
    );
    encoder.set_color(png::ColorType::Rgb);
    encoder.set_depth(png::BitDepth::Eight);
    encoder.set_compression(png::Compression::Best);
    let mut writer = encoder.write_header().map_err(|e| fail(&e))?;
    writer.write_image_data(&canvas.rgb).map_err(|e| fail(&e))?;
    writer.finish().map_err(|e| fail(&e))
}
