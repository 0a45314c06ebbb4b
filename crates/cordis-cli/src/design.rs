//! `cordis design`: from target frequencies, amplitudes and decay times (or a recording) to a
//! `.cordis` model, with a report that re-analyses the model as written.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use anyhow::{Context, Result};
use cordis_analysis::{LinearSystem, ModalAnalysis, ModeKind};
use cordis_design::cell::{design_cell, Cell, CellScale, CellTarget};
use cordis_design::chain::{design_chain, ChainSpec, Damping, Ends, Hammer};
use cordis_design::DesignError;
use cordis_model::{Model, Options};

use crate::exit;
use crate::output::Pending;

/// A number with an optional unit suffix among `units` (longest first); a bare number has scale 1.
fn with_unit(s: &str, units: &[(&str, f64)], what: &str, examples: &str) -> Result<f64, String> {
    let t = s.trim();
    let (num, scale) = units
        .iter()
        .find_map(|&(u, k)| t.strip_suffix(u).map(|n| (n, k)))
        .unwrap_or((t, 1.0));
    match num.trim().parse::<f64>() {
        Ok(v) if v.is_finite() => Ok(v * scale),
        _ => Err(format!(
            "`{s}` is not {what} (write for example {examples})"
        )),
    }
}

/// A frequency on the command line: `440`, `440Hz` or `0.44kHz` (a bare number is Hz).
pub fn parse_hz(s: &str) -> Result<f64, String> {
    with_unit(
        s,
        &[("kHz", 1000.0), ("Hz", 1.0)],
        "a frequency",
        "440, 440Hz or 0.44kHz",
    )
}

/// A time on the command line: `1.5`, `1.5s` or `1500ms` (a bare number is seconds).
pub fn parse_seconds(s: &str) -> Result<f64, String> {
    with_unit(
        s,
        &[("ms", 1e-3), ("s", 1.0)],
        "a time",
        "1.5, 1.5s or 1500ms",
    )
}

/// A plain number on the command line.
pub fn parse_number(s: &str) -> Result<f64, String> {
    match s.trim().parse::<f64>() {
        Ok(v) if v.is_finite() => Ok(v),
        _ => Err(format!("`{s}` is not a number")),
    }
}

/// A list: values separated by commas or spaces, or `@FILE` to read them from a file (commas,
/// spaces or new lines; `#` starts a comment).
pub fn parse_list(s: &str, one: fn(&str) -> Result<f64, String>) -> Result<Vec<f64>, String> {
    let text = match s.strip_prefix('@') {
        Some(file) => {
            std::fs::read_to_string(file).map_err(|e| format!("cannot read {file}: {e}"))?
        }
        None => s.to_string(),
    };
    let mut out = Vec::new();
    for line in text.lines() {
        let line = line.split('#').next().unwrap_or("");
        for item in line
            .split([',', ' ', '\t', ';'])
            .filter(|x| !x.trim().is_empty())
        {
            out.push(one(item)?);
        }
    }
    if out.is_empty() {
        return Err(format!("`{s}` holds no values"));
    }
    Ok(out)
}

/// The command as the user typed it, for the header of a generated model.
fn command_line() -> String {
    std::iter::once("cordis".to_string())
        .chain(std::env::args().skip(1))
        .map(|a| {
            if a.contains([' ', '*', '(', ')', '\'']) {
                format!("'{a}'")
            } else {
                a
            }
        })
        .collect::<Vec<_>>()
        .join(" ")
}

fn design_error(e: &DesignError) -> u8 {
    match e {
        DesignError::Invalid { message, hint } => {
            eprintln!("cordis: {message}\n  hint: {hint}");
            exit::INVALID
        }
        DesignError::Numerical(m) => {
            eprintln!("cordis: the design failed: {m}");
            exit::INVALID
        }
        DesignError::Model(m) => {
            eprintln!("{m}");
            exit::INVALID
        }
    }
}

