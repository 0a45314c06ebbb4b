//! `cargo bench -p cordis-design --bench fit`: success rates and times of `fit` on chains.
//!
//! For each size `n` (10, 15, 30, 60): 20 seeded trials of a fixed-free chain of `n` unit masses
//! with one `let` per spring (`n` free values), the targets being the `n` frequencies of a random
//! feasible chain (each stiffness drawn uniformly in `[0.5, 2] × u`), the start uniform (`u`).
//! Prints the success rate (converged to 1e-6 Hz), the median and largest time, and the median
//! number of Levenberg–Marquardt iterations and of model evaluations.
//!
//! `FIT_SIZES=10,15` and `FIT_TRIALS=5` (environment) change the sizes and the trial count.
#![allow(clippy::unwrap_used)]

use std::time::Instant;

use cordis_analysis::{LinearSystem, ModalAnalysis, ModeKind};
use cordis_design::fit::{fit, FitSpec};
use cordis_model::{load_str, Options};

/// A small deterministic generator.
struct Lcg(u64);
impl Lcg {
    fn uniform(&mut self) -> f64 {
        self.0 = self
            .0
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (self.0 >> 11) as f64 / (1u64 << 53) as f64
    }
}

fn chain(k: &[f64]) -> String {
    let mut t = String::from("sol g\n");
    for (i, v) in k.iter().enumerate() {
        t += &format!("let k{} = {v}\n", i + 1);
    }
    for i in 1..=k.len() {
        t += &format!("mas m{i} M=1\n");
    }
    t += "ref r1 g m1 K=k1\n";
    for i in 2..=k.len() {
        t += &format!("ref r{i} m{} m{i} K=k{i}\n", i - 1);
    }
    t += "sox out m1\n";
    t
}

fn frequencies(text: &str) -> Vec<f64> {
    let m = load_str("t.cordis".as_ref(), text, &Options::default()).unwrap();
    let ma = ModalAnalysis::compute(&LinearSystem::from_model(&m).unwrap()).unwrap();
    ma.modes
        .iter()
        .filter(|m| m.kind == ModeKind::Oscillating)
        .map(|m| m.freq_hz)
        .collect()
}

fn median(v: &mut [f64]) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

fn main() {
    let sizes: Vec<usize> = std::env::var("FIT_SIZES")
        .ok()
        .map(|s| s.split(',').filter_map(|v| v.trim().parse().ok()).collect())
        .unwrap_or_else(|| vec![10, 15, 30, 60]);
    let trials: usize = std::env::var("FIT_TRIALS")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(20);
    let u = 0.05; // uniform stiffness: modes up to about 4 kHz at 44.1 kHz
    println!(
        "fit: fixed-free chains of n unit masses, n free spring lets, {trials} seeded trials each"
    );
    println!(
        "{:>4} {:>8} {:>12} {:>12} {:>10} {:>10} {:>14}",
        "n", "success", "median time", "max time", "med. iter", "med. eval", "worst error"
    );
    for &n in &sizes {
        let mut times = Vec::new();
        let mut iters = Vec::new();
        let mut evals = Vec::new();
        let mut ok = 0;
        let mut worst = 0.0f64;
        for trial in 0..trials {
            let mut rng = Lcg(1000 * n as u64 + trial as u64);
            let k: Vec<f64> = (0..n).map(|_| u * (0.5 + 1.5 * rng.uniform())).collect();
            let targets = frequencies(&chain(&k));
            let spec = FitSpec::new(
                "chain.cordis",
                chain(&vec![u; n]),
                vec!["k*".into()],
                targets,
            );
            let t0 = Instant::now();
            let r = fit(&spec).unwrap();
            times.push(t0.elapsed().as_secs_f64());
            iters.push(r.iterations as f64);
            evals.push(r.evaluations as f64);
            if r.converged {
                ok += 1;
            } else {
                worst = worst.max(r.max_error_hz);
            }
        }
        let max_t = times.iter().fold(0.0f64, |a, &b| a.max(b));
        println!(
            "{n:>4} {:>8} {:>11.3}s {:>11.3}s {:>10} {:>10} {:>14}",
            format!("{ok}/{trials}"),
            median(&mut times),
            max_t,
            median(&mut iters),
            median(&mut evals),
            if ok == trials {
                "-".to_string()
            } else {
                format!("{worst:.3e} Hz")
            }
        );
    }
}
