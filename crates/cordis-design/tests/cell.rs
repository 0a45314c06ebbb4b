//! `design_cell` against the engine's rendering and the analysis of the model it writes.
#![allow(clippy::unwrap_used)]

use cordis_analysis::{LinearSystem, ModalAnalysis, ModeKind};
use cordis_design::cell::{design_cell, Cell, CellScale, CellTarget};
use cordis_design::DesignError;
use cordis_model::{load_str, Model, Options};

const FS: f64 = 44100.0;

fn load(text: &str) -> Model {
    match load_str("cell.cordis".as_ref(), text, &Options::default()) {
        Ok(m) => m,
        Err(e) => panic!("{e}\n{text}"),
    }
}

fn render(m: &Model, frames: usize) -> Vec<f64> {
    let mut e = m.compile();
    let mut out = vec![0.0; frames * e.channels()];
    e.process(frames, &mut out).unwrap();
    out.iter().step_by(e.channels()).copied().collect()
}

fn target(f: f64, tau: Option<f64>, amp: f64, phase: f64) -> CellTarget {
    CellTarget {
        freq_hz: f,
        decay_s: tau,
        amp,
        phase_rad: phase,
        rate: FS,
    }
}

/// A spread of targets: low and high, damped and undamped, every quadrant of phase, both signs.
fn targets() -> Vec<CellTarget> {
    vec![
        target(440.0, Some(1.5), 0.001, 0.3),
        target(440.0, None, 1.0, 1.0),
        target(50.0, Some(0.2), -0.02, -2.0),
        target(15000.0, Some(0.05), 3.0, 2.5),
        target(3.0, None, 1e-6, 0.0),
        target(21000.0, Some(2.0), 0.5, -0.7),
        target(1234.5, Some(1e-3), 1.0, std::f64::consts::FRAC_PI_2),
    ]
}

/// The render of `frames` samples of the written model, and the largest relative deviations from
/// `A r^n cos(θ n + P)`: over the first 100 samples, and over all of them divided by the bound
/// the rounding of the engine's coefficients allows (see `renders_the_target_oscillation`).
fn deviations(cell: &Cell, t: &CellTarget, frames: usize) -> (f64, f64, f64) {
    let text = cell.to_cordis("a test cell\nsecond line", t.rate, frames as f64 / t.rate);
    let x = render(&load(&text), frames);
    assert_eq!(x.len(), frames);
    let (a, p, r, th) = (t.amp, t.phase_rad, cell.radius, cell.theta);
    let per_step = 4.0 * f64::EPSILON / th.sin();
    let (mut first, mut all, mut worst_ratio) = (0.0f64, 0.0f64, 0.0f64);
    for (n, &v) in x.iter().enumerate() {
        let nf = n as f64;
        if r.powf(nf) < 1e-200 {
            break; // a short decay: the signal has reached the subnormal range
        }
        let env = a.abs() * r.powf(nf);
        let want = a * r.powf(nf) * (th * nf + p).cos();
        let e = (v - want).abs() / env;
        if n < 100 {
            first = first.max(e);
        }
        all = all.max(e);
        worst_ratio = worst_ratio.max(e / (1e-12 + (nf + 1.0) * per_step));
    }
    (first, all, worst_ratio)
}

/// The written model renders `x(n) = A r^n cos(θ n + P)` over 10^5 samples: to 1e-12 of the
/// envelope over the first 100 samples (but at 3 Hz), and over all of them within the drift that the rounding
/// of the engine's coefficients (`2 - (K+Z)/M` and `Z/M - 1`, each to half an ulp) allows, at most
/// `4 ε n / sin θ` of phase: the limit of double precision, not of the design.
#[test]
fn renders_the_target_oscillation() {
    for t in targets() {
        for scale in [
            CellScale::Mass(1.0),
            CellScale::Mass(3.7),
            CellScale::Stiffness(0.25),
        ] {
            let cell = design_cell(&t, scale).unwrap();
            let (first, all, ratio) = deviations(&cell, &t, 100_000);
            println!(
                "f {:>8} tau {:?} {scale:?}: first 100 {first:.2e}, 1e5 samples {all:.2e} ({ratio:.2} of the rounding bound)",
                t.freq_hz, t.decay_s
            );
            assert!(first < 1e-12 || t.freq_hz < 10.0, "first samples {first:e}");
            assert!(ratio <= 1.0, "beyond the rounding bound: {ratio}");
        }
    }
}

