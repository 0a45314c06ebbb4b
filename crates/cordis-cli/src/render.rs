//! The `render` and `check` commands.

use std::fmt::Write as _;
use std::io::{IsTerminal, Write as _};
use std::time::{Duration, Instant};

use cordis_core::{BlowUp, Material, Network};
use cordis_model::{stability, Model};
use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};

use crate::output::{self, Format, Pending, SampleFormat};
use crate::{exit, report, ModelArgs, RenderArgs};

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
    outln!(
        out,
        "stability: {}",
        if s.stable { "stable" } else { "UNSTABLE" }
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
    if net.materials.iter().any(Material::is_mobile) {
        outln!(out,
            "  network: largest eigenvalue of M^-1 K = {:.6} (must be < 4; Gershgorin bound {:.6}){}",
            s.lambda_max,
            s.lambda_bound,
            if s.includes_nonlinear { "; BUT and LNL links counted at their stiffest" } else { "" }
        );
    }
    if !s.offenders.is_empty() {
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
    if s.stable {
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
    let frames = model.duration as usize;
    let mut data = vec![0.0f64; frames * channels];
    let mut engine = model.compile();
    let block = args.block as usize;
    let started = Instant::now();
    let bar = ProgressBar::hidden();
    let mut bar_shown = false;
    let mut done = 0usize;
    while done < frames {
        let n = block.min(frames - done);
        if let Err(b) = engine.process(n, &mut data[done * channels..(done + n) * channels]) {
            bar.finish_and_clear();
            report_blow_up(&model, b);
            return exit::UNSTABLE;
        }
        done += n;
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
