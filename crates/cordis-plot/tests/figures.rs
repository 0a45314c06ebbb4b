//! Mode and response figures: the spectrum helper, option checking, and the PNGs they write.
#![allow(clippy::unwrap_used)]

mod common;
use common::*;

use std::f64::consts::PI;
use std::path::Path;

use cordis_plot::{
    modes_png, response_png, spectrum, ModeMark, ModesPlotOptions, PlotError, ResponseCurve,
    ResponsePlotOptions, Spectrum, FLOOR_DB,
};

#[test]
fn spectrum_of_a_sine_peaks_at_its_frequency() {
    for window in [1024, 4096, 3000] {
        let s = spectrum(&sine(1000.0, 1.0), RATE, window).unwrap();
        let df = RATE / window as f64;
        assert_eq!(s.freqs_hz.len(), window / 2 + 1);
        assert_eq!(s.db.len(), s.freqs_hz.len());
        assert_eq!(s.freqs_hz[0], 0.0);
        assert!((s.freqs_hz.last().unwrap() - df * (window / 2) as f64).abs() < 1e-9);
        let (k, &top) =
            s.db.iter()
                .enumerate()
                .max_by(|a, b| a.1.total_cmp(b.1))
                .unwrap();
        assert_eq!(top, 0.0, "levels are relative to the peak");
        assert!(
            (s.freqs_hz[k] - 1000.0).abs() <= df,
            "window {window}: peak at {} Hz",
            s.freqs_hz[k]
        );
        // Far from the tone the Hann window's leakage is tiny.
        let far = s.freqs_hz.iter().position(|&f| f >= 5000.0).unwrap();
        assert!(s.db[far] < -80.0, "{} dB at 5 kHz", s.db[far]);
        assert!(s.db.iter().all(|v| *v >= FLOOR_DB));
    }
    // Shorter than the window: zero padded. Silence: all at the floor.
    let s = spectrum(&sine(3000.0, 0.002), RATE, 8192).unwrap();
    assert_eq!(s.freqs_hz.len(), 4097);
    assert!(spectrum(&[0.0; 100], RATE, 64)
        .unwrap()
        .db
        .iter()
        .all(|v| *v == FLOOR_DB));
}

#[test]
fn spectrum_refuses_bad_input() {
    assert_eq!(spectrum(&[], RATE, 1024), Err(PlotError::Empty));
    let mut x = sine(1000.0, 0.1);
    x[7] = f64::NAN;
    assert!(matches!(
        spectrum(&x, RATE, 1024),
        Err(PlotError::NonFinite { index: 7, .. })
    ));
    let x = sine(1000.0, 0.1);
    for (rate, window, needle) in [
        (RATE, 8, "window"),
        (RATE, usize::MAX, "window"),
        (0.0, 1024, "sample rate"),
        (f64::NAN, 1024, "sample rate"),
    ] {
        match spectrum(&x, rate, window) {
            Err(PlotError::BadOptions(msg)) => assert!(msg.contains(needle), "{msg}"),
            other => panic!("expected BadOptions, got {other:?}"),
        }
    }
}

#[test]
fn modes_png_has_the_requested_size() {
    let dir = tempfile::tempdir().unwrap();
    let spec = tones(&[440.0, 1000.0]);
    let modes = [mode(440.0, 2.0), mode(1000.0, f64::INFINITY)];
    for (w, h) in [(1200, 700), (800, 450), (320, 240), (2000, 1600)] {
        let path = dir.path().join(format!("m{w}x{h}.png"));
        let opts = ModesPlotOptions {
            width: w,
            height: h,
            max_freq: Some(3000.0),
            title: Some("two tones".into()),
            ..Default::default()
        };
        modes_png(&spec, &modes, &opts, &path).unwrap();
        assert_eq!(png_size(&path), (w, h));
        let p = Picture::open(&path);
        assert!(p.count(BLUE) > 0 && p.count(VERMILION) > 0, "{w}x{h}");
        // Mostly paper, with ink.
        assert!(p.count([255, 255, 255]) * 2 > p.width * p.height);
        assert!(p.count([0, 0, 0]) > 100);
    }
    // Nothing but the pictures: no temporaries left behind.
    only_pictures_left(dir.path(), 4);
}

