//! `cordis sweep`: render every variant of a grid of `let` values, in parallel.

use std::fmt::Write as _;
use std::io::IsTerminal;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::Mutex;

use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};

use crate::exit;
use crate::output::{self, Pending, SampleFormat};

/// One swept `let`: its name and the values it takes (expression texts, units kept).
#[derive(Clone, Debug, PartialEq)]
pub struct Axis {
    pub name: String,
    pub values: Vec<String>,
}

/// Splits `440Hz` into `(440, "Hz")`: the longest prefix that is a finite number, and the rest.
fn split_unit(s: &str) -> Option<(f64, &str)> {
    let s = s.trim();
    (1..=s.len())
        .rev()
        .filter(|&end| s.is_char_boundary(end))
        .find_map(|end| match s[..end].parse::<f64>() {
            Ok(v) if v.is_finite() => Some((v, &s[end..])),
            _ => None,
        })
}

/// `NAME=a..b:n` (n values from a to b), `NAME=a..b:n:log` (geometric), `NAME=v1,v2,...`, or
/// `NAME=v` (one value). Values may carry a unit (`440Hz..880Hz:5`), the same at both ends.
pub fn parse_axis(s: &str) -> Result<Axis, String> {
    let (name, spec) = s.split_once('=').ok_or_else(|| {
        format!("`{s}` is not NAME=a..b:n or NAME=v1,v2,... (for example k=0.1..0.5:5)")
    })?;
    let name = name.trim().to_string();
    if name.is_empty() || !name.chars().all(|c| c.is_alphanumeric() || c == '_') {
        return Err(format!("`{name}` is not a let name"));
    }
    let spec = spec.trim();
    if let Some((a, rest)) = spec.split_once("..") {
        let mut parts = rest.split(':');
        let b = parts.next().unwrap_or("");
        let n = parts
            .next()
            .ok_or_else(|| format!("`{spec}`: say how many values, e.g. {a}..{b}:5"))?;
        let log = match parts.next() {
            None => false,
            Some("log") => true,
            Some(o) => {
                return Err(format!(
                    "`{o}` after the count: only `log` is known (e.g. {a}..{b}:{n}:log)"
                ))
            }
        };
        let n: usize = n
            .trim()
            .parse()
            .ok()
            .filter(|&n| (1..=100_000).contains(&n))
            .ok_or_else(|| format!("`{n}` is not a count of values (1 to 100000)"))?;
        let (va, ua) = split_unit(a).ok_or_else(|| format!("`{a}` is not a number"))?;
        let (vb, ub) = split_unit(b).ok_or_else(|| format!("`{b}` is not a number"))?;
        if ua != ub {
            return Err(format!("`{a}` and `{b}` have different units"));
        }
        if log && (va <= 0.0 || vb <= 0.0) {
            return Err(format!("a :log range needs positive ends, not {a} and {b}"));
        }
        let values = (0..n)
            .map(|i| {
                let t = if n == 1 {
                    0.0
                } else {
                    i as f64 / (n - 1) as f64
                };
                let v = if log {
                    va * (vb / va).powf(t)
                } else {
                    va + (vb - va) * t
                };
                // the exact ends, not rounded interpolations
                let v = if i == 0 {
                    va
                } else if i + 1 == n {
                    vb
                } else {
                    v
                };
                format!("{v:e}{ua}")
            })
            .collect();
        return Ok(Axis { name, values });
    }
    let values: Vec<String> = spec
        .split(',')
        .map(|v| v.trim().to_string())
        .filter(|v| !v.is_empty())
        .collect();
    if values.is_empty() {
        return Err(format!("`{s}` gives no value"));
    }
    Ok(Axis { name, values })
}

/// What happened to one variant.
enum Outcome {
    Rendered { peak: f64, rms: f64, path: PathBuf },
    Invalid(String),
    BlewUp(String),
    OutputFailed(String),
}

pub struct SweepRequest<'a> {
    pub args: &'a crate::ModelArgs,
    pub axes: Vec<Axis>,
    pub dir: &'a Path,
    pub threads: Option<usize>,
    pub normalize: bool,
    pub sample_format: SampleFormat,
}

/// The grid's variants: every combination, the first axis varying slowest.
fn variants(axes: &[Axis]) -> Vec<Vec<(String, String)>> {
    let mut out: Vec<Vec<(String, String)>> = vec![Vec::new()];
    for a in axes {
        out = out
            .into_iter()
            .flat_map(|prefix| {
                a.values.iter().map(move |v| {
                    let mut p = prefix.clone();
                    p.push((a.name.clone(), v.clone()));
                    p
                })
            })
            .collect();
    }
    out
}

