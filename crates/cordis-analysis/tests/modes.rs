//! Modal analysis against rendered audio and against its defining identities.
#![allow(clippy::unwrap_used)] // tests may panic on failure

use cordis_analysis::{LinearSystem, Method, ModalAnalysis, ModeKind};
use cordis_model::{load_str, Model, Options};
use rustfft::num_complex::Complex;

fn load(text: &str) -> Model {
    match load_str("m.cordis".as_ref(), text, &Options::default()) {
        Ok(m) => m,
        Err(e) => panic!("{e}"),
    }
}

fn render(m: &Model, frames: usize) -> Vec<f64> {
    let mut e = m.compile();
    let mut out = vec![0.0; frames * e.channels()];
    e.process(frames, &mut out).unwrap();
    out.iter().step_by(e.channels()).copied().collect()
}

/// |DTFT| of a Hann-windowed segment at frequency `f` (cycles per sample), with the phasor advanced
/// by a complex multiplication per sample (renormalised every 1024 samples).
fn dtft(x: &[f64], f: f64) -> f64 {
    let n = x.len() as f64;
    let step = Complex::new(
        (std::f64::consts::TAU * f).cos(),
        -(std::f64::consts::TAU * f).sin(),
    );
    let wstep = Complex::new(
        (std::f64::consts::TAU / n).cos(),
        (std::f64::consts::TAU / n).sin(),
    );
    let (mut ph, mut wph) = (Complex::new(1.0, 0.0), Complex::new(1.0, 0.0));
    let mut acc = Complex::new(0.0, 0.0);
    for (i, &v) in x.iter().enumerate() {
        acc += ph * (v * (0.5 - 0.5 * wph.re));
        ph *= step;
        wph *= wstep;
        if i % 1024 == 1023 {
            ph /= ph.norm();
            wph /= wph.norm();
        }
    }
    acc.norm()
}

/// The frequency (Hz) of the spectral peak nearest `guess`, found by golden-section search of the
/// windowed DTFT magnitude within ±half a bin, starting from the best of a fine grid.
fn peak(x: &[f64], guess: f64, fs: f64) -> f64 {
    let bin = fs / x.len() as f64;
    let mut best = guess;
    let mut best_v = 0.0;
    for k in -40..=40 {
        let f = guess + k as f64 * bin / 20.0;
        let v = dtft(x, f / fs);
        if v > best_v {
            best_v = v;
            best = f;
        }
    }
    let (mut a, mut b) = (best - bin / 20.0, best + bin / 20.0);
    let g = (5f64.sqrt() - 1.0) / 2.0;
    for _ in 0..60 {
        let (c, d) = (b - g * (b - a), a + g * (b - a));
        if dtft(x, c / fs) > dtft(x, d / fs) {
            b = d;
        } else {
            a = c;
        }
    }
    0.5 * (a + b)
}

/// Checks every well-excited, well-separated oscillating mode against a render of `frames`
/// samples: frequency to `tol_hz`, decay time to 1 %.
fn check_against_render(text: &str, frames: usize, tol_hz: f64, expect_method: &str) {
    let m = load(text);
    let sys = LinearSystem::from_model(&m).unwrap();
    let ma = if expect_method == "refined" {
        ModalAnalysis::compute_refined(&sys).unwrap().unwrap()
    } else {
        ModalAnalysis::compute(&sys).unwrap()
    };
    let method = match ma.method {
        Method::Undamped => "undamped",
        Method::Decoupled => "decoupled",
        Method::StateSpace { .. } => "state space",
        Method::Refined { .. } => "refined",
    };
    assert_eq!(method, expect_method);
    let fs = m.rate;
    let x = render(&m, frames);
    let loudest = ma
        .modes
        .iter()
        .map(|md| md.amplitudes[0])
        .fold(0.0, f64::max);
    let mut checked = 0;
    for (i, md) in ma.modes.iter().enumerate() {
        if md.kind != ModeKind::Oscillating || md.amplitudes[0] < 1e-3 * loudest {
            continue;
        }
        // neighbours closer than 30 bins would bias the peak: skip those modes
        let bin = fs / (frames / 2) as f64;
        let near = ma
            .modes
            .iter()
            .enumerate()
            .any(|(j, o)| j != i && (o.freq_hz - md.freq_hz).abs() < 30.0 * bin);
        if near || md.freq_hz < 30.0 * bin {
            continue;
        }
        // frequency: the peak of the first half, whose length sets the resolution
        let half = &x[..frames / 2];
        let f = peak(half, md.freq_hz, fs);
        assert!(
            (f - md.freq_hz).abs() < tol_hz,
            "mode at {:.6} Hz: render peaks at {f:.6} Hz",
            md.freq_hz
        );
        // decay: the same windowed DTFT over two segments, D samples apart: ratio e^{-D / (Fs tau)}
        let seg = frames / 4;
        let (a1, a2) = (
            dtft(&x[..seg], md.freq_hz / fs),
            dtft(&x[seg..2 * seg], md.freq_hz / fs),
        );
        let tau = -(seg as f64) / (fs * (a2 / a1).ln());
        assert!(
            (tau / md.tau_s - 1.0).abs() < 0.01,
            "mode at {:.3} Hz: tau {tau} s vs predicted {} s",
            md.freq_hz,
            md.tau_s
        );
        checked += 1;
    }
    assert!(checked >= 3, "only {checked} modes checked");
}