#[test]
fn markers_stand_at_the_predicted_frequencies() {
    let dir = tempfile::tempdir().unwrap();
    let spec = tones(&[500.0, 1000.0, 3000.0]);
    let freqs = [500.0, 1000.0, 2200.0, 3000.0];
    let mut modes: Vec<ModeMark> = freqs.iter().map(|&f| mode(f, 1.0 / f * 1000.0)).collect();
    // Outside the range: not drawn.
    modes.push(mode(6000.0, 0.1));
    let opts = ModesPlotOptions {
        min_freq: Some(0.0),
        max_freq: Some(4000.0),
        ..Default::default()
    };
    let path = dir.path().join("markers.png");
    modes_png(&spec, &modes, &opts, &path).unwrap();
    let p = Picture::open(&path);
    let (left, right) = p.frame_columns();
    // The frame is drawn just outside the plot, which spans [left + 1, right).
    let (x0, x1) = (left as f64 + 1.0, right as f64);
    let found = runs(&p, VERMILION, 100);
    assert_eq!(found.len(), freqs.len(), "marker columns at {found:?}");
    for (f, x) in freqs.iter().zip(&found) {
        let expected = x0 + f / 4000.0 * (x1 - x0);
        assert!(
            (x + 0.5 - expected).abs() <= 1.0,
            "{f} Hz marked at column {x}, expected about {expected}"
        );
    }
    // The spectrum peaks next to its markers: the highest blue pixel is on a marker.
    let top_blue = (0..p.width)
        .filter_map(|x| (0..p.height).find(|&y| p.bluish(x, y)).map(|y| (y, x)))
        .min()
        .unwrap();
    assert!(
        found.iter().any(|m| (m - top_blue.1 as f64).abs() <= 3.0),
        "loudest point at column {}, markers at {found:?}",
        top_blue.1
    );
}

#[test]
fn log_frequency_axis_places_markers_by_ratio() {
    let dir = tempfile::tempdir().unwrap();
    let spec = tones(&[100.0, 1000.0]);
    let freqs = [50.0, 100.0, 1000.0, 10_000.0];
    let modes: Vec<ModeMark> = freqs
        .iter()
        .enumerate()
        .map(|(i, &f)| ModeMark {
            freq_hz: f,
            // Spanning more than a decade: a log T60 axis.
            t60_s: 10f64.powi(1 - i as i32),
            label: None,
        })
        .collect();
    let opts = ModesPlotOptions {
        log_freq: true,
        min_freq: Some(20.0),
        max_freq: Some(20_000.0),
        width: 1000,
        height: 600,
        ..Default::default()
    };
    let path = dir.path().join("log.png");
    modes_png(&spec, &modes, &opts, &path).unwrap();
    assert_eq!(png_size(&path), (1000, 600));
    let p = Picture::open(&path);
    let (left, right) = p.frame_columns();
    let (x0, x1) = (left as f64 + 1.0, right as f64);
    let found = runs(&p, VERMILION, 100);
    assert_eq!(found.len(), freqs.len(), "marker columns at {found:?}");
    for (f, x) in freqs.iter().zip(&found) {
        let expected = x0 + (f / 20.0).log10() / 3.0 * (x1 - x0);
        assert!(
            (x + 0.5 - expected).abs() <= 1.0,
            "{f} Hz marked at column {x}, expected about {expected}"
        );
    }
    // The default lower bound on a log axis goes below a low mode.
    let opts = ModesPlotOptions {
        log_freq: true,
        ..Default::default()
    };
    let low = [mode(8.0, 1.0), mode(100.0, 1.0)];
    modes_png(&spec, &low, &opts, &path).unwrap();
    assert_eq!(runs(&Picture::open(&path), VERMILION, 100).len(), 2);
}

