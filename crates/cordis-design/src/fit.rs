//! Any topology tuned to target frequencies: Levenberg–Marquardt over a model's `let` values, with
//! continuation from the model's own frequencies.
//!
//! `cordis design fit MODEL --freqs LIST --free NAMES` changes the free `let` values of a model so
//! that its `N` lowest non-rigid modes (`N` = number of targets) ring at the sorted target
//! frequencies, in order. Any network the analysis can linearise works: chains, membranes, coupled
//! cels, anything whose inertias, stiffnesses and viscosities come from `let`s.
//!
//! # The problem
//!
//! - **Unknowns**: `x_k = ln p_k`, the logarithms of the free `let` values (GENESIS units). Every
//!   value stays positive whatever step is taken, steps are relative (a stiffness of 1e-6 and one of
//!   10 move alike), and a start value `<= 0` is refused.
//! - **Residuals**, in relative eigenvalue space: `r_j = ln λ_j - ln λ*_j`, with `λ_j` the
//!   eigenvalues of `K φ = λ M φ` and `λ*_j` the eigenvalue that puts mode `j` exactly on its target
//!   (`λ* = 4 sin²(π f / Fs)` undamped; with the mode's damping `c_j = φ_jᵀ R φ_j` the decoupled pole
//!   `z² + (λ + c - 2) z + (1 - c) = 0` rings at `f` when
//!   `λ* = (1 - √(1-c))² + 4 √(1-c) sin²(π f / Fs)`, so damped frequencies are met exactly for
//!   proportional damping). Why this space: `λ` is what the eigenvalue derivative gives directly
//!   (no `asin` chain); relative residuals weigh a 50 Hz mode like a 5 kHz one (absolute `λ` or Hz
//!   residuals would let the treble drown the bass); and `λ` is homogeneous of degree 1 in the
//!   stiffnesses, so a uniform scaling of all springs is exactly linear in these coordinates
//!   (each row of the Jacobian is then the distribution of the mode's potential energy over the
//!   free springs, and sums to 1). Convergence is judged in Hz:
//!   `max |f_j - target_j| <= tolerance_hz`.
//! - **Jacobian**, analytic: `∂λ_j/∂x_k = φ_jᵀ (∂K/∂x_k - λ_j ∂M/∂x_k) φ_j` (`Φᵀ M Φ = I`), from
//!   the derivative matrices `∂K/∂x_k`, `∂M/∂x_k` (`∂c_j` is left out: its effect on the frequency is
//!   of second order). The model is loaded once more per free value with `p_k` multiplied by `e^h`
//!   and the matrices differenced (divided by `e^h - 1`: exact when the matrices are linear in
//!   `p_k`). When the model is **affine** in the free values (each used directly as an inertia,
//!   stiffness or viscosity, or in sums of such: checked at the start against a load at a second
//!   point), these slopes are computed once and every later evaluation assembles the matrices
//!   from them with no load at all (10 to 100 times faster); otherwise (a `let` used through
//!   `f=` and `tau=` of a cel, in a product...) every evaluation loads the model with `--set`
//!   values and every Jacobian takes one load per free value (`h = 1e-6`, first-order accurate).
//!
//! # The solver
//!
//! Our own Levenberg–Marquardt (Nielsen's damping update), because the problems are small and
//! dense (a few to a few hundred values and frequencies), because we want positivity through the
//! log-parameters and control of the continuation, and because the linear algebra is already
//! there: faer, as in the rest of the workspace, with no second linear-algebra crate. Each step
//! solves the damped least-squares problem `min ‖J δ + r‖² + μ ‖δ‖²` as the ordinary least-squares
//! problem `[J; √μ I] δ = [-r; 0]` by a Householder QR (faer): the normal equations `JᵀJ + μI`
//! would square the condition number of `J` (1e6 and more on long chains, whose high modes hardly
//! depend on some springs), and the QR costs nothing at these sizes. Under-determined problems
//! (more free values than targets) are fine: the `μ ‖δ‖²` term picks the smallest step. A step is
//! limited to a factor `e²` on any value.
//!
//! **Continuation.** Moving every target at once from the model's frequencies to the requested ones
//! (geometrically, `f_j(s) = f0_j^(1-s) T_j^s`) often fails on square problems (as many free values
//! as targets): the map from values to sorted frequencies folds over (two equal masses fixed-free
//! with free springs reach only `f2/f1 >= 1 + √2` or so, from two solutions that meet at the fold),
//! and the straight path leaves the image of the sheet it started on; the solver then stops at a
//! turning point. So the targets are first **added one by one**, lowest first: at stage `j` the
//! modes below `j` are held on their targets while mode `j` moves to its own in 3 steps, the modes
//! above being free. Until the last stage the problem is under-determined, its solutions form a
//! manifold, and a one-parameter path generically crosses no turning point (that takes a rank drop
//! of two); only the last stage can meet one. If that fails, the targets are moved all together in
//! `steps` steps (each solved to a relative residual of 1e-4, the last to `tolerance_hz`; a step
//! that fails is halved down to 1/16, then passed from the best point found); if that fails too, up
//! to 8 restarts from the model's values multiplied by seeded factors in `[e^-0.5, e^0.5]` (each
//! adding the targets one by one). The best result is returned, with `converged = false` when no
//! attempt reached the tolerance.
//!
//! **Measured** (`cargo bench -p cordis-design --bench fit`: fixed-free chains of `n` unit masses,
//! one free `let` per spring, 20 target sets each from random chains with stiffnesses uniform in
//! `[0.5, 2]` times the uniform start): reached to 1e-6 Hz for 19/20 at `n = 10` (median 2 ms),
//! 13/20 at 15 (41 ms), 5/20 at 30 (0.9 s) and 3/20 at 60 (7.6 s, 14 s at most). Long chains with
//! fixed masses and free springs are the hard case (their spectra fold over into many sheets and
//! random restarts rarely land on one that reaches the targets); `design chain` (inverse Lanczos,
//! masses free) is the tool for them. The other fits of the tests (a damped membrane with a body,
//! cels given by frequency, under-determined chains) converge at the first attempt.
//!
//! **Frequencies reported** (`achieved_hz`) are those of the modal analysis (`cordis modes`) of
//! the tuned model, loaded from the tuned values. They equal the fit's own for undamped models and
//! proportional damping; when the damping couples the modes the fit's decoupled frequencies are
//! first-order approximations, so the targets are corrected by the difference and the fit re-run
//! (up to 4 times).

