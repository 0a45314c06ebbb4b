//! `cordis modes`, `cordis matrices`, `cordis response`: the analysis crate at the command line.

use std::fmt::Write as _;
use std::io::Write as _;
use std::path::{Path, PathBuf};

use anyhow::{Context, Result};
use cordis_analysis::{LinearSystem, Method, ModalAnalysis, ModeKind};
use cordis_model::Model;
use serde_json::json;

use crate::output::Pending;
use crate::{exit, ModelArgs};

fn load(args: &ModelArgs) -> Result<Model, u8> {
    match cordis_model::load_file(&args.model, &args.options()) {
        Ok(m) => {
            crate::report::emit(&m.path, &m.source, &m.warnings);
            Ok(m)
        }
        Err(e) => {
            crate::report::emit_load_error(&e);
            Err(exit::INVALID)
        }
    }
}

/// The model and its linearisation (errors printed).
fn load_linear(args: &ModelArgs) -> Result<(Model, LinearSystem), u8> {
    let model = load(args)?;
    let sys = LinearSystem::from_model(&model).map_err(|e| {
        eprintln!("cordis: {e}");
        exit::INVALID
    })?;
    Ok((model, sys))
}

/// The dof of a mobile module named on the command line (`flag` names the option in messages).
fn dof_named(model: &Model, sys: &LinearSystem, name: &str, flag: &str) -> Result<usize, u8> {
    sys.dof(name).ok_or_else(|| {
        let hint = cordis_model::did_you_mean(name, sys.names.iter().map(String::as_str))
            .unwrap_or_else(|| "name a mas or cel of the model".into());
        let what = if model.materials.iter().any(|m| m.name == name) {
            "is a fixed module (sol or enx): it cannot move"
        } else {
            "is not a module of the model"
        };
        eprintln!("cordis: {flag} {name}: `{name}` {what}\n  hint: {hint}");
        exit::USAGE
    })
}

fn analyse(sys: &LinearSystem) -> Result<ModalAnalysis, u8> {
    if sys.len() > 300 {
        eprintln!("cordis: analysing {} degrees of freedom...", sys.len());
    }
    ModalAnalysis::compute(sys).map_err(|e| {
        eprintln!("cordis: {e}");
        exit::INVALID
    })
}

fn write_file(path: &Path, text: &str) -> Result<()> {
    let pending = Pending::new(path);
    std::fs::write(pending.path(), text)
        .with_context(|| format!("cannot write {}", path.display()))?;
    pending.commit()
}

fn num(v: f64) -> serde_json::Value {
    if v.is_finite() {
        json!(v)
    } else if v.is_nan() {
        json!(null)
    } else if v > 0.0 {
        json!("inf")
    } else {
        json!("-inf")
    }
}

/// Modes as a command shows them, from the dense or the sparse path.
struct Found {
    modes: Vec<cordis_analysis::Mode>,
    method: String,
    max_radius: f64,
    partial: bool,
}

fn sparse_method_text(m: &cordis_analysis::SparseMethod, count: usize, residual: f64) -> String {
    let how = match m {
        cordis_analysis::SparseMethod::Undamped => "undamped".to_string(),
        cordis_analysis::SparseMethod::Rayleigh { alpha, beta } => {
            format!("damped, R = {alpha:.3e} M + {beta:.3e} K: each mode's poles in closed form")
        }
        cordis_analysis::SparseMethod::Refined { coupling, .. } => {
            format!(
                "damped, each pole refined on the full quadratic problem (coupling {coupling:.2e})"
            )
        }
    };
    format!(
        "the {count} lowest modes by shift-invert Lanczos (largest residual {residual:.1e}); {how}"
    )
}

fn method_text(m: &Method) -> String {
    match m {
        Method::Undamped => "undamped: K phi = lambda M phi, f = (Fs/pi) asin(sqrt(lambda)/2)".into(),
        Method::Decoupled => "damped, decoupled: the damping is diagonal in the undamped modes; each mode's poles in closed form".into(),
        Method::StateSpace { coupling } => format!("damped, state space: eigenvalues of A_d (the damping couples the undamped modes: largest off-diagonal {coupling:.2e} of the largest entry)"),
        Method::Refined { coupling, factorisations, lu_solves, max_residual } => format!("damped, refined: each pole refined on the full quadratic problem from its mode's own damping ({factorisations} sparse factorisations, {lu_solves} solves redone by the LU, largest residual {max_residual:.1e}; the damping couples the undamped modes: largest off-diagonal {coupling:.2e} of the largest entry)"),
    }
}

