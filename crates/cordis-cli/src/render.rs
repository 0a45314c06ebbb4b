//! The `render` and `check` commands.

use std::fmt::Write as _;
use std::io::{IsTerminal, Write as _};
use std::time::{Duration, Instant};

use cordis_core::{BlowUp, Material, Network};
use cordis_model::{stability, Model};
use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};

use crate::output::{self, Format, Pending, SampleFormat};
use crate::threads::AutoThreads;
use crate::{exit, pictures, report, ModelArgs, RenderArgs, SpecArgs};
use cordis_model::{EnergyMeter, EnergyRow, EventLog};

fn load(args: &ModelArgs) -> Result<Model, u8> {
    match cordis_model::load_file(&args.model, &args.options()) {
        Ok(m) => {
            report::emit(&m.path, &m.source, &m.warnings);
            Ok(m)
        }
        Err(e) => {
            report::emit_load_error(&e);
            Err(exit::INVALID)
        }
    }
}

/// `cordis check`.
pub fn check(args: &ModelArgs) -> u8 {
    let model = match load(args) {
        Ok(m) => m,
        Err(c) => return c,
    };
    let mut out = String::new();
    macro_rules! outln {
        ($o:expr, $($t:tt)*) => {{
            let _ = writeln!($o, $($t)*);
        }};
    }
    let net = &model.network;
    let count = |f: &dyn Fn(&Material) -> bool| net.materials.iter().filter(|m| f(m)).count();
    outln!(out, "{}: valid", model.path.display());
    outln!(out, "  rate          {} Hz", model.rate);
    outln!(
        out,
        "  duration      {:.6} s ({} samples)",
        model.duration as f64 / model.rate,
        model.duration
    );
    outln!(
        out,
        "  materials     {}: {} mas, {} cel, {} sol, {} enx",
        net.materials.len(),
        count(&|m| matches!(m, Material::Mas { .. })),
        count(&|m| matches!(m, Material::Cel { .. })),
        count(&|m| matches!(m, Material::Sol { .. })),
        count(&|m| matches!(m, Material::Enx { .. })),
    );
    let kinds = ["RES", "FRO", "REF", "BUT", "LNL"];
    let by_kind: Vec<String> = kinds
        .iter()
        .map(|k| {
            format!(
                "{} {}",
                net.links.iter().filter(|l| l.law.kind() == *k).count(),
                k.to_ascii_lowercase()
            )
        })
        .collect();
    outln!(
        out,
        "  interactions  {}: {}",
        net.links.len(),
        by_kind.join(", ")
    );
    outln!(out, "  inputs        {} enf", net.forces.len());
    let outs: Vec<String> = model
        .outputs
        .iter()
        .zip(&net.outputs)
        .map(|(n, o)| match o {
            cordis_core::Output::Position(m) => {
                format!("{} (sox {})", n.name, model.material_name(*m))
            }
            cordis_core::Output::Force(l) => {
                format!("{} (sof {})", n.name, model.links[l.index()].name)
            }
            cordis_core::Output::Sum(t) => format!("{} (sum of {} terms)", n.name, t.len()),
        })
        .collect();
    outln!(
        out,
        "  outputs       {}{}{}",
        outs.len(),
        if outs.is_empty() { "" } else { ": " },
        outs.join(", ")
    );
    let s = stability::check(&model);
    // The exact verdict: the largest pole radius of the network linearised at rest (dense, so for
    // models up to POLE_LIMIT mobile modules); beyond, the eigenvalue bound of FORMALISM.md.
    const POLE_LIMIT: usize = 600;
    let poles = cordis_analysis::LinearSystem::from_model(&model)
        .ok()
        .filter(|sys| sys.len() <= POLE_LIMIT)
        .and_then(|sys| {
            cordis_analysis::ModalAnalysis::compute(&sys)
                .ok()
                .map(|ma| (sys, ma))
        });
    let network_stable = match &poles {
        Some((_, ma)) => cordis_analysis::radius_is_stable(ma.max_radius),
        None => s.lambda_max < 4.0,
    };
    let all_stable = network_stable
        && s.cels.iter().all(|c| c.stable)
        && model.devices.iter().all(|d| d.is_stable());
    outln!(
        out,
        "stability: {}",
        if all_stable { "stable" } else { "UNSTABLE" }
    );
    for c in &s.cels {
        outln!(
            out,
            "  cel {}: Z/M = {:.6e} (must be in [0, 2)), (K+2Z)/M = {:.6e} (must be < 4): {}",
            c.name,
            c.z_over_m,
            c.k2z_over_m,
            if c.stable { "stable" } else { "UNSTABLE" }
        );
    }
    if let Some((sys, ma)) = &poles {
        outln!(
            out,
            "  network (linearised at rest, {} mobile modules): largest pole radius {:.12} (must be <= 1): {}",
            sys.len(),
            ma.max_radius,
            if cordis_analysis::radius_is_stable(ma.max_radius) { "stable" } else { "UNSTABLE" }
        );
        if s.includes_nonlinear && s.lambda_max >= 4.0 {
            outln!(out, "  warning: with every BUT and LNL at its stiffest the largest eigenvalue of M^-1 K is {:.6} (>= 4): the model may blow up when they engage", s.lambda_max);
        }
    } else if net.materials.iter().any(Material::is_mobile) {
        outln!(out,
            "  network: largest eigenvalue of M^-1 K = {:.6} (must be < 4; Gershgorin bound {:.6}){}",
            s.lambda_max,
            s.lambda_bound,
            if s.includes_nonlinear { "; BUT and LNL links counted at their stiffest" } else { "" }
        );
    }
    for d in &model.devices {
        let (lhs, bound) = d.stability();
        let (kind, cond) = match d.kind {
            cordis_model::DeviceKind::Simple => ("stick", "KL + 2 Z1 < 4 mu"),
            cordis_model::DeviceKind::Complete => ("bond", "KL + 2 KR + 2 Z1 < 4 mC"),
        };
        let sb = d
            .breaking_distance()
            .map(|b| format!(", S_B = {b:.6}"))
            .unwrap_or_default();
        outln!(
            out,
            "  device {} ({kind}): Z1 = {:.6e}{}{sb}; {cond}: {lhs:.6} vs {bound:.6}: {}",
            d.name,
            d.z1,
            if d.buts { "" } else { " (no BUTs)" },
            if d.is_stable() {
                "stable"
            } else {
                "UNSTABLE once connected"
            }
        );
    }
    let unstable_mode = poles.as_ref().and_then(|(sys, ma)| {
        let worst = ma
            .modes
            .iter()
            .max_by(|a, b| a.radius.total_cmp(&b.radius))?;
        (!cordis_analysis::radius_is_stable(worst.radius)).then(|| {
            let peak = worst.shape.iter().fold(0.0f64, |a, v| a.max(v.abs()));
            let mut at: Vec<(usize, f64)> = worst
                .shape
                .iter()
                .enumerate()
                .filter(|(_, v)| v.abs() >= 0.5 * peak)
                .map(|(i, v)| (i, v.abs()))
                .collect();
            at.sort_by(|a, b| b.1.total_cmp(&a.1));
            at.into_iter()
                .take(8)
                .map(|(i, _)| sys.names[i].clone())
                .collect::<Vec<_>>()
        })
    });
    if let Some(names) = unstable_mode {
        outln!(
            out,
            "  at fault: {} (where the growing mode lives)",
            names.join(", ")
        );
        outln!(out, "  hint: lower the stiffness or viscosity of the links at these modules, make them heavier, or raise the rate");
    } else if poles.is_none() && !s.offenders.is_empty() {
        let list: Vec<String> = s
            .offenders
            .iter()
            .map(|(n, r)| format!("{n} (row sum {r:.3})"))
            .collect();
        outln!(out, "  at fault: {}", list.join(", "));
        outln!(out, "  hint: lower the stiffness of the links at these modules, make them heavier, or raise the rate");
    }
    // A closed pipe (`cordis check m.cordis | head`) is not an error.
    let _ = std::io::stdout().write_all(out.as_bytes());
    if all_stable {
        exit::OK
    } else {
        exit::UNSTABLE
    }
}