use std::path::PathBuf;

use cordis_analysis::faer::{self, Mat};
use cordis_analysis::{LinearSystem, ModalAnalysis, ModeKind};
use cordis_model::eval::{Env, Kind, Value};
use cordis_model::syntax::{self, Statement};
use cordis_model::{did_you_mean, eval_text, load_str, Options};

use crate::DesignError;

/// Restarts from perturbed start points when a fit from the model's own values fails.
const RESTARTS: usize = 8;

/// Steps in which each target is reached when they are added one by one.
const INCREMENTAL_STEPS: usize = 3;

/// What to fit: a model, its free `let` values and the target frequencies.
#[derive(Clone, Debug, PartialEq)]
pub struct FitSpec {
    /// The model file (names it in messages and anchors its signal files).
    pub path: PathBuf,
    /// The model source.
    pub text: String,
    /// The free `let` names; a trailing `*` matches every name with that prefix (`k*`).
    pub free: Vec<String>,
    /// The target frequencies, Hz: sorted, distinct, in `(0, Fs/2)`.
    pub targets_hz: Vec<f64>,
    /// Continuation steps from the model's own frequencies to the targets (default 10; 0 counts
    /// as 1).
    pub steps: usize,
    /// Levenberg–Marquardt iterations per continuation step (default 50).
    pub max_iterations: usize,
    /// Convergence: every frequency within this many Hz of its target (default 1e-6).
    pub tolerance_hz: f64,
}

impl FitSpec {
    /// A fit with the default steps (10), iterations (50) and tolerance (1e-6 Hz).
    pub fn new(
        path: impl Into<PathBuf>,
        text: impl Into<String>,
        free: Vec<String>,
        targets_hz: Vec<f64>,
    ) -> FitSpec {
        FitSpec {
            path: path.into(),
            text: text.into(),
            free,
            targets_hz,
            steps: 10,
            max_iterations: 50,
            tolerance_hz: 1e-6,
        }
    }
}

/// The tuned model.
#[derive(Clone, Debug, PartialEq)]
pub struct FitResult {
    /// Each free `let` and its fitted value, in the model's order, in GENESIS units (as the model
    /// computes with it; the tuned text writes it in the unit its `let` was written in).
    pub values: Vec<(String, f64)>,
    /// The same `let`s and their values in the model as given.
    pub start_values: Vec<(String, f64)>,
    /// The frequencies of the tuned model's `N` lowest non-rigid modes, Hz.
    pub achieved_hz: Vec<f64>,
    /// `max |achieved - target|`, Hz.
    pub max_error_hz: f64,
    /// Levenberg–Marquardt iterations (Jacobians), over all continuation steps.
    pub iterations: usize,
    /// Model evaluations: loads of the model (for values, Jacobian columns and checks), and
    /// assemblies of its matrices when it is affine in the free values.
    pub evaluations: usize,
    /// True when every frequency is within `tolerance_hz` of its target.
    pub converged: bool,
    /// The tuned model: the source with each free `let NAME = ...` line's value replaced,
    /// everything else untouched.
    pub text: String,
}

/// The `let` names of a model source, in order (each once).
pub fn let_names(text: &str) -> Vec<String> {
    let (stmts, _) = syntax::parse(text);
    let mut names: Vec<String> = Vec::new();
    for s in &stmts {
        if let Statement::Let { name, .. } = s {
            if !names.contains(&name.text) {
                names.push(name.text.clone());
            }
        }
    }
    names
}

