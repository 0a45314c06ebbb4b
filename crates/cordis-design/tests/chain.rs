//! `design_chain` against the analysis of the model it writes, and against the engine's render.
#![allow(clippy::unwrap_used)]

use cordis_analysis::{LinearSystem, Method, ModalAnalysis, Mode, ModeKind};
use cordis_design::chain::{
    design_chain, lanczos, Chain, ChainSpec, Damping, Ends, Hammer, Spring, MAX_FREQUENCIES,
};
use cordis_design::DesignError;
use cordis_model::{load_str, Model, Options};
use rustfft::num_complex::Complex;
use rustfft::FftPlanner;

const FS: f64 = 44100.0;
const ALL_ENDS: [Ends; 4] = [
    Ends::FixedFree,
    Ends::FreeFixed,
    Ends::FixedFixed,
    Ends::FreeFree,
];

fn load(text: &str) -> Model {
    match load_str("chain.cordis".as_ref(), text, &Options::default()) {
        Ok(m) => m,
        Err(e) => panic!("{e}\n{text}"),
    }
}

fn harmonics(f0: f64, n: usize) -> Vec<f64> {
    (1..=n).map(|k| f0 * k as f64).collect()
}

/// splitmix64, as a uniform number in [0, 1).
fn uniform(state: &mut u64) -> f64 {
    *state = state.wrapping_add(0x9E37_79B9_7F4A_7C15);
    let mut z = *state;
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^= z >> 31;
    (z >> 11) as f64 / (1u64 << 53) as f64
}

/// `n` sorted random frequencies in `[lo, hi]`, at least `gap` apart (drawn again until they are).
fn random_freqs(seed: u64, n: usize, lo: f64, hi: f64, gap: f64) -> Vec<f64> {
    let mut s = seed;
    loop {
        let mut f: Vec<f64> = (0..n).map(|_| lo + (hi - lo) * uniform(&mut s)).collect();
        f.sort_by(f64::total_cmp);
        if f.windows(2).all(|w| w[1] - w[0] >= gap) {
            return f;
        }
    }
}

/// What the analysis of a designed chain's written model says.
struct Analysed {
    chain: Chain,
    model: Model,
    ma: ModalAnalysis,
    /// The chain's oscillating modes, in order (rigid and non-oscillating ones left out).
    modes: Vec<Mode>,
    /// Largest |f_model - f_target|, Hz.
    max_df: f64,
    /// Largest |m1 φ_i(m1)² - w_i| over the oscillating modes (and the 0 Hz mode of free-free).
    max_dw: f64,
}

fn analyse(spec: &ChainSpec) -> Analysed {
    let chain = design_chain(spec).unwrap();
    let hammer = Hammer::for_chain(&chain);
    let text = chain.to_cordis("test\nsecond line", &hammer, spec.rate, 1.0);
    let model = load(&text);
    let sys = LinearSystem::from_model(&model).unwrap();
    let ma = ModalAnalysis::compute(&sys).unwrap();
    let d1 = sys.dof("m1").unwrap();
    let m1 = sys.mass[d1];
    let weight = |m: &Mode| m1 * m.shape[d1] * m.shape[d1];
    let free = spec.ends == Ends::FreeFree;
    let ground_damped = matches!(chain.damping, Some((Damping::Ground, _)));
    let rigid: Vec<&Mode> = ma
        .modes
        .iter()
        .filter(|m| m.kind == ModeKind::Rigid)
        .collect();
    let modes: Vec<Mode> = ma
        .modes
        .iter()
        .filter(|m| m.kind == ModeKind::Oscillating)
        .cloned()
        .collect();
    // the hammer drifts as a whole; so does a free-free chain, unless dampers tie it to the ground
    let chain_rigid = free && !ground_damped;
    assert_eq!(rigid.len(), 1 + usize::from(chain_rigid), "{:?}", ma.method);
    assert_eq!(modes.len(), spec.freqs_hz.len(), "{:?}", ma.modes);
    let mut max_dw = 0.0f64;
    if chain_rigid {
        // the two rigid motions share λ = 0: the solver may mix them; the sum is invariant
        let w0: f64 = rigid.iter().map(|m| weight(m)).sum();
        max_dw = max_dw.max((w0 - chain.weights[0]).abs());
    }
    let off = usize::from(free);
    let mut max_df = 0.0f64;
    for (i, m) in modes.iter().enumerate() {
        max_df = max_df.max((m.freq_hz - spec.freqs_hz[i]).abs());
        max_dw = max_dw.max((weight(m) - chain.weights[i + off]).abs());
    }
    Analysed {
        chain,
        model,
        ma,
        modes,
        max_df,
        max_dw,
    }
}