/// Writes `text` to `path` (through a temporary file), or to standard output when `path` is
/// `None`.
fn write_model(path: Option<&PathBuf>, text: &str) -> Result<()> {
    match path {
        Some(p) => {
            let pending = Pending::new(p);
            std::fs::write(pending.path(), text)
                .with_context(|| format!("cannot write {}", p.display()))?;
            pending.commit()
        }
        None => {
            use std::io::Write as _;
            let mut out = std::io::stdout().lock();
            out.write_all(text.as_bytes())
                .and_then(|_| out.flush())
                .context("cannot write the model to standard output")
        }
    }
}

/// Writes the model (to `output`, or standard output), then prints the report with the file named.
fn deliver(output: Option<&PathBuf>, text: &str, mut rep: String) -> u8 {
    if let Err(e) = write_model(output, text) {
        eprintln!("cordis: {e:#}");
        return exit::OUTPUT;
    }
    if let Some(p) = output {
        let _ = writeln!(rep, "wrote {}", p.display());
    }
    say(output.is_some(), &rep);
    exit::OK
}

/// Prints the report: on standard output when the model went to a file, else on standard error.
fn say(to_file: bool, text: &str) {
    if to_file {
        print!("{text}");
    } else {
        eprint!("{text}");
    }
}

/// Loads a generated model text (it must load: a failure is a bug, reported as such).
fn reload(name: &str, text: &str) -> Result<Model, u8> {
    cordis_model::load_str(Path::new(name), text, &Options::default()).map_err(|e| {
        crate::report::emit_load_error(&e);
        eprintln!("cordis: the generated model does not load: this is a bug, please report it");
        exit::INVALID
    })
}

/// `cordis design cell`.
pub struct CellRequest<'a> {
    pub freq_hz: f64,
    pub decay_s: Option<f64>,
    pub amp: f64,
    pub phase_rad: f64,
    pub mass: Option<f64>,
    pub stiffness: Option<f64>,
    pub rate: f64,
    pub duration_s: Option<f64>,
    pub output: Option<&'a PathBuf>,
}

pub fn cell(r: &CellRequest<'_>) -> u8 {
    let target = CellTarget {
        freq_hz: r.freq_hz,
        decay_s: r.decay_s,
        amp: r.amp,
        phase_rad: r.phase_rad,
        rate: r.rate,
    };
    let scale = match (r.mass, r.stiffness) {
        (_, Some(k)) => CellScale::Stiffness(k),
        (Some(m), None) => CellScale::Mass(m),
        (None, None) => CellScale::Mass(1.0),
    };
    let c: Cell = match design_cell(&target, scale) {
        Ok(c) => c,
        Err(e) => return design_error(&e),
    };
    let duration = r.duration_s.unwrap_or_else(|| default_duration(r.decay_s));
    let header = format!(
        "A damped oscillator designed by cordis: {} Hz, decay {} (to 1/e), amplitude {}, phase {} rad.\nCommand: {}",
        r.freq_hz,
        r.decay_s.map_or("none (undamped)".into(), |t| format!("{t} s")),
        r.amp,
        r.phase_rad,
        command_line()
    );
    let text = c.to_cordis(&header, r.rate, duration);
    let model = match reload("cell.cordis", &text) {
        Ok(m) => m,
        Err(code) => return code,
    };
    let mut rep = String::new();
    let _ = writeln!(
        rep,
        "cell at {} Hz: M = {:.17e}  K = {:.17e}  Z = {:.17e}",
        r.rate, c.m, c.k, c.z
    );
    let _ = writeln!(
        rep,
        "  pole radius r = {:.17}  angle = {:.17} rad;  X0 = {:.6e}  V0 = {:.6e}",
        c.radius, c.theta, c.x0, c.v0
    );
    if let Ok(sys) = LinearSystem::from_model(&model) {
        if let Ok(ma) = ModalAnalysis::compute(&sys) {
            if let Some(md) = ma.modes.iter().find(|m| m.kind == ModeKind::Oscillating) {
                let _ = writeln!(
                    rep,
                    "  as written, re-analysed: {:.12} Hz (error {:.1e} Hz), tau {} s",
                    md.freq_hz,
                    (md.freq_hz - r.freq_hz).abs(),
                    md.tau_s
                );
            }
        }
    }
    deliver(r.output, &text, rep)
}