#[test]
fn modes_figures_draw_in_every_case() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("m.png");
    let spec = tones(&[700.0]);
    let d = ModesPlotOptions::default;
    let cases: Vec<(Vec<ModeMark>, ModesPlotOptions)> = vec![
        // No modes at all, or none in range.
        (vec![], d()),
        (
            vec![mode(700.0, 1.0)],
            ModesPlotOptions {
                max_freq: Some(500.0),
                ..d()
            },
        ),
        // Only undamped modes, a mode at 0 Hz, unlabelled modes, equal T60s.
        (vec![mode(700.0, f64::INFINITY)], d()),
        (vec![mode(0.0, 1.0), mode(700.0, 1.0)], d()),
        (
            vec![
                ModeMark {
                    freq_hz: 700.0,
                    t60_s: 1.0,
                    label: None,
                },
                ModeMark {
                    freq_hz: 701.0,
                    t60_s: 1.0,
                    label: Some("  ".into()),
                },
            ],
            d(),
        ),
        // A very long title, which is set smaller.
        (
            vec![mode(700.0, 0.5)],
            ModesPlotOptions {
                title: Some("a title far too long for a small picture ".repeat(6)),
                width: 400,
                height: 300,
                ..d()
            },
        ),
    ];
    for (modes, opts) in cases {
        modes_png(&spec, &modes, &opts, &path).unwrap();
        assert_eq!(png_size(&path), (opts.width, opts.height));
    }
    // A spectrum of one point and levels far below the range.
    let one = Spectrum {
        freqs_hz: vec![100.0],
        db: vec![-500.0],
    };
    modes_png(&one, &[mode(100.0, 1.0)], &d(), &path).unwrap();
}

#[test]
fn bad_mode_options_are_named_with_a_reason() {
    let spec = tones(&[700.0]);
    let modes = [mode(700.0, 1.0)];
    let d = ModesPlotOptions::default;
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("bad.png");
    let cases: Vec<(Spectrum, Vec<ModeMark>, ModesPlotOptions, &str)> = vec![
        (
            spec.clone(),
            modes.to_vec(),
            ModesPlotOptions {
                min_freq: Some(2000.0),
                max_freq: Some(1000.0),
                ..d()
            },
            "not below max_freq",
        ),
        (
            spec.clone(),
            modes.to_vec(),
            ModesPlotOptions {
                min_freq: Some(1000.0),
                max_freq: Some(1000.0),
                ..d()
            },
            "not below max_freq",
        ),
        (
            spec.clone(),
            modes.to_vec(),
            ModesPlotOptions {
                log_freq: true,
                min_freq: Some(0.0),
                ..d()
            },
            "logarithmic",
        ),
        (
            spec.clone(),
            modes.to_vec(),
            ModesPlotOptions {
                max_freq: Some(-5.0),
                ..d()
            },
            "max_freq",
        ),
        (
            spec.clone(),
            modes.to_vec(),
            ModesPlotOptions {
                min_freq: Some(f64::NAN),
                ..d()
            },
            "min_freq",
        ),
        (
            spec.clone(),
            modes.to_vec(),
            ModesPlotOptions {
                min_freq: Some(30_000.0),
                max_freq: Some(40_000.0),
                ..d()
            },
            "no point of the spectrum",
        ),
        (
            spec.clone(),
            modes.to_vec(),
            ModesPlotOptions {
                db_range: 0.0,
                ..d()
            },
            "db_range",
        ),
        (
            spec.clone(),
            modes.to_vec(),
            ModesPlotOptions { width: 100, ..d() },
            "width",
        ),
        (
            spec.clone(),
            modes.to_vec(),
            ModesPlotOptions {
                height: 20_000,
                ..d()
            },
            "height",
        ),
        (
            Spectrum {
                freqs_hz: vec![1.0, 2.0],
                db: vec![0.0],
            },
            modes.to_vec(),
            d(),
            "one level per frequency",
        ),
        (
            Spectrum {
                freqs_hz: vec![1.0, 3.0, 2.0],
                db: vec![0.0; 3],
            },
            modes.to_vec(),
            d(),
            "must increase",
        ),
        (spec.clone(), vec![mode(700.0, 0.0)], d(), "T60"),
        (spec.clone(), vec![mode(700.0, -1.0)], d(), "T60"),
        (spec.clone(), vec![mode(-700.0, 1.0)], d(), "0 Hz or more"),
    ];
    for (spec, modes, opts, needle) in cases {
        let msg = bad_message(modes_png(&spec, &modes, &opts, &path));
        assert!(msg.contains(needle), "{needle:?} not in {msg:?}");
        assert!(!path.exists());
        let shown = PlotError::BadOptions(msg).to_string();
        assert!(shown.starts_with("bad plot options: "), "{shown}");
    }
    let empty = Spectrum {
        freqs_hz: vec![],
        db: vec![],
    };
    assert_eq!(
        modes_png(&empty, &modes, &d(), &path),
        Err(PlotError::Empty)
    );
    assert!(!path.exists());
}