/// Fits the free `let` values of `spec.text` to the target frequencies (see the module
/// documentation).
///
/// Errors: the model does not load ([`DesignError::Model`]); an unknown free name, a pattern that
/// matches nothing, a free value `<= 0` or one that changes the model's structure, bad targets,
/// more targets than the model has modes ([`DesignError::Invalid`], with a hint); the eigensolver
/// fails ([`DesignError::Numerical`]). Not reaching the tolerance is not an error:
/// `FitResult::converged` says it.
pub fn fit(spec: &FitSpec) -> Result<FitResult, DesignError> {
    let model = load_str(&spec.path, &spec.text, &Options::default())
        .map_err(|e| DesignError::Model(e.to_string()))?;
    let fs = model.rate;
    let lets = lets_of(&spec.text, fs)?;
    let free = resolve_free(&spec.free, &lets)?;
    check_targets(&spec.targets_hz, fs)?;
    if !(spec.tolerance_hz > 0.0 && spec.tolerance_hz.is_finite()) {
        return Err(DesignError::invalid(
            format!(
                "the tolerance {} Hz is not a positive number",
                spec.tolerance_hz
            ),
            "give a tolerance in Hz such as 1e-6",
        ));
    }
    for &i in &free {
        let v = lets[i].value.v;
        if !(v > 0.0 && v.is_finite()) {
            return Err(DesignError::invalid(
                format!(
                    "`let {}` is {v}: a fitted value must start positive",
                    lets[i].name
                ),
                "the fit works on the logarithms of the values (so that they stay positive): \
                 start it from a positive value, or leave it out of the free names",
            ));
        }
    }
    let mut problem = Problem {
        spec,
        fs,
        lets: &lets,
        free: &free,
        n_targets: spec.targets_hz.len(),
        dofs: 0,
        evaluations: 0,
        iterations: 0,
        x0: free.iter().map(|&i| lets[i].value.v.ln()).collect(),
        source: Source::Load,
    };
    let x0 = problem.x0.clone();
    let start = problem.start(&x0)?;
    if start.freqs.iter().any(|f| !(*f > 0.0)) {
        return Err(DesignError::invalid(
            "a mode among the lowest of the model does not oscillate (overdamped)",
            "fit a model whose lowest modes ring, with less damping",
        ));
    }
    problem.detect_affine(&x0, &start)?;
    let targets = &spec.targets_hz;
    let steps = spec.steps.max(1);
    // the model's own values first: targets added one by one, then all moved together; then
    // restarts from perturbed values
    let mut best: (bool, Vec<f64>, Eval) = (false, x0.clone(), start.clone());
    for attempt in 0..=RESTARTS {
        let (xa, ea) = if attempt == 0 {
            (x0.clone(), start.clone())
        } else {
            let xa = perturbed(&x0, attempt);
            match problem.eval(&xa) {
                Ok(e) => (xa, e),
                Err(EvalError::Fatal(d)) => return Err(d),
                Err(_) => continue,
            }
        };
        if ea.freqs.iter().any(|f| !(*f > 0.0)) {
            continue;
        }
        let order: Vec<usize> = (0..targets.len()).collect();
        let mut tries = vec![problem.incremental(&xa, ea.clone(), INCREMENTAL_STEPS, &order)?];
        if attempt == 0 && !tries[0].0 {
            let f0 = ea.freqs.clone();
            tries.push(problem.continuation(&xa, ea, &f0, steps)?);
        }
        for t in tries {
            if !best.0 && (t.0 || max_err(&t.2.freqs, targets) < max_err(&best.2.freqs, targets)) {
                best = t;
            }
        }
        if best.0 {
            break;
        }
    }
    let (converged, mut x, mut cur) = best;
    // the frequencies of the modal analysis of the tuned model; with damping that couples the
    // modes they differ slightly from the fit's own: correct the targets by the difference
    let mut achieved = problem.analysed(&x)?.unwrap_or_else(|| cur.freqs.clone());
    let mut goal = targets.clone();
    for _ in 0..4 {
        if !converged || max_err(&achieved, targets) <= spec.tolerance_hz {
            break;
        }
        for j in 0..goal.len() {
            goal[j] += targets[j] - achieved[j];
        }
        if goal.windows(2).any(|w| !(w[0] < w[1])) || goal.iter().any(|g| !(*g > 0.0)) {
            break;
        }
        let (ok, xs, es) =
            problem.solve(&x, &cur, &goal, Tolerance::Hz(spec.tolerance_hz / 4.0))?;
        if !ok {
            break;
        }
        x = xs;
        cur = es;
        achieved = problem.analysed(&x)?.unwrap_or_else(|| cur.freqs.clone());
    }
    let max_error_hz = max_err(&achieved, targets);
    let converged = converged && max_error_hz <= spec.tolerance_hz;
    // the tuned text and values, from the exact strings the last evaluation loaded
    let strings = problem.value_strings(&x);
    let mut text = spec.text.clone();
    let mut edits: Vec<(usize, usize, &str)> = free
        .iter()
        .zip(&strings)
        .map(|(&i, s)| (lets[i].span.0, lets[i].span.1, s.as_str()))
        .collect();
    edits.sort_by_key(|e| std::cmp::Reverse(e.0));
    for (a, b, s) in edits {
        text.replace_range(a..b, s);
    }
    let values = free
        .iter()
        .zip(&strings)
        .zip(x.iter().zip(&x0))
        .map(|((&i, s), (xi, x0i))| {
            let v = if xi == x0i {
                lets[i].value.v
            } else {
                eval_text(s, fs).map(|v| v.v).unwrap_or_else(|_| xi.exp())
            };
            (lets[i].name.clone(), v)
        })
        .collect();
    let start_values = free
        .iter()
        .map(|&i| (lets[i].name.clone(), lets[i].value.v))
        .collect();
    Ok(FitResult {
        values,
        start_values,
        achieved_hz: achieved,
        max_error_hz,
        iterations: problem.iterations,
        evaluations: problem.evaluations,
        converged,
        text,
    })
}

fn max_err(a: &[f64], b: &[f64]) -> f64 {
    a.iter()
        .zip(b)
        .fold(0.0f64, |m, (x, y)| m.max((x - y).abs()))
        .max(if a.len() == b.len() {
            0.0
        } else {
            f64::INFINITY
        })
}

/// A `let` of the model: its name, value and the byte range of its expression in the source.
struct Let {
    name: String,
    value: Value,
    span: (usize, usize),
}

fn lets_of(text: &str, fs: f64) -> Result<Vec<Let>, DesignError> {
    let (stmts, _) = syntax::parse(text);
    let mut env = Env {
        fs,
        lets: Default::default(),
        failed: Default::default(),
    };
    let mut out = Vec::new();
    for s in &stmts {
        if let Statement::Let { name, value, .. } = s {
            let v = env
                .eval(value)
                .map_err(|d| DesignError::Model(format!("`let {}`: {}", name.text, d.message)))?;
            env.lets.insert(name.text.clone(), v);
            out.push(Let {
                name: name.text.clone(),
                value: v,
                span: (value.span.start, value.span.end),
            });
        }
    }
    Ok(out)
}

/// The indices (into `lets`) of the free names, in the model's order.
fn resolve_free(free: &[String], lets: &[Let]) -> Result<Vec<usize>, DesignError> {
    let names: Vec<&str> = lets.iter().map(|l| l.name.as_str()).collect();
    if free.is_empty() {
        return Err(DesignError::invalid(
            "no free value given",
            if names.is_empty() {
                "the model has no `let`: write the values to fit as `let NAME = VALUE` lines and \
                 use NAME in the modules"
                    .to_string()
            } else {
                format!(
                    "name the `let` values to fit, e.g. --free {}",
                    names.join(",")
                )
            },
        ));
    }
    let mut chosen = vec![false; lets.len()];
    for f in free {
        let f = f.trim();
        if let Some(prefix) = f.strip_suffix('*') {
            let mut any = false;
            for (i, n) in names.iter().enumerate() {
                if n.starts_with(prefix) {
                    chosen[i] = true;
                    any = true;
                }
            }
            if !any {
                return Err(DesignError::invalid(
                    format!("no `let` name starts with `{prefix}`"),
                    lets_hint(&names),
                ));
            }
        } else if let Some(i) = names.iter().position(|n| *n == f) {
            chosen[i] = true;
        } else {
            let hint = match did_you_mean(f, names.iter().copied()) {
                Some(h) => h,
                None => lets_hint(&names),
            };
            return Err(DesignError::invalid(
                format!("the model has no `let {f}`"),
                hint,
            ));
        }
    }
    Ok((0..lets.len()).filter(|&i| chosen[i]).collect())
}

fn lets_hint(names: &[&str]) -> String {
    if names.is_empty() {
        "the model has no `let`: only `let` values can be fitted".into()
    } else {
        let shown: Vec<&str> = names.iter().take(12).copied().collect();
        format!(
            "the model's `let` names are {}{}",
            shown.join(", "),
            if names.len() > 12 { ", ..." } else { "" }
        )
    }
}

