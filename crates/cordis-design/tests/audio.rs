//! Modal parameters estimated from recordings: synthetic bells with noise, renders of cordis
//! models whose exact modes are known, and bad input.
#![allow(clippy::unwrap_used)] // tests may panic on failure

use cordis_analysis::{LinearSystem, ModalAnalysis, ModeKind};
use cordis_design::audio::{estimate_modes, AudioOptions, EstimatedMode};
use cordis_design::DesignError;
use cordis_model::{load_str, Model, Options};

/// A small deterministic generator.
struct Lcg(u64);
impl Lcg {
    fn uniform(&mut self) -> f64 {
        self.0 = self
            .0
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        ((self.0 >> 11) as f64 + 0.5) / (1u64 << 53) as f64
    }
    /// Standard normal (Box–Muller).
    fn normal(&mut self) -> f64 {
        let (u, v) = (self.uniform(), self.uniform());
        (-2.0 * u.ln()).sqrt() * (std::f64::consts::TAU * v).cos()
    }
}

/// A partial: frequency (Hz), amplitude, decay time (s), phase (rad).
type Partial = (f64, f64, f64, f64);

fn synth(partials: &[Partial], rate: f64, seconds: f64) -> Vec<f64> {
    let n = (seconds * rate).round() as usize;
    (0..n)
        .map(|i| {
            let t = i as f64 / rate;
            partials
                .iter()
                .map(|&(f, a, tau, ph)| {
                    a * (-t / tau).exp() * (std::f64::consts::TAU * f * t + ph).cos()
                })
                .sum()
        })
        .collect()
}

/// Adds white Gaussian noise `db` decibels below the signal's RMS.
fn add_noise(x: &mut [f64], db: f64, seed: u64) {
    let rms = (x.iter().map(|v| v * v).sum::<f64>() / x.len() as f64).sqrt();
    let sigma = rms * 10f64.powf(db / 20.0);
    let mut rng = Lcg(seed);
    for v in x.iter_mut() {
        *v += sigma * rng.normal();
    }
}

/// The bell of the brief: partials at 0.5, 1, 1.183, 1.506, 2, 2.514, 2.662, 3.011 × 440 Hz.
fn bell() -> Vec<Partial> {
    let ratios = [0.5, 1.0, 1.183, 1.506, 2.0, 2.514, 2.662, 3.011];
    let amps = [0.6, 1.0, 0.35, 0.5, 0.25, 0.12, 0.2, 0.08];
    let taus = [4.0, 2.5, 1.8, 1.2, 0.9, 0.6, 0.5, 0.3];
    let phases = [0.3, -1.2, 2.0, 0.0, -2.8, 1.1, -0.4, 2.9];
    (0..8)
        .map(|i| (440.0 * ratios[i], amps[i], taus[i], phases[i]))
        .collect()
}

/// Matches every expected partial to the nearest estimate; returns the worst relative errors of
/// frequency, decay and amplitude, and of the phase (rad).
fn worst(expected: &[Partial], got: &[EstimatedMode]) -> (f64, f64, f64, f64) {
    let mut w = (0.0f64, 0.0f64, 0.0f64, 0.0f64);
    for &(f, a, tau, ph) in expected {
        let m = got
            .iter()
            .min_by(|x, y| (x.freq_hz - f).abs().total_cmp(&(y.freq_hz - f).abs()))
            .unwrap();
        let dph = (m.phase_rad - ph + std::f64::consts::PI).rem_euclid(std::f64::consts::TAU)
            - std::f64::consts::PI;
        w.0 = w.0.max((m.freq_hz / f - 1.0).abs());
        w.1 = w.1.max((m.decay_s / tau - 1.0).abs());
        w.2 = w.2.max((m.amp / a - 1.0).abs());
        w.3 = w.3.max(dph.abs());
    }
    w
}