#[test]
fn non_finite_mode_data_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("nf.png");
    let d = ModesPlotOptions::default();
    let mut spec = tones(&[700.0]);
    spec.db[5] = f64::NAN;
    assert!(matches!(
        modes_png(&spec, &[], &d, &path),
        Err(PlotError::NonFinite { index: 5, .. })
    ));
    let mut spec = tones(&[700.0]);
    spec.freqs_hz[9] = f64::INFINITY;
    assert!(matches!(
        modes_png(&spec, &[], &d, &path),
        Err(PlotError::NonFinite { index: 9, .. })
    ));
    let spec = tones(&[700.0]);
    for bad in [
        mode(f64::NAN, 1.0),
        mode(f64::INFINITY, 1.0),
        mode(700.0, f64::NAN),
        mode(700.0, f64::NEG_INFINITY),
    ] {
        let err = modes_png(&spec, &[mode(100.0, 1.0), bad], &d, &path).unwrap_err();
        assert!(
            matches!(err, PlotError::NonFinite { index: 1, .. }),
            "{err:?}"
        );
        assert!(err.to_string().contains("finite"), "{err}");
    }
    assert!(!path.exists());
}

/// Three curves of a one-mode resonator, with a zero magnitude in the first.
fn resonator(n: usize) -> ResponseCurve {
    let freqs: Vec<f64> = (0..n)
        .map(|i| 10f64.powf(1.0 + 3.0 * i as f64 / (n - 1) as f64))
        .collect();
    let (mut rec, mut mob, mut delay) = (Vec::new(), Vec::new(), Vec::new());
    for &f in &freqs {
        let (w, wk, zeta) = (2.0 * PI * f, 2.0 * PI * 300.0, 0.02);
        let (dr, di) = (wk * wk - w * w, 2.0 * zeta * wk * w);
        let mag = 1.0 / (dr * dr + di * di).sqrt();
        let phase = (-di).atan2(dr);
        rec.push((mag, phase));
        mob.push((mag * w, phase + PI / 2.0));
        // A pure delay: the phase wraps many times.
        delay.push((1.0, -w * 1e-3));
    }
    rec[10].0 = 0.0;
    ResponseCurve {
        freqs_hz: freqs,
        series: vec![
            ("receptance".into(), rec),
            ("mobility".into(), mob),
            ("delay".into(), delay),
        ],
    }
}

