//! Analysis timings against the targets of the modal-analysis issue.
//!
//! ```text
//! cargo bench -p cordis-analysis --bench analysis                 # every case
//! cargo bench -p cordis-analysis --bench analysis -- dense lowest  # a selection
//! cargo bench -p cordis-analysis --bench analysis -- statespace    # the slow one (run once)
//! ```
//!
//! Cases (each model built from `.cordis` text with `cordis_model::load_str`):
//! - `dense`: all modes of 2,000-mass networks by the dense `ModalAnalysis::compute`, damping
//!   proportional (decoupled method): a damped string, and a random network. Target: < 5 s.
//! - `refined`: all modes of 2,000-mass networks with non-proportional damping whose sparse
//!   factorisations are cheap (each pole refined on the full problem and certified): a string
//!   damped unevenly, and a 40 × 50 membrane with three dampers to the ground. Target: < 5 s.
//! - `statespace`: all modes of a 2,000-mass random network with non-proportional damping (the dense
//!   `2n = 4000` state matrix: a random graph has no cheap sparse factorisation). Timed once: it is
//!   the slow path. Not in the default selection unless asked for, or `CORDIS_BENCH_ALL=1`.
//! - `lowest`: the 50 lowest modes of a damped 100 × 100 membrane (10,000 masses) by
//!   `lowest_modes` (Z on every spring: Rayleigh damping), and of the same membrane with three
//!   dampers to the ground added (non-proportional: each pole refined). Target: < 10 s.
//! - `response`: a 1,000-point receptance of the same membrane by `receptance_sparse`. Target:
//!   < 10 s.
//!
//! Each case (but `statespace`) is timed 3 times and the median printed, with a rate and the target.
#![allow(clippy::unwrap_used)] // tests and benches may panic on failure

use std::hint::black_box;
use std::time::{Duration, Instant};

use cordis_analysis::{
    lowest_modes, receptance_sparse, LinearSystem, Method, ModalAnalysis, SparseMethod,
};
use cordis_model::{load_str, Options};

const RUNS: usize = 3;

fn system(text: &str) -> LinearSystem {
    let opts = Options::default();
    let model = match load_str("bench.cordis".as_ref(), text, &opts) {
        Ok(m) => m,
        Err(e) => panic!("{e}"),
    };
    LinearSystem::from_model(&model).unwrap()
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

/// `n` masses: a weak chain through all of them, one random link per mass, a third grounded.
/// Proportional damping: Z = 1e-3 K on every link; otherwise Z drawn at random.
fn random_network(n: usize, proportional: bool) -> String {
    let mut rng = Lcg(2024);
    let mut t = String::from("sol g\n");
    for i in 0..n {
        t += &format!("mas m{i} M={}\n", 0.5 + rng.next());
    }
    let mut z = |k: f64| {
        if proportional {
            1e-3 * k
        } else {
            1e-4 * rng.next()
        }
    };
    let mut rng2 = Lcg(7);
    for i in 0..n {
        let j = (i + 1 + (rng2.next() * (n - 1) as f64) as usize) % n;
        let k = 0.05 * rng2.next();
        t += &format!("ref a{i} m{i} m{j} K={k} Z={}\n", z(k));
        if i > 0 {
            let k = 0.01 * rng2.next();
            t += &format!("ref c{i} m{} m{i} K={k} Z={}\n", i - 1, z(k));
        }
        if i % 3 == 0 {
            let k = 0.05 * rng2.next();
            t += &format!("ref g{i} g m{i} K={k} Z={}\n", z(k));
        }
    }
    t + "enf hit m1 signal=impulse(at=0, amp=1)\nsox o m0\n"
}

/// A string damped unevenly: air damping growing along it, dampers to the ground at two points, a
/// heavy mass on its free end (the damping couples the undamped modes).
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
    t + "enf hit s[3] signal=impulse(at=0, amp=1)\nsox o s[1] + 0.5*heavy\n"
}

const MEMBRANE: &str = "membrane mem rows=100 cols=100 M=1 K=0.1 Z=1e-4 border=fixed\n\
    enf hit mem[2,2] signal=impulse(at=0, amp=1)\nsox o mem[50,50]\n";

/// Three dampers to the ground: damping no longer proportional.
const DAMPERS: &str = "sol g\nfro d1 g mem[20,31] Z=5e-3\nfro d2 g mem[57,12] Z=2e-3\n\
    fro d3 g mem[81,66] Z=1e-2\n";

fn median(mut t: Vec<Duration>) -> f64 {
    t.sort();
    t[t.len() / 2].as_secs_f64()
}

fn timed<R>(runs: usize, mut f: impl FnMut() -> R) -> (f64, R) {
    let mut times = Vec::new();
    let mut last = None;
    for _ in 0..runs {
        let t = Instant::now();
        let r = black_box(f());
        times.push(t.elapsed());
        last = Some(r);
    }
    (median(times), last.unwrap())
}

fn verdict(secs: f64, target: f64) -> &'static str {
    if secs < target {
        "met"
    } else {
        "NOT met"
    }
}

