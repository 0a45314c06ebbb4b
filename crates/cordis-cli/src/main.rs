//! `cordis`: check and render CORDIS-ANIMA models written in the cordis language.
//!
//! The only crate that knows about terminals, files and exit codes. Libraries return typed errors;
//! they are rendered here.

mod analysis;
mod output;
mod pictures;
mod render;
mod report;

use std::path::PathBuf;
use std::process::ExitCode;

use clap::{Args, Parser, Subcommand};
use cordis_model::{Limits, Options};

/// Exit codes, documented in the README and `cordis --help`.
pub mod exit {
    /// Success.
    pub const OK: u8 = 0;
    /// The model or an input file is invalid (errors printed with file, line and column).
    pub const INVALID: u8 = 1;
    /// The command line is wrong (unknown flag, missing argument).
    pub const USAGE: u8 = 2;
    /// The simulation blew up (render), or the model is unstable (check).
    pub const UNSTABLE: u8 = 3;
    /// The output could not be written, or would clip.
    pub const OUTPUT: u8 = 4;
}

const EXIT_CODES: &str = "\
Exit codes:
  0  success
  1  the model or an input file is invalid
  2  the command line is wrong
  3  the simulation blew up (render) or the model is unstable (check)
  4  the output could not be written, or would clip";

#[derive(Parser)]
#[command(name = "cordis", version, about = "CORDIS-ANIMA physical models: check them, render them to sound and data",
    after_help = EXIT_CODES, propagate_version = true)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Render a model's outputs (every sox and sof, in order) to .wav, .csv or .f64.
    #[command(after_help = "Examples:
  cordis render examples/plucked_string.cordis -o string.wav --normalize
  cordis render model.cordis -o data.csv --duration 100ms --set k=0.2
  cordis render model.cordis -o raw.f64 --rate 48000

The format follows the extension: .wav (see --sample-format), .csv (header of channel names,
one row per sample, 17 significant digits), .f64 (raw little-endian float64, frames
interleaved over channels).

Exit codes: 0 ok, 1 invalid model, 2 bad command line, 3 blew up, 4 output failed or would clip.")]
    Render(RenderArgs),
    /// Parse and validate a model; print its size, rate, duration and stability verdict.
    #[command(after_help = "Examples:
  cordis check examples/plucked_string.cordis
  cordis check model.cordis --set k=0.5 --rate 96000

Exit codes: 0 valid and stable, 1 invalid, 2 bad command line, 3 valid but unstable.")]
    Check(ModelArgs),
    /// Draw the spectrogram of a WAV file as a PNG (time in s, frequency in Hz, dB colour bar).
    #[command(after_help = "Examples:
  cordis spectrogram string.wav -o string.png
  cordis spectrogram bell.wav -o bell.png --log-freq --max-freq 8000 --window 4096 --hop 256

Exit codes: 0 ok, 1 the WAV file cannot be read, 2 bad command line, 4 the PNG could not be written.")]
    Spectrogram(SpectrogramArgs),
    /// List the modes of a model, exact for the discrete scheme: frequency, decay time, T60, Q, and
    /// the amplitude each pickup (sox) hears for the model's initial conditions and impulses.
    #[command(after_help = "Examples:
  cordis modes examples/plucked_string.cordis
  cordis modes model.cordis --json > modes.json
  cordis modes model.cordis --plot modes.png --max-freq 4000
  cordis modes big_membrane.cordis --count 50

The model is linearised at its initial positions (a BUT counts if it is in contact there, an LNL
with the slopes of its curves); the report says what was linearised.
Exit codes: 0 ok and stable, 1 invalid model, 2 bad command line, 3 unstable (a pole outside the unit circle), 4 the plot could not be written.")]
    Modes(ModesArgs),
    /// Write the matrices of a model: M, K, R, the finite-difference form and the state space.
    #[command(after_help = "Examples:
  cordis matrices model.cordis -o model.json
  cordis matrices model.cordis --csv model_matrices/

