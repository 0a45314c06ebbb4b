//! `cordis`: check and render CORDIS-ANIMA models written in the cordis language.
//!
//! The only crate that knows about terminals, files and exit codes. Libraries return typed errors;
//! they are rendered here.

mod analysis;
mod design;
mod output;
mod pictures;
mod render;
mod report;
mod sweep;
mod threads;

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
  4  the output could not be written, or would clip

Environment:
  CORDIS_SIMD  avx512 (the default), avx2 or none: the widest vector instructions the engine
               uses, to time what another CPU gets (the output is the same, bit for bit)";

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
    /// Render every variant of a grid of `let` values, in parallel, into a folder, with a summary.
    #[command(after_help = "Examples:
  cordis sweep examples/instrumentarium/reconfigurable_8s.cordis --set S=0.5..2:4 --set KL=0.002,0.005,0.02 -o sweep/
  cordis sweep model.cordis --set f=110Hz..880Hz:4:log -o out/ --normalize

--set NAME=a..b:n gives n values from a to b (add :log for geometric steps; units allowed, the
same at both ends), NAME=v1,v2,... a list. The grid is every combination (the first --set
varies slowest). Files are MODEL_<index>.wav; index.csv lists each variant's values, status
(ok, invalid, blew up), peak and RMS. Exit codes: 0 all rendered, 1 some variant invalid,
3 some blew up, 4 some output not written.")]
    Sweep(SweepArgs),
    /// Inverse design: from target frequencies, amplitudes and decay times, or a recording, to a
    /// model that makes them (a .cordis file, instrumentalist included).
    #[command(subcommand)]
    Design(DesignCmd),
}

#[derive(Args)]
struct SweepArgs {
    /// The model file (*.cordis).
    model: PathBuf,
    /// A swept `let`: NAME=a..b:n, NAME=a..b:n:log, NAME=v1,v2,... or NAME=v (repeatable).
    #[arg(long = "set", value_name = "NAME=a..b:n", value_parser = sweep::parse_axis, required = true)]
    sets: Vec<sweep::Axis>,
    /// Sample rate, overriding the model's `rate`.
    #[arg(long, value_name = "R")]
    rate: Option<String>,
    /// Render length, overriding the model's `duration`.
    #[arg(long, value_name = "D")]
    duration: Option<String>,
    /// The folder to write the variants and index.csv into.
    #[arg(short, long, value_name = "DIR")]
    output: PathBuf,
    /// Worker threads (default: every core).
    #[arg(long, value_name = "N")]
    threads: Option<usize>,
    /// Scale each variant's WAV to a peak of exactly full scale.
    #[arg(long)]
    normalize: bool,
    /// WAV sample format.
    #[arg(long, value_enum, default_value_t = output::SampleFormat::F32)]
    sample_format: output::SampleFormat,
}