#[test]
fn a_damped_five_mass_chain_rings_as_predicted() {
    check_against_render(
        "string s n=5 M=1 K=0.3 Z=2e-4 ends=fixed,fixed\nenf hit s[1] signal=impulse(at=0, amp=1)\nsox o s[0]\n",
        1 << 16,
        1e-3,
        "decoupled",
    );
}

#[test]
fn a_chain_with_uneven_damping_uses_the_state_space_and_rings_as_predicted() {
    check_against_render(
        "sol g\nmas a M=1\nmas b M=2\nmas c M=0.5\nmas d M=1.5\nref r1 g a K=0.2 Z=1e-4\nref r2 a b K=0.3 Z=5e-4\nref r3 b c K=0.1\nfro f3 c g Z=2e-4\nref r4 c d K=0.25 Z=1e-5\nref r5 d g K=0.15\nenf hit a signal=impulse(at=0, amp=1)\nsox o d + 0.5*b\n",
        1 << 16,
        1e-3,
        "state space",
    );
}

#[test]
fn a_membrane_rings_as_predicted() {
    check_against_render(
        "membrane mem rows=4 cols=5 M=1 K=0.2 Z=1e-4 border=fixed\nenf hit mem[1,1] signal=impulse(at=0, amp=1)\nsox o mem[0,0]\n",
        1 << 16,
        1e-3,
        "decoupled",
    );
}

#[test]
fn coupled_cels_ring_as_predicted() {
    check_against_render(
        "cel a M=1 f=300Hz tau=0.8s X0=1\ncel b M=2 f=500Hz tau=0.5s\ncel c M=1 f=900Hz tau=0.3s\nref ab a b K=0.001\nref bc b c K=0.002 Z=1e-5\nsox o a + b + c\n",
        1 << 16,
        1e-3,
        "state space",
    );
}

/// A small deterministic generator.
struct Lcg(u64);
impl Lcg {
    fn next(&mut self) -> f64 {
        self.0 = self
            .0
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (self.0 >> 11) as f64 / (1u64 << 53) as f64
    }
}

fn random_network(seed: u64, n: usize, damped: bool) -> String {
    let mut rng = Lcg(seed);
    let mut t = String::from("sol g\n");
    for i in 0..n {
        t += &format!("mas m{i} M={}\n", 0.5 + rng.next());
    }
    for i in 0..n {
        let j = (i + 1 + (rng.next() * (n - 1) as f64) as usize) % n;
        let z = if damped { 1e-4 * rng.next() } else { 0.0 };
        t += &format!("ref a{i} m{i} m{j} K={} Z={z}\n", 0.05 * rng.next());
        if i % 3 == 0 {
            t += &format!("ref g{i} g m{i} K={}\n", 0.05 * rng.next());
        }
    }
    t + "sox o m0\n"
}

#[test]
fn identities_on_seeded_random_networks() {
    for seed in 1..=5 {
        let m = load(&random_network(seed, 40, false));
        let sys = LinearSystem::from_model(&m).unwrap();
        let ma = ModalAnalysis::compute(&sys).unwrap();
        assert_eq!(ma.method, Method::Undamped);
        assert_eq!(ma.modes.len(), 40, "n masses, n modes");
        let k = sys.k.dense();
        let n = sys.len();
        let scale = ma.lambda_max;
        for a in &ma.modes {
            // K φ = λ M φ
            for i in 0..n {
                let kphi: f64 = (0..n).map(|j| k[(i, j)] * a.shape[j]).sum();
                assert!(
                    (kphi - a.lambda * sys.mass[i] * a.shape[i]).abs() < 1e-12 * scale,
                    "seed {seed}"
                );
            }
            // Φᵀ M Φ = I
            for b in &ma.modes {
                let dot: f64 = (0..n).map(|i| a.shape[i] * sys.mass[i] * b.shape[i]).sum();
                let want = if std::ptr::eq(a, b) { 1.0 } else { 0.0 };
                assert!((dot - want).abs() < 1e-12, "seed {seed}: {dot}");
            }
            // f = (Fs/π) asin(sqrt(λ)/2)
            let f = m.rate / std::f64::consts::PI * (a.lambda.sqrt() / 2.0).asin();
            assert!((a.freq_hz - f).abs() < 1e-9 * f.max(1.0));
        }
    }
}