fn render_one(
    r: &SweepRequest<'_>,
    index: usize,
    digits: usize,
    sets: &[(String, String)],
) -> Outcome {
    let mut opts = r.args.options();
    opts.sets.extend(sets.iter().cloned());
    let model = match cordis_model::load_file(&r.args.model, &opts) {
        Ok(m) => m,
        Err(e) => {
            let first = e
                .errors()
                .next()
                .map(|d| d.to_string())
                .unwrap_or_else(|| "invalid".into());
            return Outcome::Invalid(first);
        }
    };
    let channels = model.network.outputs.len();
    if channels == 0 {
        return Outcome::Invalid("the model has no outputs (sox or sof)".into());
    }
    if model.rate.fract() != 0.0 {
        return Outcome::Invalid(format!(
            "a WAV file needs a whole rate, not {} Hz",
            model.rate
        ));
    }
    let frames = model.duration as usize;
    let mut data = vec![0.0; frames * channels];
    let mut engine = model.compile();
    if let Err(b) = engine.process(frames, &mut data) {
        let name = model
            .materials
            .get(b.material.0 as usize)
            .map_or("?", |m| m.name.as_str());
        return Outcome::BlewUp(format!("{name} became non-finite at sample {}", b.step));
    }
    let peak = data.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    // scaled by the peak, so that a loud (finite) render does not overflow
    let rms = if peak > 0.0 {
        peak * (data.iter().map(|v| (v / peak).powi(2)).sum::<f64>() / data.len().max(1) as f64)
            .sqrt()
    } else {
        0.0
    };
    if r.normalize && peak > 0.0 {
        data.iter_mut().for_each(|v| *v /= peak);
    } else if peak > 1.0 && r.sample_format != SampleFormat::F32 {
        return Outcome::OutputFailed(format!(
            "peak {peak:.4} would clip an integer WAV (use --normalize or --sample-format f32)"
        ));
    }
    let stem = r
        .args
        .model
        .file_stem()
        .map_or("variant".into(), |s| s.to_string_lossy().into_owned());
    let path = r.dir.join(format!("{stem}_{index:0digits$}.wav"));
    let pending = Pending::new(&path);
    let written = output::write_wav(
        pending.path(),
        &data,
        channels,
        model.rate as u32,
        r.sample_format,
    )
    .and_then(|()| pending.commit());
    match written {
        Ok(()) => Outcome::Rendered { peak, rms, path },
        Err(e) => Outcome::OutputFailed(format!("{e:#}")),
    }
}