#[derive(Subcommand)]
enum DesignCmd {
    /// One damped oscillator (a cel), in closed form, exact for the discrete scheme.
    #[command(after_help = "Examples:
  cordis design cell --freq 440Hz --decay 1.5s -o a440.cordis
  cordis design cell --freq 440Hz --decay 1.5s --amp 0.5 --phase 1.5708 --stiffness 0.1 > cell.cordis

Z/M = 1 - r^2 and K/M = (1 - r)^2 + 4 r sin^2(theta/2), with theta = 2 pi f / Fs and
r = exp(-1 / (Fs tau)); the oscillator starts at A cos(P) and moves as A r^n cos(theta n + P).
Without -o the model goes to standard output and the report to standard error.")]
    Cell(DesignCellArgs),
    /// A chain of masses and springs with the target frequencies (inverse Lanczos), struck by a
    /// hammer and listened to at its first mass.
    #[command(after_help = "Examples:
  cordis design chain --freqs 150,300,450,600 --ends fixed-free -o chain.cordis
  cordis design chain --freqs 150,300,450 --amps 1,0.5,0.25 --decay 2s --damping ground --ends fixed-fixed -o c.cordis
  cordis design chain --freqs @partials.txt --ends free-free -o bar.cordis

Frequencies in Hz (a bare number is Hz; 440Hz and 0.44kHz work too), sorted, distinct, below
Fs/2. Amplitudes are those heard at the first mass for an impulse at the first mass (relative;
default equal). The report re-analyses the model as written and compares it with the targets.")]
    Chain(DesignChainArgs),
    /// Tune some `let` values of any model so that its lowest modes reach target frequencies
    /// (Levenberg-Marquardt with continuation from the model's own frequencies).
    #[command(after_help = "Examples:
  cordis design fit model.cordis --freqs 110,220,330 --free k1,k2,k3 -o tuned.cordis
  cordis design fit model.cordis --freqs @targets.txt --free 'k*' -o tuned.cordis

The N lowest modes of the model (N targets) are matched in order. The tuned model is the
original file with the free `let` lines rewritten; it is written only when the fit converges
(exit code 3 otherwise).")]
    Fit(DesignFitArgs),
    /// Estimate the modes of a recording and build a chain that makes them; render the chain and
    /// draw the two spectra side by side.
    #[command(after_help = "Examples:
  cordis design from-audio bell.wav --modes 12 -o bell.cordis --plot bell_compare.png

Writes the model (-o), its render (--render, default: the model's name with .wav, normalised)
and, with --plot, the spectra of the recording and of the model with their modes.")]
    FromAudio(DesignAudioArgs),
}

#[derive(Args)]
struct DesignCommon {
    /// Sample rate of the model, Hz.
    #[arg(long, value_name = "HZ", default_value_t = 44100.0)]
    rate: f64,
    /// Duration written in the model (default: 5 decay times within 1..20 s, 2 s undamped).
    #[arg(long, value_name = "TIME", value_parser = design::parse_seconds)]
    duration: Option<f64>,
    /// The model file to write (default: standard output, with the report on standard error).
    #[arg(short, long, value_name = "FILE.cordis")]
    output: Option<PathBuf>,
}

#[derive(Args)]
struct DesignCellArgs {
    /// Frequency (e.g. 440Hz).
    #[arg(long, value_name = "F", value_parser = design::parse_hz)]
    freq: f64,
    /// Decay time of the amplitude to 1/e (e.g. 1.5s); undamped if omitted.
    #[arg(long, value_name = "TAU", value_parser = design::parse_seconds)]
    decay: Option<f64>,
    /// Amplitude of the motion (length units).
    #[arg(
        long,
        value_name = "A",
        default_value_t = 0.5,
        allow_negative_numbers = true
    )]
    amp: f64,
    /// Phase at sample 0, radians (0: the oscillator starts at its amplitude, at rest).
    #[arg(
        long,
        value_name = "P",
        default_value_t = 0.0,
        allow_negative_numbers = true
    )]
    phase: f64,
    /// The mass (the stiffness follows).
    #[arg(long, value_name = "M", conflicts_with = "stiffness")]
    mass: Option<f64>,
    /// The stiffness (the mass follows).
    #[arg(long, value_name = "K")]
    stiffness: Option<f64>,
    #[command(flatten)]
    common: DesignCommon,
}

#[derive(Args)]
struct DesignChainArgs {
    /// Target frequencies, comma-separated (e.g. 150,300,450 or 150Hz,300Hz), or @FILE.
    #[arg(long, value_name = "LIST")]
    freqs: String,
    /// Amplitude of each mode at the first mass, comma-separated, or @FILE (default: equal).
    #[arg(long, value_name = "LIST")]
    amps: Option<String>,
    /// Decay time of the fundamental to 1/e (e.g. 1.5s); undamped if omitted.
    #[arg(long, value_name = "TAU", value_parser = design::parse_seconds)]
    decay: Option<f64>,
    /// How the damping is spread: springs (Z = beta K: higher modes decay faster) or ground
    /// (Z = alpha M to the ground: every mode decays alike).
    #[arg(long, value_enum, default_value_t = DampingArg::Springs)]
    damping: DampingArg,
    /// The chain's ends: the first mass's end, then the last mass's.
    #[arg(long, value_enum, default_value_t = EndsArg::FixedFree)]
    ends: EndsArg,
    /// The first mass (the overall scale of the chain).
    #[arg(long, value_name = "M", default_value_t = 1.0)]
    first_mass: f64,
    /// fixed-fixed chains: the last spring over the first (the free choice of those ends).
    #[arg(long, value_name = "RATIO", default_value_t = 1.0)]
    end_ratio: f64,
    /// free-free chains: the weight of the added 0 Hz mode at the first mass (0..1; default
    /// 1/(N+1)).
    #[arg(long, value_name = "W")]
    rigid_weight: Option<f64>,
    #[command(flatten)]
    common: DesignCommon,
}