fn spec(freqs: Vec<f64>, ends: Ends) -> ChainSpec {
    ChainSpec::new(freqs, ends, FS)
}

/// The ratio of the last ground spring to the first.
fn end_ratio(c: &Chain) -> f64 {
    let first = c.springs.first().unwrap();
    let last = c.springs.last().unwrap();
    assert!(first.from.is_none() && last.to.is_none());
    last.k / first.k
}

/// 17 harmonics of 150 Hz, every boundary: frequencies to 1e-9 Hz and weights to 1e-9.
#[test]
fn harmonics_on_every_boundary() {
    let mut cases: Vec<ChainSpec> = ALL_ENDS
        .iter()
        .map(|&e| spec(harmonics(150.0, 17), e))
        .collect();
    let mut ff = spec(harmonics(150.0, 17), Ends::FixedFixed);
    ff.end_ratio = 0.3;
    cases.push(ff);
    let mut fr = spec(harmonics(150.0, 17), Ends::FreeFree);
    fr.rigid_weight = Some(0.3);
    fr.first_mass = 2.5;
    cases.push(fr);
    for s in cases {
        let a = analyse(&s);
        println!(
            "{} ratio {}: |df| {:.2e} Hz, |dw| {:.2e}, mass spread {:.3e}, stiffness spread {:.3e}",
            s.ends,
            s.end_ratio,
            a.max_df,
            a.max_dw,
            a.chain.mass_spread(),
            a.chain.stiffness_spread()
        );
        assert!(a.max_df < 1e-9, "{}: {}", s.ends, a.max_df);
        assert!(a.max_dw < 1e-9, "{}: {}", s.ends, a.max_dw);
        assert_eq!(a.ma.method, Method::Undamped);
        let c = &a.chain;
        let n = 17 + usize::from(s.ends == Ends::FreeFree);
        assert_eq!(c.masses.len(), n);
        assert_eq!(c.lambdas.len(), n);
        assert_eq!(c.weights.len(), n);
        assert!((c.weights.iter().sum::<f64>() - 1.0).abs() < 1e-14);
        assert_eq!(c.masses[0], s.first_mass);
        assert!(c.warnings().is_empty(), "{:?}", c.warnings());
        match s.ends {
            Ends::FixedFixed => {
                assert!(
                    (end_ratio(c) / s.end_ratio - 1.0).abs() < 1e-9,
                    "{}",
                    end_ratio(c)
                );
            }
            Ends::FreeFree => {
                // the rigid weight is m1's share of the total mass
                let w0 = s.rigid_weight.unwrap_or(1.0 / 18.0);
                assert_eq!(c.weights[0], w0);
                let total: f64 = c.masses.iter().sum();
                assert!((c.masses[0] / total - w0).abs() < 1e-12);
                assert_eq!(c.lambdas[0], 0.0);
            }
            _ => {}
        }
        // the designed λ are the exact discrete eigenvalues
        for (i, f) in s.freqs_hz.iter().enumerate() {
            let t = (std::f64::consts::PI * f / FS).sin();
            let l = c.lambdas[i + usize::from(s.ends == Ends::FreeFree)];
            assert!((l - 4.0 * t * t).abs() < 1e-15);
        }
    }
}