/// `cordis render`.
pub fn render(args: &RenderArgs) -> u8 {
    let out_path = args
        .output
        .clone()
        .unwrap_or_else(|| args.model.model.with_extension("wav"));
    let format = match Format::from_path(&out_path) {
        Ok(f) => f,
        Err(e) => {
            eprintln!("cordis: {e:#}");
            return exit::USAGE;
        }
    };
    let model = match load(&args.model) {
        Ok(m) => m,
        Err(c) => return c,
    };
    let channels = model.network.outputs.len();
    if channels == 0 {
        eprintln!(
            "cordis: {} has no outputs, so there is nothing to render",
            model.path.display()
        );
        eprintln!(
            "  hint: add `sox NAME MASS` to record a position, or `sof NAME LINK` for a force"
        );
        return exit::INVALID;
    }
    if format == Format::Wav && model.rate.fract() != 0.0 {
        eprintln!(
            "cordis: a WAV file needs a whole-number sample rate, and the model runs at {} Hz",
            model.rate
        );
        eprintln!("  hint: write .csv or .f64, or use a whole rate");
        return exit::INVALID;
    }
    if args.spectrogram_channel >= channels && args.spectrogram.is_some() {
        eprintln!(
            "cordis: --spectrogram-channel {} does not exist: the model has {channels} output channel(s), numbered from 0",
            args.spectrogram_channel
        );
        return exit::USAGE;
    }
    let mut events = args.events.as_ref().map(|_| EventLog::new(&model));
    let mut energy = args
        .energy
        .as_ref()
        .map(|_| EnergyMeter::new(&model, args.energy_every));
    let observing = events.is_some() || energy.is_some();
    let frames = model.duration as usize;
    let mut data = vec![0.0f64; frames * channels];
    let mut engine = model.compile();
    let threads = args.threads.map_or_else(
        || std::thread::available_parallelism().map_or(1, |n| n.get()),
        |t| t as usize,
    );
    engine.set_threads(threads);
    // (no `--threads`: every core, kept only while faster than one, `threads.rs`)
    let mut auto = (args.threads.is_none() && engine.is_parallel() && !observing)
        .then(|| AutoThreads::new(threads, frames));
    let block = args.block as usize;
    let started = Instant::now();
    let bar = ProgressBar::hidden();
    let mut bar_shown = false;
    let mut done = 0usize;
    while done < frames {
        // (a chunk of frames on the threads `auto` asks for, or a block)
        let step = auto.as_mut().map(|a| a.next(started.elapsed()));
        if let Some(t) = step.map(|s| s.threads).filter(|&t| t != engine.threads()) {
            engine.set_threads(t);
        }
        let chunk = step
            .and_then(|s| s.frames)
            .unwrap_or(block)
            .min(frames - done);
        let chunk_started = Instant::now();
        let mut stepped = 0;
        while stepped < chunk {
            let n = block.min(chunk - stepped);
            let at = done + stepped;
            let block_out = &mut data[at * channels..(at + n) * channels];
            let result = if observing {
                engine.process_observed(n, block_out, &mut |v| {
                    if let Some(log) = events.as_mut() {
                        log.observe(v);
                    }
                    if let Some(meter) = energy.as_mut() {
                        meter.observe(v);
                    }
                })
            } else {
                engine.process(n, block_out)
            };
            if let Err(b) = result {
                bar.finish_and_clear();
                report_blow_up(&model, b);
                return exit::UNSTABLE;
            }
            stepped += n;
        }
        if let Some(a) = auto.as_mut() {
            a.record(chunk, chunk_started.elapsed(), started.elapsed());
        }
        done += chunk;
        if !bar_shown
            && started.elapsed() > Duration::from_millis(700)
            && std::io::stderr().is_terminal()
        {
            bar.set_length(frames as u64);
            bar.set_style(
                ProgressStyle::with_template(
                    "{spinner} rendering [{bar:40}] {percent:>3}% {pos}/{len} samples, eta {eta}",
                )
                .unwrap_or_else(|_| ProgressStyle::default_bar())
                .progress_chars("=> "),
            );
            bar.set_draw_target(ProgressDrawTarget::stderr());
            bar_shown = true;
        }
        bar.set_position(done as u64);
    }
    bar.finish_and_clear();
    let elapsed = started.elapsed().as_secs_f64();
    let names: Vec<String> = model.outputs.iter().map(|n| n.name.clone()).collect();
    let pending = Pending::new(&out_path);
    let mut note = String::new();
    let result = match format {
        Format::Csv => output::write_csv(pending.path(), &data, &names),
        Format::F64 => output::write_f64(pending.path(), &data),
        Format::Wav => {
            let peak = data.iter().fold(0.0f64, |m, v| m.max(v.abs()));
            if args.normalize {
                if peak > 0.0 {
                    let g = 1.0 / peak;
                    data.iter_mut().for_each(|v| *v *= g);
                    note = format!(", normalized (gain {g:.6e})");
                } else {
                    eprintln!("cordis: warning: the render is silent (every sample is 0); nothing to normalize");
                }
            } else if peak > 1.0 {
                let db = 20.0 * peak.log10();
                if args.sample_format == SampleFormat::F32 {
                    eprintln!("cordis: WARNING: the peak is {peak:.6} (+{db:.2} dBFS), above full scale: most players will clip it");
                    eprintln!("  hint: add --normalize to scale the peak to full scale");
                } else if args.allow_clipping {
                    let clipped = data.iter().filter(|v| v.abs() > 1.0).count();
                    eprintln!("cordis: WARNING: {clipped} samples above full scale (peak +{db:.2} dBFS) are clipped (--allow-clipping)");
                } else {
                    eprintln!("cordis: the peak is {peak:.6} (+{db:.2} dBFS): a {} WAV would clip; nothing was written",
                        if args.sample_format == SampleFormat::I16 { "16-bit" } else { "24-bit" });
                    eprintln!("  hint: add --normalize, or --sample-format f32, or --allow-clipping to clip on purpose");
                    return exit::OUTPUT;
                }
            } else if peak < 1e-6 && peak > 0.0 {
                eprintln!("cordis: warning: the peak is {peak:.3e} ({:.1} dBFS): nearly inaudible; add --normalize", 20.0 * peak.log10());
            }
            output::write_wav(
                pending.path(),
                &data,
                channels,
                model.rate as u32,
                args.sample_format,
            )
        }
    };
    if let Err(e) = result.and_then(|()| pending.commit()) {
        eprintln!("cordis: {e:#}");
        return exit::OUTPUT;
    }
    let mut extras = Vec::new();
    if let (Some(path), Some(log)) = (&args.events, &events) {
        match write_events(path, &model, log) {
            Ok(()) => extras.push(format!("{} events to {}", log.events.len(), path.display())),
            Err(e) => {
                eprintln!("cordis: {e:#}");
                return exit::OUTPUT;
            }
        }
    }
    if let (Some(path), Some(meter)) = (&args.energy, &energy) {
        match write_energy(path, model.rate, &meter.rows) {
            Ok(()) => extras.push(format!(
                "{} energy rows to {}",
                meter.rows.len(),
                path.display()
            )),
            Err(e) => {
                eprintln!("cordis: {e:#}");
                return exit::OUTPUT;
            }
        }
    }
    if let Some(path) = &args.spectrogram {
        let c = args.spectrogram_channel;
        let samples: Vec<f64> = data.iter().skip(c).step_by(channels).copied().collect();
        let sets: String = args
            .model
            .sets
            .iter()
            .map(|(n, v)| format!(" {n}={v}"))
            .collect();
        let title = format!("{}: {}{sets}", model.path.display(), model.outputs[c].name);
        match pictures::draw(&samples, model.rate, &args.spec, title, path) {
            Ok(()) => extras.push(format!("spectrogram to {}", path.display())),
            Err(e) => {
                eprintln!("cordis: {e:#}");
                return exit::OUTPUT;
            }
        }
    }
    let rate = (frames as f64 * model.network.materials.len() as f64) / elapsed.max(1e-9);
    eprintln!(
        "cordis: wrote {} ({} channel{}, {} samples, {:.3} s at {} Hz{note}) in {:.2} s ({:.3e} mass-steps/s)",
        out_path.display(),
        channels,
        if channels == 1 { "" } else { "s" },
        frames,
        frames as f64 / model.rate,
        model.rate,
        elapsed,
        rate
    );
    if let Some(s) = auto.as_ref().and_then(AutoThreads::summary) {
        eprintln!("cordis: stepped on {s}");
    }
    for e in extras {
        eprintln!("cordis: wrote {e}");
    }
    exit::OK
}