fn check_targets(t: &[f64], fs: f64) -> Result<(), DesignError> {
    if t.is_empty() {
        return Err(DesignError::invalid(
            "no target frequency given",
            "give the frequencies to reach in Hz, e.g. --freqs 220,440,660",
        ));
    }
    for &f in t {
        if !(f > 0.0 && f < fs / 2.0) {
            return Err(DesignError::invalid(
                format!(
                    "the target {f} Hz is not between 0 and the Nyquist frequency {} Hz",
                    fs / 2.0
                ),
                "give positive frequencies below half the model's rate (or raise its `rate`)",
            ));
        }
    }
    for w in t.windows(2) {
        if !(w[0] < w[1]) {
            return Err(DesignError::invalid(
                if w[0] == w[1] {
                    format!("the target {} Hz is given twice", w[0])
                } else {
                    format!(
                        "the targets are not sorted: {} Hz comes before {} Hz",
                        w[0], w[1]
                    )
                },
                "give distinct frequencies in increasing order: they are matched in order to the \
                 model's lowest modes",
            ));
        }
    }
    Ok(())
}

/// The matrices of the linearised model at some free values (dense; GENESIS units).
#[derive(Clone)]
struct Mats {
    mass: Vec<f64>,
    k: Mat<f64>,
    r: Mat<f64>,
    damped: bool,
}

impl Mats {
    fn of(sys: &LinearSystem) -> Mats {
        Mats {
            mass: sys.mass.clone(),
            k: sys.k.dense(),
            r: sys.r.dense(),
            damped: !sys.r.is_zero(),
        }
    }
}

/// A symmetric sparse matrix as `(i, j, v)` with `i <= j` (`v` at both `(i, j)` and `(j, i)`).
type Triplets = Vec<(usize, usize, f64)>;

/// `d/dx_k` of the matrices (`x_k = ln p_k`).
struct Deriv {
    k: Triplets,
    m: Vec<(usize, f64)>,
    r: Triplets,
}

/// `(A - B) / div` as triplets, for two matrices of the same size (exact zeros dropped).
fn diff_triplets(a: &Mat<f64>, b: &Mat<f64>, div: f64) -> Triplets {
    let n = a.nrows();
    let mut out = Vec::new();
    for j in 0..n {
        for i in 0..=j {
            let d = a[(i, j)] - b[(i, j)];
            if d != 0.0 {
                out.push((i, j, d / div));
            }
        }
    }
    out
}

/// `φᵀ A φ` for triplets `A`.
fn quad(t: &Triplets, p: &[f64]) -> f64 {
    t.iter()
        .map(|&(i, j, v)| {
            if i == j {
                v * p[i] * p[i]
            } else {
                2.0 * v * p[i] * p[j]
            }
        })
        .sum()
}

/// Where the matrices come from.
enum Source {
    /// A load of the model with `--set` overrides per evaluation, finite differences of loads
    /// for the Jacobian.
    Load,
    /// The model is affine in the free values (each used directly as a stiffness, inertia or
    /// viscosity, or in sums of such): `X(p) = X(p0) + Σ (p_k - p0_k) A_k`, checked at a second
    /// point; no load is needed until the end.
    Affine {
        base: Mats,
        p0: Vec<f64>,
        slopes: Vec<Deriv>,
    },
}

/// One evaluation of the model at some free values.
#[derive(Clone)]
struct Eval {
    mats: Mats,
    /// The N lowest non-rigid modes: undamped eigenvalue, shape (`Φᵀ M Φ = I`), modal damping.
    lambda: Vec<f64>,
    phi: Vec<Vec<f64>>,
    c: Vec<f64>,
    /// Their frequencies (decoupled damping), Hz.
    freqs: Vec<f64>,
}

enum Tolerance {
    /// Every constrained `|r_j|` below this.
    Relative(f64),
    /// Every constrained frequency within this many Hz.
    Hz(f64),
}

/// Why an evaluation failed.
enum EvalError {
    /// The model does not load or linearise at these values (a trial step too far).
    Load(String),
    /// The number of mobile modules changed.
    Structure,
    /// A mode to fit has `λ <= 0`, or absurd damping.
    Modes,
    /// A hard error.
    Fatal(DesignError),
}

/// The state of a fit: the model, its free values, and counters.
struct Problem<'a> {
    spec: &'a FitSpec,
    fs: f64,
    lets: &'a [Let],
    free: &'a [usize],
    n_targets: usize,
    dofs: usize,
    evaluations: usize,
    iterations: usize,
    /// The start point: a value still there is written as the model wrote it.
    x0: Vec<f64>,
    source: Source,
}

/// A deterministic perturbation of the start for restart `attempt`: each value multiplied by a
/// factor in `[e^-0.5, e^0.5)`.
fn perturbed(x0: &[f64], attempt: usize) -> Vec<f64> {
    let mut state = 0x9e37_79b9_7f4a_7c15u64 ^ (attempt as u64).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    x0.iter()
        .map(|&v| {
            state = state
                .wrapping_mul(6_364_136_223_846_793_005)
                .wrapping_add(1_442_695_040_888_963_407);
            let u = (state >> 11) as f64 / (1u64 << 53) as f64;
            v + (u - 0.5)
        })
        .collect()
}

/// Formats `v` so that it reads back exactly (shortest round trip).
fn number(v: f64) -> String {
    let a = v.abs();
    if (1e-4..1e9).contains(&a) {
        format!("{v}")
    } else {
        format!("{v:e}")
    }
}

/// A message and hint for a free value that cannot be fitted.
fn not_fittable(name: &str, why: String) -> DesignError {
    DesignError::invalid(
        why,
        format!(
            "leave `{name}` out of the free names: only values that set inertias, stiffnesses \
             and viscosities can be fitted"
        ),
    )
}

