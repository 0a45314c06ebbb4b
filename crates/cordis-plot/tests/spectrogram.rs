//! Spectrogram numbers and PNG figures.
#![allow(clippy::unwrap_used)]

mod common;
use common::*;

use std::f64::consts::PI;
use std::path::Path;

use cordis_plot::{
    spectrogram, spectrogram_png, PlotError, SpectrogramOptions, FLOOR_DB, MAX_FRAMES,
};

fn peak_hz(freqs: &[f64], frame: &[f64]) -> f64 {
    let (k, _) = frame
        .iter()
        .enumerate()
        .fold((0, f64::NEG_INFINITY), |best, (k, &v)| {
            if v > best.1 {
                (k, v)
            } else {
                best
            }
        });
    freqs[k]
}

fn bad_message(result: Result<cordis_plot::Spectrogram, PlotError>) -> String {
    match result {
        Err(PlotError::BadOptions(msg)) => msg,
        other => panic!("expected BadOptions, got {other:?}"),
    }
}

#[test]
fn sine_peaks_at_its_frequency_in_every_frame() {
    let x = sine(1000.0, 1.0);
    let opts = SpectrogramOptions::default();
    let spec = spectrogram(&x, RATE, &opts).unwrap();
    let df = RATE / opts.window as f64;
    assert_eq!(spec.freqs_hz.len(), opts.window / 2 + 1);
    assert_eq!(spec.times_s.len(), spec.db.len());
    assert_eq!(spec.times_s.len(), x.len() / opts.hop + 1);
    for (t, frame) in spec.times_s.iter().zip(&spec.db) {
        assert_eq!(frame.len(), spec.freqs_hz.len());
        let f = peak_hz(&spec.freqs_hz, frame);
        assert!((f - 1000.0).abs() <= df, "frame at {t} s peaks at {f} Hz");
    }
    let max = spec.db.iter().flatten().copied().fold(f64::MIN, f64::max);
    assert_eq!(max, 0.0, "the loudest bin is the 0 dB reference");
    assert!(spec.db.iter().flatten().all(|v| *v >= FLOOR_DB));
}

#[test]
fn two_tones_show_up_in_their_own_frames() {
    let mut x = sine(500.0, 1.0);
    x.extend(sine(3000.0, 1.0));
    let spec = spectrogram(&x, RATE, &SpectrogramOptions::default()).unwrap();
    let df = RATE / 2048.0;
    let bin_of = |f: f64| {
        spec.freqs_hz
            .iter()
            .position(|&g| (g - f).abs() <= df / 2.0)
            .unwrap()
    };
    let (b500, b3000) = (bin_of(500.0), bin_of(3000.0));
    let (mut early, mut late) = (0, 0);
    for (t, frame) in spec.times_s.iter().zip(&spec.db) {
        // Frames whose window lies within one tone (the ends of the signal are clicks).
        if *t < 0.97 {
            early += 1;
            assert!(
                (peak_hz(&spec.freqs_hz, frame) - 500.0).abs() <= df,
                "at {t} s"
            );
            assert!(
                frame[b3000] < -60.0,
                "3 kHz already at {t} s: {} dB",
                frame[b3000]
            );
        } else if *t > 1.03 && *t < 1.97 {
            late += 1;
            assert!(
                (peak_hz(&spec.freqs_hz, frame) - 3000.0).abs() <= df,
                "at {t} s"
            );
            assert!(
                frame[b500] < -60.0,
                "500 Hz still at {t} s: {} dB",
                frame[b500]
            );
        }
    }
    assert!(early > 50 && late > 50);
}

#[test]
fn png_has_the_requested_size_and_looks_like_a_spectrogram() {
    let dir = tempfile::tempdir().unwrap();
    let x = sine(1000.0, 0.5);
    for (w, h) in [(1200, 600), (800, 450), (240, 160), (1000, 1000)] {
        let path = dir.path().join(format!("s{w}x{h}.png"));
        let opts = SpectrogramOptions {
            width: w,
            height: h,
            max_freq: Some(4000.0),
            title: Some("a 1 kHz sine".into()),
            ..Default::default()
        };
        let spec = spectrogram_png(&x, RATE, &opts, &path).unwrap();
        assert!(!spec.times_s.is_empty());
        assert_eq!(png_size(&path), (w, h));
        let (dw, dh, rgb) = decode(&path);
        assert_eq!((dw, dh), (w, h));
        // Mostly silence (magma's black) with a bright partial (its pale yellow end).
        let pixels: Vec<&[u8]> = rgb.chunks(3).collect();
        let dark = pixels
            .iter()
            .filter(|p| p[0] < 10 && p[1] < 10 && p[2] < 16)
            .count();
        let bright = pixels
            .iter()
            .filter(|p| p[0] > 240 && p[1] > 230 && p[2] > 150)
            .count();
        let white = pixels
            .iter()
            .filter(|p| p.iter().all(|&b| b == 255))
            .count();
        assert!(dark * 4 > pixels.len(), "{w}x{h}: only {dark} dark pixels");
        assert!(bright > 0, "{w}x{h}: no bright partial");
        assert!(
            white > pixels.len() / 20,
            "{w}x{h}: no white margins for the labels"
        );
    }
    // Nothing but the pictures: no temporaries left behind.
    only_pictures_left(dir.path(), 4);
}

