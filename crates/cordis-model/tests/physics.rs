//! Closed forms of FORMALISM.md checked against renders of models written in the language.
#![allow(clippy::unwrap_used)] // tests and benches may panic on failure

use cordis_model::{load_str, Model, Options};

fn load(text: &str) -> Model {
    match load_str("test.cordis".as_ref(), text, &Options::default()) {
        Ok(m) => m,
        Err(e) => panic!("{e}"),
    }
}

fn render(model: &Model, frames: usize) -> Vec<f64> {
    let mut e = model.compile();
    let mut out = vec![0.0; frames * e.channels()];
    e.process(frames, &mut out).expect("stable");
    out
}

/// Frequency (Hz) from zero crossings, interpolated linearly, first to last.
fn zero_crossing_freq(x: &[f64], fs: f64) -> f64 {
    let mut times = Vec::new();
    for n in 1..x.len() {
        if x[n - 1] > 0.0 && x[n] <= 0.0 {
            times.push((n - 1) as f64 + x[n - 1] / (x[n - 1] - x[n]));
        }
    }
    let periods = (times.len() - 1) as f64;
    fs * periods / (times[times.len() - 1] - times[0])
}

#[test]
fn cel_given_by_frequency_and_decay_rings_at_them() {
    // 441 Hz at 44100 Hz: exactly 100 samples per period, so x(n + 100) / x(n) = r^100.
    for (f, tau) in [(441.0, 2.0), (441.0, 0.25), (882.0, 1.0)] {
        let m = load(&format!(
            "duration 5s\ncel c M=1 f={f}Hz tau={tau}s X0=1\nsox out c\n"
        ));
        let x = render(&m, m.duration as usize);
        let fz = zero_crossing_freq(&x, 44100.0);
        assert!((fz / f - 1.0).abs() < 1e-6, "f = {f}: measured {fz}");
        let period = (44100.0 / f) as usize;
        let n0 = 1000;
        let ratio = x[n0 + period] / x[n0];
        let tau_measured = -(period as f64) / (44100.0 * ratio.ln());
        assert!(
            (tau_measured / tau - 1.0).abs() < 1e-6,
            "tau = {tau}: measured {tau_measured}"
        );
    }
}

#[test]
fn cel_given_by_k_and_z_matches_its_poles() {
    let (k, z) = (0.01, 1e-5);
    let m = load(&format!(
        "duration 3s\ncel c M=1 K={k} Z={z} X0=1\nsox out c\n"
    ));
    let x = render(&m, m.duration as usize);
    let (f_cps, tau_samples) = cordis_model::cel_modal(1.0, k, z).unwrap();
    let fz = zero_crossing_freq(&x, 44100.0);
    assert!(
        (fz / (f_cps * 44100.0) - 1.0).abs() < 1e-6,
        "{fz} vs {}",
        f_cps * 44100.0
    );
    // least-squares AR(2) fit of the render gives the poles
    let (mut s11, mut s12, mut s22, mut b1, mut b2) = (0.0, 0.0, 0.0, 0.0, 0.0);
    for n in 1..x.len() - 1 {
        s11 += x[n] * x[n];
        s12 += x[n] * x[n - 1];
        s22 += x[n - 1] * x[n - 1];
        b1 += x[n + 1] * x[n];
        b2 += x[n + 1] * x[n - 1];
    }
    let det = s11 * s22 - s12 * s12;
    let a = (b1 * s22 - b2 * s12) / det;
    let b = (s11 * b2 - s12 * b1) / det;
    let r = (-b).sqrt();
    let tau = -1.0 / r.ln();
    assert!(
        (tau / tau_samples - 1.0).abs() < 1e-6,
        "{tau} vs {tau_samples}"
    );
    assert!((a - (2.0 - (k + z))).abs() < 1e-9);
}