impl Problem<'_> {
    /// The expressions written for the free values: in the unit their `let` was written in (the
    /// model's own expression for a value that has not moved).
    fn value_strings(&self, x: &[f64]) -> Vec<String> {
        let fs = self.fs;
        self.free
            .iter()
            .zip(x)
            .zip(&self.x0)
            .map(|((&i, &xi), &x0)| {
                if xi == x0 {
                    let (a, b) = self.lets[i].span;
                    return self.spec.text.get(a..b).unwrap_or_default().to_string();
                }
                let g = xi.exp();
                match self.lets[i].value.kind {
                    Kind::Freq => format!("{}Hz", number(g * fs)),
                    Kind::Time => format!("{}s", number(g / fs)),
                    Kind::Stiffness => format!("{}N/m", number(g * fs * fs)),
                    Kind::Viscosity => format!("{}N.s/m", number(g * fs)),
                    Kind::Velocity => format!("{}m/s", number(g * fs)),
                    Kind::Plain | Kind::Mixed => number(g),
                }
            })
            .collect()
    }

    /// Loads and linearises the model at `x`.
    fn load(&mut self, x: &[f64]) -> Result<LinearSystem, EvalError> {
        self.evaluations += 1;
        let strings = self.value_strings(x);
        let sets = self
            .free
            .iter()
            .zip(strings)
            .map(|(&i, s)| (self.lets[i].name.clone(), s))
            .collect();
        let opts = Options {
            sets,
            ..Default::default()
        };
        let model = load_str(&self.spec.path, &self.spec.text, &opts)
            .map_err(|e| EvalError::Load(e.to_string()))?;
        let sys = LinearSystem::from_model(&model).map_err(|e| EvalError::Load(e.to_string()))?;
        if self.dofs != 0 && sys.len() != self.dofs {
            return Err(EvalError::Structure);
        }
        Ok(sys)
    }

    /// The matrices at `x`.
    fn mats(&mut self, x: &[f64]) -> Result<Mats, EvalError> {
        match &self.source {
            Source::Load => Ok(Mats::of(&self.load(x)?)),
            Source::Affine { base, p0, slopes } => {
                self.evaluations += 1;
                let mut m = base.clone();
                for ((&xk, &pk), d) in x.iter().zip(p0).zip(slopes) {
                    // the slopes are per unit of x at p0: per unit of p, divide by p0
                    let w = xk.exp() / pk - 1.0;
                    if w == 0.0 {
                        continue;
                    }
                    for &(i, j, v) in &d.k {
                        m.k[(i, j)] += w * v;
                        if i != j {
                            m.k[(j, i)] += w * v;
                        }
                    }
                    for &(i, v) in &d.m {
                        m.mass[i] += w * v;
                    }
                    for &(i, j, v) in &d.r {
                        m.r[(i, j)] += w * v;
                        if i != j {
                            m.r[(j, i)] += w * v;
                        }
                    }
                }
                if m.mass.iter().any(|v| !(*v > 0.0)) {
                    return Err(EvalError::Modes);
                }
                Ok(m)
            }
        }
    }

    /// Evaluates at `x`: the N lowest non-rigid modes.
    fn eval(&mut self, x: &[f64]) -> Result<Eval, EvalError> {
        let mats = self.mats(x)?;
        self.modes(mats)
    }

    /// Solves `K φ = λ M φ` for the N lowest non-rigid modes.
    fn modes(&self, mats: Mats) -> Result<Eval, EvalError> {
        let n = mats.mass.len();
        if mats.mass.iter().any(|m| !(*m > 0.0 && m.is_finite())) {
            return Err(EvalError::Modes);
        }
        let isq: Vec<f64> = mats.mass.iter().map(|m| 1.0 / m.sqrt()).collect();
        let ks = Mat::<f64>::from_fn(n, n, |i, j| mats.k[(i, j)] * isq[i] * isq[j]);
        for j in 0..n {
            for i in 0..n {
                if !ks[(i, j)].is_finite() || !mats.r[(i, j)].is_finite() {
                    return Err(EvalError::Modes);
                }
            }
        }
        let (all, v) = sym_eigen_seq(&ks).map_err(|e| {
            EvalError::Fatal(DesignError::Numerical(format!(
                "the eigensolver did not converge: {e:?}"
            )))
        })?;
        let scale = all
            .iter()
            .fold(0.0f64, |a, &b| a.max(b.abs()))
            .max(f64::MIN_POSITIVE);
        let moving: Vec<usize> = (0..n).filter(|&j| all[j].abs() > 1e-11 * scale).collect();
        if moving.len() < self.n_targets {
            let rigid = n - moving.len();
            return Err(EvalError::Fatal(DesignError::invalid(
                format!(
                    "{} target frequencies, but the model has only {} non-rigid modes ({n} \
                     mobile modules{})",
                    self.n_targets,
                    moving.len(),
                    if rigid > 0 {
                        format!(", {rigid} of their modes free to drift as a whole")
                    } else {
                        String::new()
                    }
                ),
                "give fewer targets, or fit a model with more masses",
            )));
        }
        let nt = self.n_targets;
        let (mut lambda, mut phi, mut c, mut freqs) = (
            Vec::with_capacity(nt),
            Vec::with_capacity(nt),
            Vec::with_capacity(nt),
            Vec::with_capacity(nt),
        );
        for &j in &moving[..nt] {
            let l = all[j];
            if !(l > 0.0) {
                return Err(EvalError::Modes);
            }
            let p: Vec<f64> = (0..n).map(|i| v[(i, j)] * isq[i]).collect();
            let cj = if mats.damped {
                let mut acc = 0.0;
                for (b, pb) in p.iter().enumerate() {
                    let row: f64 = p
                        .iter()
                        .enumerate()
                        .map(|(a, pa)| mats.r[(a, b)] * pa)
                        .sum();
                    acc += row * pb;
                }
                acc
            } else {
                0.0
            };
            if !(cj > -1e-12 && cj < 1.0) {
                return Err(EvalError::Modes);
            }
            let cj = cj.max(0.0);
            lambda.push(l);
            phi.push(p);
            c.push(cj);
            freqs.push(damped_freq(l, cj, self.fs));
        }
        Ok(Eval {
            mats,
            lambda,
            phi,
            c,
            freqs,
        })
    }

    /// The first evaluation (by a load, whatever the source): its failures are the user's.
    fn start(&mut self, x: &[f64]) -> Result<Eval, DesignError> {
        let r = self.load(x).and_then(|sys| {
            self.dofs = sys.len();
            self.modes(Mats::of(&sys))
        });
        match r {
            Ok(e) => Ok(e),
            Err(EvalError::Fatal(e)) => Err(e),
            Err(EvalError::Load(m)) => Err(DesignError::Model(m)),
            Err(EvalError::Structure) => Err(DesignError::Numerical(
                "the model changed size between two loads".into(),
            )),
            Err(EvalError::Modes) => Err(DesignError::invalid(
                "the model's lowest modes do not oscillate (a non-positive stiffness, or damping \
                 too strong to analyse)",
                "check the model with `cordis modes`",
            )),
        }
    }

    /// `d/dx_k` of the matrices at `x` (evaluated as `e`) by a load with `x_k + h`.
    fn loaded_deriv(
        &mut self,
        x: &[f64],
        e: &Eval,
        k: usize,
        h: f64,
    ) -> Result<Deriv, DesignError> {
        let mut xp = x.to_vec();
        xp[k] += h;
        let name = self.lets[self.free[k]].name.clone();
        let sys = match self.load(&xp) {
            Ok(s) => s,
            Err(EvalError::Structure) => {
                return Err(not_fittable(
                    &name,
                    format!("changing `{name}` changes the number of masses of the model"),
                ))
            }
            Err(EvalError::Load(msg)) => {
                return Err(not_fittable(
                    &name,
                    format!("the model does not load when `{name}` changes slightly: {msg}"),
                ))
            }
            Err(EvalError::Fatal(d)) => return Err(d),
            Err(EvalError::Modes) => {
                return Err(DesignError::Numerical("a load failed".into()));
            }
        };
        let div = h.exp_m1();
        let m2 = Mats::of(&sys);
        Ok(Deriv {
            k: diff_triplets(&m2.k, &e.mats.k, div),
            m: m2
                .mass
                .iter()
                .zip(&e.mats.mass)
                .enumerate()
                .filter(|(_, (a, b))| a != b)
                .map(|(i, (a, b))| (i, (a - b) / div))
                .collect(),
            r: diff_triplets(&m2.r, &e.mats.r, div),
        })
    }

    /// Decides whether the model is affine in the free values: slopes from one load per value
    /// at the start, checked against a load at a second point.
    fn detect_affine(&mut self, x0: &[f64], start: &Eval) -> Result<(), DesignError> {
        const H: f64 = 1e-3;
        let mut slopes = Vec::with_capacity(x0.len());
        for k in 0..x0.len() {
            slopes.push(self.loaded_deriv(x0, start, k, H)?);
        }
        // slopes at p0 per unit of x: exact for an affine model
        let p0: Vec<f64> = x0.iter().map(|v| v.exp()).collect();
        let affine = Source::Affine {
            base: start.mats.clone(),
            p0,
            slopes,
        };
        let xt = perturbed(x0, 1_000_003);
        let loaded = match self.load(&xt) {
            Ok(s) => Mats::of(&s),
            Err(EvalError::Fatal(d)) => return Err(d),
            Err(_) => return Ok(()), // keep loading
        };
        let saved = std::mem::replace(&mut self.source, affine);
        let assembled = match self.mats(&xt) {
            Ok(m) => m,
            Err(_) => {
                self.source = saved;
                return Ok(());
            }
        };
        let close = |a: &Mat<f64>, b: &Mat<f64>| {
            let big = (0..a.ncols())
                .flat_map(|j| (0..a.nrows()).map(move |i| (i, j)))
                .fold(0.0f64, |m, (i, j)| {
                    m.max(a[(i, j)].abs()).max(b[(i, j)].abs())
                });
            (0..a.ncols())
                .flat_map(|j| (0..a.nrows()).map(move |i| (i, j)))
                .all(|(i, j)| (a[(i, j)] - b[(i, j)]).abs() <= 1e-9 * big)
        };
        let mbig = loaded.mass.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        let ok = close(&loaded.k, &assembled.k)
            && close(&loaded.r, &assembled.r)
            && loaded
                .mass
                .iter()
                .zip(&assembled.mass)
                .all(|(a, b)| (a - b).abs() <= 1e-9 * mbig);
        if !ok {
            self.source = saved;
        }
        Ok(())
    }

    /// Residuals `ln λ_j - ln λ*_j` for the target frequencies `goal` (0 where `goal` is NaN: a
    /// mode not constrained).
    fn residuals(&self, e: &Eval, goal: &[f64]) -> Vec<f64> {
        e.lambda
            .iter()
            .zip(&e.c)
            .zip(goal)
            .map(|((&l, &c), &f)| {
                if f.is_nan() {
                    0.0
                } else {
                    l.ln() - lambda_for(f, c, self.fs).ln()
                }
            })
            .collect()
    }

    /// `J_jk = ∂ ln λ_j / ∂ ln p_k` at `x` (evaluated as `e`).
    fn jacobian(&mut self, x: &[f64], e: &Eval) -> Result<Mat<f64>, DesignError> {
        let nt = e.lambda.len();
        let m = x.len();
        let mut jac = Mat::<f64>::zeros(nt, m);
        for k in 0..m {
            let owned;
            let d = match &self.source {
                Source::Affine { p0, slopes, .. } => {
                    // d/dx_k at x = p_k / p0_k × the slope at p0
                    let w = x[k].exp() / p0[k];
                    for j in 0..nt {
                        let p = &e.phi[j];
                        let dk = quad(&slopes[k].k, p);
                        let dm: f64 = slopes[k].m.iter().map(|&(i, v)| v * p[i] * p[i]).sum();
                        jac[(j, k)] = w * (dk - e.lambda[j] * dm) / e.lambda[j];
                    }
                    continue;
                }
                Source::Load => {
                    owned = self.loaded_deriv(x, e, k, 1e-6)?;
                    &owned
                }
            };
            for j in 0..nt {
                let p = &e.phi[j];
                let dk = quad(&d.k, p);
                let dm: f64 = d.m.iter().map(|&(i, v)| v * p[i] * p[i]).sum();
                jac[(j, k)] = (dk - e.lambda[j] * dm) / e.lambda[j];
            }
        }
        Ok(jac)
    }

    /// Levenberg–Marquardt from `x` (evaluated as `e`) towards the frequencies `goal` (NaN: not
    /// constrained). Returns whether the tolerance was met, and the final point and evaluation.
    fn solve(
        &mut self,
        x: &[f64],
        e: &Eval,
        goal: &[f64],
        tol: Tolerance,
    ) -> Result<(bool, Vec<f64>, Eval), DesignError> {
        let weights: Vec<f64> = goal
            .iter()
            .map(|g| if g.is_nan() { 0.0 } else { 1.0 })
            .collect();
        self.solve_weighted(x, e, goal, &weights, tol)
    }

    /// [`Problem::solve`] with a weight per residual: 1 for the targets to meet, a small weight
    /// for targets only leaned towards, 0 for free modes. The tolerance counts the first kind.
    fn solve_weighted(
        &mut self,
        x: &[f64],
        e: &Eval,
        goal: &[f64],
        weights: &[f64],
        tol: Tolerance,
    ) -> Result<(bool, Vec<f64>, Eval), DesignError> {
        let mut x = x.to_vec();
        let mut e = e.clone();
        let weigh = |mut r: Vec<f64>| {
            for (v, w) in r.iter_mut().zip(weights) {
                *v *= w;
            }
            r
        };
        let mut r = weigh(self.residuals(&e, goal));
        let mut mu = -1.0; // set from the first Jacobian
        let mut nu = 2.0;
        let m = x.len();
        let hard: Vec<f64> = goal
            .iter()
            .zip(weights)
            .map(|(&g, &w)| if w == 1.0 { g } else { f64::NAN })
            .collect();
        let done = |e: &Eval, r: &[f64]| match tol {
            Tolerance::Relative(t) => r
                .iter()
                .zip(weights)
                .all(|(v, &w)| w != 1.0 || v.abs() <= t),
            Tolerance::Hz(t) => max_err(&e.freqs, &hard) <= t,
        };
        for _ in 0..self.spec.max_iterations {
            if done(&e, &r) {
                return Ok((true, x, e));
            }
            self.iterations += 1;
            let mut jac = self.jacobian(&x, &e)?;
            for (j, &w) in weights.iter().enumerate() {
                for k in 0..m {
                    jac[(j, k)] *= w;
                }
            }
            if mu < 0.0 {
                let big = (0..m)
                    .map(|k| (0..r.len()).map(|j| jac[(j, k)].powi(2)).sum::<f64>())
                    .fold(0.0f64, f64::max);
                mu = 1e-3 * big.max(1e-12);
            }
            let cost = sq(&r);
            let mut accepted = false;
            for _ in 0..16 {
                let Some(mut delta) = lm_step(&jac, &r, mu) else {
                    break;
                };
                let big = delta.iter().fold(0.0f64, |a, &b| a.max(b.abs()));
                if big > 2.0 {
                    for d in &mut delta {
                        *d *= 2.0 / big;
                    }
                }
                // the decrease the linear model predicts
                let lin: Vec<f64> = (0..r.len())
                    .map(|j| r[j] + (0..m).map(|k| jac[(j, k)] * delta[k]).sum::<f64>())
                    .collect();
                let predicted = cost - sq(&lin);
                let xn: Vec<f64> = x.iter().zip(&delta).map(|(a, b)| a + b).collect();
                match self.eval(&xn) {
                    Ok(en) => {
                        let rn = weigh(self.residuals(&en, goal));
                        let actual = cost - sq(&rn);
                        let rho = if predicted > 0.0 {
                            actual / predicted
                        } else {
                            -1.0
                        };
                        if rho > 1e-4 || (actual > 0.0 && done(&en, &rn)) {
                            mu *= (1.0 / 3.0f64).max(1.0 - (2.0 * rho - 1.0).powi(3));
                            nu = 2.0;
                            x = xn;
                            e = en;
                            r = rn;
                            accepted = true;
                            break;
                        }
                    }
                    Err(EvalError::Fatal(d)) => return Err(d),
                    Err(_) => {}
                }
                mu *= nu;
                nu *= 2.0;
            }
            if !accepted {
                break;
            }
        }
        let ok = done(&e, &r);
        Ok((ok, x, e))
    }

    /// All targets at once: they move from `f0` (the frequencies at `x0`) geometrically,
    /// `f0^(1-s) T^s`, in `steps` steps, each solved by Levenberg–Marquardt from the last; a
    /// step that fails is halved (down to 1/16), then passed from the best point found.
    fn continuation(
        &mut self,
        x0: &[f64],
        start: Eval,
        f0: &[f64],
        steps: usize,
    ) -> Result<(bool, Vec<f64>, Eval), DesignError> {
        let targets = self.spec.targets_hz.clone();
        let mut x = x0.to_vec();
        let mut cur = start;
        let mut s = 0.0f64;
        let full = 1.0 / steps as f64;
        let mut ds = full;
        let min_ds = full / 16.0;
        let budget = self.iterations + steps * self.spec.max_iterations;
        loop {
            if self.iterations >= budget {
                return Ok((false, x, cur));
            }
            let last = s + ds >= 1.0 - 1e-12;
            let s_next = if last { 1.0 } else { s + ds };
            let goal: Vec<f64> = f0
                .iter()
                .zip(&targets)
                .map(|(&a, &b)| {
                    if last {
                        b
                    } else {
                        a.powf(1.0 - s_next) * b.powf(s_next)
                    }
                })
                .collect();
            let tol = if last {
                Tolerance::Hz(self.spec.tolerance_hz)
            } else {
                Tolerance::Relative(1e-4)
            };
            let (ok, xs, es) = self.solve(&x, &cur, &goal, tol)?;
            if ok {
                x = xs;
                cur = es;
                s = s_next;
                if last {
                    return Ok((true, x, cur));
                }
                ds = (2.0 * ds).min(full);
            } else if ds > min_ds {
                ds /= 2.0;
            } else {
                x = xs;
                cur = es;
                s = s_next;
                if last {
                    return Ok((false, x, cur));
                }
            }
        }
    }

    /// Targets added one by one, lowest first: at stage `j` the modes below `j` are held on their
    /// targets while mode `j` moves to its own in `sub` steps; the modes above are free, so until
    /// the last stage the problem is under-determined and its solutions form a manifold that a
    /// one-parameter path generically crosses without turning points.
    fn incremental(
        &mut self,
        x0: &[f64],
        start: Eval,
        sub: usize,
        order: &[usize],
    ) -> Result<(bool, Vec<f64>, Eval), DesignError> {
        let targets = self.spec.targets_hz.clone();
        let nt = targets.len();
        let mut x = x0.to_vec();
        let mut cur = start;
        let budget = self.iterations + sub * self.spec.max_iterations * nt;
        let mut weights = vec![0.0; nt];
        for (jj, &j) in order.iter().enumerate() {
            let from = cur.freqs[j];
            weights[j] = 1.0;
            let final_stage = jj + 1 == nt;
            for k in 1..=sub {
                if self.iterations >= budget {
                    return Ok((false, x, cur));
                }
                let sg = k as f64 / sub as f64;
                let mut goal = targets.clone();
                if k < sub {
                    goal[j] = from.powf(1.0 - sg) * targets[j].powf(sg);
                }
                let last = final_stage && k == sub;
                let tol = if last {
                    Tolerance::Hz(self.spec.tolerance_hz)
                } else {
                    Tolerance::Relative(1e-6)
                };
                let (ok, xs, es) = self.solve_weighted(&x, &cur, &goal, &weights, tol)?;
                x = xs;
                cur = es;
                if last || (!ok && final_stage) {
                    return Ok((ok, x, cur));
                }
            }
        }
        Ok((false, x, cur))
    }

    /// The frequencies the modal analysis gives for the model loaded at `x` (the `N` lowest
    /// oscillating modes), or `None` when they cannot be matched to the fit's modes (an
    /// overdamped mode among them).
    fn analysed(&mut self, x: &[f64]) -> Result<Option<Vec<f64>>, DesignError> {
        let sys = match self.load(x) {
            Ok(s) => s,
            Err(EvalError::Fatal(d)) => return Err(d),
            Err(EvalError::Load(m)) => return Err(DesignError::Model(m)),
            Err(_) => return Ok(None),
        };
        let ma =
            ModalAnalysis::compute(&sys).map_err(|err| DesignError::Numerical(err.to_string()))?;
        if ma.modes.iter().any(|m| m.kind == ModeKind::NonOscillating) {
            return Ok(None);
        }
        let osc: Vec<f64> = ma
            .modes
            .iter()
            .filter(|m| m.kind == ModeKind::Oscillating)
            .map(|m| m.freq_hz)
            .take(self.n_targets)
            .collect();
        Ok((osc.len() == self.n_targets).then_some(osc))
    }
}