/// The written model holds the chain's numbers exactly, with the names and lines the
/// documentation gives.
#[test]
fn the_written_model_is_the_chain() {
    for ends in ALL_ENDS {
        for damping in [None, Some(Damping::Springs), Some(Damping::Ground)] {
            let mut s = spec(harmonics(150.0, 5), ends);
            if let Some(d) = damping {
                s.decay_s = Some(1.5);
                s.damping = d;
            }
            let c = design_chain(&s).unwrap();
            let h = Hammer::for_chain(&c);
            let text = c.to_cordis("targets: 150 300\ncordis design chain", &h, FS, 2.0);
            assert!(
                text.starts_with(
                    "# targets: 150 300\n# cordis design chain\nrate 44100\nduration "
                ),
                "{text}"
            );
            let grounded = ends != Ends::FreeFree || damping == Some(Damping::Ground);
            assert_eq!(text.contains("\nsol ground\n"), grounded, "{text}");
            assert_eq!(
                text.contains("\nref k1 ground m1 K="),
                ends.fixed_start(),
                "{text}"
            );
            let n = c.masses.len();
            assert_eq!(
                text.contains(&format!("\nref k{} m{n} ground K=", n + 1)),
                ends.fixed_end(),
                "{text}"
            );
            assert!(text.contains("\nref k2 m1 m2 K="), "{text}");
            assert_eq!(
                text.lines()
                    .any(|l| l.starts_with("ref") && l.contains(" Z=")),
                damping == Some(Damping::Springs),
                "{text}"
            );
            assert_eq!(
                text.contains("\nfro d1 ground m1 Z="),
                damping == Some(Damping::Ground),
                "{text}"
            );
            assert!(text.contains("\nmas hammer M="), "{text}");
            assert!(text.contains("\nbut strike m1 hammer K="), "{text}");
            assert!(text.ends_with("\nsox out m1\n"), "{text}");
            let sys = LinearSystem::from_model(&load(&text)).unwrap();
            assert_eq!(sys.names.len(), n + 1);
            assert_eq!(&sys.mass[..n], &c.masses[..]);
            assert_eq!(sys.mass[n], h.mass);
            assert_eq!(sys.x0[n], h.velocity);
            assert_eq!(sys.xm1[n], 2.0 * h.velocity);
            // the contact is open at rest: the analysis leaves it out
            assert!(sys.notes.iter().any(|t| t.contains("strike: inactive")));
            // K and R as the chain says, bit for bit
            let mut kd = vec![0.0; n + 1];
            let mut rd = vec![0.0; n + 1];
            for sp in &c.springs {
                for e in [sp.from, sp.to].into_iter().flatten() {
                    kd[e] += sp.k;
                    rd[e] += sp.z;
                }
            }
            for (i, z) in c.ground_dampers.iter().enumerate() {
                rd[i] += z;
            }
            for i in 0..n {
                assert!((sys.k.diag[i] - kd[i]).abs() <= 1e-15 * kd[i]);
                assert!((sys.r.diag[i] - rd[i]).abs() <= 1e-15 * rd[i].abs());
            }
            for sp in &c.springs {
                if let (Some(a), Some(b)) = (sp.from, sp.to) {
                    let k = sys
                        .k
                        .off
                        .iter()
                        .find(|(i, j, _)| (*i, *j) == (a, b) || (*i, *j) == (b, a))
                        .unwrap()
                        .2;
                    assert_eq!(k, -sp.k);
                }
            }
        }
    }
}

/// Given amplitudes are the amplitudes of the modes at `m1` for an impulse on `m1` (the
/// analysis's own prediction for the written chain struck by an `enf` impulse), to 1e-9 in ratio;
/// undamped and damped.
#[test]
fn amplitudes_are_reproduced() {
    let freqs = harmonics(150.0, 17);
    let amps: Vec<f64> = (1..=17)
        .map(|k| 1.0 / k as f64 * (1.0 + 0.5 * (k as f64).sin()))
        .collect();
    for ends in ALL_ENDS {
        for damping in [None, Some(Damping::Springs), Some(Damping::Ground)] {
            let mut s = spec(freqs.clone(), ends);
            s.amps = Some(amps.clone());
            if let Some(d) = damping {
                s.decay_s = Some(1.5);
                s.damping = d;
            }
            let a = analyse(&s);
            assert!(a.max_df < 1e-9, "{}", a.max_df);
            assert!(a.max_dw < 1e-9, "{}", a.max_dw);
            // the same chain struck by an impulse instead of the hammer
            let text = a.chain.to_cordis("", &Hammer::for_chain(&a.chain), FS, 1.0);
            let text: String = text
                .lines()
                .filter(|l| !l.starts_with("mas hammer") && !l.starts_with("but strike"))
                .map(|l| {
                    if l.starts_with("sox") {
                        format!("enf kick m1 signal=impulse(at=0, amp=0.001)\n{l}\n")
                    } else {
                        format!("{l}\n")
                    }
                })
                .collect();
            let sys = LinearSystem::from_model(&load(&text)).unwrap();
            let ma = ModalAnalysis::compute(&sys).unwrap();
            let got: Vec<f64> = ma
                .modes
                .iter()
                .filter(|m| m.kind == ModeKind::Oscillating)
                .map(|m| m.amplitudes[0])
                .collect();
            assert_eq!(got.len(), 17);
            let mut worst = 0.0f64;
            for i in 0..17 {
                worst = worst.max(((got[i] / got[0]) / (amps[i] / amps[0]) - 1.0).abs());
            }
            println!("{ends} {damping:?}: amplitude ratios to {worst:.2e}");
            assert!(worst < 1e-9, "{ends} {damping:?}: {worst}");
        }
    }
}