/// Render length for a design: 5 decay times (at least 1 s, at most 20 s), 2 s when undamped.
fn default_duration(decay_s: Option<f64>) -> f64 {
    decay_s.map_or(2.0, |t| (5.0 * t).clamp(1.0, 20.0))
}

/// `cordis design chain` (and the chain step of `from-audio`).
pub struct ChainRequest<'a> {
    pub freqs_hz: Vec<f64>,
    pub amps: Option<Vec<f64>>,
    pub decay_s: Option<f64>,
    pub damping: Damping,
    pub ends: Ends,
    pub first_mass: f64,
    pub end_ratio: f64,
    pub rigid_weight: Option<f64>,
    pub rate: f64,
    pub duration_s: Option<f64>,
    pub output: Option<&'a PathBuf>,
    /// A line describing where the targets came from, for the header.
    pub origin: String,
}

/// The designed chain, its model text and the re-analysis of that text.
pub struct Designed {
    pub text: String,
    pub model: Model,
    pub report: String,
    pub max_error_hz: f64,
}

fn list_text(v: &[f64]) -> String {
    v.iter()
        .map(|x| format!("{x}"))
        .collect::<Vec<_>>()
        .join(",")
}

/// Designs, writes the text (not the file) and re-analyses it.
pub fn design_chain_model(r: &ChainRequest<'_>) -> Result<Designed, u8> {
    let mut spec = ChainSpec::new(r.freqs_hz.clone(), r.ends, r.rate);
    spec.amps = r.amps.clone();
    spec.decay_s = r.decay_s;
    spec.damping = r.damping;
    spec.first_mass = r.first_mass;
    spec.end_ratio = r.end_ratio;
    spec.rigid_weight = r.rigid_weight;
    let chain = design_chain(&spec).map_err(|e| design_error(&e))?;
    let hammer = Hammer::for_chain(&chain);
    let duration = r.duration_s.unwrap_or_else(|| default_duration(r.decay_s));
    let mut header = format!(
        "A chain of {} masses designed by cordis ({} ends) from {} target frequencies.\n{}\nTargets (Hz): {}\n",
        chain.masses.len(),
        r.ends,
        r.freqs_hz.len(),
        r.origin,
        list_text(&r.freqs_hz),
    );
    if let Some(a) = &r.amps {
        let _ = writeln!(header, "Amplitudes at m1 (impulse at m1): {}", list_text(a));
    }
    if let Some(t) = r.decay_s {
        let how = match r.damping {
            Damping::Springs => "dampers proportional to the springs (higher modes decay faster)",
            Damping::Ground => {
                "dampers to the ground proportional to the masses (every mode decays alike)"
            }
        };
        let _ = writeln!(header, "Fundamental decay time: {t} s, {how}");
    }
    let _ = write!(header, "Command: {}", command_line());
    let text = chain.to_cordis(&header, &hammer, r.rate, duration);
    let model = reload("chain.cordis", &text)?;
    let sys = LinearSystem::from_model(&model).map_err(|e| {
        eprintln!("cordis: {e}");
        exit::INVALID
    })?;
    if sys.len() > 300 {
        eprintln!(
            "cordis: re-analysing the {} masses as written...",
            sys.len()
        );
    }
    let ma = ModalAnalysis::compute(&sys).map_err(|e| {
        eprintln!("cordis: {e}");
        exit::INVALID
    })?;
    let found: Vec<&cordis_analysis::Mode> = ma
        .modes
        .iter()
        .filter(|m| m.kind == ModeKind::Oscillating)
        .collect();
    let mut rep = String::new();
    let _ = writeln!(
        rep,
        "chain of {} masses, {} ends, {} Hz; the model as written, re-analysed ({} modes):",
        chain.masses.len(),
        r.ends,
        r.rate,
        found.len()
    );
    let mut sorted = r.freqs_hz.clone();
    sorted.sort_by(f64::total_cmp);
    let mut max_err = 0.0f64;
    if found.len() != sorted.len() {
        let _ = writeln!(
            rep,
            "  the model has {} oscillating modes for {} targets",
            found.len(),
            sorted.len()
        );
        max_err = f64::INFINITY;
    }
    let damped = r.decay_s.is_some();
    let _ = writeln!(
        rep,
        "  {:>4}  {:>14}  {:>20}  {:>10}{}",
        "mode",
        "target (Hz)",
        "model (Hz)",
        "error (Hz)",
        if damped { "     tau (s)" } else { "" }
    );
    let many = sorted.len() > 40;
    for (i, (t, m)) in sorted.iter().zip(&found).enumerate() {
        let err = (m.freq_hz - t).abs();
        max_err = max_err.max(err);
        if many && i >= 20 && i + 10 < sorted.len() {
            if i == 20 {
                let _ = writeln!(rep, "  ...");
            }
            continue;
        }
        let _ = write!(
            rep,
            "  {:>4}  {t:>14.6}  {:>20.12}  {err:>10.1e}",
            i + 1,
            m.freq_hz
        );
        if damped {
            let _ = write!(rep, "  {:>10.6}", m.tau_s);
        }
        let _ = writeln!(rep);
    }
    let _ = writeln!(rep, "  largest frequency error: {max_err:.2e} Hz");
    let _ = writeln!(
        rep,
        "  mass spread (max/min) {:.3e}, stiffness spread {:.3e}",
        chain.mass_spread(),
        chain.stiffness_spread()
    );
    for w in chain.warnings() {
        let _ = writeln!(rep, "  warning: {w}");
    }
    Ok(Designed {
        text,
        model,
        report: rep,
        max_error_hz: max_err,
    })
}