JSON holds every matrix as a list of rows, with `order` naming the rows (the mobile modules).
CSV writes one file per matrix (M.csv, K.csv, R.csv, A1.csv, A0.csv, Am1.csv, Ad.csv, Bd.csv,
Cd.csv, Dd.csv, b.csv) plus order.csv and a README.txt. GENESIS units throughout.")]
    Matrices(MatricesArgs),
    /// Frequency response from a force at one module to the position at another, exact in
    /// z = e^{iw} for the discrete scheme: receptance, mobility (admittance), position transfer.
    #[command(after_help = "Examples:
  cordis response examples/plucked_string.cordis --force-at 's[3]' --listen-at 's[10]' -o resp.csv
  cordis response model.cordis --force-at m1 --listen-at m2 --from 20 --to 5000 --points 2000 --plot resp.png

CSV columns: freq_hz, receptance (X_B/F_A), mobility (V_B/F_A, velocity per sample), transfer
(X_B/X_A), and the driving-point mobility at A, each as magnitude and phase (rad). GENESIS units.")]
    Response(ResponseCmd),
    /// Write the network as a Graphviz graph: material modules as nodes, interactions as edges.
    #[command(after_help = "Examples:
  cordis graph examples/bouncing_ball.cordis -o ball.dot && dot -Tpng ball.dot -o ball.png")]
    Graph(GraphArgs),
    /// Export a model to another tool.
    #[command(subcommand)]
    Export(ExportCmd),
}

#[derive(Args)]
struct GraphArgs {
    #[command(flatten)]
    model: ModelArgs,
    /// The .dot file to write (default: standard output).
    #[arg(short, long, value_name = "FILE.dot")]
    output: Option<PathBuf>,
}

#[derive(Subcommand)]
enum ExportCmd {
    /// The mobility electrical analogue as a SPICE netlist (velocities are voltages, masses
    /// capacitors to ground, springs inductors, dampers resistors, a 1 A AC source as the force).
    #[command(after_help = "Examples:
  cordis export spice model.cordis --force-at m1 -o model.cir && ngspice -b model.cir

Physical units (k = K Fs^2, z = Z Fs); the netlist's comments say which node is which module.
The continuous circuit agrees with the discrete model at low frequency (below about Fs/200).")]
    Spice(SpiceArgs),
}

#[derive(Args)]
struct SpiceArgs {
    #[command(flatten)]
    model: ModelArgs,
    /// The mobile module the 1 A AC source drives (default: the first one).
    #[arg(long, value_name = "MODULE")]
    force_at: Option<String>,
    /// The netlist to write (default: standard output).
    #[arg(short, long, value_name = "FILE.cir")]
    output: Option<PathBuf>,
}

#[derive(Args)]
struct ModesArgs {
    #[command(flatten)]
    model: ModelArgs,
    /// Print JSON instead of a table.
    #[arg(long)]
    json: bool,
    /// Draw the modes over the spectrum of a 2 s render of output 0.
    #[arg(long, value_name = "OUT.png")]
    plot: Option<PathBuf>,
    /// Only the N lowest modes, by a sparse method (for large models).
    #[arg(long, value_name = "N")]
    count: Option<usize>,
    #[command(flatten)]
    spec: SpecArgs,
}

#[derive(Args)]
struct MatricesArgs {
    #[command(flatten)]
    model: ModelArgs,
    /// JSON file to write (default: standard output).
    #[arg(short, long, value_name = "FILE.json")]
    output: Option<PathBuf>,
    /// Write CSV files into this folder instead of JSON.
    #[arg(long, value_name = "DIR", conflicts_with = "output")]
    csv: Option<PathBuf>,
}