#[test]
fn undamped_string_energy_stays_bounded() {
    let m = load("string s n=40 M=1 K=0.3 Z=0 ends=fixed,fixed pluck=(9, 1)\n");
    let net = &m.network;
    let mut e = m.compile();
    let energy = |e: &cordis_core::Engine| {
        let mut kin = 0.0;
        for (i, mat) in net.materials.iter().enumerate() {
            if let cordis_core::Material::Mas { m, .. } = mat {
                let id = cordis_core::MatId(i as u32);
                let v = e.position(id) - e.previous_position(id);
                kin += 0.5 * m * v * v;
            }
        }
        let mut pot = 0.0;
        for l in &net.links {
            if let cordis_core::Interaction::Ref { k, .. } = l.law {
                let d = e.position(l.a) - e.position(l.b);
                pot += 0.5 * k * d * d;
            }
        }
        kin + pot
    };
    let e0 = energy(&e);
    assert!(e0 > 0.0);
    let (mut lo, mut hi) = (e0, e0);
    let mut late = (f64::MAX, f64::MIN);
    let steps = 200_000;
    for n in 0..steps {
        e.process(1, &mut []).unwrap();
        let en = energy(&e);
        lo = lo.min(en);
        hi = hi.max(en);
        if n >= steps - 20_000 {
            late = (late.0.min(en), late.1.max(en));
        }
    }
    // The discrete energy oscillates within a band set by K/M (here 0.3: a few percent)...
    assert!(
        hi / e0 < 1.2 && lo / e0 > 0.8,
        "energy band [{lo}, {hi}] around {e0}"
    );
    // ...and does not drift: the band at the end is inside the band overall, not above it.
    assert!(late.1 <= hi && late.0 >= lo);
    assert!(late.1 / e0 < 1.2);
}

#[test]
fn units_convert_with_the_models_rate() {
    let m = load("rate 48000\nmas a M=1 V0=480m/s\ncel c M=1 K=48000N/m Z=4.8Ns/m\nsox o a\n");
    match (&m.network.materials[0], &m.network.materials[1]) {
        (cordis_core::Material::Mas { v0, .. }, cordis_core::Material::Cel { k, z, .. }) => {
            assert_eq!(*v0, 0.01);
            assert_eq!(*k, 48000.0 / (48000.0 * 48000.0));
            assert_eq!(*z, 4.8 / 48000.0);
        }
        other => panic!("{other:?}"),
    }
    // --rate overrides, and the conversions follow it
    let opts = Options {
        rate: Some("96kHz".into()),
        ..Options::default()
    };
    let m = load_str(
        "t.cordis".as_ref(),
        "rate 48000\nduration 10ms\nmas a M=1\nsox o a\n",
        &opts,
    )
    .unwrap();
    assert_eq!(m.rate, 96000.0);
    assert_eq!(m.duration, 960);
}

#[test]
fn set_overrides_a_let_and_everything_that_uses_it() {
    let text = "let k = 0.1\nlet k2 = 2*k\nsol g\nmas m M=1\nref r g m K=k2\nsox o m\n";
    let opts = Options {
        sets: vec![("k".into(), "0.25".into())],
        ..Options::default()
    };
    let m = load_str("t.cordis".as_ref(), text, &opts).unwrap();
    assert_eq!(
        m.network.links[0].law,
        cordis_core::Interaction::Ref { k: 0.5, z: 0.0 }
    );
}