pub fn chain(r: &ChainRequest<'_>) -> u8 {
    let d = match design_chain_model(r) {
        Ok(d) => d,
        Err(code) => return code,
    };
    let mut rep = d.report;
    if d.max_error_hz > 1e-6 {
        let _ = writeln!(
            rep,
            "warning: the model as written misses a target by {:.2e} Hz\n  hint: the targets may be too close together or the spreads too wide for double precision",
            d.max_error_hz
        );
    }
    deliver(r.output, &d.text, rep)
}

/// `cordis design fit`.
pub struct FitRequest<'a> {
    pub model: &'a Path,
    pub freqs_hz: Vec<f64>,
    pub free: Vec<String>,
    pub steps: usize,
    pub max_iterations: usize,
    pub tolerance_hz: f64,
    pub output: Option<&'a PathBuf>,
}

pub fn fit(r: &FitRequest<'_>) -> u8 {
    let text = match std::fs::read_to_string(r.model) {
        Ok(t) => t,
        Err(e) => {
            eprintln!("cordis: cannot read {}: {e}", r.model.display());
            return exit::INVALID;
        }
    };
    let spec = cordis_design::fit::FitSpec {
        path: r.model.to_path_buf(),
        text,
        free: r.free.clone(),
        targets_hz: r.freqs_hz.clone(),
        steps: r.steps,
        max_iterations: r.max_iterations,
        tolerance_hz: r.tolerance_hz,
    };
    let started = std::time::Instant::now();
    let res = match cordis_design::fit::fit(&spec) {
        Ok(x) => x,
        Err(e) => return design_error(&e),
    };
    let secs = started.elapsed().as_secs_f64();
    let mut rep = String::new();
    let _ = writeln!(
        rep,
        "fit of {} to {} target frequencies over {} free values: {} ({} iterations, {} evaluations, {secs:.2} s)",
        r.model.display(),
        r.freqs_hz.len(),
        res.values.len(),
        if res.converged { "converged" } else { "NOT converged" },
        res.iterations,
        res.evaluations
    );
    let _ = writeln!(rep, "  {:<16} {:>22} {:>22}", "value", "start", "fitted");
    for ((name, v), (_, v0)) in res.values.iter().zip(&res.start_values) {
        let _ = writeln!(rep, "  {name:<16} {v0:>22.15e} {v:>22.15e}");
    }
    let mut sorted = r.freqs_hz.clone();
    sorted.sort_by(f64::total_cmp);
    let _ = writeln!(
        rep,
        "  {:>4}  {:>14}  {:>20}  {:>10}",
        "mode", "target (Hz)", "model (Hz)", "error (Hz)"
    );
    for (i, (t, a)) in sorted.iter().zip(&res.achieved_hz).enumerate() {
        let _ = writeln!(
            rep,
            "  {:>4}  {t:>14.6}  {a:>20.12}  {:>10.1e}",
            i + 1,
            (a - t).abs()
        );
    }
    let _ = writeln!(
        rep,
        "  largest frequency error: {:.2e} Hz (tolerance {:.1e} Hz)",
        res.max_error_hz, r.tolerance_hz
    );
    if !res.converged {
        let _ = writeln!(
            rep,
            "the tuned model was not written: the targets were not reached\n  hint: free more values, use more --steps, or check that the targets suit the topology"
        );
        eprint!("{rep}");
        return exit::UNSTABLE;
    }
    deliver(r.output, &res.text, rep)
}