#[test]
fn log_scale_keeps_the_bins_it_shows_and_draws() {
    let mut x = sine(100.0, 1.0);
    for (i, v) in sine(5000.0, 1.0).iter().enumerate() {
        x[i] += 0.5 * v;
    }
    let opts = SpectrogramOptions {
        log_freq: true,
        ..Default::default()
    };
    let spec = spectrogram(&x, RATE, &opts).unwrap();
    let df = RATE / 2048.0;
    // Default lower bound 20 Hz: the bins start at or below it, within one bin.
    assert!(spec.freqs_hz[0] <= 20.0 && spec.freqs_hz[0] > 20.0 - df);
    assert_eq!(*spec.freqs_hz.last().unwrap(), RATE / 2.0);
    let mid = &spec.db[spec.db.len() / 2];
    assert!((peak_hz(&spec.freqs_hz, mid) - 100.0).abs() <= df);
    let k5000 = spec
        .freqs_hz
        .iter()
        .position(|&f| (f - 5000.0).abs() <= df / 2.0)
        .unwrap();
    assert!(mid[k5000] > -10.0, "5 kHz partial at {} dB", mid[k5000]);

    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("log.png");
    let opts = SpectrogramOptions {
        log_freq: true,
        min_freq: Some(50.0),
        max_freq: Some(10_000.0),
        width: 900,
        height: 500,
        ..Default::default()
    };
    let spec = spectrogram_png(&x, RATE, &opts, &path).unwrap();
    assert!(spec.freqs_hz[0] <= 50.0 && *spec.freqs_hz.last().unwrap() >= 10_000.0);
    assert!(*spec.freqs_hz.last().unwrap() < 10_000.0 + df);
    assert_eq!(png_size(&path), (900, 500));
}

#[test]
fn frequency_range_keeps_only_the_bins_shown() {
    let x = sine(1000.0, 0.2);
    let opts = SpectrogramOptions {
        min_freq: Some(500.0),
        max_freq: Some(2000.0),
        ..Default::default()
    };
    let spec = spectrogram(&x, RATE, &opts).unwrap();
    let df = RATE / 2048.0;
    let (lo, hi) = (spec.freqs_hz[0], *spec.freqs_hz.last().unwrap());
    assert!(lo <= 500.0 && lo > 500.0 - df, "{lo}");
    assert!(hi >= 2000.0 && hi < 2000.0 + df, "{hi}");
}

#[test]
fn short_signals_are_padded_with_zeros() {
    let x = sine(3000.0, 0.002); // 96 samples, far shorter than the window
    let spec = spectrogram(&x, RATE, &SpectrogramOptions::default()).unwrap();
    assert_eq!(spec.times_s.len(), 1);
    assert!((peak_hz(&spec.freqs_hz, &spec.db[0]) - 3000.0).abs() < 2.0 * RATE / 2048.0 * 4.0);
    // A single sample still draws.
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("one.png");
    spectrogram_png(&[1.0], RATE, &SpectrogramOptions::default(), &path).unwrap();
    assert_eq!(png_size(&path), (1200, 600));
}

#[test]
fn long_signals_are_averaged_into_at_most_max_frames_columns() {
    let rate = 8000.0;
    let x: Vec<f64> = (0..(60.0 * rate) as usize)
        .map(|n| (2.0 * PI * 440.0 * n as f64 / rate).sin())
        .collect();
    let opts = SpectrogramOptions {
        window: 256,
        hop: 16,
        ..Default::default()
    };
    let spec = spectrogram(&x, rate, &opts).unwrap();
    assert!(x.len() / 16 + 1 > MAX_FRAMES);
    assert!(spec.times_s.len() <= MAX_FRAMES && spec.times_s.len() > MAX_FRAMES / 2);
    assert!(spec.times_s.windows(2).all(|w| w[0] < w[1]));
    assert!(*spec.times_s.last().unwrap() > 59.0);
    for frame in &spec.db {
        assert!((peak_hz(&spec.freqs_hz, frame) - 440.0).abs() <= rate / 256.0);
    }
}

#[test]
fn silence_is_all_floor_and_still_draws() {
    let x = vec![0.0; 10_000];
    let spec = spectrogram(&x, RATE, &SpectrogramOptions::default()).unwrap();
    assert!(spec.db.iter().flatten().all(|v| *v == FLOOR_DB));
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("silence.png");
    spectrogram_png(&x, RATE, &SpectrogramOptions::default(), &path).unwrap();
    assert_eq!(png_size(&path), (1200, 600));
}