#[test]
fn a_noisy_bell_gives_back_its_partials() {
    let partials = bell();
    let rate = 44100.0;
    let mut x = synth(&partials, rate, 2.0);
    add_noise(&mut x, -60.0, 7);
    let t0 = std::time::Instant::now();
    let got = estimate_modes(&x, rate, &AudioOptions::new(8)).unwrap();
    let took = t0.elapsed();
    assert_eq!(got.len(), 8, "{got:#?}");
    let (ef, ed, ea, ep) = worst(&partials, &got);
    println!(
        "noisy bell: worst relative errors: frequency {ef:.2e}, decay {ed:.2e}, amplitude {ea:.2e}, phase {ep:.2e} rad ({took:?})"
    );
    assert!(ef < 1e-6, "frequency error {ef:e}");
    assert!(ed < 0.01, "decay error {ed:e}");
    assert!(ea < 0.01, "amplitude error {ea:e}");
    assert!(ep < 0.01, "phase error {ep:e}");
    // sorted by frequency
    assert!(got.windows(2).all(|w| w[0].freq_hz < w[1].freq_hz));
}

#[test]
fn a_clean_bell_is_recovered_to_rounding_level() {
    let partials = bell();
    let rate = 44100.0;
    let x = synth(&partials, rate, 2.0);
    let got = estimate_modes(&x, rate, &AudioOptions::new(8)).unwrap();
    let (ef, ed, ea, ep) = worst(&partials, &got);
    println!(
        "clean bell: worst relative errors: frequency {ef:.2e}, decay {ed:.2e}, amplitude {ea:.2e}, phase {ep:.2e} rad"
    );
    assert!(ef < 1e-9 && ed < 1e-5 && ea < 1e-5 && ep < 1e-5);
}

fn load(text: &str) -> Model {
    match load_str("m.cordis".as_ref(), text, &Options::default()) {
        Ok(m) => m,
        Err(e) => panic!("{e}"),
    }
}

/// The first output channel of a render of `frames` samples.
fn render(m: &Model, frames: usize) -> Vec<f64> {
    let mut e = m.compile();
    let mut out = vec![0.0; frames * e.channels()];
    e.process(frames, &mut out).unwrap();
    out.iter().step_by(e.channels()).copied().collect()
}

/// Renders `text` for 2 s, estimates its modes from the render and compares them with the exact
/// modes of the modal analysis (frequency, decay time, amplitude at the output at step 0) for
/// every oscillating mode above 1e-3 of the loudest; returns the worst relative errors.
fn check_render(text: &str, modes: usize) -> (f64, f64, f64) {
    let m = load(text);
    let sys = LinearSystem::from_model(&m).unwrap();
    let ma = ModalAnalysis::compute(&sys).unwrap();
    let x = render(&m, (2.0 * m.rate) as usize);
    let got = estimate_modes(&x, m.rate, &AudioOptions::new(modes)).unwrap();
    let loudest = ma
        .modes
        .iter()
        .map(|md| md.amplitudes[0])
        .fold(0.0, f64::max);
    let mut w = (0.0f64, 0.0f64, 0.0f64);
    let mut checked = 0;
    for md in &ma.modes {
        if md.kind != ModeKind::Oscillating || md.amplitudes[0] < 1e-3 * loudest {
            continue;
        }
        let e = got
            .iter()
            .min_by(|a, b| {
                (a.freq_hz - md.freq_hz)
                    .abs()
                    .total_cmp(&(b.freq_hz - md.freq_hz).abs())
            })
            .unwrap();
        w.0 = w.0.max((e.freq_hz / md.freq_hz - 1.0).abs());
        w.1 = w.1.max((e.decay_s / md.tau_s - 1.0).abs());
        w.2 = w.2.max((e.amp / md.amplitudes[0] - 1.0).abs());
        checked += 1;
    }
    assert!(checked >= 3, "only {checked} modes checked");
    w
}

