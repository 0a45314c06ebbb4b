#![allow(clippy::unwrap_used)]
//! The comparison figure: spectra stacked on one frequency axis, each with its own modes.

mod common;
use common::*;

use std::ops::Range;
use std::path::Path;

use cordis_plot::{
    compare_png, modes_png, ComparePanel, ModeMark, ModesPlotOptions, PlotError, Spectrum,
};

/// The colour of each panel's spectrum line, from the top.
const LINES: [[u8; 3]; 4] = [BLUE, GREEN, PURPLE, SKY];

/// `spec` with every level moved by `db`.
fn shifted(spec: &Spectrum, db: f64) -> Spectrum {
    Spectrum {
        freqs_hz: spec.freqs_hz.clone(),
        db: spec.db.iter().map(|v| v + db).collect(),
    }
}

/// A spectrum every 5 Hz from `lo` to `hi` Hz, 60 dB below a peak at `peak` Hz.
fn ramp(lo: f64, hi: f64, peak: f64) -> Spectrum {
    let freqs_hz: Vec<f64> = (0..)
        .map(|k| lo + 5.0 * k as f64)
        .take_while(|&f| f <= hi)
        .collect();
    let db = freqs_hz
        .iter()
        .map(|f| if (f - peak).abs() < 1.0 { 0.0 } else { -60.0 })
        .collect();
    Spectrum { freqs_hz, db }
}

/// The rows inside each panel, from the top (the frame lines are just outside them).
fn panel_rows(p: &Picture) -> Vec<Range<usize>> {
    let frames = p.frame_rows();
    assert_eq!(frames.len() % 2, 0, "frame lines at {frames:?}");
    frames.chunks(2).map(|f| f[0] + 1..f[1]).collect()
}

/// The columns inside the panels, as continuous coordinates `(x0, x1)`.
fn plot_span(p: &Picture) -> (f64, f64) {
    let (left, right) = p.frame_columns();
    (left as f64 + 1.0, right as f64)
}

/// Pixels of colour `c` (blended at least halfway into paper) within `rows`.
fn tinted_in(p: &Picture, c: [u8; 3], rows: Range<usize>) -> usize {
    rows.map(|y| (0..p.width).filter(|&x| p.tinted(x, y, c)).count())
        .sum()
}

/// How many pixels of each column are colour `c` blended at least halfway into paper.
fn tinted_columns(p: &Picture, c: [u8; 3]) -> Vec<usize> {
    (0..p.width)
        .map(|x| (0..p.height).filter(|&y| p.tinted(x, y, c)).count())
        .collect()
}

/// Checks that the marker runs found lie at the expected columns of `freqs`, where `at` maps a
/// frequency to its fraction of the plot's width.
fn assert_markers(found: &[f64], freqs: &[f64], (x0, x1): (f64, f64), at: impl Fn(f64) -> f64) {
    assert_eq!(found.len(), freqs.len(), "marker columns at {found:?}");
    for (f, x) in freqs.iter().zip(found) {
        let expected = x0 + at(*f) * (x1 - x0);
        assert!(
            (x + 0.5 - expected).abs() <= 1.0,
            "{f} Hz marked at column {x}, expected about {expected}"
        );
    }
}

#[test]
fn compare_png_has_the_requested_size() {
    let dir = tempfile::tempdir().unwrap();
    let recording = tones(&[440.0, 1000.0]);
    let model = tones(&[445.0, 990.0]);
    let (rec_modes, model_modes) = (
        [mode(440.0, 2.0), mode(1000.0, 1.0)],
        [mode(445.0, 2.1), mode(990.0, 0.9)],
    );
    let panels = [
        ComparePanel {
            label: "recording",
            spectrum: &recording,
            modes: &rec_modes,
        },
        ComparePanel {
            label: "model",
            spectrum: &model,
            modes: &model_modes,
        },
    ];
    for (w, h) in [(1200, 700), (800, 450), (320, 240), (2000, 1600)] {
        let path = dir.path().join(format!("c{w}x{h}.png"));
        let opts = ModesPlotOptions {
            width: w,
            height: h,
            max_freq: Some(3000.0),
            title: Some("recording and model".into()),
            ..Default::default()
        };
        compare_png(&panels, &opts, &path).unwrap();
        assert_eq!(png_size(&path), (w, h));
        let p = Picture::open(&path);
        for c in [BLUE, GREEN, VERMILION] {
            assert!(p.count(c) > 0, "{w}x{h}: colour {c:?} missing");
        }
        assert_eq!(panel_rows(&p).len(), 2, "{w}x{h}");
        // Mostly paper, with ink.
        assert!(p.count([255, 255, 255]) * 2 > p.width * p.height);
        assert!(p.count([0, 0, 0]) > 100);
    }
    // Nothing but the pictures: no temporaries left behind.
    only_pictures_left(dir.path(), 4);
}