fn report_blow_up(model: &Model, b: BlowUp) {
    let net: &Network = &model.network;
    let m = b.material;
    let named = &model.materials[m.index()];
    let t = b.step as f64 / model.rate;
    eprintln!(
        "cordis: the simulation blew up: the position of `{}` ({}, declared at {}:{}) became non-finite at sample {} (t = {:.6} s)",
        named.name,
        net.materials[m.index()].kind().to_ascii_lowercase(),
        model.path.display(),
        named.span.line,
        b.step,
        t
    );
    let links: Vec<String> = model
        .links_of(m)
        .into_iter()
        .take(6)
        .map(|l| {
            format!(
                "{} ({})",
                model.links[l.index()].name,
                net.links[l.index()].law.kind().to_ascii_lowercase()
            )
        })
        .collect();
    if !links.is_empty() {
        eprintln!("  its interactions: {}", links.join(", "));
    }
    eprintln!("  nothing was written.");
    eprintln!("  hint: the explicit scheme needs K/M < 4 (and K + 2Z < 4M for a cel): lower the stiffness or viscosity");
    eprintln!("        of these links, raise the inertia M, or raise the rate; `cordis check` shows the stability verdict");
}

/// `step,time_s,link,state`, one row per change.
fn write_events(path: &std::path::Path, model: &Model, log: &EventLog) -> anyhow::Result<()> {
    let mut text = String::from("step,time_s,link,state\n");
    for e in &log.events {
        let _ = writeln!(
            text,
            "{},{},{},{}",
            e.step,
            e.step as f64 / model.rate,
            model.links[e.link.index()].name,
            u8::from(e.active)
        );
    }
    write_text(path, &text)
}