#[test]
fn response_png_draws_each_series_in_its_colour() {
    let dir = tempfile::tempdir().unwrap();
    let resp = resonator(500);
    for (w, h) in [(1200, 700), (640, 400), (320, 240)] {
        let path = dir.path().join(format!("r{w}x{h}.png"));
        let opts = ResponsePlotOptions {
            width: w,
            height: h,
            title: Some("resonator".into()),
            ..Default::default()
        };
        response_png(&resp, &opts, &path).unwrap();
        assert_eq!(png_size(&path), (w, h));
        let p = Picture::open(&path);
        for c in [BLUE, VERMILION, GREEN] {
            assert!(p.count_tinted(c) > 100, "{w}x{h}: colour {c:?} missing");
        }
    }
    // One series: the first colour only, and no legend needed.
    let one = ResponseCurve {
        freqs_hz: resp.freqs_hz.clone(),
        series: vec![resp.series[0].clone()],
    };
    let path = dir.path().join("one.png");
    let opts = ResponsePlotOptions {
        db_range: Some(60.0),
        ..Default::default()
    };
    response_png(&one, &opts, &path).unwrap();
    let p = Picture::open(&path);
    assert!(p.count_tinted(BLUE) > 100);
    assert_eq!(p.count_tinted(VERMILION), 0);
    // All-zero magnitudes, constant magnitudes: still drawn.
    for mag in [0.0, 2.0] {
        let flat = ResponseCurve {
            freqs_hz: vec![10.0, 100.0, 1000.0],
            series: vec![("flat".into(), vec![(mag, 0.0); 3])],
        };
        response_png(&flat, &ResponsePlotOptions::default(), &path).unwrap();
    }
}

#[test]
fn response_phase_panel_spans_its_grid() {
    // A flat response of phase 0: its line lies halfway down the phase panel, on the
    // 0-degree grid line; -180 and 180 are the panel's edges.
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("flat.png");
    let flat = ResponseCurve {
        freqs_hz: vec![10.0, 10_000.0],
        series: vec![("flat".into(), vec![(1.0, 0.0); 2])],
    };
    response_png(&flat, &ResponsePlotOptions::default(), &path).unwrap();
    let p = Picture::open(&path);
    let (left, right) = p.frame_columns();
    // Clear of the frequency labels and the axis description.
    let x = left + 3 * (right - left) / 8;
    let rows: Vec<usize> = (0..p.height).filter(|&y| p.bluish(x, y)).collect();
    // Two lines: the magnitude (0 dB) and the phase (0 degrees).
    let frames: Vec<usize> = (0..p.height).filter(|&y| p.at(x, y) == [0, 0, 0]).collect();
    assert_eq!(
        frames.len(),
        4,
        "top and bottom frames of two panels: {frames:?}"
    );
    // The plot spans the rows between its frame lines.
    let (top, bottom) = (frames[2] as f64 + 1.0, frames[3] as f64);
    // The centre of the last line of blue rows.
    let last = *rows.last().unwrap();
    let first = rows
        .iter()
        .rev()
        .take_while(|&&y| last - y < 4)
        .last()
        .unwrap();
    let phase_row = (first + last) as f64 / 2.0 + 0.5;
    let middle = (top + bottom) / 2.0;
    assert!((phase_row - middle).abs() <= 1.5, "{phase_row} vs {middle}");
}