/// `cordis design from-audio`.
pub struct AudioRequest<'a> {
    pub input: &'a Path,
    pub channel: usize,
    pub modes: usize,
    pub min_freq_hz: Option<f64>,
    pub max_freq_hz: Option<f64>,
    pub start_s: f64,
    pub ends: Ends,
    pub damping: Damping,
    pub output: &'a PathBuf,
    pub render: Option<&'a PathBuf>,
    pub plot: Option<&'a PathBuf>,
}

pub fn from_audio(r: &AudioRequest<'_>) -> u8 {
    let (samples, rate) = match crate::pictures::read_wav_channel(r.input, r.channel) {
        Ok(x) => x,
        Err(e) => {
            eprintln!("cordis: {e:#}");
            return exit::INVALID;
        }
    };
    let mut opts = cordis_design::audio::AudioOptions::new(r.modes);
    if let Some(f) = r.min_freq_hz {
        opts.min_freq_hz = f;
    }
    if let Some(f) = r.max_freq_hz {
        opts.max_freq_hz = f;
    }
    opts.start_s = r.start_s;
    let est = match cordis_design::audio::estimate_modes(&samples, rate, &opts) {
        Ok(m) => m,
        Err(e) => return design_error(&e),
    };
    let mut rep = String::new();
    let _ = writeln!(
        rep,
        "{}: {} modes estimated ({} s at {rate} Hz)",
        r.input.display(),
        est.len(),
        samples.len() as f64 / rate
    );
    let _ = writeln!(
        rep,
        "  {:>4}  {:>14}  {:>12}  {:>10}",
        "mode", "freq (Hz)", "amplitude", "tau (s)"
    );
    for (i, m) in est.iter().enumerate() {
        let _ = writeln!(
            rep,
            "  {:>4}  {:>14.4}  {:>12.4e}  {:>10.4}",
            i + 1,
            m.freq_hz,
            m.amp,
            m.decay_s
        );
    }
    // the chain: frequencies, amplitudes, and the fundamental's decay
    let freqs: Vec<f64> = est.iter().map(|m| m.freq_hz).collect();
    let amps: Vec<f64> = est.iter().map(|m| m.amp).collect();
    let decay = est
        .first()
        .map(|m| m.decay_s)
        .filter(|t| t.is_finite() && *t > 0.0);
    let req = ChainRequest {
        freqs_hz: freqs,
        amps: Some(amps),
        decay_s: decay,
        damping: r.damping,
        ends: r.ends,
        first_mass: 1.0,
        end_ratio: 1.0,
        rigid_weight: None,
        rate,
        duration_s: Some(samples.len() as f64 / rate),
        output: Some(r.output),
        origin: format!("Modes estimated from {}.", r.input.display()),
    };
    let d = match design_chain_model(&req) {
        Ok(d) => d,
        Err(code) => return code,
    };
    rep.push_str(&d.report);
    if let Err(e) = write_model(Some(r.output), &d.text) {
        eprintln!("cordis: {e:#}");
        return exit::OUTPUT;
    }
    let _ = writeln!(rep, "wrote {}", r.output.display());
    // render the model, for listening and for the comparison
    let frames = d.model.duration as usize;
    let mut engine = d.model.compile();
    let channels = d.model.network.outputs.len().max(1);
    let mut data = vec![0.0; frames * channels];
    if let Err(b) = engine.process(frames, &mut data) {
        eprint!("{rep}");
        eprintln!(
            "cordis: the designed model blew up at step {} ({}): this is a bug, please report it",
            b.step,
            d.model
                .materials
                .get(b.material.0 as usize)
                .map_or("?", |m| m.name.as_str())
        );
        return exit::UNSTABLE;
    }
    let rendered: Vec<f64> = data.iter().step_by(channels).copied().collect();
    let wav = r
        .render
        .cloned()
        .unwrap_or_else(|| r.output.with_extension("wav"));
    let peak = rendered.iter().fold(0.0f64, |a, x| a.max(x.abs()));
    let scaled: Vec<f64> = rendered
        .iter()
        .map(|x| if peak > 0.0 { x / peak } else { 0.0 })
        .collect();
    let pending = Pending::new(&wav);
    let written = crate::output::write_wav(
        pending.path(),
        &scaled,
        1,
        rate as u32,
        crate::output::SampleFormat::F32,
    )
    .and_then(|_| pending.commit());
    if let Err(e) = written {
        eprintln!("cordis: {e:#}");
        return exit::OUTPUT;
    }
    let _ = writeln!(
        rep,
        "wrote {} (the model's render, normalised)",
        wav.display()
    );
    if let Some(plot) = r.plot {
        if let Err(e) = compare_plot(&samples, &rendered, rate, &est, &d, plot) {
            eprintln!("cordis: {e:#}");
            return exit::OUTPUT;
        }
        let _ = writeln!(rep, "wrote {}", plot.display());
    }
    print!("{rep}");
    exit::OK
}