#[test]
fn the_state_space_poles_equal_the_undamped_roots_when_r_is_zero() {
    for seed in 1..=3 {
        let m = load(&random_network(seed, 30, false));
        let sys = LinearSystem::from_model(&m).unwrap();
        let undamped = ModalAnalysis::compute(&sys).unwrap();
        let state = ModalAnalysis::compute_state_space(&sys).unwrap();
        assert_eq!(state.modes.len(), undamped.modes.len());
        for (a, b) in undamped.modes.iter().zip(&state.modes) {
            assert!(
                (a.freq_hz - b.freq_hz).abs() < 1e-8 * a.freq_hz.max(1.0),
                "{} vs {}",
                a.freq_hz,
                b.freq_hz
            );
            assert!((b.radius - 1.0).abs() < 1e-10);
        }
        // and with damping the two exact methods agree on a proportional network
        let m = load(&random_network(seed, 30, false).replace("Z=0", "Z=1e-4"));
        let text = m.source.to_string();
        let prop = load(
            &text
                .lines()
                .map(|l| {
                    if l.starts_with("ref") {
                        let k: f64 = l
                            .split("K=")
                            .nth(1)
                            .unwrap()
                            .split(' ')
                            .next()
                            .unwrap()
                            .parse()
                            .unwrap();
                        format!("{} Z={}", l.split(" Z=").next().unwrap(), 0.01 * k)
                    } else {
                        l.to_string()
                    }
                })
                .collect::<Vec<_>>()
                .join("\n"),
        );
        let sys = LinearSystem::from_model(&prop).unwrap();
        let dec = ModalAnalysis::compute(&sys).unwrap();
        assert_eq!(dec.method, Method::Decoupled);
        let st = ModalAnalysis::compute_state_space(&sys).unwrap();
        for (a, b) in dec.modes.iter().zip(&st.modes) {
            assert!((a.freq_hz - b.freq_hz).abs() < 1e-7 * a.freq_hz.max(1.0));
            assert!(
                (a.tau_s / b.tau_s - 1.0).abs() < 1e-6,
                "{} vs {}",
                a.tau_s,
                b.tau_s
            );
        }
    }
}

#[test]
fn rigid_and_free_floating_parts() {
    let m = load("mas a M=1\nmas b M=2\nref s a b K=0.1\nsox o a\n");
    let sys = LinearSystem::from_model(&m).unwrap();
    assert_eq!(sys.free_parts, vec![vec![0, 1]]);
    let ma = ModalAnalysis::compute(&sys).unwrap();
    assert_eq!(ma.modes.len(), 2);
    assert_eq!(ma.modes[0].kind, ModeKind::Rigid);
    assert_eq!(ma.modes[0].freq_hz, 0.0);
    // the other is the relative motion: λ = k (1/m1 + 1/m2)
    assert!((ma.modes[1].lambda - 0.1 * 1.5).abs() < 1e-15);
}

#[test]
fn the_response_equals_the_dtft_of_a_rendered_impulse_response() {
    for text in [
        "string s n=6 M=1 K=0.2 Z=0.02 ends=fixed,free\nenf hit s[2] signal=impulse(at=0, amp=1)\nsox o s[4]\n",
        "sol g\nmas a M=1\nmas b M=2\nref r1 g a K=0.2 Z=0.02\nref r2 a b K=0.3 Z=0.03\nfro f b g Z=0.02\nenf hit a signal=impulse(at=0, amp=1)\nsox o b\n",
    ] {
        let m = load(text);
        let sys = LinearSystem::from_model(&m).unwrap();
        let ma = ModalAnalysis::compute(&sys).unwrap();
        let (a, b) = (sys.impulses[0].1, sys.outputs[0].1[0].1);
        let x = render(&m, 1 << 16);
        assert!(x[x.len() - 1].abs() < 1e-12, "decayed");
        let mut buf: Vec<Complex<f64>> = x.iter().map(|&v| Complex::new(v, 0.0)).collect();
        rustfft::FftPlanner::new().plan_fft_forward(buf.len()).process(&mut buf);
        let peak = buf.iter().map(|c| c.norm()).fold(0.0, f64::max);
        for k in (1..buf.len() / 2).step_by(97) {
            let f = k as f64 * m.rate / buf.len() as f64;
            let h = ma.receptance(a, b, f, m.rate);
            let d = (Complex::new(h.re, h.im) - buf[k]).norm();
            assert!(d < 1e-9 * peak, "{f} Hz: {h:?} vs {:?}", buf[k]);
        }
        // and the magnitude peaks at the first mode's frequency
        let f1 = ma.modes.iter().find(|md| md.kind == ModeKind::Oscillating).unwrap().freq_hz;
        let at = |f: f64| ma.receptance(a, b, f, m.rate).norm();
        assert!(at(f1) > at(f1 * 0.98) && at(f1) > at(f1 * 1.02));
    }
}