pub fn sweep(r: &SweepRequest<'_>) -> u8 {
    if r.axes.is_empty() {
        eprintln!("cordis: sweep needs at least one --set NAME=a..b:n (or NAME=v1,v2,...)");
        return exit::USAGE;
    }
    // the model must load with its own values first: its errors are shown in full once
    if let Err(e) = cordis_model::load_file(&r.args.model, &r.args.options()) {
        crate::report::emit_load_error(&e);
        return exit::INVALID;
    }
    let grid = variants(&r.axes);
    if grid.len() > 100_000 {
        eprintln!(
            "cordis: the grid has {} variants; at most 100000",
            grid.len()
        );
        return exit::USAGE;
    }
    if let Err(e) = std::fs::create_dir_all(r.dir) {
        eprintln!("cordis: cannot create {}: {e}", r.dir.display());
        return exit::OUTPUT;
    }
    let digits = grid.len().saturating_sub(1).max(1).to_string().len();
    let threads = r
        .threads
        .unwrap_or_else(|| std::thread::available_parallelism().map_or(1, |n| n.get()))
        .clamp(1, grid.len());
    let bar = if std::io::stderr().is_terminal() {
        let b = ProgressBar::new(grid.len() as u64);
        b.set_style(
            ProgressStyle::with_template(
                "{spinner} sweeping [{bar:40}] {pos}/{len} variants, eta {eta}",
            )
            .unwrap_or_else(|_| ProgressStyle::default_bar())
            .progress_chars("=> "),
        );
        b.set_draw_target(ProgressDrawTarget::stderr());
        b
    } else {
        ProgressBar::hidden()
    };
    let next = AtomicUsize::new(0);
    let results: Mutex<Vec<Option<Outcome>>> = Mutex::new((0..grid.len()).map(|_| None).collect());
    let started = std::time::Instant::now();
    std::thread::scope(|s| {
        for _ in 0..threads {
            s.spawn(|| loop {
                let i = next.fetch_add(1, Ordering::Relaxed);
                let Some(sets) = grid.get(i) else { break };
                let outcome = render_one(r, i, digits, sets);
                if let Ok(mut v) = results.lock() {
                    v[i] = Some(outcome);
                }
                bar.inc(1);
            });
        }
    });
    bar.finish_and_clear();
    let secs = started.elapsed().as_secs_f64();
    let results = results.into_inner().unwrap_or_default();
    // the summary: a table on stdout and index.csv in the folder
    let mut table = String::new();
    let mut csv = String::from("index");
    for a in &r.axes {
        let _ = write!(csv, ",{}", a.name);
    }
    csv.push_str(",status,peak,rms,file,message\n");
    let (mut ok, mut invalid, mut blew, mut failed) = (0, 0, 0, 0);
    let _ = write!(table, "{:>w$}", "#", w = digits.max(1));
    for a in &r.axes {
        let _ = write!(table, "  {:>14}", a.name);
    }
    let _ = writeln!(
        table,
        "  {:>10}  {:>12}  {:>12}  file",
        "status", "peak", "rms"
    );
    for (i, (sets, res)) in grid.iter().zip(&results).enumerate() {
        let _ = write!(table, "{i:>w$}", w = digits.max(1));
        let _ = write!(csv, "{i}");
        for (_, v) in sets {
            let _ = write!(table, "  {v:>14}");
            let _ = write!(csv, ",{v}");
        }
        let (status, peak, rms, file, msg) = match res {
            Some(Outcome::Rendered { peak, rms, path }) => {
                ok += 1;
                (
                    "ok",
                    format!("{peak:.6e}"),
                    format!("{rms:.6e}"),
                    path.display().to_string(),
                    String::new(),
                )
            }
            Some(Outcome::Invalid(m)) => {
                invalid += 1;
                (
                    "invalid",
                    String::new(),
                    String::new(),
                    String::new(),
                    m.clone(),
                )
            }
            Some(Outcome::BlewUp(m)) => {
                blew += 1;
                (
                    "blew up",
                    String::new(),
                    String::new(),
                    String::new(),
                    m.clone(),
                )
            }
            Some(Outcome::OutputFailed(m)) => {
                failed += 1;
                (
                    "not written",
                    String::new(),
                    String::new(),
                    String::new(),
                    m.clone(),
                )
            }
            None => {
                failed += 1;
                (
                    "lost",
                    String::new(),
                    String::new(),
                    String::new(),
                    "a worker stopped".into(),
                )
            }
        };
        let _ = writeln!(
            table,
            "  {status:>10}  {peak:>12}  {rms:>12}  {file}{}",
            if msg.is_empty() {
                String::new()
            } else {
                format!(" {msg}")
            }
        );
        let quoted = msg.replace('"', "'");
        let _ = writeln!(csv, ",{status},{peak},{rms},{file},\"{quoted}\"");
    }
    print!("{table}");
    let index = r.dir.join("index.csv");
    let pending = Pending::new(&index);
    if let Err(e) = std::fs::write(pending.path(), csv)
        .map_err(anyhow::Error::from)
        .and_then(|()| pending.commit())
    {
        eprintln!("cordis: cannot write {}: {e:#}", index.display());
        return exit::OUTPUT;
    }
    eprintln!(
        "cordis: {} variants in {secs:.2} s on {threads} thread{}: {ok} rendered, {invalid} invalid, {blew} blew up, {failed} not written; summary in {}",
        grid.len(),
        if threads == 1 { "" } else { "s" },
        index.display()
    );
    if failed > 0 {
        exit::OUTPUT
    } else if blew > 0 {
        exit::UNSTABLE
    } else if invalid > 0 {
        exit::INVALID
    } else {
        exit::OK
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn axes_parse() {
        let a = parse_axis("k=0.1..0.5:5").unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(a.name, "k");
        assert_eq!(a.values.len(), 5);
        assert_eq!(a.values[0], "1e-1");
        assert_eq!(a.values[4], "5e-1");
        let f = parse_axis("f=110Hz..880Hz:4:log").unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(f.values[0], "1.1e2Hz");
        assert!(f.values[1].ends_with("Hz"));
        let l = parse_axis("s = 1, 2 ,3").unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(l.values, vec!["1", "2", "3"]);
        assert!(parse_axis("k=0.1..0.5").is_err());
        assert!(parse_axis("k=1Hz..2s:3").is_err());
        assert!(parse_axis("k=0..1:3:log").is_err());
        assert!(parse_axis("=1").is_err());
        assert!(parse_axis("k=1..2:0").is_err());
        let e = parse_axis("k=1e-3..2e-3:2").unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(e.values, vec!["1e-3", "2e-3"]);
    }

    #[test]
    fn the_grid_is_every_combination() {
        let g = variants(&[
            Axis {
                name: "a".into(),
                values: vec!["1".into(), "2".into()],
            },
            Axis {
                name: "b".into(),
                values: vec!["x".into(), "y".into(), "z".into()],
            },
        ]);
        assert_eq!(g.len(), 6);
        assert_eq!(
            g[1],
            vec![("a".into(), "1".into()), ("b".into(), "y".into())]
        );
    }
}
