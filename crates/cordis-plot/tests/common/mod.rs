//! Helpers shared by the picture tests.
#![allow(dead_code)]

use std::ops::Range;
use std::path::Path;

use cordis_plot::{spectrum, ModeMark, PlotError, Spectrum};

/// The sample rate of the test signals.
pub const RATE: f64 = 48_000.0;

/// Colours of the figures: the spectrum (first series), the predicted modes (second), then the
/// third, fourth and sixth series (the spectra of the lower panels of a comparison).
pub const BLUE: [u8; 3] = [0, 114, 178];
pub const VERMILION: [u8; 3] = [213, 94, 0];
pub const GREEN: [u8; 3] = [0, 158, 115];
pub const PURPLE: [u8; 3] = [204, 121, 167];
pub const SKY: [u8; 3] = [86, 180, 233];

/// `seconds` of a unit sine at `freq` Hz, sampled at [`RATE`].
pub fn sine(freq: f64, seconds: f64) -> Vec<f64> {
    (0..(seconds * RATE) as usize)
        .map(|n| (std::f64::consts::TAU * freq * n as f64 / RATE).sin())
        .collect()
}

/// The spectrum (8192-sample window) of half a second of unit sines at `freqs` Hz.
pub fn tones(freqs: &[f64]) -> Spectrum {
    let mut x = vec![0.0; 24_000];
    for f in freqs {
        for (s, v) in x.iter_mut().zip(sine(*f, 0.5)) {
            *s += v;
        }
    }
    spectrum(&x, RATE, 8192).unwrap()
}

/// A mode at `freq_hz` labelled with its frequency.
pub fn mode(freq_hz: f64, t60_s: f64) -> ModeMark {
    ModeMark {
        freq_hz,
        t60_s,
        label: Some(format!("{freq_hz}")),
    }
}

/// The message of a [`PlotError::BadOptions`], or a panic.
pub fn bad_message(result: Result<(), PlotError>) -> String {
    match result {
        Err(PlotError::BadOptions(msg)) => msg,
        other => panic!("expected BadOptions, got {other:?}"),
    }
}

/// Width and height from the IHDR chunk, after checking the PNG signature.
pub fn png_size(path: &Path) -> (u32, u32) {
    let bytes = std::fs::read(path).unwrap();
    assert_eq!(&bytes[..8], b"\x89PNG\r\n\x1a\n", "not a PNG");
    assert_eq!(&bytes[12..16], b"IHDR");
    let be = |i: usize| u32::from_be_bytes(bytes[i..i + 4].try_into().unwrap());
    (be(16), be(20))
}

/// Decodes a PNG to width, height and RGB bytes.
pub fn decode(path: &Path) -> (u32, u32, Vec<u8>) {
    let decoder = png::Decoder::new(std::fs::File::open(path).unwrap());
    let mut reader = decoder.read_info().unwrap();
    let mut buf = vec![0; reader.output_buffer_size()];
    let info = reader.next_frame(&mut buf).unwrap();
    assert_eq!(info.color_type, png::ColorType::Rgb);
    buf.truncate(info.buffer_size());
    (info.width, info.height, buf)
}

/// The folder holds exactly `count` files, none of them a hidden temporary.
pub fn only_pictures_left(dir: &Path, count: usize) {
    let names: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    assert_eq!(names.len(), count, "{names:?}");
    assert!(names.iter().all(|n| !n.starts_with('.')), "{names:?}");
}

/// A decoded RGB picture.
pub struct Picture {
    pub width: usize,
    pub height: usize,
    pub rgb: Vec<u8>,
}

impl Picture {
    pub fn open(path: &Path) -> Picture {
        let (width, height, rgb) = decode(path);
        Picture {
            width: width as usize,
            height: height as usize,
            rgb,
        }
    }

    pub fn at(&self, x: usize, y: usize) -> [u8; 3] {
        let i = (y * self.width + x) * 3;
        [self.rgb[i], self.rgb[i + 1], self.rgb[i + 2]]
    }

    /// How many pixels of colour `c` each column holds.
    pub fn column_counts(&self, c: [u8; 3]) -> Vec<usize> {
        self.column_counts_in(c, 0..self.height)
    }

    /// How many pixels of colour `c` each column holds within `rows`.
    pub fn column_counts_in(&self, c: [u8; 3], rows: Range<usize>) -> Vec<usize> {
        (0..self.width)
            .map(|x| rows.clone().filter(|&y| self.at(x, y) == c).count())
            .collect()
    }

    /// Whether a pixel is the blue of the first series, blended at least a quarter into paper.
    pub fn bluish(&self, x: usize, y: usize) -> bool {
        let [r, g, b] = self.at(x, y).map(i32::from);
        b > r + 60 && b > g + 15
    }

    /// Whether a pixel is colour `c` blended at least halfway into white paper.
    pub fn tinted(&self, x: usize, y: usize, c: [u8; 3]) -> bool {
        let p = self.at(x, y);
        let k = (0..3).max_by_key(|&k| 255 - c[k]).unwrap();
        let a = f64::from(255 - p[k]) / f64::from(255 - c[k]);
        a >= 0.5
            && (0..3).all(|j| {
                let expect = 255.0 - a * f64::from(255 - c[j]);
                (expect - f64::from(p[j])).abs() <= 12.0
            })
    }

    /// How many pixels are colour `c` blended at least halfway into white paper.
    pub fn count_tinted(&self, c: [u8; 3]) -> usize {
        (0..self.height)
            .map(|y| (0..self.width).filter(|&x| self.tinted(x, y, c)).count())
            .sum()
    }

    pub fn count(&self, c: [u8; 3]) -> usize {
        self.rgb.chunks(3).filter(|p| *p == c).count()
    }

    /// The left and right frame lines of the plots: the columns with the longest black runs.
    pub fn frame_columns(&self) -> (usize, usize) {
        let black = self.column_counts([0, 0, 0]);
        let tallest = *black.iter().max().unwrap();
        let tall: Vec<usize> = (0..self.width)
            .filter(|&x| black[x] * 10 >= tallest * 9)
            .collect();
        (*tall.first().unwrap(), *tall.last().unwrap())
    }

    /// The top and bottom frame lines of the plots, from the top: the rows black across at
    /// least nine tenths of the span between the frame columns.
    pub fn frame_rows(&self) -> Vec<usize> {
        let (left, right) = self.frame_columns();
        (0..self.height)
            .filter(|&y| {
                let black = (left..=right)
                    .filter(|&x| self.at(x, y) == [0, 0, 0])
                    .count();
                black * 10 >= (right - left + 1) * 9
            })
            .collect()
    }
}

/// Centres of the runs of columns holding at least `min` pixels of colour `c`.
pub fn runs(p: &Picture, c: [u8; 3], min: usize) -> Vec<f64> {
    runs_in(p, c, min, 0..p.height)
}

/// Centres of the runs of columns holding at least `min` pixels of colour `c` within `rows`.
pub fn runs_in(p: &Picture, c: [u8; 3], min: usize, rows: Range<usize>) -> Vec<f64> {
    let counts = p.column_counts_in(c, rows);
    let mut out = Vec::new();
    let mut start = None;
    for x in 0..=p.width {
        let on = counts.get(x).is_some_and(|&n| n >= min);
        match (on, start) {
            (true, None) => start = Some(x),
            (false, Some(s)) => {
                out.push((s + x - 1) as f64 / 2.0);
                start = None;
            }
            _ => {}
        }
    }
    out
}