fn compare_plot(
    recording: &[f64],
    model: &[f64],
    rate: f64,
    est: &[cordis_design::audio::EstimatedMode],
    d: &Designed,
    path: &Path,
) -> Result<()> {
    use cordis_plot::{ComparePanel, ModeMark, ModesPlotOptions};
    let window = 1usize << 15;
    let a = cordis_plot::spectrum(recording, rate, window).context("spectrum of the recording")?;
    let b = cordis_plot::spectrum(model, rate, window).context("spectrum of the model")?;
    let t60 = |tau: f64| {
        if tau.is_finite() {
            tau * 6.907_755_278_982_137
        } else {
            f64::INFINITY
        }
    };
    let marks_a: Vec<ModeMark> = est
        .iter()
        .map(|m| ModeMark {
            freq_hz: m.freq_hz,
            t60_s: t60(m.decay_s),
            label: None,
        })
        .collect();
    let sys = LinearSystem::from_model(&d.model).context("linearising the model")?;
    let ma = ModalAnalysis::compute(&sys).context("modes of the model")?;
    let marks_b: Vec<ModeMark> = ma
        .modes
        .iter()
        .filter(|m| m.kind == ModeKind::Oscillating)
        .map(|m| ModeMark {
            freq_hz: m.freq_hz,
            t60_s: m.t60_s,
            label: None,
        })
        .collect();
    let top = est.iter().fold(0.0f64, |x, m| x.max(m.freq_hz));
    let opts = ModesPlotOptions {
        max_freq: Some((top * 1.3).min(rate / 2.0)),
        title: Some("the recording and the model designed from it".into()),
        ..Default::default()
    };
    cordis_plot::compare_png(
        &[
            ComparePanel {
                label: "recording",
                spectrum: &a,
                modes: &marks_a,
            },
            ComparePanel {
                label: "model",
                spectrum: &b,
                modes: &marks_b,
            },
        ],
        &opts,
        path,
    )
    .with_context(|| format!("cannot draw {}", path.display()))
}