#[test]
fn bad_options_are_named_with_a_reason() {
    let x = sine(1000.0, 0.1);
    let d = SpectrogramOptions::default;
    let cases: Vec<(SpectrogramOptions, f64, &str)> = vec![
        (SpectrogramOptions { window: 8, ..d() }, RATE, "window"),
        (SpectrogramOptions { window: 0, ..d() }, RATE, "window"),
        (SpectrogramOptions { hop: 0, ..d() }, RATE, "hop"),
        (
            SpectrogramOptions {
                max_freq: Some(30_000.0),
                ..d()
            },
            RATE,
            "Nyquist",
        ),
        (
            SpectrogramOptions {
                max_freq: Some(0.0),
                ..d()
            },
            RATE,
            "max_freq",
        ),
        (
            SpectrogramOptions {
                max_freq: Some(f64::NAN),
                ..d()
            },
            RATE,
            "max_freq",
        ),
        (
            SpectrogramOptions {
                min_freq: Some(-1.0),
                ..d()
            },
            RATE,
            "min_freq",
        ),
        (
            SpectrogramOptions {
                min_freq: Some(5000.0),
                max_freq: Some(2000.0),
                ..d()
            },
            RATE,
            "not below max_freq",
        ),
        (
            SpectrogramOptions {
                log_freq: true,
                min_freq: Some(0.0),
                ..d()
            },
            RATE,
            "logarithmic",
        ),
        (
            SpectrogramOptions {
                db_range: 0.0,
                ..d()
            },
            RATE,
            "db_range",
        ),
        (
            SpectrogramOptions {
                db_range: f64::INFINITY,
                ..d()
            },
            RATE,
            "db_range",
        ),
        (SpectrogramOptions { width: 0, ..d() }, RATE, "width"),
        (SpectrogramOptions { height: 10, ..d() }, RATE, "height"),
        (
            SpectrogramOptions {
                width: 100_000,
                ..d()
            },
            RATE,
            "width",
        ),
        (d(), 0.0, "sample rate"),
        (d(), f64::NAN, "sample rate"),
    ];
    let dir = tempfile::tempdir().unwrap();
    for (opts, rate, needle) in cases {
        let msg = bad_message(spectrogram(&x, rate, &opts));
        assert!(msg.contains(needle), "{needle:?} not in {msg:?}");
        // The PNG path checks the same options and writes nothing.
        let path = dir.path().join("bad.png");
        let msg = bad_message(spectrogram_png(&x, rate, &opts, &path));
        assert!(msg.contains(needle), "{needle:?} not in {msg:?}");
        assert!(!path.exists());
        let shown = PlotError::BadOptions(msg).to_string();
        assert!(shown.starts_with("bad plot options: "), "{shown}");
    }
}

#[test]
fn empty_and_non_finite_input_are_refused() {
    let opts = SpectrogramOptions::default();
    assert_eq!(spectrogram(&[], RATE, &opts), Err(PlotError::Empty));
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("empty.png");
    assert_eq!(
        spectrogram_png(&[], RATE, &opts, &path),
        Err(PlotError::Empty)
    );
    assert!(!path.exists());
    assert!(PlotError::Empty.to_string().contains("empty"));

    let mut x = sine(1000.0, 0.1);
    x[123] = f64::NAN;
    match spectrogram(&x, RATE, &opts) {
        Err(PlotError::NonFinite { index: 123, value }) => assert!(value.is_nan()),
        other => panic!("expected NonFinite, got {other:?}"),
    }
    x[123] = f64::INFINITY;
    let err = spectrogram(&x, RATE, &opts).unwrap_err();
    assert!(err.to_string().contains("value 123 is inf"), "{err}");
}

#[test]
fn unwritable_paths_are_draw_errors() {
    let dir = tempfile::tempdir().unwrap();
    let x = sine(1000.0, 0.1);
    let path = dir.path().join("no such folder").join("s.png");
    match spectrogram_png(&x, RATE, &SpectrogramOptions::default(), &path) {
        Err(e @ PlotError::Draw(_)) => {
            let msg = e.to_string();
            assert!(
                msg.contains("does not exist") && msg.contains("hint"),
                "{msg}"
            );
        }
        other => panic!("expected Draw, got {other:?}"),
    }
    // A path naming a folder, not a file.
    let err =
        spectrogram_png(&x, RATE, &SpectrogramOptions::default(), Path::new("/")).unwrap_err();
    assert!(matches!(err, PlotError::Draw(_)), "{err:?}");
}

#[test]
fn options_default_as_documented() {
    let d = SpectrogramOptions::default();
    assert_eq!((d.window, d.hop), (2048, 512));
    assert_eq!((d.width, d.height), (1200, 600));
    assert_eq!(d.db_range, 90.0);
    assert_eq!((d.max_freq, d.min_freq, d.log_freq), (None, None, false));
    assert!(d.title.is_none());
}
