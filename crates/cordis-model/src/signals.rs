//! Signals for ENF and ENX: inline generators and signal files (WAV, CSV).

use std::path::{Path, PathBuf};
use std::sync::Arc;

use cordis_core::{Curve, Signal};

use crate::error::{did_you_mean, Diagnostic, ErrorKind};
use crate::eval::{Env, Kind};
use crate::model::Limits;
use crate::syntax::{Arg, Expr, ExprKind};

const GENERATORS: &[&str] = &[
    "impulse", "step", "sine", "noise", "env", "file", "constant",
];

type R<T> = Result<T, Diagnostic>;

/// Binds the arguments of a call to parameter names (positional in order, or `key=value`).
fn bind<'e>(
    name: &str,
    args: &'e [Arg],
    spec: &[&str],
    span: crate::Span,
) -> R<Vec<Option<&'e Expr>>> {
    let mut out: Vec<Option<&Expr>> = vec![None; spec.len()];
    for (i, a) in args.iter().enumerate() {
        let slot = match &a.key {
            Some(k) => spec
                .iter()
                .position(|s| s.eq_ignore_ascii_case(&k.text))
                .ok_or_else(|| {
                    Diagnostic::error(
                        ErrorKind::UnknownParameter,
                        k.span,
                        format!("`{name}` has no argument `{}`", k.text),
                    )
                    .with_hint(
                        did_you_mean(&k.text, spec.iter().copied())
                            .unwrap_or_else(|| format!("`{name}` takes {}", spec.join(", "))),
                    )
                })?,
            None if i < spec.len() => i,
            None => {
                return Err(Diagnostic::error(
                    ErrorKind::Syntax,
                    a.value.span,
                    format!("`{name}` takes at most {} arguments", spec.len()),
                ))
            }
        };
        if out[slot].is_some() {
            return Err(Diagnostic::error(
                ErrorKind::ConflictingParameter,
                a.value.span,
                format!("`{}` is given twice", spec[slot]),
            ));
        }
        out[slot] = Some(&a.value);
    }
    let _ = span;
    Ok(out)
}

fn sample_index(env: &Env, e: Option<&Expr>) -> R<u64> {
    let Some(e) = e else { return Ok(0) };
    let v = env.number(e, Kind::Time, "at")?;
    if v < 0.0 {
        return Err(Diagnostic::error(
            ErrorKind::OutOfRange,
            e.span,
            "`at` must not be negative",
        ));
    }
    Ok(v.round() as u64)
}

fn opt(env: &Env, e: Option<&Expr>, kind: Kind, what: &str, default: f64) -> R<f64> {
    e.map_or(Ok(default), |e| env.number(e, kind, what))
}