fn method(m: &Method) -> String {
    match m {
        Method::Undamped => "undamped".into(),
        Method::Decoupled => "decoupled".into(),
        Method::StateSpace { coupling } => format!("state space (coupling {coupling:.2e})"),
        Method::Refined {
            factorisations,
            lu_solves,
            ..
        } => format!("refined ({factorisations} LDLᵀ, {lu_solves} LU)"),
    }
}

fn dense(name: &str, text: &str, runs: usize, target: Option<f64>) {
    let sys = system(text);
    let n = sys.len();
    let (secs, ma) = timed(runs, || ModalAnalysis::compute(&sys).unwrap());
    let target = match target {
        Some(t) => format!("target < {t} s: {}", verdict(secs, t)),
        None => "no target (the slow path)".into(),
    };
    println!(
        "dense    {name:<40} n = {n:5}  {:<32} {secs:8.3} s  ({:8.1} modes/s)   {target}   [median of {runs}]",
        method(&ma.method),
        ma.modes.len() as f64 / secs,
    );
}

fn main() {
    let args: Vec<String> = std::env::args()
        .skip(1)
        .filter(|a| !a.starts_with("--"))
        .collect();
    let all = std::env::var("CORDIS_BENCH_ALL").is_ok_and(|v| v == "1");
    let want = |w: &str| {
        if args.is_empty() {
            w != "statespace" || all
        } else {
            args.iter().any(|a| a == w)
        }
    };
    println!(
        "cordis-analysis benchmarks ({} threads available)",
        std::thread::available_parallelism().map_or(1, |n| n.get())
    );
    if want("dense") {
        dense(
            "string_N2000 (Z on every link)",
            "string s n=2000 M=1 K=0.1 Z=1e-4 ends=fixed,fixed\nenf hit s[500] signal=impulse(at=0, amp=1)\nsox o s[1000]\n",
            RUNS,
            Some(5.0),
        );
        dense(
            "random_N2000 (Z = 1e-3 K)",
            &random_network(2000, true),
            RUNS,
            Some(5.0),
        );
    }
    if want("refined") {
        dense(
            "string_N2000 uneven damping",
            &uneven_string(2000),
            RUNS,
            Some(5.0),
        );
        dense(
            "membrane_40x50 + 3 dampers",
            "membrane mem rows=40 cols=50 M=1 K=0.1 Z=1e-4 border=fixed\nsol g\nfro d1 g mem[20,31] Z=5e-3\nfro d2 g mem[7,12] Z=2e-3\nfro d3 g mem[31,46] Z=1e-2\nenf hit mem[2,2] signal=impulse(at=0, amp=1)\nsox o mem[20,25]\n",
            RUNS,
            Some(5.0),
        );
    }
    if want("statespace") {
        dense(
            "random_N2000 (Z random)",
            &random_network(2000, false),
            1,
            None,
        );
    }
    if want("lowest") {
        for (name, text) in [
            ("membrane_100x100", MEMBRANE.to_string()),
            (
                "membrane_100x100 + 3 dampers",
                format!("{MEMBRANE}{DAMPERS}"),
            ),
        ] {
            let sys = system(&text);
            let (secs, lm) = timed(RUNS, || lowest_modes(&sys, 50).unwrap());
            let method = match lm.method {
                SparseMethod::Undamped => "undamped".to_string(),
                SparseMethod::Rayleigh { alpha, beta } => {
                    format!("Rayleigh (α = {alpha:.1e}, β = {beta:.1e})")
                }
                SparseMethod::Refined {
                    factorisations,
                    lu_solves,
                    ..
                } => {
                    format!("refined ({factorisations} complex LDLᵀ, {lu_solves} LU)")
                }
            };
            println!(
                "lowest   {:<40} n = {:5}  {method:<32} {secs:8.3} s  ({:8.1} modes/s)   target < 10 s: {}   [median of {RUNS}]",
                format!("{name} (50 modes)"),
                sys.len(),
                50.0 / secs,
                verdict(secs, 10.0),
            );
            let (first, last) = (&lm.modes[0], &lm.modes[49]);
            println!(
                "         {} solves of K - σM; modes {:.3} Hz (tau {:.4} s) .. {:.3} Hz (tau {:.4} s); largest relative residual {:.1e} (poles {:.1e})",
                lm.solves,
                first.freq_hz,
                first.tau_s,
                last.freq_hz,
                last.tau_s,
                lm.max_residual,
                lm.max_pole_residual
            );
        }
    }
    if want("response") {
        let sys = system(MEMBRANE);
        let (a, b) = (sys.dof("mem[2,2]").unwrap(), sys.dof("mem[50,50]").unwrap());
        let freqs: Vec<f64> = (0..1000).map(|k| 20.0 + 10.0 * k as f64).collect();
        let (secs, h) = timed(RUNS, || receptance_sparse(&sys, a, b, &freqs).unwrap());
        let peak = h.iter().fold(0.0f64, |x, v| x.max(v.norm()));
        println!(
            "response {:<40} n = {:5}  {:<32} {secs:8.3} s  ({:8.1} freqs/s)   target < 10 s: {}   [median of {RUNS}]",
            "membrane_100x100 (1000 freqs)",
            sys.len(),
            "sparse complex LDLᵀ per frequency",
            1000.0 / secs,
            verdict(secs, 10.0),
        );
        println!("         20 Hz .. 10010 Hz, |X/F| peak {peak:.4e}");
    }
}