#[test]
fn generators_make_the_documented_names_and_shapes() {
    let m =
        load("string s n=5 M=1 K=0.1 ends=fixed,free pluck=(1, 0.5)\nsox a s[4]\nsof f s.l[0]\n");
    let names: Vec<&str> = m.materials.iter().map(|n| n.name.as_str()).collect();
    assert_eq!(names, ["s[0]", "s[1]", "s[2]", "s[3]", "s[4]", "s.left"]);
    let links: Vec<&str> = m.links.iter().map(|n| n.name.as_str()).collect();
    assert_eq!(links, ["s.l[0]", "s.l[1]", "s.l[2]", "s.l[3]", "s.l[4]"]);
    let x0: Vec<f64> = m
        .network
        .materials
        .iter()
        .map(|mt| mt.initial_state().0)
        .collect();
    assert_eq!(x0, [0.25, 0.5, 0.375, 0.25, 0.125, 0.0]);

    let m = load(
        "membrane mem rows=3 cols=4 M=1 K=0.1 Z=1e-4 border=fixed\nlet r = 2\nsox o mem[r, 3]\n",
    );
    assert_eq!(m.network.materials.len(), 12 + 1);
    // 3*3 horizontal + 2*4 vertical + 2*(3+4) border links
    assert_eq!(m.network.links.len(), 9 + 8 + 14);
    assert_eq!(m.outputs.len(), 1);
    assert_eq!(
        m.network.outputs[0],
        cordis_core::Output::Position(cordis_core::MatId(11))
    );
    let free = load("membrane mem rows=3 cols=4 M=1 K=0.1 border=free\nsox o mem[0,0]\n");
    assert_eq!(free.network.links.len(), 17);
}

#[test]
fn signals_from_files_and_generators() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(
        dir.path().join("f.csv"),
        "# made by hand\nforce\n0.5\n-0.25\n1e-3\n",
    )
    .unwrap();
    let spec = hound::WavSpec {
        channels: 2,
        sample_rate: 44100,
        bits_per_sample: 16,
        sample_format: hound::SampleFormat::Int,
    };
    let mut w = hound::WavWriter::create(dir.path().join("f.wav"), spec).unwrap();
    for s in [100i16, 16384, -16384, 0] {
        w.write_sample(s).unwrap();
    }
    w.finalize().unwrap();
    let text = "mas a M=1\nmas b M=1\nenf fa a signal=file(\"f.csv\")\nenf fb b signal=file(\"f.wav\", channel=1, gain=2)\nsox oa a\nsox ob b\n";
    let path = dir.path().join("m.cordis");
    std::fs::write(&path, text).unwrap();
    let m = cordis_model::load_file(&path, &Options::default()).unwrap();
    let x = render(&m, 4);
    // x(1) = F(0)/M for a mass at rest
    assert_eq!(x[2], 0.5);
    assert_eq!(x[3], 2.0 * 0.5);
    let env = load("enx e signal=env([(0, 0) (10, 1) (20, 0)], amp=2)\nsox o e\n");
    let x = render(&env, 25);
    assert_eq!((x[0], x[5], x[10], x[15], x[24]), (0.0, 1.0, 2.0, 1.0, 0.0));
    let imp = load("mas a M=2\nenf i a signal=impulse(at=1ms, amp=4)\nsox o a\n");
    let x = render(&imp, 50);
    assert_eq!(x[44], 0.0); // the force arrives at sample 44 (1 ms = 44.1 samples, rounded)
    assert_eq!(x[45], 2.0);
}