#[derive(Args)]
struct ResponseCmd {
    #[command(flatten)]
    model: ModelArgs,
    /// The mobile module the force is applied to.
    #[arg(long, value_name = "MODULE")]
    force_at: String,
    /// The mobile module whose position is read.
    #[arg(long, value_name = "MODULE")]
    listen_at: String,
    /// Lowest frequency, Hz.
    #[arg(long, value_name = "HZ", default_value_t = 10.0)]
    from: f64,
    /// Highest frequency, Hz (default: 0.99 of Nyquist).
    #[arg(long, value_name = "HZ")]
    to: Option<f64>,
    /// Number of log-spaced frequencies.
    #[arg(long, value_name = "N", default_value_t = 1000)]
    points: usize,
    /// CSV file to write (default: standard output).
    #[arg(short, long, value_name = "FILE.csv")]
    output: Option<PathBuf>,
    /// Draw a Bode plot (magnitude and phase over log frequency).
    #[arg(long, value_name = "OUT.png")]
    plot: Option<PathBuf>,
}

/// Spectrogram drawing options (shared by `spectrogram` and `render --spectrogram`).
#[derive(Args, Clone)]
pub struct SpecArgs {
    /// FFT window length in samples (Hann window).
    #[arg(long, value_name = "SAMPLES", default_value_t = 2048)]
    pub window: usize,
    /// Hop between windows in samples (default: window / 4).
    #[arg(long, value_name = "SAMPLES")]
    pub hop: Option<usize>,
    /// Highest frequency shown, Hz (default: Nyquist).
    #[arg(long, value_name = "HZ")]
    pub max_freq: Option<f64>,
    /// Lowest frequency shown, Hz (default: 0, or 20 with --log-freq).
    #[arg(long, value_name = "HZ")]
    pub min_freq: Option<f64>,
    /// Logarithmic frequency axis.
    #[arg(long)]
    pub log_freq: bool,
    /// Dynamic range shown below the peak, dB.
    #[arg(long, value_name = "DB", default_value_t = 90.0)]
    pub db_range: f64,
    /// Image width and height in pixels.
    #[arg(long, value_name = "WxH", default_value = "1200x600", value_parser = parse_size)]
    pub size: (u32, u32),
}

#[derive(Args)]
struct SpectrogramArgs {
    /// The WAV file.
    input: PathBuf,
    /// The PNG to write.
    #[arg(short, long, value_name = "OUT.png")]
    output: PathBuf,
    /// Which channel of the file (from 0).
    #[arg(long, default_value_t = 0)]
    channel: usize,
    #[command(flatten)]
    spec: SpecArgs,
}

fn parse_size(s: &str) -> Result<(u32, u32), String> {
    let err = || format!("`{s}` is not WIDTHxHEIGHT (for example 1200x600)");
    let (w, h) = s.split_once(['x', 'X']).ok_or_else(err)?;
    let (w, h) = (
        w.trim().parse().map_err(|_| err())?,
        h.trim().parse().map_err(|_| err())?,
    );
    if w < 200 || h < 150 || w > 10_000 || h > 10_000 {
        return Err(format!(
            "{s}: width must be 200..10000 and height 150..10000 pixels"
        ));
    }
    Ok((w, h))
}

#[derive(Args)]
struct ModelArgs {
    /// The model file (*.cordis).
    model: PathBuf,
    /// Sample rate, overriding the model's `rate` (e.g. 48000 or 48kHz).
    #[arg(long, value_name = "R")]
    rate: Option<String>,
    /// Render length, overriding the model's `duration` (e.g. 3s, 250ms, or samples).
    #[arg(long, value_name = "D")]
    duration: Option<String>,
    /// Override a `let` value of the model (repeatable), e.g. --set k=0.2 --set f=440Hz.
    #[arg(long = "set", value_name = "NAME=VALUE", value_parser = parse_set)]
    sets: Vec<(String, String)>,
    /// Most modules a model may have.
    #[arg(long, value_name = "N", default_value_t = Limits::default().max_modules)]
    max_modules: usize,
    /// Longest render, in seconds.
    #[arg(long, value_name = "SECONDS", default_value_t = Limits::default().max_duration_s)]
    max_duration: f64,
    /// Highest sample rate, in Hz.
    #[arg(long, value_name = "HZ", default_value_t = Limits::default().max_rate)]
    max_rate: f64,
}