#[test]
fn coupled_cels_rendered_by_the_engine_give_their_exact_modes() {
    // damping that couples the modes: the analysis takes the state-space method
    let (ef, ed, ea) = check_render(
        "cel a M=1 f=300Hz tau=0.8s X0=1\ncel b M=2 f=500Hz tau=0.5s X0=0.5\n\
         cel c M=1 f=900Hz tau=0.3s X0=-0.7\nref ab a b K=0.001\nref bc b c K=0.002 Z=1e-5\n\
         sox o a + b + c\n",
        3,
    );
    println!("coupled cels: worst relative errors: frequency {ef:.2e}, decay {ed:.2e}, amplitude {ea:.2e}");
    assert!(ef < 1e-9 && ed < 1e-6 && ea < 1e-6, "{ef:e} {ed:e} {ea:e}");
}

#[test]
fn a_damped_plucked_string_rendered_by_the_engine_gives_its_exact_modes() {
    let (ef, ed, ea) = check_render(
        "string s n=6 M=1 K=0.05 Z=1e-4 pluck=(1, 0.01)\nsox o s[4]\n",
        6,
    );
    println!("damped string: worst relative errors: frequency {ef:.2e}, decay {ed:.2e}, amplitude {ea:.2e}");
    assert!(ef < 1e-9 && ed < 1e-6 && ea < 1e-6, "{ef:e} {ed:e} {ea:e}");
}

#[test]
fn five_seconds_with_forty_partials_are_analysed_quickly() {
    // a rich inharmonic spectrum (a stiff string's partials), 5 s at 48 kHz, noise at -50 dB
    let rate = 48000.0;
    let partials: Vec<Partial> = (1..=40)
        .map(|k| {
            let k = k as f64;
            (
                110.0 * k * (1.0 + 4e-4 * k * k).sqrt(),
                1.0 / k,
                3.0 / (1.0 + 0.2 * k),
                0.7 * k,
            )
        })
        .collect();
    let mut x = synth(&partials, rate, 5.0);
    add_noise(&mut x, -50.0, 11);
    let t0 = std::time::Instant::now();
    let got = estimate_modes(&x, rate, &AudioOptions::new(30)).unwrap();
    let took = t0.elapsed();
    assert_eq!(got.len(), 30);
    // the 30 strongest by energy are the 30 lowest partials here
    let (ef, ed, ea, _) = worst(&partials[..30], &got);
    println!(
        "40 partials, 5 s at 48 kHz: {took:?}; worst relative errors of the 30 strongest: frequency {ef:.2e}, decay {ed:.2e}, amplitude {ea:.2e}"
    );
    assert!(ef < 1e-6 && ed < 0.01 && ea < 0.01, "{ef:e} {ed:e} {ea:e}");
    // generous: the test profile is barely optimised
    assert!(took.as_secs_f64() < 5.0, "took {took:?}");
}

#[test]
fn fewer_modes_than_asked_are_returned_as_found() {
    let partials = [(500.0, 1.0, 1.0, 0.0), (1234.5, 0.5, 0.7, 1.0)];
    let mut x = synth(&partials, 44100.0, 1.0);
    add_noise(&mut x, -60.0, 3);
    let got = estimate_modes(&x, 44100.0, &AudioOptions::new(10)).unwrap();
    assert_eq!(got.len(), 2, "{got:#?}");
    let (ef, ..) = worst(&partials, &got);
    assert!(ef < 1e-6);
}

#[test]
fn a_steady_sinusoid_does_not_decay() {
    let x: Vec<f64> = (0..44100)
        .map(|i| 0.5 * (std::f64::consts::TAU * 441.0 * i as f64 / 44100.0).sin())
        .collect();
    let got = estimate_modes(&x, 44100.0, &AudioOptions::new(1)).unwrap();
    assert_eq!(got.len(), 1);
    assert!((got[0].freq_hz - 441.0).abs() < 1e-9);
    assert!((got[0].amp - 0.5).abs() < 1e-9);
    assert!(got[0].decay_s > 1e6, "{}", got[0].decay_s);
}