/// A decay time of 1.5 s, both strategies, every boundary: the damped frequencies still on target
/// (1e-9 Hz), the fundamental's decay time 1.5 s (1e-9 relative); ground damping decays every mode
/// alike, spring damping the higher ones faster. The damping is decoupled (closed-form poles).
#[test]
fn damped_chains_keep_their_frequencies() {
    for ends in ALL_ENDS {
        for d in [Damping::Springs, Damping::Ground] {
            let mut s = spec(harmonics(150.0, 17), ends);
            s.decay_s = Some(1.5);
            s.damping = d;
            let a = analyse(&s);
            let taus: Vec<f64> = a.modes.iter().map(|m| m.tau_s).collect();
            println!(
                "{ends} {d}: |df| {:.2e} Hz, tau1 - 1.5 = {:.2e} s, taus {:.4} {:.4} ... {:.4}",
                a.max_df,
                taus[0] - 1.5,
                taus[0],
                taus[1],
                taus[16]
            );
            assert_eq!(a.ma.method, Method::Decoupled);
            assert!(a.max_df < 1e-9, "{}", a.max_df);
            assert!(a.max_dw < 1e-9, "{}", a.max_dw);
            assert!((taus[0] / 1.5 - 1.0).abs() < 1e-9, "{}", taus[0]);
            match d {
                Damping::Ground => {
                    for t in &taus {
                        assert!((t / 1.5 - 1.0).abs() < 1e-9, "{t}");
                    }
                    assert_eq!(a.chain.ground_dampers.len(), a.chain.masses.len());
                    assert!(a.chain.springs.iter().all(|s| s.z == 0.0));
                }
                Damping::Springs => {
                    for w in taus.windows(2) {
                        assert!(w[1] < w[0], "{taus:?}");
                    }
                    assert!(a.chain.ground_dampers.is_empty());
                    let beta = a.chain.damping.unwrap().1;
                    for sp in &a.chain.springs {
                        assert!((sp.z - beta * sp.k).abs() <= 1e-15 * sp.z);
                    }
                }
            }
        }
    }
}

/// Crowded and long targets: two frequencies 1 Hz apart, 40 and 100 harmonics (100 reach 15
/// kHz), every boundary: frequencies to 1e-8 Hz.
#[test]
fn close_and_many_frequencies() {
    let mut close = harmonics(150.0, 17);
    close[2] = 301.0; // 150, 300, 301, 600, ...
    for freqs in [close, harmonics(150.0, 40), harmonics(150.0, 100)] {
        for ends in ALL_ENDS {
            let s = spec(freqs.clone(), ends);
            let a = analyse(&s);
            println!(
                "{} frequencies up to {} Hz, {ends}: |df| {:.2e} Hz, |dw| {:.2e}, spreads {:.2e} {:.2e}",
                freqs.len(),
                freqs[freqs.len() - 1],
                a.max_df,
                a.max_dw,
                a.chain.mass_spread(),
                a.chain.stiffness_spread()
            );
            assert!(a.max_df < 1e-8, "{ends}: {}", a.max_df);
            assert!(a.max_dw < 1e-9, "{ends}: {}", a.max_dw);
        }
    }
}

