//! Chain design timings and accuracy, against plain three-term Lanczos.
//!
//! ```text
//! cargo bench -p cordis-design --bench design
//! ```
//!
//! - `design`: `design_chain` on 1,000 frequencies (fixed-free): 20, 40, ..., 20,000 Hz (1,000
//!   harmonics of 20 Hz) and 1,000 log-spaced frequencies from 20 Hz to 20 kHz. Target: < 1 s.
//!   The error is recomputed from the chain as written: the Jacobi matrix rebuilt from its masses
//!   and springs, all its eigenvalues by a dense symmetric solver (faer), `f = (Fs/π)
//!   asin(sqrt(λ)/2)` against the targets.
//! - `lanczos`: the reorthogonalised Lanczos that the design uses against the plain three-term
//!   recurrence, at 17, 40, 100 (harmonics of 150 Hz) and 1,000 frequencies (20 Hz steps): time,
//!   frequencies per second, the ratio of the times, and the largest error of each Jacobi
//!   matrix's eigenvalues (dense solve) as frequencies.
//!
//! Each case is timed `RUNS` times and the median printed.
#![allow(clippy::unwrap_used)] // benches may panic on failure

use std::hint::black_box;
use std::time::{Duration, Instant};

use cordis_analysis::faer::{Mat, Side};
use cordis_design::chain::{design_chain, lanczos, ChainSpec, Ends, Jacobi};

const FS: f64 = 44100.0;
const RUNS: usize = 5;

fn median<T>(mut f: impl FnMut() -> T) -> (Duration, T) {
    let mut times = Vec::with_capacity(RUNS);
    let mut last = None;
    for _ in 0..RUNS {
        let t = Instant::now();
        let v = black_box(f());
        times.push(t.elapsed());
        last = Some(v);
    }
    times.sort();
    (times[RUNS / 2], last.unwrap())
}

/// Eigenvalues of `tridiag(-off, diag, -off)`, ascending (dense symmetric solver).
fn eigenvalues(j: &Jacobi) -> Vec<f64> {
    let n = j.diag.len();
    let t = Mat::<f64>::from_fn(n, n, |a, b| {
        if a == b {
            j.diag[a]
        } else if a.abs_diff(b) == 1 {
            -j.off[a.min(b)]
        } else {
            0.0
        }
    });
    let ev = t.self_adjoint_eigen(Side::Lower).unwrap();
    // faer's products can leave the vector registers' upper bits dirty, which would slow every
    // SSE loop timed after this check (the Lanczos table 2.8-3.4x from 100 frequencies on a Zen 4)
    cordis_analysis::clean_upper();
    (0..n).map(|i| ev.S()[i]).collect()
}

fn freq(lambda: f64) -> f64 {
    FS / std::f64::consts::PI * (lambda.clamp(0.0, 4.0).sqrt() / 2.0).asin()
}

/// Largest |f(λ_i) - target_i| over the sorted eigenvalues of `j`, Hz.
fn max_error(j: &Jacobi, targets: &[f64]) -> f64 {
    let ev = eigenvalues(j);
    ev.iter()
        .zip(targets)
        .map(|(l, f)| (freq(*l) - f).abs())
        .fold(0.0, f64::max)
}

fn lambdas(freqs: &[f64]) -> Vec<f64> {
    freqs
        .iter()
        .map(|f| 4.0 * (std::f64::consts::PI * f / FS).sin().powi(2))
        .collect()
}

fn main() {
    let steps: Vec<f64> = (1..=1000).map(|k| 20.0 * k as f64).collect();
    let logs: Vec<f64> = (0..1000)
        .map(|k| 20.0 * 1000f64.powf(k as f64 / 999.0))
        .collect();
    println!("design: design_chain, fixed-free, 1,000 frequencies (target < 1 s)");
    for (name, freqs) in [
        ("20 Hz steps to 20 kHz", &steps),
        ("log-spaced 20 Hz to 20 kHz", &logs),
    ] {
        let spec = ChainSpec::new(freqs.clone(), Ends::FixedFree, FS);
        let (t, chain) = median(|| design_chain(&spec).unwrap());
        let err = max_error(&chain.jacobi(), freqs);
        println!(
            "  {name:<28} {:>8.3} s  {:>9.0} frequencies/s  max |df| {:.2e} Hz  mass spread {:.2e}  stiffness spread {:.2e}  {}",
            t.as_secs_f64(),
            1000.0 / t.as_secs_f64(),
            err,
            chain.mass_spread(),
            chain.stiffness_spread(),
            if t.as_secs_f64() < 1.0 { "ok" } else { "ABOVE TARGET" }
        );
    }
    println!();
    println!("lanczos: reorthogonalised (design) vs plain three-term, equal weights");
    println!(
        "  {:>5}  {:>10} {:>13} {:>12}   {:>10} {:>13} {:>12}   {:>7}",
        "N", "reorth s", "freq/s", "max |df| Hz", "plain s", "freq/s", "max |df| Hz", "ratio"
    );
    let cases: Vec<Vec<f64>> = vec![
        (1..=17).map(|k| 150.0 * k as f64).collect(),
        (1..=40).map(|k| 150.0 * k as f64).collect(),
        (1..=100).map(|k| 150.0 * k as f64).collect(),
        steps.clone(),
    ];
    for freqs in &cases {
        let n = freqs.len();
        let l = lambdas(freqs);
        let w = vec![1.0 / n as f64; n];
        let (tr, jr) = median(|| lanczos(&l, &w, true).unwrap());
        let (tp, jp) = median(|| lanczos(&l, &w, false).unwrap());
        let (er, ep) = (max_error(&jr, freqs), max_error(&jp, freqs));
        println!(
            "  {n:>5}  {:>10.3e} {:>13.0} {:>12.2e}   {:>10.3e} {:>13.0} {:>12.2e}   {:>7.1}",
            tr.as_secs_f64(),
            n as f64 / tr.as_secs_f64(),
            er,
            tp.as_secs_f64(),
            n as f64 / tp.as_secs_f64(),
            ep,
            tr.as_secs_f64() / tp.as_secs_f64()
        );
    }
}