fn kind_text(k: ModeKind) -> &'static str {
    match k {
        ModeKind::Oscillating => "oscillating",
        ModeKind::NonOscillating => "non-oscillating",
        ModeKind::Rigid => "rigid",
    }
}

/// `cordis modes`.
pub fn modes(
    args: &ModelArgs,
    json_out: bool,
    plot: Option<&PathBuf>,
    spec: &crate::SpecArgs,
    count: Option<usize>,
) -> u8 {
    let (model, sys) = match load_linear(args) {
        Ok(x) => x,
        Err(c) => return c,
    };
    let ma = match count {
        None => match analyse(&sys) {
            Ok(m) => Found {
                method: method_text(&m.method),
                max_radius: m.max_radius,
                modes: m.modes,
                partial: false,
            },
            Err(c) => return c,
        },
        Some(k) => match cordis_analysis::lowest_modes(&sys, k) {
            Ok(lm) => Found {
                method: sparse_method_text(&lm.method, k, lm.max_residual),
                max_radius: lm.modes.iter().fold(0.0f64, |a, m| a.max(m.radius)),
                modes: lm.modes,
                partial: k < sys.len(),
            },
            Err(e) => {
                eprintln!("cordis: {e}");
                return exit::INVALID;
            }
        },
    };
    let outs: Vec<&str> = sys.outputs.iter().map(|(n, _)| n.as_str()).collect();
    let mut text = String::new();
    if json_out {
        let modes: Vec<serde_json::Value> = ma
            .modes
            .iter()
            .map(|m| {
                json!({
                    "kind": kind_text(m.kind),
                    "freq_hz": num(m.freq_hz),
                    "tau_s": num(m.tau_s),
                    "t60_s": num(m.t60_s),
                    "q": num(m.q),
                    "radius": num(m.radius),
                    "lambda": num(m.lambda),
                    "amplitudes": outs.iter().zip(&m.amplitudes).map(|(o, a)| (o.to_string(), num(*a))).collect::<serde_json::Map<_, _>>(),
                    "shape": m.shape.iter().map(|v| num(*v)).collect::<Vec<_>>(),
                })
            })
            .collect();
        let doc = json!({
            "model": model.path.display().to_string(),
            "rate_hz": model.rate,
            "method": ma.method,
            "dofs": sys.names,
            "outputs": outs,
            "max_pole_radius": num(ma.max_radius),
            "stable": cordis_analysis::radius_is_stable(ma.max_radius),
            "free_parts": sys.free_parts.iter().map(|p| p.iter().map(|&d| sys.names[d].clone()).collect::<Vec<_>>()).collect::<Vec<_>>(),
            "linearised": sys.notes,
            "modes": modes,
        });
        let _ = writeln!(
            text,
            "{}",
            serde_json::to_string_pretty(&doc).unwrap_or_default()
        );
    } else {
        let _ = writeln!(
            text,
            "{}: {} modes of {} mobile modules, at {} Hz",
            model.path.display(),
            ma.modes.len(),
            sys.len(),
            model.rate
        );
        let _ = writeln!(text, "method: {}", ma.method);
        for n in &sys.notes {
            let _ = writeln!(text, "linearised: {n}");
        }
        for p in &sys.free_parts {
            let names: Vec<&str> = p.iter().take(6).map(|&d| sys.names[d].as_str()).collect();
            let _ = writeln!(
                text,
                "free-floating part ({} modules: {}{}): it has a rigid mode at 0 Hz",
                p.len(),
                names.join(", "),
                if p.len() > 6 { ", ..." } else { "" }
            );
        }
        let _ = writeln!(
            text,
            "stability: largest pole radius {:.12}{} ({})",
            ma.max_radius,
            if ma.partial {
                " of the modes listed"
            } else {
                ""
            },
            if cordis_analysis::radius_is_stable(ma.max_radius) {
                "stable"
            } else {
                "UNSTABLE: some mode grows"
            }
        );
        let _ = write!(
            text,
            "{:>5} {:>16} {:>12} {:>12} {:>12} {:>16}",
            "mode", "kind", "freq (Hz)", "tau (s)", "T60 (s)", "Q"
        );
        for o in &outs {
            let _ = write!(text, " {:>14}", format!("amp@{o}"));
        }
        let _ = writeln!(text);
        for (i, m) in ma.modes.iter().enumerate() {
            let _ = write!(
                text,
                "{:>5} {:>16} {:>12.4} {:>12.5} {:>12.5} {:>16.2}",
                i + 1,
                kind_text(m.kind),
                m.freq_hz,
                m.tau_s,
                m.t60_s,
                m.q
            );
            for a in &m.amplitudes {
                let _ = write!(text, " {a:>14.4e}");
            }
            let _ = writeln!(text);
        }
        let _ = writeln!(text, "amplitudes: the envelope at step 0 at each output, for the initial conditions and impulses");
    }
    let _ = std::io::stdout().write_all(text.as_bytes());
    if let Some(path) = plot {
        if let Err(e) = modes_plot(&model, &ma, spec, path) {
            eprintln!("cordis: {e:#}");
            return exit::OUTPUT;
        }
        eprintln!("cordis: wrote {}", path.display());
    }
    if !cordis_analysis::radius_is_stable(ma.max_radius) {
        exit::UNSTABLE
    } else {
        exit::OK
    }
}