/// Sample 0 is `X0 = A cos P` and the model holds the designed numbers exactly (17 digits).
#[test]
fn the_written_model_is_the_design_exactly() {
    for t in targets() {
        let cell = design_cell(&t, CellScale::Mass(2.5)).unwrap();
        let text = cell.to_cordis("line one\nline two", FS, 0.5);
        assert!(text.contains("# line one\n# line two\n"), "{text}");
        assert!(text.contains("rate 44100\n"), "{text}");
        assert!(text.contains("\ncel cell M="), "{text}");
        assert!(text.contains("\nsox out cell"), "{text}");
        let model = load(&text);
        let sys = LinearSystem::from_model(&model).unwrap();
        assert_eq!(sys.mass, vec![cell.m]);
        assert_eq!(sys.k.diag, vec![cell.k]);
        assert_eq!(sys.r.diag, vec![cell.z]);
        assert_eq!(sys.x0, vec![cell.x0]);
        assert_eq!(sys.xm1, vec![cell.x0 - cell.v0]);
        let x = render(&model, 1);
        assert!((x[0] - t.amp * t.phase_rad.cos()).abs() <= 1e-15 * t.amp.abs());
    }
}

/// The analysis of the written model finds the target frequency (1e-9 Hz) and decay time (1e-9
/// relative), and the amplitude `|A|` at the output.
#[test]
fn analysis_finds_the_targets() {
    for t in targets() {
        for scale in [CellScale::Mass(1.0), CellScale::Stiffness(1e-3)] {
            let cell = design_cell(&t, scale).unwrap();
            let model = load(&cell.to_cordis("", FS, 1.0));
            let sys = LinearSystem::from_model(&model).unwrap();
            let ma = ModalAnalysis::compute(&sys).unwrap();
            assert_eq!(ma.modes.len(), 1);
            let m = &ma.modes[0];
            assert_eq!(m.kind, ModeKind::Oscillating);
            assert!(
                (m.freq_hz - t.freq_hz).abs() < 1e-9,
                "{} vs {}",
                m.freq_hz,
                t.freq_hz
            );
            match t.decay_s {
                None => assert!(m.tau_s.is_infinite()),
                Some(tau) => assert!((m.tau_s / tau - 1.0).abs() < 1e-9, "{} vs {tau}", m.tau_s),
            }
            assert!((m.amplitudes[0] / t.amp.abs() - 1.0).abs() < 1e-9);
        }
    }
}

/// The scale: a given mass is the cell's mass, a given stiffness its stiffness, and the ratios
/// `K/M`, `Z/M` do not depend on it.
#[test]
fn scale_sets_mass_or_stiffness() {
    let t = target(440.0, Some(1.5), 0.001, 0.0);
    let a = design_cell(&t, CellScale::Mass(2.0)).unwrap();
    let b = design_cell(&t, CellScale::Stiffness(0.5)).unwrap();
    assert_eq!(a.m, 2.0);
    assert_eq!(b.k, 0.5);
    assert!((a.k / a.m - b.k / b.m).abs() <= 1e-15 * a.k / a.m);
    assert!((a.z / a.m - b.z / b.m).abs() <= 1e-15 * a.z / a.m);
    // the closed form of FORMALISM.md
    let r = (-1.0 / (FS * 1.5f64)).exp();
    assert!((a.radius - r).abs() < 1e-15);
    assert!((a.z / a.m - (1.0 - r * r)).abs() < 1e-15);
    let u = design_cell(&target(440.0, None, 1.0, 0.0), CellScale::Mass(1.0)).unwrap();
    assert_eq!(u.z, 0.0);
    assert_eq!(u.radius, 1.0);
    let s = (std::f64::consts::PI * 440.0 / FS).sin();
    assert!((u.k - 4.0 * s * s).abs() < 1e-17);
}

fn invalid(t: &CellTarget, scale: CellScale) {
    match design_cell(t, scale) {
        Err(DesignError::Invalid { message, hint }) => {
            assert!(!message.is_empty() && !hint.is_empty());
        }
        other => panic!("{t:?} {scale:?}: expected Invalid, got {other:?}"),
    }
}

/// Every bad input is a `DesignError::Invalid` with a message and a hint, never a panic.
#[test]
fn bad_inputs_are_refused() {
    let ok = target(440.0, Some(1.0), 1.0, 0.0);
    let m = CellScale::Mass(1.0);
    for f in [0.0, -1.0, 22050.0, 30000.0, f64::NAN, f64::INFINITY] {
        invalid(
            &CellTarget {
                freq_hz: f,
                ..ok.clone()
            },
            m,
        );
    }
    for tau in [0.0, -1.0, f64::NAN, f64::INFINITY] {
        invalid(
            &CellTarget {
                decay_s: Some(tau),
                ..ok.clone()
            },
            m,
        );
    }
    for amp in [0.0, f64::NAN, f64::INFINITY] {
        invalid(&CellTarget { amp, ..ok.clone() }, m);
    }
    invalid(
        &CellTarget {
            phase_rad: f64::NAN,
            ..ok.clone()
        },
        m,
    );
    for rate in [0.0, -44100.0, f64::NAN] {
        invalid(&CellTarget { rate, ..ok.clone() }, m);
    }
    for v in [0.0, -1.0, f64::NAN, f64::INFINITY] {
        invalid(&ok, CellScale::Mass(v));
        invalid(&ok, CellScale::Stiffness(v));
    }
    // a scale that overflows the other parameter
    invalid(&target(1.0, None, 1.0, 0.0), CellScale::Stiffness(f64::MAX));
}