#[test]
fn a_damped_free_floating_part_is_not_reported_unstable() {
    // a, MC1, MC2, b float freely (no spring to a fixed point) and the device's BUTs damp
    // unevenly: state-space method, with a double pole at z = 1 that must stay at radius 1.
    let m =
        load("sol g\nmas a M=1\nmas b M=1\nbond good a b mC=0.2 KL=0.1 S=0.1 KR=0.05\nsox o a\n");
    let sys = LinearSystem::from_model(&m).unwrap();
    assert_eq!(sys.free_parts.len(), 1);
    let ma = ModalAnalysis::compute(&sys).unwrap();
    assert!(matches!(ma.method, Method::StateSpace { .. }));
    assert_eq!(
        ma.modes
            .iter()
            .filter(|md| md.kind == ModeKind::Rigid)
            .count(),
        1
    );
    assert_eq!(ma.modes.len(), 4);
    assert!(ma.max_radius <= 1.0, "{}", ma.max_radius);
}

#[test]
fn non_finite_or_singular_input_is_an_error_not_a_panic() {
    let m = load("string s n=3 M=1 K=0.1\nsox o s[0]\n");
    let mut sys = LinearSystem::from_model(&m).unwrap();
    sys.mass[1] = 0.0;
    assert!(matches!(
        ModalAnalysis::compute(&sys),
        Err(cordis_analysis::AnalysisError::Singular(_))
    ));
    let mut sys = LinearSystem::from_model(&m).unwrap();
    sys.k.diag[0] = f64::NAN;
    let e = ModalAnalysis::compute(&sys).unwrap_err();
    assert!(e.to_string().contains("non-finite"), "{e}");
    let empty = load("sol g\nsox o g\n");
    assert_eq!(
        LinearSystem::from_model(&empty).unwrap_err(),
        cordis_analysis::AnalysisError::NoMobileModule
    );
}

#[test]
fn undamped_modes_of_widely_spread_inertias_count_as_stable() {
    // The reconfigurable instrument's 1e10 bridges make its undamped modes read r = 1 + ~1e-12:
    // rounding, not growth. A spring too stiff for its mass is a real instability.
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../examples/instrumentarium/reconfigurable_11s.cordis");
    let m = cordis_model::load_file(&path, &Options::default()).unwrap();
    let ma = ModalAnalysis::compute(&LinearSystem::from_model(&m).unwrap()).unwrap();
    assert!(
        cordis_analysis::radius_is_stable(ma.max_radius),
        "{}",
        ma.max_radius
    );
    let hot = load("sol g\nmas m M=1 X0=1\nres r g m K=5\nsox o m\n");
    let ma = ModalAnalysis::compute(&LinearSystem::from_model(&hot).unwrap()).unwrap();
    assert!(
        !cordis_analysis::radius_is_stable(ma.max_radius),
        "{}",
        ma.max_radius
    );
}

/// A 300-mass string, damped unevenly (air damping growing along it, dampers to the ground at two
/// points, a free end on a heavy mass): the damping couples the undamped modes.
fn uneven_string(n: usize) -> String {
    let mut t = format!(
        "sol g\nstring s n={n} M=1 K=0.2 Z=1e-5 ends=fixed,free\nmas heavy M=40\nref end s[{}] heavy K=0.05\n",
        n - 1
    );
    for i in (0..n).step_by(7) {
        t += &format!("fro air{i} s[{i}] g Z={}\n", 1e-6 * (1.0 + i as f64 / 50.0));
    }
    t += &format!(
        "fro d1 g s[{}] Z=3e-3\nfro d2 g s[{}] Z=1e-3\n",
        n / 3,
        2 * n / 3
    );
    t += &format!(
        "enf hit s[3] signal=impulse(at=0, amp=1)\nsox o s[1] + 0.5*heavy\nsox p s[{}]\n",
        n / 7
    );
    t
}