#[test]
fn panels_stack_in_order_each_in_its_colour_and_scale() {
    // Panel i is 25 i dB quieter than the first, and still peaks at the top of its own axis.
    let dir = tempfile::tempdir().unwrap();
    let spectra: Vec<Spectrum> = (0..4)
        .map(|i| {
            shifted(
                &tones(&[2000.0, 700.0 + 500.0 * i as f64]),
                -25.0 * i as f64,
            )
        })
        .collect();
    let labels = ["recording", "model", "", "other"];
    let opts = ModesPlotOptions {
        min_freq: Some(0.0),
        max_freq: Some(4000.0),
        db_range: 60.0,
        ..Default::default()
    };
    for n in 1..=4 {
        let panels: Vec<ComparePanel<'_>> = (0..n)
            .map(|i| ComparePanel {
                label: labels[i],
                spectrum: &spectra[i],
                modes: &[],
            })
            .collect();
        let path = dir.path().join(format!("stack{n}.png"));
        compare_png(&panels, &opts, &path).unwrap();
        let p = Picture::open(&path);
        let rows = panel_rows(&p);
        assert_eq!(rows.len(), n, "{n} panels");
        // Equal shares of the height, give or take a pixel or two of rounding.
        let heights: Vec<usize> = rows.iter().map(|r| r.len()).collect();
        let (lo, hi) = (heights.iter().min().unwrap(), heights.iter().max().unwrap());
        assert!(hi - lo <= 2, "{n} panels of heights {heights:?}");
        let (x0, x1) = plot_span(&p);
        // Columns around 2 kHz, halfway across: clear of any legend.
        let peak_cols = ((x0 + x1) / 2.0 - 3.0) as usize..((x0 + x1) / 2.0 + 3.0) as usize;
        for (i, r) in rows.iter().enumerate() {
            let colour = LINES[i];
            let inside = tinted_in(&p, colour, r.clone());
            assert!(
                inside > 100,
                "{n} panels: panel {i} has {inside} pixels of its colour"
            );
            assert_eq!(
                p.count_tinted(colour),
                inside,
                "{n} panels: colour of panel {i} drawn outside it"
            );
            // The loudest point sits a twenty-first of the panel below its top (the axis runs
            // 5% of the range above it).
            let expected = r.end as f64 - r.len() as f64 / 1.05;
            let top = r
                .clone()
                .find(|&y| peak_cols.clone().any(|x| p.tinted(x, y, colour)))
                .unwrap();
            assert!(
                (top as f64 + 0.5 - expected).abs() <= 2.0,
                "{n} panels: panel {i} peaks at row {top}, expected about {expected}"
            );
        }
        for c in &LINES[n..] {
            assert_eq!(
                p.count_tinted(*c),
                0,
                "{n} panels: colour {c:?} of a panel not drawn"
            );
        }
        // No modes: no markers.
        assert_eq!(p.count(VERMILION), 0);
    }
}

#[test]
fn markers_stand_at_each_panels_own_modes() {
    let dir = tempfile::tempdir().unwrap();
    let recording = tones(&[500.0, 1000.0, 3000.0]);
    let model = tones(&[700.0, 2200.0]);
    let rec_freqs = [500.0, 1000.0, 3000.0];
    let model_freqs = [700.0, 2200.0, 3500.0];
    let marks = |f: &[f64]| -> Vec<ModeMark> { f.iter().map(|&f| mode(f, 1.0)).collect() };
    let mut rec_modes = marks(&rec_freqs);
    // Outside the range: not drawn.
    rec_modes.push(mode(6000.0, 0.1));
    let model_modes = marks(&model_freqs);
    let panels = [
        ComparePanel {
            label: "recording",
            spectrum: &recording,
            modes: &rec_modes,
        },
        ComparePanel {
            label: "model",
            spectrum: &model,
            modes: &model_modes,
        },
    ];
    let path = dir.path().join("markers.png");
    let opts = ModesPlotOptions {
        min_freq: Some(0.0),
        max_freq: Some(4000.0),
        ..Default::default()
    };
    compare_png(&panels, &opts, &path).unwrap();
    let p = Picture::open(&path);
    let rows = panel_rows(&p);
    assert_eq!(rows.len(), 2);
    let span = plot_span(&p);
    let linear = |f: f64| f / 4000.0;
    for (r, freqs) in rows.iter().zip([&rec_freqs[..], &model_freqs[..]]) {
        let found = runs_in(&p, VERMILION, r.len() / 2, r.clone());
        assert_markers(&found, freqs, span, linear);
    }

    // On a logarithmic axis, by ratio.
    let rec_freqs = [50.0, 1000.0];
    let model_freqs = [100.0, 10_000.0];
    let (rec_modes, model_modes) = (marks(&rec_freqs), marks(&model_freqs));
    let panels = [
        ComparePanel {
            modes: &rec_modes,
            ..panels[0]
        },
        ComparePanel {
            modes: &model_modes,
            ..panels[1]
        },
    ];
    let opts = ModesPlotOptions {
        log_freq: true,
        min_freq: Some(20.0),
        max_freq: Some(20_000.0),
        width: 1000,
        height: 600,
        ..Default::default()
    };
    compare_png(&panels, &opts, &path).unwrap();
    assert_eq!(png_size(&path), (1000, 600));
    let p = Picture::open(&path);
    let rows = panel_rows(&p);
    let span = plot_span(&p);
    let log = |f: f64| (f / 20.0).log10() / 3.0;
    for (r, freqs) in rows.iter().zip([&rec_freqs[..], &model_freqs[..]]) {
        let found = runs_in(&p, VERMILION, r.len() / 2, r.clone());
        assert_markers(&found, freqs, span, log);
    }
}