#[derive(Args)]
struct DesignFitArgs {
    /// The model to tune.
    model: PathBuf,
    /// Target frequencies, comma-separated, or @FILE.
    #[arg(long, value_name = "LIST")]
    freqs: String,
    /// The `let` values to tune, comma-separated; `k*` names every let starting with k.
    #[arg(long, value_name = "NAMES", value_delimiter = ',', required = true)]
    free: Vec<String>,
    /// Continuation steps from the model's frequencies to the targets.
    #[arg(long, value_name = "N", default_value_t = 10)]
    steps: usize,
    /// Levenberg-Marquardt iterations per step.
    #[arg(long, value_name = "N", default_value_t = 50)]
    max_iterations: usize,
    /// Largest frequency error accepted, Hz.
    #[arg(long, value_name = "HZ", default_value_t = 1e-6)]
    tolerance: f64,
    /// The tuned model to write (default: standard output, with the report on standard error).
    #[arg(short, long, value_name = "FILE.cordis")]
    output: Option<PathBuf>,
}

#[derive(Args)]
struct DesignAudioArgs {
    /// The recording (WAV).
    input: PathBuf,
    /// How many modes to estimate (the strongest).
    #[arg(long, value_name = "N")]
    modes: usize,
    /// Which channel of the file (from 0).
    #[arg(long, default_value_t = 0)]
    channel: usize,
    /// Lowest frequency considered, Hz.
    #[arg(long, value_name = "HZ", value_parser = design::parse_hz)]
    min_freq: Option<f64>,
    /// Highest frequency considered, Hz.
    #[arg(long, value_name = "HZ", value_parser = design::parse_hz)]
    max_freq: Option<f64>,
    /// Skip the attack: start the analysis this far into the recording.
    #[arg(long, value_name = "TIME", default_value = "0", value_parser = design::parse_seconds)]
    start: f64,
    /// The chain's ends.
    #[arg(long, value_enum, default_value_t = EndsArg::FixedFree)]
    ends: EndsArg,
    /// How the damping is spread (see `design chain`).
    #[arg(long, value_enum, default_value_t = DampingArg::Springs)]
    damping: DampingArg,
    /// The model file to write.
    #[arg(short, long, value_name = "FILE.cordis")]
    output: PathBuf,
    /// The model's render (WAV; default: the model's name with .wav).
    #[arg(long, value_name = "OUT.wav")]
    render: Option<PathBuf>,
    /// Draw the spectra of the recording and of the model, with their modes.
    #[arg(long, value_name = "OUT.png")]
    plot: Option<PathBuf>,
}

#[derive(Clone, Copy, clap::ValueEnum)]
enum EndsArg {
    FixedFree,
    FreeFixed,
    FixedFixed,
    FreeFree,
}

impl From<EndsArg> for cordis_design::chain::Ends {
    fn from(e: EndsArg) -> Self {
        use cordis_design::chain::Ends;
        match e {
            EndsArg::FixedFree => Ends::FixedFree,
            EndsArg::FreeFixed => Ends::FreeFixed,
            EndsArg::FixedFixed => Ends::FixedFixed,
            EndsArg::FreeFree => Ends::FreeFree,
        }
    }
}

#[derive(Clone, Copy, clap::ValueEnum)]
enum DampingArg {
    Springs,
    Ground,
}