#[test]
fn fft_of_a_struck_string_peaks_at_its_exact_discrete_modes() {
    // A fixed-fixed chain of n unit masses and springs K has the eigenvalues of M^-1 K
    // lambda_j = 4 K sin^2(j pi / (2 (n + 1))), and the scheme rings at
    // f_j = (Fs / pi) asin(sqrt(lambda_j) / 2) (FORMALISM.md), not at the continuous-time value.
    let (n, k, fs) = (12usize, 0.3, 44100.0);
    let m = load(&format!(
        "duration 65536\nstring s n={n} M=1 K={k} ends=fixed,fixed\nenf hit s[0] signal=impulse(at=0, amp=1)\nsox o s[0]\n"
    ));
    let x = render(&m, 65536);
    let len = x.len();
    let mut buf: Vec<rustfft::num_complex::Complex<f64>> = x
        .iter()
        .enumerate()
        .map(|(i, v)| {
            let w = 0.5 - 0.5 * (std::f64::consts::TAU * i as f64 / len as f64).cos();
            rustfft::num_complex::Complex::new(v * w, 0.0)
        })
        .collect();
    rustfft::FftPlanner::new()
        .plan_fft_forward(len)
        .process(&mut buf);
    let mag: Vec<f64> = buf[..len / 2]
        .iter()
        .map(|c| c.norm().max(1e-300).ln())
        .collect();
    let bin_hz = fs / len as f64;
    for j in 1..=n {
        let a = j as f64 * std::f64::consts::PI / (2.0 * (n + 1) as f64);
        let lambda = 4.0 * k * a.sin().powi(2);
        let f = fs / std::f64::consts::PI * (lambda.sqrt() / 2.0).asin();
        // the local maximum near f, refined by a parabola through the log magnitudes
        let c = (f / bin_hz).round() as usize;
        let i = (c - 3..=c + 3)
            .max_by(|&p, &q| mag[p].total_cmp(&mag[q]))
            .unwrap();
        let (l, mid, r) = (mag[i - 1], mag[i], mag[i + 1]);
        let peak = (i as f64 + 0.5 * (l - r) / (l - 2.0 * mid + r)) * bin_hz;
        // Hann-windowed parabolic interpolation is good to a few hundredths of a bin here.
        assert!(
            (peak - f).abs() < 0.05 * bin_hz,
            "mode {j}: predicted {f:.4} Hz, FFT peak {peak:.4} Hz"
        );
        // and the continuous-time formula would be visibly off for the high modes
        let continuous = fs / std::f64::consts::TAU * lambda.sqrt();
        if j == n {
            assert!(
                (continuous - f).abs() > 100.0 * bin_hz,
                "{continuous} vs {f}"
            );
        }
    }
}

#[test]
fn a_string_can_sit_at_an_offset() {
    let m = load("string s n=3 M=1 K=0.1 ends=fixed,free X0=3 pluck=(0, 1)\nsox o s[0]\n");
    let x0: Vec<f64> = m
        .network
        .materials
        .iter()
        .map(|mt| mt.initial_state().0)
        .collect();
    assert_eq!(x0, [4.0, 3.0 + 2.0 / 3.0, 3.0 + 1.0 / 3.0, 3.0]);
}

#[test]
fn a_string_can_hang_from_an_existing_module_with_air_damping() {
    let m = load("cel bridge M=1e10 K=1 R=3 X0=3\nstring s n=3 M=1 K=0.1 ends=fixed,free left=bridge air=1e-3 X0=3\nsox o s[2]\n");
    let names: Vec<&str> = m.materials.iter().map(|n| n.name.as_str()).collect();
    assert_eq!(
        names,
        ["bridge", "s[0]", "s[1]", "s[2]"],
        "no SOL of its own"
    );
    let links: Vec<&str> = m.links.iter().map(|n| n.name.as_str()).collect();
    assert_eq!(
        links,
        ["s.l[0]", "s.l[1]", "s.l[2]", "s.air[0]", "s.air[1]", "s.air[2]"]
    );
    let bridge = cordis_core::MatId(0);
    assert_eq!(m.network.links[0].a, bridge);
    for l in &m.network.links[3..] {
        assert_eq!(l.a, bridge);
        assert_eq!(l.law, cordis_core::Interaction::Fro { z: 1e-3 });
    }
    // a right anchor, and the errors
    let m =
        load("sol wall\nstring s n=2 M=1 K=0.1 right=wall ends=free,fixed air=1e-4\nsox o s[0]\n");
    assert_eq!(
        m.network.links.last().map(|l| l.a),
        Some(cordis_core::MatId(0))
    );
    let err = |t: &str| {
        load_str("t.cordis".as_ref(), t, &Options::default())
            .unwrap_err()
            .diagnostics
            .remove(0)
    };
    assert!(err("sol w\nstring s n=2 M=1 K=0.1 ends=free left=w\n")
        .message
        .contains("`ends` makes it free"));
    assert!(err("string s n=2 M=1 K=0.1 ends=free air=1e-3\n")
        .message
        .contains("both ends are free"));
    assert!(err("string s n=2 M=1 K=0.1 left=nowhere\n")
        .message
        .contains("no module is named `nowhere`"));
}