/// 200 seeded random frequencies between 50 Hz and 15 kHz, at least 1 Hz apart, every boundary:
/// frequencies to 1e-8 Hz, however wide the masses spread (and that spread is reported).
#[test]
fn random_frequencies() {
    for seed in [1u64, 2, 3] {
        let freqs = random_freqs(seed, 200, 50.0, 15000.0, 1.0);
        for ends in ALL_ENDS {
            let s = spec(freqs.clone(), ends);
            let a = analyse(&s);
            println!(
                "seed {seed} {ends}: |df| {:.2e} Hz, |dw| {:.2e}, mass spread {:.2e}, stiffness spread {:.2e}",
                a.max_df,
                a.max_dw,
                a.chain.mass_spread(),
                a.chain.stiffness_spread()
            );
            assert!(a.max_df < 1e-8, "seed {seed} {ends}: {}", a.max_df);
            assert!(a.max_dw < 1e-9, "seed {seed} {ends}: {}", a.max_dw);
            let fragile = a.chain.mass_spread() > 1e6 || a.chain.stiffness_spread() > 1e6;
            assert_eq!(
                a.chain.warnings().iter().any(|w| w.starts_with("fragile")),
                fragile
            );
        }
    }
}

/// |DTFT| at `f` (cycles per sample) of the windowed signal `xw`, with the phasor recomputed
/// exactly every 1024 samples (no drift over 2^20 samples).
fn dtft(xw: &[f64], f: f64) -> f64 {
    let step = Complex::new(
        (std::f64::consts::TAU * f).cos(),
        -(std::f64::consts::TAU * f).sin(),
    );
    let mut acc = Complex::new(0.0, 0.0);
    for (b, block) in xw.chunks(1024).enumerate() {
        let phase = std::f64::consts::TAU * (f * (b * 1024) as f64).fract();
        let mut ph = Complex::new(phase.cos(), -phase.sin());
        let mut part = Complex::new(0.0, 0.0);
        for &v in block {
            part += ph * v;
            ph *= step;
        }
        acc += part;
    }
    acc.norm()
}

/// The peak of |DTFT| within a bin either side of `bin`, by golden-section search (Hz).
fn peak(xw: &[f64], bin: usize, fs: f64) -> f64 {
    let n = xw.len() as f64;
    let (mut a, mut b) = ((bin as f64 - 1.0) / n, (bin as f64 + 1.0) / n);
    let g = (5f64.sqrt() - 1.0) / 2.0;
    let (mut c, mut d) = (b - g * (b - a), a + g * (b - a));
    let (mut fc, mut fd) = (dtft(xw, c), dtft(xw, d));
    for _ in 0..48 {
        if fc > fd {
            b = d;
            d = c;
            fd = fc;
            c = b - g * (b - a);
            fc = dtft(xw, c);
        } else {
            a = c;
            c = d;
            fc = fd;
            d = a + g * (b - a);
            fd = dtft(xw, d);
        }
    }
    0.5 * (a + b) * fs
}