impl From<DampingArg> for cordis_design::chain::Damping {
    fn from(d: DampingArg) -> Self {
        match d {
            DampingArg::Springs => cordis_design::chain::Damping::Springs,
            DampingArg::Ground => cordis_design::chain::Damping::Ground,
        }
    }
}

/// A list option, or a usage error naming the option.
fn list_arg(flag: &str, s: &str, one: fn(&str) -> Result<f64, String>) -> Result<Vec<f64>, u8> {
    design::parse_list(s, one).map_err(|e| {
        eprintln!("cordis: {flag}: {e}");
        exit::USAGE
    })
}

fn design_command(cmd: &DesignCmd) -> u8 {
    match cmd {
        DesignCmd::Cell(a) => design::cell(&design::CellRequest {
            freq_hz: a.freq,
            decay_s: a.decay,
            amp: a.amp,
            phase_rad: a.phase,
            mass: a.mass,
            stiffness: a.stiffness,
            rate: a.common.rate,
            duration_s: a.common.duration,
            output: a.common.output.as_ref(),
        }),
        DesignCmd::Chain(a) => {
            let freqs = match list_arg("--freqs", &a.freqs, design::parse_hz) {
                Ok(f) => f,
                Err(c) => return c,
            };
            let amps = match a
                .amps
                .as_deref()
                .map(|s| list_arg("--amps", s, design::parse_number))
            {
                Some(Err(c)) => return c,
                Some(Ok(v)) => Some(v),
                None => None,
            };
            design::chain(&design::ChainRequest {
                freqs_hz: freqs,
                amps,
                decay_s: a.decay,
                damping: a.damping.into(),
                ends: a.ends.into(),
                first_mass: a.first_mass,
                end_ratio: a.end_ratio,
                rigid_weight: a.rigid_weight,
                rate: a.common.rate,
                duration_s: a.common.duration,
                output: a.common.output.as_ref(),
                origin: "Targets given on the command line.".into(),
            })
        }
        DesignCmd::Fit(a) => {
            let freqs = match list_arg("--freqs", &a.freqs, design::parse_hz) {
                Ok(f) => f,
                Err(c) => return c,
            };
            design::fit(&design::FitRequest {
                model: &a.model,
                freqs_hz: freqs,
                free: a.free.clone(),
                steps: a.steps,
                max_iterations: a.max_iterations,
                tolerance_hz: a.tolerance,
                output: a.output.as_ref(),
            })
        }
        DesignCmd::FromAudio(a) => design::from_audio(&design::AudioRequest {
            input: &a.input,
            channel: a.channel,
            modes: a.modes,
            min_freq_hz: a.min_freq,
            max_freq_hz: a.max_freq,
            start_s: a.start,
            ends: a.ends.into(),
            damping: a.damping.into(),
            output: &a.output,
            render: a.render.as_ref(),
            plot: a.plot.as_ref(),
        }),
    }
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
    /// Engine threads (default: every core, kept only while they step faster than one thread,
    /// timed as the render runs). Used for networks of at least 20,000 modules (100,000 without
    /// locality); the output is the same, bit for bit, whatever the number.
    #[arg(long, value_name = "N", value_parser = clap::value_parser!(u32).range(1..=256))]
    threads: Option<u32>,
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
    if let Err(e) = cordis_core::SimdLimit::from_env() {
        eprintln!("cordis: {e}");
        return ExitCode::from(exit::USAGE);
    }
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
        Command::Design(d) => design_command(&d),
        Command::Sweep(a) => sweep::sweep(&sweep::SweepRequest {
            args: &ModelArgs {
                model: a.model.clone(),
                rate: a.rate.clone(),
                duration: a.duration.clone(),
                sets: Vec::new(),
                max_modules: Limits::default().max_modules,
                max_duration: Limits::default().max_duration_s,
                max_rate: Limits::default().max_rate,
            },
            axes: a.sets.clone(),
            dir: &a.output,
            threads: a.threads,
            normalize: a.normalize,
            sample_format: a.sample_format,
        }),
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