#[test]
fn the_default_range_is_the_union_of_the_spectra() {
    // The recording runs from 0 to 2 kHz, the model from 1 to 4 kHz: the axis runs from 0 to
    // 4 kHz, and each line only over its own spectrum.
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("union.png");
    let recording = ramp(0.0, 2000.0, 500.0);
    let model = ramp(1000.0, 4000.0, 3000.0);
    let (rec_modes, model_modes) = ([mode(500.0, 1.0)], [mode(3000.0, 1.0)]);
    let panels = [
        ComparePanel {
            label: "recording",
            spectrum: &recording,
            modes: &rec_modes,
        },
        ComparePanel {
            label: "model",
            spectrum: &model,
            modes: &model_modes,
        },
    ];
    compare_png(&panels, &ModesPlotOptions::default(), &path).unwrap();
    let p = Picture::open(&path);
    let rows = panel_rows(&p);
    let span @ (x0, x1) = plot_span(&p);
    let linear = |f: f64| f / 4000.0;
    assert_markers(
        &runs_in(&p, VERMILION, 50, rows[0].clone()),
        &[500.0],
        span,
        linear,
    );
    assert_markers(
        &runs_in(&p, VERMILION, 50, rows[1].clone()),
        &[3000.0],
        span,
        linear,
    );
    let blue = tinted_columns(&p, BLUE);
    let green = tinted_columns(&p, GREEN);
    let col = |f: f64| (x0 + linear(f) * (x1 - x0)) as usize;
    // Left of the legends (in the top right corners), the lines stop where their spectra do.
    let middle = col(600.0)..col(3000.0);
    assert!(blue[middle.clone()].iter().any(|&n| n > 0));
    assert!(green[middle.clone()].iter().any(|&n| n > 0));
    assert!(middle
        .clone()
        .filter(|&x| x > col(2000.0) + 3)
        .all(|x| blue[x] == 0));
    assert!(middle
        .filter(|&x| x + 3 < col(1000.0))
        .all(|x| green[x] == 0));

    // On a logarithmic axis the default reaches below the lowest mode of any panel.
    let low = [mode(10.0, 1.0)];
    let panels = [
        panels[0],
        ComparePanel {
            modes: &low,
            ..panels[1]
        },
    ];
    let opts = ModesPlotOptions {
        log_freq: true,
        ..Default::default()
    };
    compare_png(&panels, &opts, &path).unwrap();
    let p = Picture::open(&path);
    let rows = panel_rows(&p);
    let span = plot_span(&p);
    let log = |f: f64| (f / 8.0).log10() / (4000.0f64 / 8.0).log10();
    assert_markers(
        &runs_in(&p, VERMILION, 50, rows[0].clone()),
        &[500.0],
        span,
        log,
    );
    assert_markers(
        &runs_in(&p, VERMILION, 50, rows[1].clone()),
        &[10.0],
        span,
        log,
    );

    // A range set in the options leaves out what lies beyond it: the model's mode at 3 kHz.
    let panels = [
        panels[0],
        ComparePanel {
            modes: &model_modes,
            ..panels[1]
        },
    ];
    let opts = ModesPlotOptions {
        max_freq: Some(2000.0),
        ..Default::default()
    };
    compare_png(&panels, &opts, &path).unwrap();
    let p = Picture::open(&path);
    let rows = panel_rows(&p);
    assert_eq!(
        runs_in(&p, VERMILION, 50, rows[1].clone()),
        Vec::<f64>::new()
    );
    assert!(tinted_in(&p, GREEN, rows[1].clone()) > 0);
}