/// Builds the signal an `enf` or `enx` statement asks for.
pub fn build(env: &Env, e: &Expr, model_path: &Path, limits: &Limits) -> R<Signal> {
    let (name, args) = match &e.kind {
        ExprKind::Call(w, args) => (w, args),
        _ => return Ok(Signal::Constant(env.number(e, Kind::Mixed, "signal")?)),
    };
    let lower = name.text.to_ascii_lowercase();
    let s = match lower.as_str() {
        "impulse" | "step" => {
            let a = bind(&lower, args, &["at", "amp"], e.span)?;
            let at = sample_index(env, a[0])?;
            let amp = opt(env, a[1], Kind::Mixed, "amp", 1.0)?;
            if lower == "impulse" {
                Signal::Impulse { at, amp }
            } else {
                Signal::Step { at, amp }
            }
        }
        "sine" => {
            let a = bind(&lower, args, &["freq", "amp", "phase"], e.span)?;
            let fe = a[0].ok_or_else(|| {
                Diagnostic::error(
                    ErrorKind::MissingParameter,
                    e.span,
                    "`sine` needs a frequency",
                )
                .with_hint("sine(freq=2Hz, amp=1)")
            })?;
            let freq = env.number(fe, Kind::Freq, "freq")?;
            if !(0.0..0.5).contains(&freq) {
                let bare = env.eval(fe).map(|v| v.kind == Kind::Plain).unwrap_or(false);
                return Err(crate::model::nyquist(fe.span, freq, env.fs, bare));
            }

            Signal::Sine {
                freq,
                amp: opt(env, a[1], Kind::Mixed, "amp", 1.0)?,
                phase: opt(env, a[2], Kind::Plain, "phase", 0.0)?,
            }
        }
        "noise" => {
            let a = bind(&lower, args, &["seed", "amp"], e.span)?;
            let seed = opt(env, a[0], Kind::Plain, "seed", 0.0)?;
            if seed.fract() != 0.0 || !(0.0..=9.0e15).contains(&seed) {
                return Err(Diagnostic::error(
                    ErrorKind::OutOfRange,
                    a[0].map_or(e.span, |x| x.span),
                    "the seed must be a whole number >= 0",
                ));
            }
            Signal::Noise {
                seed: seed as u64,
                amp: opt(env, a[1], Kind::Mixed, "amp", 1.0)?,
            }
        }
        "constant" => {
            let a = bind(&lower, args, &["value"], e.span)?;
            Signal::Constant(opt(env, a[0], Kind::Mixed, "value", 0.0)?)
        }
        "env" => {
            let a = bind(&lower, args, &["points", "amp"], e.span)?;
            let pe = a[0].ok_or_else(|| {
                Diagnostic::error(
                    ErrorKind::MissingParameter,
                    e.span,
                    "`env` needs its points",
                )
                .with_hint("env([(0, 0) (10ms, 1) (1s, 0)])")
            })?;
            let ExprKind::Curve(items) = &pe.kind else {
                return Err(Diagnostic::error(
                    ErrorKind::BadCurve,
                    pe.span,
                    "the points of `env` are a curve: [(time, value) ...]",
                ));
            };
            if items.len() > limits.max_curve_points {
                return Err(Diagnostic::error(
                    ErrorKind::Limit,
                    pe.span,
                    format!("more than {} points", limits.max_curve_points),
                ));
            }
            let amp = opt(env, a[1], Kind::Mixed, "amp", 1.0)?;
            let mut pts = Vec::new();
            for it in items {
                match &it.kind {
                    ExprKind::Tuple(xy) if xy.len() == 2 => pts.push((
                        env.number(&xy[0], Kind::Time, "env time")?,
                        amp * env.number(&xy[1], Kind::Mixed, "env value")?,
                    )),
                    _ => {
                        return Err(Diagnostic::error(
                            ErrorKind::BadCurve,
                            it.span,
                            "a point of `env` is (time, value)",
                        ))
                    }
                }
            }
            let c = Curve::new(&pts).map_err(|err| {
                Diagnostic::error(ErrorKind::BadCurve, pe.span, format!("env: {err}"))
                    .with_hint("list the points in time order")
            })?;
            Signal::Envelope(c)
        }
        "file" => {
            let a = bind(&lower, args, &["path", "channel", "gain"], e.span)?;
            let pe = a[0].ok_or_else(|| {
                Diagnostic::error(ErrorKind::MissingParameter, e.span, "`file` needs a path")
                    .with_hint("file(\"force.wav\")")
            })?;
            let ExprKind::Str(rel) = &pe.kind else {
                return Err(Diagnostic::error(
                    ErrorKind::Syntax,
                    pe.span,
                    "the path of `file` is quoted text",
                )
                .with_hint("file(\"force.wav\")"));
            };
            let channel = opt(env, a[1], Kind::Plain, "channel", 0.0)?;
            if channel.fract() != 0.0 || channel < 0.0 {
                return Err(Diagnostic::error(
                    ErrorKind::OutOfRange,
                    a[1].map_or(e.span, |x| x.span),
                    "the channel must be a whole number >= 0",
                ));
            }
            let gain = opt(env, a[2], Kind::Mixed, "gain", 1.0)?;
            let path = resolve(model_path, rel);
            let max_samples = (limits.max_duration_s * env.fs).ceil() as usize;
            let data = read_file(&path, channel as usize, env.fs, max_samples).map_err(
                |(msg, hint)| {
                    Diagnostic::error(
                        ErrorKind::SignalFile,
                        pe.span,
                        format!("{}: {msg}", path.display()),
                    )
                    .with_hint_opt(hint)
                },
            )?;
            Signal::Samples {
                data: Arc::from(data),
                gain,
            }
        }
        _ => {
            return Err(Diagnostic::error(
                ErrorKind::UnknownName,
                name.span,
                format!("unknown signal `{}`", name.text),
            )
            .with_hint(
                did_you_mean(&name.text, GENERATORS.iter().copied())
                    .unwrap_or_else(|| format!("signals are {}", GENERATORS.join(", "))),
            ))
        }
    };
    if !s.is_finite() {
        return Err(Diagnostic::error(
            ErrorKind::NonFinite,
            e.span,
            "this signal has non-finite values",
        ));
    }
    Ok(s)
}