/// The predicted modes over the spectrum of a short render (output channel 0).
fn modes_plot(model: &Model, ma: &Found, spec: &crate::SpecArgs, path: &Path) -> Result<()> {
    anyhow::ensure!(
        !model.network.outputs.is_empty(),
        "the plot shows the spectrum of output 0, and the model has no outputs"
    );
    let frames = (model.rate * 2.0) as usize;
    let mut e = model.compile();
    let ch = e.channels();
    let mut out = vec![0.0; frames * ch];
    if let Err(b) = e.process(frames, &mut out) {
        anyhow::bail!("the render for the plot blew up at sample {}", b.step);
    }
    let x: Vec<f64> = out.iter().step_by(ch).copied().collect();
    let spectrum = cordis_plot::spectrum(&x, model.rate, spec.window.max(4096))
        .context("cannot compute the spectrum")?;
    let marks: Vec<cordis_plot::ModeMark> = ma
        .modes
        .iter()
        .filter(|m| m.kind == ModeKind::Oscillating)
        .map(|m| cordis_plot::ModeMark {
            freq_hz: m.freq_hz,
            t60_s: m.t60_s,
            label: None,
        })
        .collect();
    let opts = cordis_plot::ModesPlotOptions {
        min_freq: spec.min_freq,
        max_freq: spec.max_freq,
        log_freq: spec.log_freq,
        db_range: spec.db_range,
        width: spec.size.0,
        height: spec.size.1.max(500),
        title: Some(format!(
            "{}: predicted modes over the spectrum of output {} (2 s)",
            model.path.display(),
            model.outputs[0].name
        )),
    };
    cordis_plot::modes_png(&spectrum, &marks, &opts, path)
        .with_context(|| format!("cannot draw {}", path.display()))
}

/// `cordis matrices`.
pub fn matrices(args: &ModelArgs, out: Option<&PathBuf>, csv_dir: Option<&PathBuf>) -> u8 {
    let (model, sys) = match load_linear(args) {
        Ok(x) => x,
        Err(c) => return c,
    };
    let mx = sys.matrices();
    let (mdense, k, r, a0, am1, ad, bd, cd, dd) = (
        &mx.m, &mx.k, &mx.r, &mx.a0, &mx.am1, &mx.ad, &mx.bd, &mx.cd, &mx.dd,
    );
    let rows = cordis_analysis::rows;
    let outs: Vec<String> = sys.outputs.iter().map(|(n, _)| n.clone()).collect();
    let result = if let Some(dir) = csv_dir {
        (|| -> Result<()> {
            std::fs::create_dir_all(dir)
                .with_context(|| format!("cannot create {}", dir.display()))?;
            let csv = |m: &cordis_analysis::faer::Mat<f64>| {
                let mut s = String::new();
                for i in 0..m.nrows() {
                    let row: Vec<String> = (0..m.ncols())
                        .map(|j| format!("{:.17e}", m[(i, j)]))
                        .collect();
                    let _ = writeln!(s, "{}", row.join(","));
                }
                s
            };
            for (name, m) in [
                ("M", mdense),
                ("K", k),
                ("R", r),
                ("A1", &mx.a1),
                ("A0", a0),
                ("Am1", am1),
                ("Ad", ad),
                ("Bd", bd),
                ("Cd", cd),
                ("Dd", dd),
            ] {
                write_file(&dir.join(format!("{name}.csv")), &csv(m))?;
            }
            write_file(
                &dir.join("b.csv"),
                &sys.b
                    .iter()
                    .map(|v| format!("{v:.17e}\n"))
                    .collect::<String>(),
            )?;
            write_file(
                &dir.join("order.csv"),
                &sys.names
                    .iter()
                    .map(|n| format!("{n}\n"))
                    .collect::<String>(),
            )?;
            write_file(
                &dir.join("outputs.csv"),
                &outs.iter().map(|n| format!("{n}\n")).collect::<String>(),
            )?;
            write_file(&dir.join("README.txt"), &readme_text(&model, &sys))?;
            Ok(())
        })()
    } else {
        let doc = json!({
            "model": model.path.display().to_string(),
            "rate_hz": model.rate,
            "units": "GENESIS: K = k/Fs^2, Z = z/Fs; positions in model units; time in samples",
            "order": sys.names,
            "outputs": outs,
            "M": rows(mdense), "K": rows(k), "R": rows(r),
            "finite_difference": {
                "equation": "A1 x(n+1) + A0 x(n) + Am1 x(n-1) = F(n) + b, with A1 = M, A0 = K + R - 2M, Am1 = M - R",
                "A1": rows(&mx.a1), "A0": rows(a0), "Am1": rows(am1), "b": sys.b,
            },
            "state_space": {
                "state": "s(n) = [x(n); x(n-1)]; s(n+1) = Ad s(n) + Bd F(n); y(n) = Cd s(n) + Dd F(n)",
                "inputs": "the force on every mobile module, in `order`",
                "Ad": rows(ad), "Bd": rows(bd), "Cd": rows(cd), "Dd": rows(dd),
            },
            "linearised": sys.notes,
        });
        return write_or_print(
            out,
            &(serde_json::to_string(&doc).unwrap_or_default() + "\n"),
        );
    };
    match result {
        Ok(()) => exit::OK,
        Err(e) => {
            eprintln!("cordis: {e:#}");
            exit::OUTPUT
        }
    }
}