/// The undamped 17-harmonic fixed-free chain struck by its hammer and rendered by the engine for
/// 2^20 samples after the strike: every peak of the Blackman–Harris-windowed spectrum at the
/// target to 1e-6 Hz.
#[test]
fn rendered_spectrum_peaks_at_the_targets() {
    let s = spec(harmonics(150.0, 17), Ends::FixedFree);
    let a = analyse(&s);
    let len = 1usize << 20;
    let skip = 4096; // the strike is over within a few samples
    let frames = skip + len;
    // the written model with the hammer's position as a second output
    let text = a.chain.to_cordis("", &Hammer::for_chain(&a.chain), FS, 1.0) + "sox top hammer\n";
    let mut e = load(&text).compile();
    assert_eq!(e.channels(), 2);
    let mut out = vec![0.0; frames * 2];
    e.process(frames, &mut out).unwrap();
    let x: Vec<f64> = out.iter().step_by(2).copied().collect();
    let hammer: Vec<f64> = out.iter().skip(1).step_by(2).copied().collect();
    assert_eq!(x, {
        let mut e = a.model.compile();
        let mut o = vec![0.0; frames];
        e.process(frames, &mut o).unwrap();
        o
    });
    assert!(x[skip..].iter().all(|v| v.is_finite()));
    // the hammer bounced off within the skipped samples and flies up, far above m1, for good
    let top = x.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    assert!(top > 0.0);
    assert!(hammer[skip] > 10.0 * top && hammer[skip + 1] > hammer[skip]);
    let up = hammer[frames - 1] - hammer[frames - 2];
    assert!(up > 0.9 * 1e-3, "rebound speed {up}");
    // (4-term Blackman–Harris, sidelobes at -92 dB)
    let (a0, a1, a2, a3) = (0.35875, 0.48829, 0.14128, 0.01168);
    let w = |i: usize| {
        let t = std::f64::consts::TAU * i as f64 / len as f64;
        a0 - a1 * t.cos() + a2 * (2.0 * t).cos() - a3 * (3.0 * t).cos()
    };
    let xw: Vec<f64> = x[skip..]
        .iter()
        .enumerate()
        .map(|(i, v)| v * w(i))
        .collect();
    let mut buf: Vec<Complex<f64>> = xw.iter().map(|&v| Complex::new(v, 0.0)).collect();
    FftPlanner::new().plan_fft_forward(len).process(&mut buf);
    let mut worst = 0.0f64;
    for &f in &s.freqs_hz {
        let guess = (f / FS * len as f64).round() as usize;
        let bin = (guess - 3..=guess + 3)
            .max_by(|&i, &j| buf[i].norm().total_cmp(&buf[j].norm()))
            .unwrap();
        let est = peak(&xw, bin, FS);
        println!("{f} Hz: peak at {est:.10} Hz ({:+.2e})", est - f);
        worst = worst.max((est - f).abs());
    }
    println!("largest deviation {worst:.2e} Hz over {len} samples");
    assert!(worst < 1e-6, "{worst}");
}

fn invalid(s: &ChainSpec, what: &str) {
    match design_chain(s) {
        Err(DesignError::Invalid { message, hint }) => {
            assert!(!message.is_empty() && !hint.is_empty());
            println!("{what}: {message} (hint: {hint})");
        }
        other => panic!("{what}: expected Invalid, got {other:?}"),
    }
}

/// Every bad input is a `DesignError::Invalid` with a message and a hint, never a panic.
#[test]
fn bad_inputs_are_refused() {
    let ok = || spec(vec![100.0, 200.0, 300.0], Ends::FixedFree);
    let with = |f: &dyn Fn(&mut ChainSpec)| {
        let mut s = ok();
        f(&mut s);
        s
    };
    assert!(design_chain(&ok()).is_ok());
    invalid(&with(&|s| s.freqs_hz.clear()), "empty");
    invalid(
        &with(&|s| s.freqs_hz = vec![100.0, 300.0, 200.0]),
        "unsorted",
    );
    invalid(
        &with(&|s| s.freqs_hz = vec![100.0, 200.0, 200.0]),
        "duplicate",
    );
    for ends in [
        Ends::FixedFree,
        Ends::FreeFixed,
        Ends::FixedFixed,
        Ends::FreeFree,
    ] {
        invalid(
            &with(&|s| {
                s.freqs_hz = vec![0.0, 100.0];
                s.ends = ends;
            }),
            "0 Hz",
        );
    }
    for f in [-100.0, 22050.0, 30000.0, f64::NAN, f64::INFINITY] {
        invalid(&with(&|s| s.freqs_hz = vec![50.0, f]), "out of range");
    }
    for a in [0.0, -1.0, f64::NAN, f64::INFINITY] {
        invalid(&with(&|s| s.amps = Some(vec![1.0, a, 1.0])), "amplitude");
    }
    invalid(&with(&|s| s.amps = Some(vec![1.0, 1.0])), "amplitude count");
    for t in [0.0, -1.0, f64::NAN, f64::INFINITY] {
        invalid(&with(&|s| s.decay_s = Some(t)), "decay");
    }
    // decay times that cannot be met
    invalid(&with(&|s| s.decay_s = Some(1e-3)), "too short for springs");
    invalid(
        &with(&|s| {
            s.decay_s = Some(1e-8);
            s.damping = Damping::Ground;
        }),
        "too short for ground",
    );
    for m in [0.0, -1.0, f64::NAN, f64::INFINITY] {
        invalid(&with(&|s| s.first_mass = m), "first mass");
    }
    for r in [0.0, -1.0, f64::NAN] {
        invalid(
            &with(&|s| {
                s.ends = Ends::FixedFixed;
                s.end_ratio = r;
            }),
            "end ratio",
        );
    }
    for w in [0.0, 1.0, -0.5, f64::NAN] {
        invalid(
            &with(&|s| {
                s.ends = Ends::FreeFree;
                s.rigid_weight = Some(w);
            }),
            "rigid weight",
        );
    }
    invalid(
        &with(&|s| s.rigid_weight = Some(0.5)),
        "rigid weight on fixed-free",
    );
    for r in [0.0, -44100.0, f64::NAN] {
        invalid(&with(&|s| s.rate = r), "rate");
    }
    invalid(
        &with(&|s| {
            s.freqs_hz = (1..=MAX_FREQUENCIES + 1)
                .map(|k| k as f64 * 0.001)
                .collect()
        }),
        "too many",
    );
    invalid(
        &with(&|s| s.amps = Some(vec![1.0, 1e-320, 1e300])),
        "amplitudes beyond range",
    );
    assert!("fixed-loose".parse::<Ends>().is_err());
    assert!("wood".parse::<Damping>().is_err());
}