fn sq(v: &[f64]) -> f64 {
    v.iter().map(|a| a * a).sum()
}

/// The least-squares solution of `[J; √μ I] δ = [-r; 0]`, by QR.
fn lm_step(jac: &Mat<f64>, r: &[f64], mu: f64) -> Option<Vec<f64>> {
    let (nt, m) = (jac.nrows(), jac.ncols());
    let s = mu.sqrt();
    let a = Mat::<f64>::from_fn(nt + m, m, |i, k| {
        if i < nt {
            jac[(i, k)]
        } else if i - nt == k {
            s
        } else {
            0.0
        }
    });
    let b: Vec<f64> = (0..nt + m)
        .map(|i| if i < nt { -r[i] } else { 0.0 })
        .collect();
    let out = lstsq_seq(a, &b);
    out.iter().all(|v| v.is_finite()).then_some(out)
}

// The matrices here are small (tens to a few hundred rows) and factored thousands of times: faer's
// default parallelism (a thread pool) then costs more in synchronisation than it saves (half the
// time of a 60-value fit went to the scheduler), so these two call faer's kernels sequentially.

/// Least squares `min ‖A x - b‖` (`A` tall, full column rank) by Householder QR, sequentially.
fn lstsq_seq(mut a: Mat<f64>, b: &[f64]) -> Vec<f64> {
    use faer::dyn_stack::{MemBuffer, MemStack, StackReq};
    use faer::linalg::qr::no_pivoting::{factor, solve};
    let (rows, cols) = a.shape();
    let bs = factor::recommended_block_size::<f64>(rows, cols);
    let mut coeff = Mat::<f64>::zeros(bs, cols.min(rows));
    let req = StackReq::any_of(&[
        factor::qr_in_place_scratch::<f64>(rows, cols, bs, faer::Par::Seq, Default::default()),
        solve::solve_lstsq_in_place_scratch::<f64>(rows, cols, bs, 1, faer::Par::Seq),
    ]);
    let mut buf = MemBuffer::new(req);
    let stack = MemStack::new(&mut buf);
    factor::qr_in_place(
        a.as_mut(),
        coeff.as_mut(),
        faer::Par::Seq,
        stack,
        Default::default(),
    );
    // Householder vectors below a unit diagonal, R above it (as faer's own `Qr` splits them)
    let basis = Mat::<f64>::from_fn(rows, cols, |i, j| match i.cmp(&j) {
        std::cmp::Ordering::Greater => a[(i, j)],
        std::cmp::Ordering::Equal => 1.0,
        std::cmp::Ordering::Less => 0.0,
    });
    let r = Mat::<f64>::from_fn(cols, cols, |i, j| if i <= j { a[(i, j)] } else { 0.0 });
    let mut rhs = Mat::<f64>::from_fn(rows, 1, |i, _| b[i]);
    solve::solve_lstsq_in_place(
        basis.as_ref(),
        coeff.as_ref(),
        r.as_ref(),
        rhs.as_mut(),
        faer::Par::Seq,
        stack,
    );
    cordis_analysis::clean_upper();
    (0..cols).map(|k| rhs[(k, 0)]).collect()
}