#[test]
fn the_refined_poles_equal_the_dense_state_space_ones() {
    let m = load(&uneven_string(300));
    let sys = LinearSystem::from_model(&m).unwrap();
    let refined = ModalAnalysis::compute_refined(&sys).unwrap().unwrap();
    let Method::Refined { max_residual, .. } = refined.method else {
        panic!("expected the refined method, got {:?}", refined.method)
    };
    assert!(max_residual < 1e-12, "{max_residual}");
    let dense = ModalAnalysis::compute_state_space(&sys).unwrap();
    assert_eq!(refined.modes.len(), sys.len());
    assert_eq!(dense.modes.len(), refined.modes.len());
    let loud = |ma: &ModalAnalysis, c: usize| {
        ma.modes
            .iter()
            .map(|md| md.amplitudes[c])
            .fold(0.0, f64::max)
    };
    for (a, b) in refined.modes.iter().zip(&dense.modes) {
        assert_eq!(a.kind, b.kind);
        assert!(
            (a.freq_hz - b.freq_hz).abs() <= 1e-9 * m.rate,
            "{a:?} vs {b:?}"
        );
        assert!(
            (a.radius - b.radius).abs() <= 1e-12,
            "{} vs {}",
            a.radius,
            b.radius
        );
        for c in 0..2 {
            let (x, y) = (a.amplitudes[c], b.amplitudes[c]);
            assert!(
                (x - y).abs() <= 1e-7 * loud(&dense, c),
                "{} Hz channel {c}: {x} vs {y}",
                a.freq_hz
            );
        }
    }
    assert!((refined.max_radius - dense.max_radius).abs() < 1e-12);
    // the receptances agree too (driving point at s[3], transfer to heavy)
    let (hit, heavy) = (sys.dof("s[3]").unwrap(), sys.dof("heavy").unwrap());
    // (relative to the driving point: far transfers at high frequency are at rounding level)
    for f in [13.0, 110.0, 1234.5, 8000.0, 20000.0] {
        let scale = dense.receptance(hit, hit, f, m.rate).norm();
        for (x, y) in [(hit, hit), (hit, heavy)] {
            let (p, q) = (
                refined.receptance(x, y, f, m.rate),
                dense.receptance(x, y, f, m.rate),
            );
            assert!((p - q).norm() <= 1e-8 * scale, "{f} Hz: {p:?} vs {q:?}");
        }
    }
}

#[test]
fn a_long_unevenly_damped_string_rings_as_refined() {
    check_against_render(&uneven_string(240), 1 << 17, 1e-3, "refined");
}

#[test]
fn a_refined_network_with_a_free_floating_part_keeps_its_rigid_mode() {
    // the string is fixed; a separate free pair of masses floats, damped internally
    let mut text = uneven_string(250);
    text += "mas fa M=1\nmas fb M=3\nref fl fa fb K=0.1 Z=1e-3\ninit fa X0=0.5\n";
    let m = load(&text);
    let sys = LinearSystem::from_model(&m).unwrap();
    let ma = ModalAnalysis::compute_refined(&sys).unwrap().unwrap();
    assert!(
        matches!(ma.method, Method::Refined { .. }),
        "{:?}",
        ma.method
    );
    assert_eq!(ma.modes.len(), sys.len());
    assert_eq!(
        ma.modes
            .iter()
            .filter(|md| md.kind == ModeKind::Rigid)
            .count(),
        1
    );
    // the response of the free part includes its rigid motion: dense and refined agree
    let dense = ModalAnalysis::compute_state_space(&sys).unwrap();
    let (fa, fb) = (sys.dof("fa").unwrap(), sys.dof("fb").unwrap());
    for f in [50.0, 500.0, 5000.0] {
        let (p, q) = (
            ma.receptance(fa, fb, f, m.rate),
            dense.receptance(fa, fb, f, m.rate),
        );
        assert!((p - q).norm() <= 1e-6 * q.norm(), "{f} Hz: {p:?} vs {q:?}");
    }
}

#[test]
fn the_refined_method_declines_what_it_need_not_or_cannot_do() {
    // decoupled damping: the closed forms are exact, nothing to refine
    let m = load("string s n=10 M=1 K=0.1 Z=1e-4 ends=fixed,fixed\nsox o s[1]\n");
    let sys = LinearSystem::from_model(&m).unwrap();
    assert!(ModalAnalysis::compute_refined(&sys).unwrap().is_none());
    // a small network with coupling damping: compute takes the dense state space
    let m = load(&uneven_string(30));
    let sys = LinearSystem::from_model(&m).unwrap();
    assert!(matches!(
        ModalAnalysis::compute(&sys).unwrap().method,
        Method::StateSpace { .. }
    ));
}