#[derive(Args)]
struct RenderArgs {
    #[command(flatten)]
    model: ModelArgs,
    /// Output file: .wav, .csv or .f64 (default: the model's name with .wav).
    #[arg(short, long, value_name = "OUT")]
    output: Option<PathBuf>,
    /// WAV sample format.
    #[arg(long, value_enum, default_value_t = output::SampleFormat::F32)]
    sample_format: output::SampleFormat,
    /// Scale the WAV so that its peak is exactly full scale (1.0).
    #[arg(long)]
    normalize: bool,
    /// Write an integer WAV even if samples exceed full scale (they are clipped, with a warning).
    #[arg(long)]
    allow_clipping: bool,
    /// Write the event log (step,time_s,link,state: when each BUT, sticking spring and tracked LNL
    /// becomes active or inactive) to this CSV file.
    #[arg(long, value_name = "FILE.csv")]
    events: Option<PathBuf>,
    /// Write the energy log (kinetic, potential, dissipated, input, total) to this CSV file.
    #[arg(long, value_name = "FILE.csv")]
    energy: Option<PathBuf>,
    /// Write an energy row every N steps.
    #[arg(long, value_name = "N", default_value_t = 1, value_parser = clap::value_parser!(u64).range(1..))]
    energy_every: u64,
    /// Also draw the spectrogram of one output channel as a PNG.
    #[arg(long, value_name = "OUT.png")]
    spectrogram: Option<PathBuf>,
    /// The output channel the spectrogram shows (from 0).
    #[arg(long, value_name = "N", default_value_t = 0)]
    spectrogram_channel: usize,
    #[command(flatten)]
    spec: SpecArgs,
    /// Frames per engine block (output does not depend on it).
    #[arg(long, default_value_t = 4096, value_parser = clap::value_parser!(u32).range(1..=1_048_576))]
    block: u32,
}

fn parse_set(s: &str) -> Result<(String, String), String> {
    match s.split_once('=') {
        Some((n, v)) if !n.trim().is_empty() && !v.trim().is_empty() => {
            Ok((n.trim().to_string(), v.trim().to_string()))
        }
        _ => Err(format!(
            "`{s}` is not NAME=VALUE (for example k=0.2 or f=440Hz)"
        )),
    }
}

impl ModelArgs {
    fn options(&self) -> Options {
        Options {
            rate: self.rate.clone(),
            duration: self.duration.clone(),
            sets: self.sets.clone(),
            limits: Limits {
                max_modules: self.max_modules,
                max_duration_s: self.max_duration,
                max_rate: self.max_rate,
                ..Limits::default()
            },
        }
    }
}

fn main() -> ExitCode {
    let cli = match Cli::try_parse() {
        Ok(c) => c,
        Err(e) => {
            let code = if e.use_stderr() {
                exit::USAGE
            } else {
                exit::OK
            };
            let _ = e.print();
            return ExitCode::from(code);
        }
    };
    let code = match cli.command {
        Command::Render(a) => render::render(&a),
        Command::Check(a) => render::check(&a),
        Command::Spectrogram(a) => render::spectrogram(&a.input, &a.output, a.channel, &a.spec),
        Command::Modes(a) => analysis::modes(&a.model, a.json, a.plot.as_ref(), &a.spec, a.count),
        Command::Matrices(a) => analysis::matrices(&a.model, a.output.as_ref(), a.csv.as_ref()),
        Command::Graph(a) => analysis::graph(&a.model, a.output.as_ref()),
        Command::Export(ExportCmd::Spice(a)) => {
            analysis::spice(&a.model, a.force_at.as_deref(), a.output.as_ref())
        }
        Command::Response(a) => analysis::response(
            &a.model,
            &analysis::ResponseArgs {
                force_at: &a.force_at,
                listen_at: &a.listen_at,
                from_hz: a.from,
                to_hz: a.to,
                points: a.points,
                output: a.output.as_ref(),
                plot: a.plot.as_ref(),
            },
        ),
    };
    ExitCode::from(code)
}