/// Extreme requests fail cleanly (an error, never a panic or a chain with a negative spring).
#[test]
fn extreme_requests_fail_cleanly() {
    let mut seed = 7u64;
    let cases = [
        // 1000 frequencies from 20 Hz to 22 kHz, log-spaced and jittered
        (0..1000)
            .map(|k| 20.0 * 1100f64.powf((k as f64 + 0.5 * uniform(&mut seed)) / 1000.0))
            .collect::<Vec<f64>>(),
        (1..=600).map(|k| 20.0 + 0.01 * k as f64).collect(),
        vec![1e-6, 2e-6, 22049.9],
        // frequencies that differ in the last digits only
        vec![1000.0, 1000.0 + 1e-9, 2000.0],
        vec![1000.0, 1000.0f64.next_up(), 2000.0],
    ];
    for freqs in cases {
        for ends in ALL_ENDS {
            match design_chain(&spec(freqs.clone(), ends)) {
                Ok(c) => {
                    assert!(c.masses.iter().all(|m| *m > 0.0 && m.is_finite()));
                    assert!(c.springs.iter().all(|s| s.k > 0.0 && s.k.is_finite()));
                    println!(
                        "{} frequencies {ends}: designed, spreads {:.2e} {:.2e}",
                        freqs.len(),
                        c.mass_spread(),
                        c.stiffness_spread()
                    );
                }
                Err(e) => {
                    println!("{} frequencies {ends}: {e}", freqs.len());
                    assert!(matches!(e, DesignError::Numerical(_)), "{e:?}");
                }
            }
        }
    }
}

/// Names read and written, and the warnings of a hand-made chain.
#[test]
fn names_spreads_and_warnings() {
    for e in ALL_ENDS {
        assert_eq!(e.to_string().parse::<Ends>().unwrap(), e);
    }
    assert_eq!("Fixed_Free".parse::<Ends>().unwrap(), Ends::FixedFree);
    for d in [Damping::Springs, Damping::Ground] {
        assert_eq!(d.to_string().parse::<Damping>().unwrap(), d);
    }
    let spring = |from, to, k| Spring {
        from,
        to,
        k,
        z: 0.0,
    };
    let c = Chain {
        ends: Ends::FixedFree,
        masses: vec![1.0, 1e-7],
        springs: vec![spring(None, Some(0), 1.0), spring(Some(0), Some(1), -1e-3)],
        ground_dampers: Vec::new(),
        lambdas: vec![0.1, 0.2],
        weights: vec![0.5, 0.5],
        damping: None,
    };
    assert_eq!(c.mass_spread(), 1e7);
    assert_eq!(c.stiffness_spread(), 1e3);
    let w = c.warnings();
    assert!(
        w.iter()
            .any(|t| t.contains("masses span") && t.contains("1.000e7")),
        "{w:?}"
    );
    assert!(
        w.iter()
            .any(|t| t.contains("k2") && t.contains("not a physical")),
        "{w:?}"
    );
    let good = design_chain(&spec(harmonics(150.0, 17), Ends::FixedFree)).unwrap();
    assert!(good.warnings().is_empty());
    let h = Hammer::for_chain(&good);
    assert_eq!(h.mass, 0.01 * good.masses[0]);
    assert_eq!(h.velocity, 1e-3);
    assert!(h.stiffness > 0.0 && h.stiffness <= 0.5 * h.mass);
    assert_eq!(h.damping, 0.0);
}