fn readme_text(model: &Model, sys: &LinearSystem) -> String {
    let mut s = format!(
        "Matrices of {} at {} Hz, GENESIS units (K = k/Fs^2, Z = z/Fs).\n\
         Rows and columns follow order.csv (the mobile modules); outputs.csv names the rows of Cd.\n\
         Finite differences: A1 x(n+1) + A0 x(n) + Am1 x(n-1) = F(n) + b (A1 = M, A0 = K + R - 2M, Am1 = M - R).\n\
         State space: s(n) = [x(n); x(n-1)], s(n+1) = Ad s(n) + Bd F(n), y(n) = Cd s(n) + Dd F(n).\n\
         Python: numpy.loadtxt('K.csv', delimiter=','); Matlab: readmatrix('K.csv').\n",
        model.path.display(),
        model.rate
    );
    for n in &sys.notes {
        let _ = writeln!(s, "linearised: {n}");
    }
    s
}

/// Above this many mobile modules, responses are solved sparse, frequency by frequency.
const SPARSE_RESPONSE_FROM: usize = 1500;

/// Options of `cordis response`.
pub struct ResponseArgs<'a> {
    /// Where the force is applied.
    pub force_at: &'a str,
    /// Where the position is read.
    pub listen_at: &'a str,
    /// Lowest frequency, Hz.
    pub from_hz: f64,
    /// Highest frequency, Hz (default: 0.99 Nyquist).
    pub to_hz: Option<f64>,
    /// Number of points (log-spaced).
    pub points: usize,
    /// CSV output.
    pub output: Option<&'a PathBuf>,
    /// Bode plot.
    pub plot: Option<&'a PathBuf>,
}