#[test]
fn bad_response_options_are_named_with_a_reason() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("bad.png");
    let d = ResponsePlotOptions::default;
    let good = resonator(20);
    let with = |f: &dyn Fn(&mut ResponseCurve)| {
        let mut r = good.clone();
        f(&mut r);
        r
    };
    let cases: Vec<(ResponseCurve, ResponsePlotOptions, &str)> = vec![
        (
            with(&|r| {
                r.freqs_hz.truncate(1);
                for s in &mut r.series {
                    s.1.truncate(1);
                }
            }),
            d(),
            "at least two",
        ),
        (with(&|r| r.freqs_hz[0] = 0.0), d(), "above 0 Hz"),
        (with(&|r| r.freqs_hz.swap(3, 4)), d(), "must increase"),
        (
            with(&|r| {
                r.series[1].1.pop();
            }),
            d(),
            "\"mobility\"",
        ),
        (with(&|r| r.series[0].1[2].0 = -1.0), d(), "magnitude"),
        (
            good.clone(),
            ResponsePlotOptions {
                db_range: Some(0.0),
                ..d()
            },
            "db_range",
        ),
        (
            good.clone(),
            ResponsePlotOptions {
                db_range: Some(f64::NAN),
                ..d()
            },
            "db_range",
        ),
        (
            good.clone(),
            ResponsePlotOptions { width: 0, ..d() },
            "width",
        ),
        (
            good.clone(),
            ResponsePlotOptions { height: 100, ..d() },
            "height",
        ),
    ];
    for (resp, opts, needle) in cases {
        let msg = bad_message(response_png(&resp, &opts, &path));
        assert!(msg.contains(needle), "{needle:?} not in {msg:?}");
        assert!(!path.exists());
    }
    let no_series = ResponseCurve {
        freqs_hz: vec![1.0, 2.0],
        series: vec![],
    };
    assert_eq!(response_png(&no_series, &d(), &path), Err(PlotError::Empty));
    let no_freqs = ResponseCurve {
        freqs_hz: vec![],
        series: vec![("x".into(), vec![])],
    };
    assert_eq!(response_png(&no_freqs, &d(), &path), Err(PlotError::Empty));
    assert!(!path.exists());
}

#[test]
fn non_finite_response_values_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("nf.png");
    let d = ResponsePlotOptions::default();
    let cases: [(usize, usize, f64, bool); 4] = [
        (0, 3, f64::NAN, true),
        (1, 4, f64::INFINITY, true),
        (2, 5, f64::NAN, false),
        (0, 6, f64::NEG_INFINITY, false),
    ];
    for (series, index, value, magnitude) in cases {
        let mut r = resonator(20);
        let v = &mut r.series[series].1[index];
        if magnitude {
            v.0 = value;
        } else {
            v.1 = value;
        }
        match response_png(&r, &d, &path) {
            Err(PlotError::NonFinite { index: i, .. }) => assert_eq!(i, index),
            other => panic!("expected NonFinite, got {other:?}"),
        }
    }
    let mut r = resonator(20);
    r.freqs_hz[2] = f64::NAN;
    assert!(matches!(
        response_png(&r, &d, &path),
        Err(PlotError::NonFinite { index: 2, .. })
    ));
    assert!(!path.exists());
}

#[test]
fn paths_are_checked_and_special_files_written_in_place() {
    let dir = tempfile::tempdir().unwrap();
    let spec = tones(&[700.0]);
    let path = dir.path().join("no such folder").join("m.png");
    match modes_png(&spec, &[], &ModesPlotOptions::default(), &path) {
        Err(e @ PlotError::Draw(_)) => {
            let msg = e.to_string();
            assert!(
                msg.contains("does not exist") && msg.contains("hint"),
                "{msg}"
            );
        }
        other => panic!("expected Draw, got {other:?}"),
    }
    let err = response_png(
        &resonator(20),
        &ResponsePlotOptions::default(),
        Path::new("/"),
    )
    .unwrap_err();
    assert!(matches!(err, PlotError::Draw(_)), "{err:?}");
    #[cfg(unix)]
    {
        // A device is written in place, not replaced by a renamed file.
        let null = Path::new("/dev/null");
        modes_png(&spec, &[], &ModesPlotOptions::default(), null).unwrap();
        response_png(&resonator(20), &ResponsePlotOptions::default(), null).unwrap();
        assert!(!std::fs::metadata(null).unwrap().is_file());
    }
}

#[test]
fn options_default_as_documented() {
    let m = ModesPlotOptions::default();
    assert_eq!((m.width, m.height), (1200, 700));
    assert_eq!(m.db_range, 90.0);
    assert_eq!((m.min_freq, m.max_freq, m.log_freq), (None, None, false));
    assert!(m.title.is_none());
    let r = ResponsePlotOptions::default();
    assert_eq!((r.width, r.height), (1200, 700));
    assert_eq!(r.db_range, None);
    assert!(r.title.is_none());
}