/// `step,time_s,kinetic,potential,dissipated,input,total`.
fn write_energy(path: &std::path::Path, rate: f64, rows: &[EnergyRow]) -> anyhow::Result<()> {
    let mut text = String::from("step,time_s,kinetic,potential,dissipated,input,total\n");
    for r in rows {
        let _ = writeln!(
            text,
            "{},{},{:.16e},{:.16e},{:.16e},{:.16e},{:.16e}",
            r.step,
            r.step as f64 / rate,
            r.kinetic,
            r.potential,
            r.dissipated,
            r.input,
            r.total
        );
    }
    write_text(path, &text)
}

fn write_text(path: &std::path::Path, text: &str) -> anyhow::Result<()> {
    use anyhow::Context;
    let pending = Pending::new(path);
    std::fs::write(pending.path(), text)
        .with_context(|| format!("cannot write {}", path.display()))?;
    pending.commit()
}

/// `cordis spectrogram`.
pub fn spectrogram(
    input: &std::path::Path,
    output: &std::path::Path,
    channel: usize,
    spec: &SpecArgs,
) -> u8 {
    let (samples, rate) = match pictures::read_wav_channel(input, channel) {
        Ok(v) => v,
        Err(e) => {
            eprintln!("cordis: {e:#}");
            return exit::INVALID;
        }
    };
    let title = format!("{} (channel {channel})", input.display());
    match pictures::draw(&samples, rate, spec, title, output) {
        Ok(()) => {
            eprintln!("cordis: wrote {}", output.display());
            exit::OK
        }
        Err(e) => {
            eprintln!("cordis: {e:#}");
            exit::OUTPUT
        }
    }
}