/// `cordis response`.
pub fn response(args: &ModelArgs, r: &ResponseArgs<'_>) -> u8 {
    let (model, sys) = match load_linear(args) {
        Ok(x) => x,
        Err(c) => return c,
    };
    let (a, b) = match (
        dof_named(&model, &sys, r.force_at, "--force-at"),
        dof_named(&model, &sys, r.listen_at, "--listen-at"),
    ) {
        (Ok(a), Ok(b)) => (a, b),
        (Err(c), _) | (_, Err(c)) => return c,
    };
    let fs = model.rate;
    let to = r.to_hz.unwrap_or(0.99 * fs / 2.0);
    if !(r.from_hz > 0.0 && to > r.from_hz && to < fs / 2.0 && r.points >= 2) {
        eprintln!("cordis: the frequency grid must satisfy 0 < --from < --to < Nyquist ({} Hz) with --points >= 2", fs / 2.0);
        return exit::USAGE;
    }
    for n in &sys.notes {
        eprintln!("cordis: linearised: {n}");
    }
    let freqs: Vec<f64> = (0..r.points)
        .map(|i| r.from_hz * (to / r.from_hz).powf(i as f64 / (r.points - 1) as f64))
        .collect();
    // Small models: from the modal decomposition. Large ones: a sparse solve per frequency.
    let (hab, haa) = if sys.len() <= SPARSE_RESPONSE_FROM {
        let ma = match analyse(&sys) {
            Ok(m) => m,
            Err(c) => return c,
        };
        let at = |x: usize| {
            freqs
                .iter()
                .map(|&f| ma.receptance(a, x, f, fs))
                .collect::<Vec<_>>()
        };
        (at(b), at(a))
    } else {
        match (
            cordis_analysis::receptance_sparse(&sys, a, b, &freqs),
            cordis_analysis::receptance_sparse(&sys, a, a, &freqs),
        ) {
            (Ok(x), Ok(y)) => (x, y),
            (Err(e), _) | (_, Err(e)) => {
                eprintln!("cordis: {e}");
                return exit::INVALID;
            }
        }
    };
    let mut csv = String::from("freq_hz,receptance_mag,receptance_phase_rad,mobility_mag,mobility_phase_rad,transfer_mag,transfer_phase_rad,driving_point_mobility_mag,driving_point_mobility_phase_rad\n");
    let mut series = vec![
        ("receptance X_B/F_A".to_string(), Vec::new()),
        ("mobility V_B/F_A".to_string(), Vec::new()),
        ("transfer X_B/X_A".to_string(), Vec::new()),
    ];
    for (i, &f) in freqs.iter().enumerate() {
        let (h, haa) = (hab[i], haa[i]);
        let w = std::f64::consts::TAU * f / fs;
        // velocity per sample: (1 - z^-1) X
        let d = cordis_analysis::faer::c64::new(1.0 - w.cos(), w.sin());
        let (mob, dp, tr) = (h * d, haa * d, h / haa);
        let _ = writeln!(
            csv,
            "{f},{:.17e},{:.17e},{:.17e},{:.17e},{:.17e},{:.17e},{:.17e},{:.17e}",
            h.norm(),
            h.arg(),
            mob.norm(),
            mob.arg(),
            tr.norm(),
            tr.arg(),
            dp.norm(),
            dp.arg()
        );
        series[0].1.push((h.norm(), h.arg()));
        series[1].1.push((mob.norm(), mob.arg()));
        series[2].1.push((tr.norm(), tr.arg()));
    }
    let written = write_or_print(r.output, &csv);
    if written != exit::OK {
        return written;
    }
    if let Some(path) = r.plot {
        let curve = cordis_plot::ResponseCurve {
            freqs_hz: freqs.clone(),
            series,
        };
        let opts = cordis_plot::ResponsePlotOptions {
            title: Some(format!(
                "{}: force at {}, listen at {}",
                model.path.display(),
                r.force_at,
                r.listen_at
            )),
            ..Default::default()
        };
        if let Err(e) = cordis_plot::response_png(&curve, &opts, path) {
            eprintln!("cordis: cannot draw {}: {e}", path.display());
            return exit::OUTPUT;
        }
        eprintln!("cordis: wrote {}", path.display());
    }
    exit::OK
}

fn write_or_print(out: Option<&PathBuf>, text: &str) -> u8 {
    let result = match out {
        Some(p) => write_file(p, text),
        None => {
            let _ = std::io::stdout().write_all(text.as_bytes());
            Ok(())
        }
    };
    match result {
        Ok(()) => exit::OK,
        Err(e) => {
            eprintln!("cordis: {e:#}");
            exit::OUTPUT
        }
    }
}

/// `cordis graph`.
pub fn graph(args: &ModelArgs, out: Option<&PathBuf>) -> u8 {
    match load(args) {
        Ok(model) => write_or_print(out, &cordis_analysis::graph_dot(&model)),
        Err(c) => c,
    }
}

/// `cordis export spice`.
pub fn spice(args: &ModelArgs, force_at: Option<&str>, out: Option<&PathBuf>) -> u8 {
    let (model, sys) = match load_linear(args) {
        Ok(x) => x,
        Err(c) => return c,
    };
    let a = match force_at.map(|name| dof_named(&model, &sys, name, "--force-at")) {
        None => 0,
        Some(Ok(d)) => d,
        Some(Err(c)) => return c,
    };
    let title = format!("cordis mobility analogue of {}", model.path.display());
    match cordis_analysis::spice_netlist(
        &sys,
        &model,
        &cordis_analysis::SpiceOptions::new(a, model.rate, &title),
    ) {
        Ok(text) => write_or_print(out, &text),
        Err(e) => {
            eprintln!("cordis: {e}");
            exit::INVALID
        }
    }
}