/// `lanczos` with reorthogonalisation gives back the spectrum; the rebuilt chain's Jacobi matrix
/// is the designed one to a few ulps.
#[test]
fn lanczos_gives_back_the_spectrum() {
    let f = harmonics(150.0, 100);
    let l: Vec<f64> = f
        .iter()
        .map(|f| 4.0 * (std::f64::consts::PI * f / FS).sin().powi(2))
        .collect();
    let w = vec![0.01; 100];
    let j = lanczos(&l, &w, true).unwrap();
    assert_eq!((j.diag.len(), j.off.len()), (100, 99));
    assert!(j.off.iter().all(|b| *b > 0.0));
    let n = 100;
    let t = cordis_analysis::faer::Mat::<f64>::from_fn(n, n, |a, b| {
        if a == b {
            j.diag[a]
        } else if a.abs_diff(b) == 1 {
            -j.off[a.min(b)]
        } else {
            0.0
        }
    });
    let ev = t
        .self_adjoint_eigen(cordis_analysis::faer::Side::Lower)
        .unwrap();
    for (i, li) in l.iter().enumerate() {
        assert!((ev.S()[i] - li).abs() < 1e-13, "{} vs {li}", ev.S()[i]);
        // the weights are the squared first components
        assert!((ev.U()[(0, i)].powi(2) - 0.01).abs() < 1e-13);
    }
    assert!(lanczos(&l, &w[..10], true).is_err());
    assert!(lanczos(&l, &vec![0.0; 100], true).is_err());
    let rebuilt = design_chain(&spec(f, Ends::FixedFree)).unwrap().jacobi();
    assert_eq!(rebuilt.diag.len(), 100);
}

/// One frequency, every boundary and damping: one mass (two for free-free), on target.
#[test]
fn single_frequency_chains() {
    for ends in ALL_ENDS {
        for damping in [None, Some(Damping::Springs), Some(Damping::Ground)] {
            let mut s = spec(vec![440.0], ends);
            s.end_ratio = 0.5;
            if let Some(d) = damping {
                s.decay_s = Some(0.8);
                s.damping = d;
            }
            let a = analyse(&s);
            assert_eq!(
                a.chain.masses.len(),
                1 + usize::from(ends == Ends::FreeFree)
            );
            assert!(a.max_df < 1e-9, "{ends} {damping:?}: {}", a.max_df);
            assert!(a.max_dw < 1e-12, "{ends} {damping:?}: {}", a.max_dw);
            if damping.is_some() {
                assert!((a.modes[0].tau_s / 0.8 - 1.0).abs() < 1e-9);
            }
            if ends == Ends::FixedFixed {
                assert!((end_ratio(&a.chain) - 0.5).abs() < 1e-12);
            }
        }
    }
}

/// A chain whose top mode is near half the rate: the hammer's contact is softened so that the
/// strike stays stable, and the render is finite.
#[test]
fn the_hammer_is_stable_near_nyquist() {
    for d in [None, Some(Damping::Springs), Some(Damping::Ground)] {
        let mut s = spec(vec![150.0, 1000.0, 21900.0, 22040.0], Ends::FixedFree);
        if let Some(d) = d {
            s.decay_s = Some(0.5);
            s.damping = d;
        }
        let a = analyse(&s);
        assert!(a.max_df < 1e-8, "{}", a.max_df);
        let h = Hammer::for_chain(&a.chain);
        assert!(h.stiffness > 0.0 && h.stiffness < 0.5 * h.mass);
        let frames = 20_000;
        let mut e = a.model.compile();
        let mut out = vec![0.0; frames * e.channels()];
        e.process(frames, &mut out).unwrap();
        assert!(out.iter().all(|v| v.is_finite()));
        assert!(out.iter().any(|v| *v != 0.0));
    }
}
