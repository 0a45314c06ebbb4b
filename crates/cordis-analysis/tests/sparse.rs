//! The sparse methods against the dense ones: the lowest modes by shift-invert Lanczos equal the
//! dense modal analysis, and the sparse receptance equals the dense one.
#![allow(clippy::unwrap_used)] // tests may panic on failure

use cordis_analysis::faer::{c64, linalg::solvers::Solve, Mat};
use cordis_analysis::{
    lowest_modes, receptance_sparse, AnalysisError, LinearSystem, Method, ModalAnalysis, Mode,
    ModeKind, SparseMethod,
};
use cordis_model::{load_str, Model, Options};

fn load(text: &str) -> Model {
    match load_str("m.cordis".as_ref(), text, &Options::default()) {
        Ok(m) => m,
        Err(e) => panic!("{e}"),
    }
}

fn system(text: &str) -> LinearSystem {
    LinearSystem::from_model(&load(text)).unwrap()
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

/// A random sparse network: a weak chain through every mass (so that no part floats free), each
/// mass linked to one other at random, a third of them grounded.
/// `damping`: "none", "proportional" (Z = 0.01 K on every link) or "random".
fn random_network(seed: u64, n: usize, damping: &str) -> String {
    let mut rng = Lcg(seed);
    let mut t = String::from("sol g\n");
    for i in 0..n {
        t += &format!("mas m{i} M={}\n", 0.5 + rng.next());
    }
    let z = |k: f64, rng: &mut Lcg| match damping {
        "proportional" => 0.01 * k,
        "random" => 2e-3 * rng.next(),
        _ => 0.0,
    };
    for i in 0..n {
        let j = (i + 1 + (rng.next() * (n - 1) as f64) as usize) % n;
        let k = 0.05 * rng.next();
        t += &format!("ref a{i} m{i} m{j} K={k} Z={}\n", z(k, &mut rng));
        if i > 0 {
            let k = 0.01 * rng.next();
            t += &format!("ref c{i} m{} m{i} K={k} Z={}\n", i - 1, z(k, &mut rng));
        }
        if i % 3 == 0 {
            let k = 0.05 * rng.next();
            t += &format!("ref g{i} g m{i} K={k} Z={}\n", z(k, &mut rng));
        }
    }
    t + "sox o m0\n"
}

fn rel(a: f64, b: f64) -> f64 {
    if a == b {
        0.0
    } else {
        (a - b).abs() / a.abs().max(b.abs())
    }
}

/// `‖K φ - λ M φ‖` relative to `‖K‖₁ ‖φ‖`, and `φᵀ M φ`.
fn residual(sys: &LinearSystem, md: &Mode) -> (f64, f64) {
    let n = sys.len();
    let mut kphi = vec![0.0; n];
    sys.k.mul(&md.shape, &mut kphi);
    let knorm = sys.k.dense().norm_l1().max(f64::MIN_POSITIVE);
    let phin: f64 = md.shape.iter().map(|x| x * x).sum::<f64>().sqrt();
    let r: f64 = (0..n)
        .map(|i| (kphi[i] - md.lambda * sys.mass[i] * md.shape[i]).powi(2))
        .sum::<f64>()
        .sqrt();
    let mnorm: f64 = (0..n).map(|i| sys.mass[i] * md.shape[i].powi(2)).sum();
    (r / (knorm * phin), mnorm)
}

/// The `count` lowest modes from both methods agree: frequencies and decay times to `tol`
/// relative, shapes up to sign (for modes whose frequency is not shared), residuals small.
fn compare(text: &str, count: usize, tol: f64) -> (ModalAnalysis, cordis_analysis::LowestModes) {
    let sys = system(text);
    let dense = ModalAnalysis::compute(&sys).unwrap();
    let sparse = lowest_modes(&sys, count).unwrap();
    assert_eq!(sparse.modes.len(), count);
    let refined = matches!(sparse.method, SparseMethod::Refined { .. });
    for (j, (d, s)) in dense.modes.iter().zip(&sparse.modes).enumerate() {
        assert_eq!(d.kind, s.kind, "mode {j}");
        assert!(
            rel(d.freq_hz, s.freq_hz) <= tol,
            "mode {j}: {} Hz dense, {} Hz sparse",
            d.freq_hz,
            s.freq_hz
        );
        // a pole known to a few ulps fixes the decay time to 1e-9 only while 1 - r is not tiny:
        // the dense state-space eigenvalues carry ~eps absolute error, so allow 32 eps / (1 - r)
        // there (the closed forms of the decoupled methods agree to `tol` regardless)
        let tau_tol = if refined {
            tol.max(32.0 * f64::EPSILON / (1.0 - d.radius).abs())
        } else {
            tol
        };
        if refined && (1.0 - d.radius).abs() < 64.0 * f64::EPSILON {
            // undamped to rounding (a damper on a node of the mode): only the sign of 1 - r is
            // noise, in either method
            assert!(s.tau_s.abs() > 1e7, "mode {j}: tau {} s", s.tau_s);
        } else {
            assert!(
                rel(d.tau_s, s.tau_s) <= tau_tol,
                "mode {j}: tau {} s dense, {} s sparse",
                d.tau_s,
                s.tau_s
            );
        }
        assert!((d.radius - s.radius).abs() <= 1e-13, "mode {j}");
        if refined {
            continue;
        }
        assert!(rel(d.lambda, s.lambda) <= tol || (d.lambda - s.lambda).abs() < 1e-14);
        let (r, mn) = residual(&sys, s);
        assert!(r < 1e-12, "mode {j}: residual {r:e}");
        assert!((mn - 1.0).abs() < 1e-12, "mode {j}: φᵀMφ = {mn}");
        let shared = dense
            .modes
            .iter()
            .enumerate()
            .any(|(i, o)| i != j && rel(o.freq_hz, d.freq_hz) < 1e-6);
        if !shared {
            let dot: f64 = (0..sys.len())
                .map(|i| d.shape[i] * sys.mass[i] * s.shape[i])
                .sum();
            let sign = dot.signum();
            let diff = d
                .shape
                .iter()
                .zip(&s.shape)
                .map(|(a, b)| (a - sign * b).abs())
                .fold(0.0, f64::max);
            let peak = d.shape.iter().fold(0.0f64, |a, b| a.max(b.abs()));
            assert!(diff < 1e-7 * peak, "mode {j}: shapes differ by {diff:e}");
            // so the amplitudes at the pickups agree too
            for (a, b) in d.amplitudes.iter().zip(&s.amplitudes) {
                assert!(
                    (a - b).abs() <= 1e-7 * a.abs().max(1e-12),
                    "mode {j}: amplitude {a} vs {b}"
                );
            }
        }
    }
    (dense, sparse)
}

#[test]
fn membrane_20x20_undamped_and_damped() {
    let (d, s) = compare(
        "membrane mem rows=20 cols=20 M=1 K=0.1 border=fixed\nsox o mem[3,4]\nenf hit mem[5,5] signal=impulse(at=0, amp=1)\n",
        40,
        1e-9,
    );
    assert_eq!(d.method, Method::Undamped);
    assert_eq!(s.method, SparseMethod::Undamped);
    let (d, s) = compare(
        "membrane mem rows=20 cols=20 M=1 K=0.1 Z=1e-4 border=fixed\nsox o mem[3,4]\nenf hit mem[5,5] signal=impulse(at=0, amp=1)\n",
        40,
        1e-9,
    );
    assert_eq!(d.method, Method::Decoupled);
    assert!(
        matches!(s.method, SparseMethod::Rayleigh { alpha, beta } if alpha.abs() < 1e-15 && rel(beta, 1e-3) < 1e-12)
    );
}

#[test]
fn membrane_24x24_against_its_closed_form() {
    // λ_pq = 4 K/M (sin²(pπ / 2(R+1)) + sin²(qπ / 2(C+1))): pairs of equal frequencies, all found
    let (rows, cols, k) = (24usize, 24usize, 0.1);
    let sys = system(&format!(
        "membrane mem rows={rows} cols={cols} M=1 K={k} border=fixed\nsox o mem[3,4]\n"
    ));
    let mut exact: Vec<f64> = (1..=rows)
        .flat_map(|p| (1..=cols).map(move |q| (p, q)))
        .map(|(p, q)| {
            let s = |i: usize, n: usize| {
                (i as f64 * std::f64::consts::PI / (2.0 * (n + 1) as f64)).sin()
            };
            4.0 * k * (s(p, rows).powi(2) + s(q, cols).powi(2))
        })
        .collect();
    exact.sort_by(f64::total_cmp);
    let count = 40;
    let lm = lowest_modes(&sys, count).unwrap();
    for (j, md) in lm.modes.iter().enumerate() {
        assert!(
            rel(md.lambda, exact[j]) < 1e-12,
            "mode {j}: {} vs {}",
            md.lambda,
            exact[j]
        );
        let f = sys.rate / std::f64::consts::PI * (exact[j].sqrt() / 2.0).asin();
        assert!(rel(md.freq_hz, f) < 1e-12);
        let (r, mn) = residual(&sys, md);
        assert!(r < 1e-12 && (mn - 1.0).abs() < 1e-12);
    }
    // the degenerate pairs are M-orthogonal
    for a in 0..count {
        for b in a + 1..count {
            let dot: f64 = (0..sys.len())
                .map(|i| lm.modes[a].shape[i] * sys.mass[i] * lm.modes[b].shape[i])
                .sum();
            assert!(dot.abs() < 1e-10, "modes {a}, {b}: {dot}");
        }
    }
}

#[test]
fn damped_string_of_300() {
    let (d, s) = compare(
        "string s n=300 M=1 K=0.2 Z=2e-4 ends=fixed,fixed\nenf hit s[40] signal=impulse(at=0, amp=1)\nsox o s[100]\n",
        30,
        1e-9,
    );
    assert_eq!(d.method, Method::Decoupled);
    assert!(matches!(s.method, SparseMethod::Rayleigh { .. }));
    assert!(s.max_residual < 1e-12);
}

#[test]
fn random_networks_undamped_and_proportional() {
    for seed in 1..=2 {
        compare(&random_network(seed, 200, "none"), 25, 1e-9);
        let (_, s) = compare(&random_network(seed, 200, "proportional"), 25, 1e-9);
        assert!(matches!(s.method, SparseMethod::Rayleigh { .. }));
    }
}

#[test]
fn random_network_with_non_proportional_damping() {
    for seed in 1..=2 {
        let (d, s) = compare(&random_network(seed, 100, "random"), 15, 1e-9);
        assert!(matches!(d.method, Method::StateSpace { .. }));
        assert!(matches!(s.method, SparseMethod::Refined { .. }));
        assert!(s.max_pole_residual < 1e-12, "{}", s.max_pole_residual);
    }
}

#[test]
fn membrane_with_a_local_damper() {
    // a square membrane (pairs of equal frequencies) damped at one point only: the damping couples
    // each pair, the state-space and the refined poles must still agree
    let (d, s) = compare(
        "membrane mem rows=10 cols=10 M=1 K=0.1 border=fixed\nsol g\nfro f g mem[3,5] Z=2e-3\nsox o mem[3,4]\n",
        20,
        1e-9,
    );
    assert!(matches!(d.method, Method::StateSpace { .. }));
    assert!(matches!(s.method, SparseMethod::Refined { .. }));
}

#[test]
fn free_floating_chain_with_uneven_damping() {
    let mut t = String::new();
    for i in 0..80 {
        t += &format!("mas m{i} M={}\n", 1.0 + 0.25 * (i % 3) as f64);
    }
    for i in 1..80 {
        let z = if i % 2 == 0 { 1e-3 } else { 1e-4 };
        t += &format!("ref l{i} m{} m{i} K=0.1 Z={z}\n", i - 1);
    }
    t += "sox o m0\n";
    let (d, s) = compare(&t, 12, 1e-9);
    assert!(matches!(d.method, Method::StateSpace { .. }));
    assert!(matches!(s.method, SparseMethod::Refined { .. }));
    assert_eq!(s.modes[0].kind, ModeKind::Rigid);
}

#[test]
fn free_floating_string_has_its_rigid_mode() {
    let (_, s) = compare(
        "string s n=120 M=1 K=0.1 ends=free,free\nsox o s[0]\n",
        10,
        1e-9,
    );
    assert_eq!(s.modes[0].kind, ModeKind::Rigid);
}

/// The receptance from a dense complex LU of the dynamic stiffness.
fn receptance_dense_lu(sys: &LinearSystem, a: usize, b: usize, f: f64) -> c64 {
    let n = sys.len();
    let (kd, rd) = (sys.k.dense(), sys.r.dense());
    let w = std::f64::consts::TAU * f / sys.rate;
    let z = c64::new(w.cos(), w.sin());
    let zi = c64::new(1.0, 0.0) / z;
    let am = Mat::<c64>::from_fn(n, n, |i, j| {
        let m = if i == j { sys.mass[i] } else { 0.0 };
        z * m + c64::new(kd[(i, j)] + rd[(i, j)] - 2.0 * m, 0.0) + zi * (m - rd[(i, j)])
    });
    let mut e = Mat::<c64>::zeros(n, 1);
    e[(a, 0)] = c64::new(1.0, 0.0);
    am.partial_piv_lu().solve(&e)[(b, 0)]
}

#[test]
fn receptance_equals_the_dense_one() {
    for text in [
        "membrane mem rows=20 cols=20 M=1 K=0.1 Z=1e-3 border=fixed\nsox o mem[3,4]\n".to_string(),
        "membrane mem rows=12 cols=12 M=1 K=0.1 border=fixed\nsox o mem[3,4]\n".to_string(),
        "string s n=300 M=1 K=0.2 Z=2e-4 ends=fixed,free\nsox o s[100]\n".to_string(),
        random_network(7, 120, "random"),
    ] {
        let m = load(&text);
        let sys = LinearSystem::from_model(&m).unwrap();
        let dense = ModalAnalysis::compute(&sys).unwrap();
        let (a, b) = (3, sys.len() / 2);
        // 50 frequencies across the band of the modes (above it the response between distant
        // dofs is evanescent, tiny, and the modal sum loses its digits to cancellation)
        let top = dense.modes.iter().fold(0.0f64, |x, md| x.max(md.freq_hz));
        let freqs: Vec<f64> = (0..50).map(|k| (k as f64 + 0.37) / 50.0 * top).collect();
        let h = receptance_sparse(&sys, a, b, &freqs).unwrap();
        for (f, hs) in freqs.iter().zip(&h) {
            let hd = dense.receptance(a, b, *f, m.rate);
            // the modal sum's own rounding: each denominator z + λ + c - 2 + z⁻¹ (1 - c) carries
            // a few eps of absolute error, which matters next to a lightly damped pole
            let w = std::f64::consts::TAU * f / m.rate;
            let z = c64::new(w.cos(), w.sin());
            let modal_err: f64 = match dense.method {
                Method::StateSpace { .. } => 0.0,
                _ => dense
                    .modes
                    .iter()
                    .map(|md| {
                        let th = md.freq_hz * std::f64::consts::TAU / m.rate;
                        let p = c64::new(md.radius * th.cos(), md.radius * th.sin());
                        let den = ((z - p) * (z - p.conj())).norm();
                        (md.shape[a] * md.shape[b]).abs() * 8.0 * f64::EPSILON / (den * den)
                    })
                    .sum(),
            };
            assert!(
                (hd - hs).norm() <= 1e-9 * hd.norm() + modal_err,
                "{f} Hz: dense {hd:?}, sparse {hs:?}"
            );
            // and against a dense LU of the same matrix, to the same 1e-9
            if sys.len() <= 150 {
                let hl = receptance_dense_lu(&sys, a, b, *f);
                assert!(
                    (hl - hs).norm() <= 1e-9 * hl.norm(),
                    "{f} Hz: {hl:?} vs {hs:?}"
                );
            }
        }
    }
}

#[test]
fn receptance_keeps_its_digits_above_the_band() {
    // a damped string: modes up to ~6.5 kHz; at 8-20 kHz the response 150 masses away is ~1e-100
    let m = load("string s n=300 M=1 K=0.2 Z=2e-4 ends=fixed,free\nsox o s[100]\n");
    let sys = LinearSystem::from_model(&m).unwrap();
    let freqs: Vec<f64> = (0..12).map(|k| 8000.0 + 1000.0 * k as f64).collect();
    let h = receptance_sparse(&sys, 3, 150, &freqs).unwrap();
    for (f, hs) in freqs.iter().zip(&h) {
        let hl = receptance_dense_lu(&sys, 3, 150, *f);
        assert!(hl.norm() < 1e-50 && hl.norm() > 0.0);
        assert!(
            (hl - hs).norm() <= 1e-9 * hl.norm(),
            "{f} Hz: {hl:?} vs {hs:?}"
        );
    }
}

#[test]
fn bad_requests_are_refused_clearly() {
    let sys = system("string s n=10 M=1 K=0.1\nsox o s[0]\n");
    for count in [0, 11] {
        match lowest_modes(&sys, count) {
            Err(e @ AnalysisError::InvalidRequest(_)) => {
                let msg = e.to_string();
                assert!(msg.contains("1 to 10"), "{msg}");
            }
            other => panic!("{other:?}"),
        }
    }
    assert!(matches!(
        receptance_sparse(&sys, 0, 10, &[100.0]),
        Err(AnalysisError::InvalidRequest(_))
    ));
    // every mode of a small network: the dense fallback inside
    let all = lowest_modes(&sys, 10).unwrap();
    let dense = ModalAnalysis::compute(&sys).unwrap();
    for (d, s) in dense.modes.iter().zip(&all.modes) {
        assert!(rel(d.freq_hz, s.freq_hz) < 1e-12);
    }
}
