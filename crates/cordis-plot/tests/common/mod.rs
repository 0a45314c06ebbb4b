//! Helpers shared by the picture tests.
#![allow(dead_code)]

use std::path::Path;

/// The sample rate of the test signals.
pub const RATE: f64 = 48_000.0;

/// `seconds` of a unit sine at `freq` Hz, sampled at [`RATE`].
pub fn sine(freq: f64, seconds: f64) -> Vec<f64> {
    (0..(seconds * RATE) as usize)
        .map(|n| (std::f64::consts::TAU * freq * n as f64 / RATE).sin())
        .collect()
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