fn resolve(model_path: &Path, rel: &str) -> PathBuf {
    let p = Path::new(rel);
    if p.is_absolute() {
        p.to_path_buf()
    } else {
        model_path.parent().unwrap_or(Path::new(".")).join(p)
    }
}

type FileResult = Result<Vec<f64>, (String, Option<String>)>;

fn read_file(path: &Path, channel: usize, fs: f64, max_samples: usize) -> FileResult {
    let ext = path
        .extension()
        .and_then(|e| e.to_str())
        .unwrap_or("")
        .to_ascii_lowercase();
    match ext.as_str() {
        "wav" => read_wav(path, channel, fs, max_samples),
        "csv" | "txt" => read_csv(path, channel, max_samples),
        _ => Err((
            format!("cannot read `.{ext}` files"),
            Some("signal files are .wav or .csv".into()),
        )),
    }
}

fn read_wav(path: &Path, channel: usize, fs: f64, max_samples: usize) -> FileResult {
    let (data, rate) = read_wav_channel(path, channel, max_samples)?;
    if f64::from(rate) != fs {
        return Err((
            format!("its sample rate is {rate} Hz but the model runs at {fs} Hz"),
            Some(format!(
                "resample the file to {fs} Hz, or set `rate {rate}` in the model"
            )),
        ));
    }
    Ok(data)
}

/// Reads one channel of a WAV file as `f64` (integer samples scaled to [-1, 1)), with the file's
/// sample rate. Refuses files of more than `max_samples` frames and non-finite samples. The error
/// is a message and an optional hint.
pub fn read_wav_channel(
    path: &Path,
    channel: usize,
    max_samples: usize,
) -> Result<(Vec<f64>, u32), (String, Option<String>)> {
    let reader =
        hound::WavReader::open(path).map_err(|e| (format!("cannot read it as WAV: {e}"), None))?;
    let spec = reader.spec();
    let chans = usize::from(spec.channels);
    if channel >= chans {
        return Err((
            format!("it has {chans} channel(s); channel {channel} does not exist"),
            Some(format!("channels are numbered 0..{}", chans - 1)),
        ));
    }
    let frames = reader.duration() as usize;
    if frames > max_samples {
        return Err((
            format!("it has {frames} samples, more than the {max_samples} allowed"),
            Some("raise --max-duration".into()),
        ));
    }
    let mut out = Vec::with_capacity(frames);
    let err = |e: hound::Error| (format!("a sample cannot be read: {e}"), None);
    match spec.sample_format {
        hound::SampleFormat::Float => {
            for (i, s) in reader.into_samples::<f32>().enumerate() {
                let s = s.map_err(err)?;
                if i % chans == channel {
                    out.push(f64::from(s));
                }
            }
        }
        hound::SampleFormat::Int => {
            let scale = 1.0 / f64::from(1u32 << (spec.bits_per_sample.clamp(1, 32) - 1));
            for (i, s) in reader.into_samples::<i32>().enumerate() {
                let s = s.map_err(err)?;
                if i % chans == channel {
                    out.push(f64::from(s) * scale);
                }
            }
        }
    }
    if let Some(i) = out.iter().position(|v| !v.is_finite()) {
        return Err((format!("sample {i} is not finite"), None));
    }
    Ok((out, spec.sample_rate))
}

fn read_csv(path: &Path, column: usize, max_samples: usize) -> FileResult {
    let text = std::fs::read_to_string(path).map_err(|e| (format!("cannot read it: {e}"), None))?;
    let mut out = Vec::new();
    for (n, line) in text.lines().enumerate() {
        let line = line.trim();
        if line.is_empty() || line.starts_with('#') {
            continue;
        }
        let fields: Vec<&str> = line.split([',', ';', '\t']).map(str::trim).collect();
        let Some(field) = fields.get(column) else {
            return Err((
                format!(
                    "line {} has {} column(s); column {column} does not exist",
                    n + 1,
                    fields.len()
                ),
                Some("pick the column with channel=N (from 0)".into()),
            ));
        };
        match field.parse::<f64>() {
            Ok(v) if v.is_finite() => out.push(v),
            Ok(_) => return Err((format!("line {}: `{field}` is not finite", n + 1), None)),
            Err(_) if out.is_empty() => continue, // header lines before the data
            Err(_) => {
                return Err((
                    format!("line {}: `{field}` is not a number", n + 1),
                    Some("one number per line (or per row, in the chosen column)".into()),
                ))
            }
        }
        if out.len() > max_samples {
            return Err((
                format!("it has more than {max_samples} samples, the longest render allowed"),
                Some("raise --max-duration".into()),
            ));
        }
    }
    Ok(out)
}