#[test]
fn the_analysis_window_skips_the_attack_and_reads_amplitudes_at_its_start() {
    let partials = [(700.0, 1.0, 0.5, 0.2), (1900.0, 0.4, 0.25, -1.0)];
    let rate = 44100.0;
    let x = synth(&partials, rate, 2.0);
    let mut opts = AudioOptions::new(2);
    opts.start_s = 0.2;
    opts.length_s = Some(1.0);
    let got = estimate_modes(&x, rate, &opts).unwrap();
    // amplitudes and phases at t = 0.2 s
    let at: Vec<Partial> = partials
        .iter()
        .map(|&(f, a, tau, ph)| {
            (
                f,
                a * (-0.2 / tau).exp(),
                tau,
                ph + std::f64::consts::TAU * f * 0.2,
            )
        })
        .collect();
    let (ef, ed, ea, ep) = worst(&at, &got);
    assert!(
        ef < 1e-9 && ed < 1e-6 && ea < 1e-6 && ep < 1e-6,
        "{ef:e} {ed:e} {ea:e} {ep:e}"
    );
}

fn invalid(r: Result<Vec<EstimatedMode>, DesignError>) -> String {
    match r {
        Err(DesignError::Invalid { message, hint }) => {
            assert!(!hint.is_empty());
            message
        }
        other => panic!("expected an invalid-input error, got {other:?}"),
    }
}

#[test]
fn bad_input_is_an_error_never_a_panic() {
    let opts = AudioOptions::new(4);
    let rate = 44100.0;
    let m = invalid(estimate_modes(&vec![0.0; 44100], rate, &opts));
    assert!(m.contains("the recording is silent"), "{m}");
    let mut x = synth(&[(440.0, 1.0, 1.0, 0.0)], rate, 0.5);
    x[1000] = f64::NAN;
    let m = invalid(estimate_modes(&x, rate, &opts));
    assert!(m.contains("sample 1000") && m.contains("NaN"), "{m}");
    x[1000] = f64::INFINITY;
    invalid(estimate_modes(&x, rate, &opts));
    x[1000] = 0.0;
    let m = invalid(estimate_modes(&x[..100], rate, &opts));
    assert!(m.contains("100 samples"), "{m}");
    invalid(estimate_modes(&[], rate, &opts));
    invalid(estimate_modes(&x, 0.0, &opts));
    invalid(estimate_modes(&x, f64::NAN, &opts));
    invalid(estimate_modes(&x, rate, &AudioOptions::new(0)));
    for (min, max) in [
        (-1.0, 1000.0),
        (500.0, 400.0),
        (f64::NAN, 1000.0),
        (20.0, f64::NAN),
        (30000.0, f64::INFINITY),
        (440.0, 440.1),
    ] {
        let mut o = opts.clone();
        o.min_freq_hz = min;
        o.max_freq_hz = max;
        invalid(estimate_modes(&x, rate, &o));
    }
    for (start, len) in [
        (-1.0, None),
        (f64::NAN, None),
        (0.497, None),
        (10.0, None),
        (0.0, Some(0.0)),
        (0.0, Some(f64::NAN)),
    ] {
        let mut o = opts.clone();
        o.start_s = start;
        o.length_s = len;
        invalid(estimate_modes(&x, rate, &o));
    }
    // white noise alone has no resonance
    let mut noise = vec![0.0; 44100];
    add_noise(&mut noise[..1], 0.0, 1); // (no-op on a silent sample: rms 0)
    let mut rng = Lcg(5);
    for v in noise.iter_mut() {
        *v = rng.normal();
    }
    let m = invalid(estimate_modes(&noise, rate, &opts));
    assert!(m.contains("no resonance"), "{m}");
    // a constant offset, a single click, tiny and huge scales: no panic
    let _ = estimate_modes(&vec![0.3; 4096], rate, &opts);
    let mut click = vec![0.0; 4096];
    click[100] = 1.0;
    let _ = estimate_modes(&click, rate, &opts);
    let tiny: Vec<f64> = x.iter().map(|v| v * 1e-300).collect();
    let _ = estimate_modes(&tiny, rate, &opts);
    let huge: Vec<f64> = x.iter().map(|v| v * 1e300).collect();
    let _ = estimate_modes(&huge, rate, &opts);
}