/// Eigenvalues (ascending) and orthonormal eigenvectors of a symmetric matrix (its lower
/// triangle), sequentially.
fn sym_eigen_seq(a: &Mat<f64>) -> Result<(Vec<f64>, Mat<f64>), faer::linalg::evd::EvdError> {
    use faer::dyn_stack::{MemBuffer, MemStack};
    use faer::linalg::evd;
    let n = a.nrows();
    let mut u = Mat::<f64>::zeros(n, n);
    let mut s = faer::diag::Diag::<f64>::zeros(n);
    let req = evd::self_adjoint_evd_scratch::<f64>(
        n,
        evd::ComputeEigenvectors::Yes,
        faer::Par::Seq,
        Default::default(),
    );
    let mut buf = MemBuffer::new(req);
    evd::self_adjoint_evd(
        a.as_ref(),
        s.as_mut(),
        Some(u.as_mut()),
        faer::Par::Seq,
        MemStack::new(&mut buf),
        Default::default(),
    )?;
    cordis_analysis::clean_upper();
    let s = s.as_ref();
    Ok(((0..n).map(|i| s[i]).collect(), u))
}

/// The undamped eigenvalue that makes a decoupled mode of modal damping `c` ring at `f` Hz:
/// `(1 - √(1-c))² + 4 √(1-c) sin²(π f / Fs)`.
fn lambda_for(f: f64, c: f64, fs: f64) -> f64 {
    let r = (1.0 - c).sqrt();
    let a = c / (1.0 + r);
    let s = (std::f64::consts::PI * f / fs).sin();
    a * a + 4.0 * r * s * s
}

/// The frequency (Hz) of a decoupled mode `z² + (λ + c - 2) z + (1 - c) = 0`; 0 when it does not
/// oscillate.
fn damped_freq(lambda: f64, c: f64, fs: f64) -> f64 {
    let r = (1.0 - c).sqrt();
    let a = c / (1.0 + r);
    let s2 = (lambda - a * a) / (4.0 * r);
    if !(s2 > 0.0) {
        return 0.0;
    }
    if s2 >= 1.0 {
        return fs / 2.0;
    }
    fs / std::f64::consts::PI * s2.sqrt().asin()
}