#[test]
fn bad_input_fails_like_modes_png_and_writes_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("bad.png");
    let good = tones(&[700.0]);
    let good_modes = [mode(700.0, 1.0)];
    let d = ModesPlotOptions::default;
    let recording = ComparePanel {
        label: "recording",
        spectrum: &good,
        modes: &good_modes,
    };

    // No panels, or too many.
    for n in [0, 5] {
        let msg = bad_message(compare_png(&vec![recording; n], &d(), &path));
        assert!(msg.contains("1 to 4"), "{msg}");
        assert!(!path.exists());
    }

    let with = |f: &dyn Fn(&mut Spectrum)| {
        let mut s = good.clone();
        f(&mut s);
        s
    };
    let empty = Spectrum {
        freqs_hz: vec![],
        db: vec![],
    };
    // A bad model (the second panel), or bad options: each refused as modes_png refuses it.
    let cases: Vec<(Spectrum, Vec<ModeMark>, ModesPlotOptions)> = vec![
        (empty, good_modes.to_vec(), d()),
        (with(&|s| s.db[5] = f64::NAN), vec![], d()),
        (with(&|s| s.freqs_hz[9] = f64::INFINITY), vec![], d()),
        (with(&|s| s.freqs_hz.swap(3, 4)), vec![], d()),
        (with(&|s| s.db.truncate(3)), vec![], d()),
        (
            good.clone(),
            vec![mode(700.0, 1.0), mode(f64::NAN, 1.0)],
            d(),
        ),
        (good.clone(), vec![mode(700.0, f64::NEG_INFINITY)], d()),
        (good.clone(), vec![mode(700.0, 0.0)], d()),
        (good.clone(), vec![mode(-700.0, 1.0)], d()),
        (
            good.clone(),
            vec![],
            ModesPlotOptions {
                db_range: 0.0,
                ..d()
            },
        ),
        (good.clone(), vec![], ModesPlotOptions { width: 100, ..d() }),
        (
            good.clone(),
            vec![],
            ModesPlotOptions {
                height: 20_000,
                ..d()
            },
        ),
        (
            good.clone(),
            vec![],
            ModesPlotOptions {
                min_freq: Some(2000.0),
                max_freq: Some(1000.0),
                ..d()
            },
        ),
        (
            good.clone(),
            vec![],
            ModesPlotOptions {
                log_freq: true,
                min_freq: Some(0.0),
                ..d()
            },
        ),
        (
            good.clone(),
            vec![],
            ModesPlotOptions {
                max_freq: Some(-5.0),
                ..d()
            },
        ),
        (
            good.clone(),
            vec![],
            ModesPlotOptions {
                min_freq: Some(30_000.0),
                max_freq: Some(40_000.0),
                ..d()
            },
        ),
    ];
    for (spec, modes, opts) in cases {
        let expected = modes_png(&spec, &modes, &opts, &path).unwrap_err();
        let model = ComparePanel {
            label: "model",
            spectrum: &spec,
            modes: &modes,
        };
        let got = compare_png(&[recording, model], &opts, &path).unwrap_err();
        match (&expected, &got) {
            (PlotError::BadOptions(want), PlotError::BadOptions(msg)) => {
                // Messages about a panel's data name it.
                assert!(
                    msg.ends_with(want.as_str()),
                    "{msg:?} does not end with {want:?}"
                );
                assert!(
                    msg == want
                        || msg.starts_with("panel 2 (model): ")
                        || msg.starts_with("panel 1 (recording): "),
                    "{msg:?}"
                );
            }
            // NaN is not equal to itself: compare as written.
            _ => assert_eq!(format!("{got:?}"), format!("{expected:?}")),
        }
        assert!(!path.exists(), "{got:?} left a file");
    }
    // A fault in the first panel is named as the first.
    let bad = with(&|s| s.freqs_hz.swap(3, 4));
    let panels = [
        ComparePanel {
            spectrum: &bad,
            ..recording
        },
        recording,
    ];
    let msg = bad_message(compare_png(&panels, &d(), &path));
    assert!(msg.starts_with("panel 1 (recording): "), "{msg}");
    assert!(!path.exists());

    // A folder that does not exist.
    let path = dir.path().join("no such folder").join("c.png");
    let err = compare_png(&[recording], &d(), &path).unwrap_err();
    assert!(matches!(err, PlotError::Draw(_)), "{err:?}");
    only_pictures_left(dir.path(), 0);
}

#[test]
fn a_blank_label_and_a_single_panel_still_draw() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("one.png");
    let spec = tones(&[700.0]);
    let modes = [mode(700.0, f64::INFINITY)];
    let panel = ComparePanel {
        label: "  ",
        spectrum: &spec,
        modes: &modes,
    };
    compare_png(&[panel], &ModesPlotOptions::default(), Path::new(&path)).unwrap();
    let p = Picture::open(&path);
    assert_eq!(panel_rows(&p).len(), 1);
    assert!(p.count(BLUE) > 0 && p.count(VERMILION) > 0);
}
