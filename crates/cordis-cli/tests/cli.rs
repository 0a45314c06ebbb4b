//! The `cordis` binary as a black box, run in temporary folders (STYLE.md practice 10).
#![allow(clippy::unwrap_used)] // tests may panic on failure

#[macro_use]
mod common;

use std::path::{Path, PathBuf};
use std::process::Command;

use common::{cordis, cordis_with};

fn write(dir: &Path, name: &str, text: &str) -> PathBuf {
    let p = dir.join(name);
    std::fs::write(&p, text).unwrap();
    p
}

const OSC: &str = "rate 44100\nduration 100ms\nlet k = 0.01\ncel c M=1 f=441Hz tau=1s X0=1\nsol g\nmas m M=1\nref r g m K=k Z=1e-4\nenf hit m signal=impulse(at=0, amp=0.5)\nsox pos c\nsox pm m\nsof force r\n";

fn files_in(dir: &Path) -> Vec<String> {
    let mut v: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    v.sort();
    v
}

#[test]
fn renders_a_wav_with_the_right_header_length_and_peak() {
    let dir = tempfile::tempdir().unwrap();
    write(dir.path(), "osc.cordis", OSC);
    let r = cordis(
        dir.path(),
        &["render", "osc.cordis", "-o", "out.wav", "--normalize"],
    );
    expect_code!(r, 0);
    let mut rd = hound::WavReader::open(dir.path().join("out.wav")).unwrap();
    let spec = rd.spec();
    assert_eq!(
        (spec.channels, spec.sample_rate, spec.bits_per_sample),
        (3, 44100, 32)
    );
    assert_eq!(spec.sample_format, hound::SampleFormat::Float);
    assert_eq!(rd.duration(), 4410);
    let samples: Vec<f32> = rd.samples::<f32>().map(Result::unwrap).collect();
    let peak = samples.iter().fold(0.0f32, |m, v| m.max(v.abs()));
    assert_eq!(peak, 1.0);
    assert!(r.stderr.contains("normalized"), "{}", r.stderr);
    // 16- and 24-bit integer WAV
    for (fmt, bits) in [("i16", 16), ("i24", 24)] {
        let r = cordis(
            dir.path(),
            &[
                "render",
                "osc.cordis",
                "-o",
                "int.wav",
                "--normalize",
                "--sample-format",
                fmt,
            ],
        );
        expect_code!(r, 0);
        let rd = hound::WavReader::open(dir.path().join("int.wav")).unwrap();
        assert_eq!(rd.spec().bits_per_sample, bits);
        assert_eq!(rd.duration(), 4410);
    }
}

#[test]
fn csv_and_f64_hold_the_exact_samples() {
    let dir = tempfile::tempdir().unwrap();
    write(dir.path(), "osc.cordis", OSC);
    expect_code!(
        cordis(dir.path(), &["render", "osc.cordis", "-o", "a.csv"]),
        0
    );
    expect_code!(
        cordis(dir.path(), &["render", "osc.cordis", "-o", "a.f64"]),
        0
    );
    let csv = std::fs::read_to_string(dir.path().join("a.csv")).unwrap();
    let mut lines = csv.lines();
    assert_eq!(lines.next(), Some("pos,pm,force"));
    let rows: Vec<Vec<f64>> = lines
        .map(|l| l.split(',').map(|v| v.parse().unwrap()).collect())
        .collect();
    assert_eq!(rows.len(), 4410);
    let raw = std::fs::read(dir.path().join("a.f64")).unwrap();
    assert_eq!(raw.len(), 4410 * 3 * 8);
    let f: Vec<f64> = raw
        .chunks(8)
        .map(|c| f64::from_le_bytes(c.try_into().unwrap()))
        .collect();
    // 17 significant digits round-trip exactly
    for (i, row) in rows.iter().enumerate() {
        for (c, v) in row.iter().enumerate() {
            assert_eq!(v.to_bits(), f[i * 3 + c].to_bits(), "row {i} col {c}");
        }
    }
    assert_eq!(rows[0][0], 1.0); // sample 0 of a sox is X0
    assert_eq!(rows[1][1], 0.5); // the impulse moved the unit mass by F/M
}

#[test]
fn command_line_overrides_duration_rate_and_lets() {
    let dir = tempfile::tempdir().unwrap();
    write(dir.path(), "osc.cordis", OSC);
    let r = cordis(
        dir.path(),
        &[
            "render",
            "osc.cordis",
            "-o",
            "a.f64",
            "--duration",
            "10",
            "--rate",
            "48kHz",
            "--set",
            "k=0.02",
        ],
    );
    expect_code!(r, 0);
    assert_eq!(
        std::fs::metadata(dir.path().join("a.f64")).unwrap().len(),
        10 * 3 * 8
    );
    let r = cordis(
        dir.path(),
        &["check", "osc.cordis", "--rate", "48000", "--duration", "1s"],
    );
    expect_code!(r, 0);
    assert!(r.stdout.contains("rate          48000 Hz"), "{}", r.stdout);
    assert!(r.stdout.contains("48000 samples"), "{}", r.stdout);
    let r = cordis(dir.path(), &["check", "osc.cordis", "--set", "kk=1"]);
    expect_code!(r, 1);
    assert!(r.stderr.contains("did you mean `k`?"), "{}", r.stderr);
}

#[test]
fn integer_wav_clipping_is_refused_unless_asked() {
    let dir = tempfile::tempdir().unwrap();
    write(
        dir.path(),
        "loud.cordis",
        "duration 100\ncel c M=1 K=0.01 X0=2\nsox o c\n",
    );
    let r = cordis(
        dir.path(),
        &[
            "render",
            "loud.cordis",
            "-o",
            "x.wav",
            "--sample-format",
            "i16",
        ],
    );
    expect_code!(r, 4);
    assert!(r.stderr.contains("would clip"), "{}", r.stderr);
    assert_eq!(files_in(dir.path()), ["loud.cordis"]);
    let r = cordis(
        dir.path(),
        &[
            "render",
            "loud.cordis",
            "-o",
            "x.wav",
            "--sample-format",
            "i16",
            "--allow-clipping",
        ],
    );
    expect_code!(r, 0);
    assert!(r.stderr.contains("clipped"), "{}", r.stderr);
    // float WAV: written, with a loud warning
    let r = cordis(dir.path(), &["render", "loud.cordis", "-o", "f.wav"]);
    expect_code!(r, 0);
    assert!(
        r.stderr.contains("WARNING") && r.stderr.contains("--normalize"),
        "{}",
        r.stderr
    );
}

#[test]
fn a_blow_up_names_the_module_and_time_and_leaves_no_file() {
    let dir = tempfile::tempdir().unwrap();
    write(
        dir.path(),
        "boom.cordis",
        "duration 1s\nsol g\nmas quiet M=1\nmas hot M=1 X0=1\nres spring g hot K=5\nsox o hot\n",
    );
    let r = cordis(dir.path(), &["render", "boom.cordis", "-o", "boom.wav"]);
    expect_code!(r, 3);
    assert!(
        r.stderr.contains("`hot` (mas, declared at boom.cordis:4)"),
        "{}",
        r.stderr
    );
    assert!(r.stderr.contains("non-finite at sample"), "{}", r.stderr);
    assert!(r.stderr.contains("spring (res)"), "{}", r.stderr);
    assert!(r.stderr.contains("K/M < 4"), "{}", r.stderr);
    assert_eq!(
        files_in(dir.path()),
        ["boom.cordis"],
        "no output, no partial file"
    );
    // check says so before rendering, naming the module
    let r = cordis(dir.path(), &["check", "boom.cordis"]);
    expect_code!(r, 3);
    assert!(
        r.stdout.contains("UNSTABLE") && r.stdout.contains("at fault: hot"),
        "{}",
        r.stdout
    );
}

#[test]
fn invalid_models_print_file_line_column_and_hint() {
    let dir = tempfile::tempdir().unwrap();
    write(
        dir.path(),
        "bad.cordis",
        "mas m1 M=1\nsol g\nref r g m2 K=0.1\n",
    );
    let r = cordis(dir.path(), &["render", "bad.cordis", "-o", "x.wav"]);
    expect_code!(r, 1);
    assert!(r.stderr.contains("bad.cordis:3:9"), "{}", r.stderr);
    assert!(r.stderr.contains("no module is named `m2`"), "{}", r.stderr);
    assert!(r.stderr.contains("did you mean `m1`?"), "{}", r.stderr);
    assert_eq!(files_in(dir.path()), ["bad.cordis"]);
    let r = cordis(dir.path(), &["check", "missing.cordis"]);
    expect_code!(r, 1);
    assert!(
        r.stderr.contains("cannot read the model file"),
        "{}",
        r.stderr
    );
    // a model with no outputs renders nothing
    write(dir.path(), "mute.cordis", "mas m M=1\n");
    let r = cordis(dir.path(), &["render", "mute.cordis", "-o", "x.wav"]);
    expect_code!(r, 1);
    assert!(r.stderr.contains("no outputs"), "{}", r.stderr);
}

#[test]
fn usage_errors_exit_2_and_help_has_examples() {
    let dir = tempfile::tempdir().unwrap();
    write(dir.path(), "osc.cordis", OSC);
    expect_code!(
        cordis(dir.path(), &["render", "osc.cordis", "--frobnicate"]),
        2
    );
    let r = cordis(dir.path(), &["render", "osc.cordis", "-o", "out.mp3"]);
    expect_code!(r, 2);
    assert!(r.stderr.contains(".wav, .csv or .f64"), "{}", r.stderr);
    expect_code!(
        cordis(dir.path(), &["render", "osc.cordis", "--set", "novalue"]),
        2
    );
    for cmd in ["render", "check"] {
        let r = cordis(dir.path(), &[cmd, "--help"]);
        expect_code!(r, 0);
        assert!(
            r.stdout.contains("Examples:") && r.stdout.contains("Exit codes"),
            "{}",
            r.stdout
        );
    }
    let r = cordis(dir.path(), &["--help"]);
    assert!(r.stdout.contains("Exit codes"), "{}", r.stdout);
}

/// `CORDIS_SIMD` limits the engine's vector instructions without changing a bit of the output;
/// a value it does not know is a usage error that names the values it may take.
#[test]
fn the_simd_limit_changes_no_bit_and_a_wrong_one_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    write(
        dir.path(),
        "s.cordis",
        "duration 0.2s\nstring s n=100 M=1 K=0.1 Z=1e-4 pluck=(30, 1)\nsox o s[10]\n",
    );
    let mut renders = Vec::new();
    for limit in ["avx512", "avx2", "none"] {
        let out = format!("{limit}.f64");
        let r = cordis_with(
            dir.path(),
            &["render", "s.cordis", "-o", &out],
            &[("CORDIS_SIMD", limit)],
        );
        expect_code!(r, 0);
        renders.push(std::fs::read(dir.path().join(&out)).unwrap());
    }
    assert!(renders[0].len() > 8000 && renders[0].iter().any(|&b| b != 0));
    assert!(renders.iter().all(|r| *r == renders[0]));
    let r = cordis_with(
        dir.path(),
        &["render", "s.cordis", "-o", "x.f64"],
        &[("CORDIS_SIMD", "avx-2")],
    );
    expect_code!(r, 2);
    assert!(
        r.stderr.contains("CORDIS_SIMD is \"avx-2\"") && r.stderr.contains("did you mean avx2?"),
        "{}",
        r.stderr
    );
    assert!(!dir.path().join("x.f64").exists());
}

#[test]
fn no_progress_bar_when_stderr_is_not_a_terminal() {
    let dir = tempfile::tempdir().unwrap();
    write(
        dir.path(),
        "long.cordis",
        "duration 5s\nstring s n=200 M=1 K=0.1 Z=1e-4 pluck=(50, 1)\nsox o s[10]\n",
    );
    let r = cordis(dir.path(), &["render", "long.cordis", "-o", "x.f64"]);
    expect_code!(r, 0);
    assert!(!r.stderr.contains("rendering ["), "{}", r.stderr);
    assert_eq!(r.stderr.lines().count(), 1, "{}", r.stderr);
}

#[test]
fn check_reports_counts_and_verdicts() {
    let dir = tempfile::tempdir().unwrap();
    write(dir.path(), "osc.cordis", OSC);
    let r = cordis(dir.path(), &["check", "osc.cordis"]);
    expect_code!(r, 0);
    for needle in [
        "materials     3: 1 mas, 1 cel, 1 sol, 0 enx",
        "interactions  1: 0 res, 0 fro, 1 ref, 0 but, 0 lnl",
        "inputs        1 enf",
        "outputs       3: pos (sox c), pm (sox m), force (sof r)",
        "stability: stable",
        "cel c:",
        "network (linearised at rest, 2 mobile modules): largest pole radius 0.99997",
    ] {
        assert!(
            r.stdout.contains(needle),
            "missing {needle:?} in\n{}",
            r.stdout
        );
    }
    write(dir.path(), "hot.cordis", "cel c M=1 K=3.9 Z=0.1\nsox o c\n");
    let r = cordis(dir.path(), &["check", "hot.cordis"]);
    expect_code!(r, 3);
    assert!(
        r.stdout.contains("cel c:") && r.stdout.contains("UNSTABLE"),
        "{}",
        r.stdout
    );
}

/// Golden renders: small models rendered to CSV and compared with `tests/data/golden/NAME.csv`
/// within a tolerance of 1e-12 of each channel's peak (renders are bit-exact on one machine; the
/// tolerance leaves room for another platform's `sin`). Regenerate with `CORDIS_BLESS=1`.
#[test]
fn golden_renders() {
    let golden = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/golden");
    let mut checked = 0;
    for entry in std::fs::read_dir(&golden).unwrap() {
        let model = entry.unwrap().path();
        if model.extension().and_then(|e| e.to_str()) != Some("cordis") {
            continue;
        }
        let dir = tempfile::tempdir().unwrap();
        let out = dir.path().join("out.csv");
        let r = cordis(
            dir.path(),
            &[
                "render",
                model.to_str().unwrap(),
                "-o",
                out.to_str().unwrap(),
            ],
        );
        expect_code!(r, 0);
        let expected_path = model.with_extension("csv");
        if std::env::var_os("CORDIS_BLESS").is_some() {
            std::fs::copy(&out, &expected_path).unwrap();
        }
        let parse = |p: &Path| -> (String, Vec<Vec<f64>>) {
            let text = std::fs::read_to_string(p)
                .unwrap_or_else(|e| panic!("{}: {e} (bless with CORDIS_BLESS=1)", p.display()));
            let mut lines = text.lines();
            let header = lines.next().unwrap().to_string();
            (
                header,
                lines
                    .map(|l| l.split(',').map(|v| v.parse().unwrap()).collect())
                    .collect(),
            )
        };
        let (h_got, got) = parse(&out);
        let (h_exp, exp) = parse(&expected_path);
        assert_eq!(h_got, h_exp);
        assert_eq!(got.len(), exp.len());
        let channels = exp[0].len();
        for c in 0..channels {
            let peak = exp
                .iter()
                .fold(0.0f64, |m, r| m.max(r[c].abs()))
                .max(f64::MIN_POSITIVE);
            let (mut worst, mut failing) = (0.0f64, 0usize);
            for (g, e) in got.iter().zip(&exp) {
                let d = (g[c] - e[c]).abs() / peak;
                worst = worst.max(d);
                failing += usize::from(d > 1e-12);
            }
            assert_eq!(
                failing,
                0,
                "{}: channel {c}: {failing} samples off, worst {worst:.3e} of peak",
                model.display()
            );
        }
        checked += 1;
    }
    assert!(checked >= 1, "no golden models found");
}

/// Every example in `examples/` and `examples/instrumentarium/` checks, and renders a short
/// excerpt to WAV.
#[test]
fn examples_check_and_render() {
    let examples = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples");
    let mut n = 0;
    let files = std::fs::read_dir(&examples)
        .unwrap()
        .chain(std::fs::read_dir(examples.join("instrumentarium")).unwrap())
        .map(|e| e.unwrap().path());
    for model in files {
        if model.extension().and_then(|e| e.to_str()) != Some("cordis") {
            continue;
        }
        let dir = tempfile::tempdir().unwrap();
        let m = model.to_str().unwrap();
        let r = cordis(dir.path(), &["check", m]);
        expect_code!(r, 0);
        let r = cordis(
            dir.path(),
            &[
                "render",
                m,
                "-o",
                "x.wav",
                "--duration",
                "300ms",
                "--normalize",
            ],
        );
        expect_code!(r, 0);
        n += 1;
    }
    assert!(
        n >= 11,
        "expected the five examples and the six instrumentarium models, found {n}"
    );
}

#[test]
fn check_into_a_closed_pipe_does_not_panic() {
    use std::io::Read;
    let dir = tempfile::tempdir().unwrap();
    write(dir.path(), "osc.cordis", OSC);
    let mut child = Command::new(env!("CARGO_BIN_EXE_cordis"))
        .current_dir(dir.path())
        .args(["check", "osc.cordis"])
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    drop(child.stdout.take()); // the reader goes away at once, as `| head -0` would
    let status = child.wait().unwrap();
    let mut err = String::new();
    child
        .stderr
        .take()
        .unwrap()
        .read_to_string(&mut err)
        .unwrap();
    assert!(!err.contains("panicked"), "{err}");
    assert_eq!(status.code(), Some(0), "{err}");
}

/// The model of the README's tour checks and renders.
#[test]
fn the_readme_tour_model_works() {
    let readme =
        std::fs::read_to_string(Path::new(env!("CARGO_MANIFEST_DIR")).join("../../README.md"))
            .unwrap();
    let tour = readme.split("## A short tour").nth(1).unwrap();
    let model = tour.split("```").nth(1).unwrap();
    let dir = tempfile::tempdir().unwrap();
    write(dir.path(), "tour.cordis", model);
    expect_code!(cordis(dir.path(), &["check", "tour.cordis"]), 0);
    expect_code!(
        cordis(
            dir.path(),
            &[
                "render",
                "tour.cordis",
                "-o",
                "t.wav",
                "--duration",
                "200ms",
                "--normalize"
            ]
        ),
        0
    );
}

/// Width and height from a PNG's IHDR chunk.
fn png_size(path: &Path) -> (u32, u32) {
    let b = std::fs::read(path).unwrap();
    assert_eq!(
        &b[..8],
        b"\x89PNG\r\n\x1a\n",
        "{} is not a PNG",
        path.display()
    );
    let be = |i: usize| u32::from_be_bytes(b[i..i + 4].try_into().unwrap());
    (be(16), be(20))
}

const STICKY: &str = "duration 2000\nsol g\nmas m M=1 X0=0.15 V0=-1e-3\nstick st g m KL=0.1 S=0.1\nmas ball M=1 X0=0.3 V0=-2e-3\nbut floor g ball K=0.1 Z=1e-3\nlnl drag g ball LZ=[(-1,-1e-6) (0,0) (1,0)] track=yes\nsox o m\nsof f st.L\n";

#[test]
fn render_writes_events_energy_and_a_spectrogram() {
    let dir = tempfile::tempdir().unwrap();
    write(dir.path(), "sticky.cordis", STICKY);
    let r = cordis(
        dir.path(),
        &[
            "render",
            "sticky.cordis",
            "-o",
            "x.wav",
            "--normalize",
            "--events",
            "ev.csv",
            "--energy",
            "en.csv",
            "--energy-every",
            "10",
            "--spectrogram",
            "s.png",
            "--size",
            "640x320",
            "--max-freq",
            "2000",
        ],
    );
    expect_code!(r, 0);
    let ev = std::fs::read_to_string(dir.path().join("ev.csv")).unwrap();
    let rows: Vec<&str> = ev.lines().collect();
    assert_eq!(rows[0], "step,time_s,link,state");
    // the spring catches m when |d| < 0.1 (x from 0.15 at -1e-3 per step: step 50 or 51)
    let st: Vec<&str> = rows
        .iter()
        .filter(|l| l.contains(",st.L,"))
        .copied()
        .collect();
    assert!(st[0].ends_with(",st.L,1"), "{ev}");
    let step: u64 = st[0].split(',').next().unwrap().parse().unwrap();
    assert!((50..=51).contains(&step), "{ev}");
    // the BUTs of the device and the floor are followed too; the drag LNL as asked
    for name in [",st.B1,", ",floor,", ",drag,"] {
        assert!(ev.contains(name), "{name} missing in\n{ev}");
    }
    let en = std::fs::read_to_string(dir.path().join("en.csv")).unwrap();
    let mut lines = en.lines();
    assert_eq!(
        lines.next(),
        Some("step,time_s,kinetic,potential,dissipated,input,total")
    );
    assert_eq!(lines.count(), 200);
    assert_eq!(png_size(&dir.path().join("s.png")), (640, 320));
    // the standalone command draws the WAV
    let r = cordis(
        dir.path(),
        &[
            "spectrogram",
            "x.wav",
            "-o",
            "t.png",
            "--log-freq",
            "--window",
            "512",
        ],
    );
    expect_code!(r, 0);
    assert_eq!(png_size(&dir.path().join("t.png")), (1200, 600));
    let r = cordis(
        dir.path(),
        &["spectrogram", "x.wav", "-o", "u.png", "--channel", "3"],
    );
    expect_code!(r, 1);
    assert!(
        r.stderr.contains("channel 3 does not exist"),
        "{}",
        r.stderr
    );
    let r = cordis(
        dir.path(),
        &["spectrogram", "x.wav", "-o", "u.png", "--size", "10x10"],
    );
    expect_code!(r, 2);
    assert!(!dir.path().join("u.png").exists());
}

#[test]
fn check_reports_each_device() {
    let dir = tempfile::tempdir().unwrap();
    write(
        dir.path(),
        "dev.cordis",
        "sol g\nmas a M=1\nmas b M=1\nbond good a b mC=0.2 KL=0.1 S=0.1 KR=0.05\nsox o a\n",
    );
    let r = cordis(dir.path(), &["check", "dev.cordis"]);
    expect_code!(r, 0);
    assert!(
        r.stdout.contains("device good (bond): Z1 = "),
        "{}",
        r.stdout
    );
    assert!(r.stdout.contains("S_B = 0.400000"), "{}", r.stdout);
    write(
        dir.path(),
        "bad.cordis",
        "sol g\nmas a M=1\nmas b M=1\nbond hot a b mC=0.1 KL=0.1 S=0.1 KR=0.05\nsox o a\n",
    );
    let r = cordis(dir.path(), &["check", "bad.cordis"]);
    expect_code!(r, 3);
    assert!(
        r.stdout.contains("device hot (bond)") && r.stdout.contains("UNSTABLE once connected"),
        "{}",
        r.stdout
    );
    assert!(
        r.stderr.contains("`hot` is unstable once connected"),
        "{}",
        r.stderr
    );
}

/// Writing to a special file (here a FIFO read by another thread; `/dev/stdout` is the everyday
/// case) must write into it, never rename a temporary over it.
#[cfg(unix)]
#[test]
fn outputs_to_a_special_file_are_written_in_place() {
    use std::io::Read;
    let dir = tempfile::tempdir().unwrap();
    write(dir.path(), "sticky.cordis", STICKY);
    let fifo = dir.path().join("events.pipe");
    let made = Command::new("mkfifo").arg(&fifo).status().unwrap();
    assert!(made.success());
    let reader = {
        let fifo = fifo.clone();
        std::thread::spawn(move || {
            let mut s = String::new();
            std::fs::File::open(&fifo)
                .unwrap()
                .read_to_string(&mut s)
                .unwrap();
            s
        })
    };
    let r = cordis(
        dir.path(),
        &[
            "render",
            "sticky.cordis",
            "-o",
            "x.f64",
            "--events",
            "events.pipe",
        ],
    );
    expect_code!(r, 0);
    let text = reader.join().unwrap();
    assert!(
        text.starts_with("step,time_s,link,state\n") && text.contains(",st.L,1"),
        "{text}"
    );
    let kind = std::fs::symlink_metadata(&fifo).unwrap().file_type();
    assert!(!kind.is_file(), "the FIFO is still a FIFO");
}

/// Connections of sticking springs in an events CSV: (time_s, link).
fn connections(csv: &str) -> Vec<(f64, String)> {
    csv.lines()
        .skip(1)
        .filter_map(|l| {
            let f: Vec<&str> = l.split(',').collect();
            (f[2].ends_with(".L") && f[3] == "1").then(|| (f[1].parse().unwrap(), f[2].to_string()))
        })
        .collect()
}

/// The instrumentarium behaves as `docs/INSTRUMENTARIUM.md` reports (a regression anchor for the
/// documented measurements): the (St)ring's devices connect at 0.800, 1.797 and 2.767 s, and the
/// reconfigurable instrument's first 8 s hold 1 + 15 + 3 + 20 events beginning with L1 sticking to
/// R3 at 0.643 s.
#[test]
fn the_instrumentarium_does_what_its_documentation_says() {
    let x = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples/instrumentarium");
    let dir = tempfile::tempdir().unwrap();
    let ring = x.join("string_ring.cordis");
    let r = cordis(
        dir.path(),
        &[
            "render",
            ring.to_str().unwrap(),
            "-o",
            "r.f64",
            "--events",
            "ring.csv",
        ],
    );
    expect_code!(r, 0);
    let c = connections(&std::fs::read_to_string(dir.path().join("ring.csv")).unwrap());
    let firsts: Vec<(f64, &str)> = c
        .iter()
        .filter(|(_, l)| l.ends_with(".S1.L"))
        .map(|(t, l)| (*t, l.as_str()))
        .collect();
    assert_eq!(firsts.len(), 3, "{c:?}");
    for ((t, l), (want_t, want_l)) in firsts.iter().zip([
        (0.7998, "dev1.S1.L"),
        (1.7971, "dev2.S1.L"),
        (2.7671, "dev3.S1.L"),
    ]) {
        assert_eq!(*l, want_l);
        assert!(
            (t - want_t).abs() < 1e-3,
            "{l} at {t} s, documented {want_t} s"
        );
    }
    let reconf = x.join("reconfigurable_8s.cordis");
    let r = cordis(
        dir.path(),
        &[
            "render",
            reconf.to_str().unwrap(),
            "-o",
            "i.f64",
            "--duration",
            "8s",
            "--events",
            "inst.csv",
        ],
    );
    expect_code!(r, 0);
    let text = std::fs::read_to_string(dir.path().join("inst.csv")).unwrap();
    let springs: Vec<&str> = text
        .lines()
        .skip(1)
        .filter(|l| l.split(',').nth(2).is_some_and(|n| n.ends_with(".L")))
        .collect();
    assert_eq!(springs.len(), 39, "{text}");
    let first: Vec<&str> = springs[0].split(',').collect();
    assert!(
        (first[1].parse::<f64>().unwrap() - 0.643).abs() < 1e-3 && first[3] == "1",
        "{}",
        springs[0]
    );
    assert!(
        first[2].contains("L1") && first[2].contains("R3"),
        "{}",
        springs[0]
    );
}

const CHAIN: &str = "string s n=5 M=1 K=0.3 Z=2e-4 ends=fixed,fixed\nenf hit s[1] signal=impulse(at=0, amp=1)\nsox o s[0]\nsox mid s[2]\n";

#[test]
fn modes_matrices_and_response_as_a_user_runs_them() {
    let dir = tempfile::tempdir().unwrap();
    write(dir.path(), "chain.cordis", CHAIN);
    // the table: 5 modes, the first at the closed form of a fixed-fixed chain
    let r = cordis(dir.path(), &["modes", "chain.cordis"]);
    expect_code!(r, 0);
    assert!(
        r.stdout.contains("5 modes of 5 mobile modules") && r.stdout.contains("decoupled"),
        "{}",
        r.stdout
    );
    // closed form: λ1 = 4 K sin²(π/12) for a fixed-fixed chain of 5; proportional damping
    // c = (Z/K) λ makes mode 1 a CEL: r = sqrt(1 - c), cos θ = (2 - λ - c) / (2r), f = θ Fs / 2π
    let lambda = 4.0 * 0.3 * (std::f64::consts::PI / 12.0).sin().powi(2);
    let c = 2e-4 / 0.3 * lambda;
    let theta = ((2.0 - lambda - c) / (2.0 * (1.0 - c).sqrt())).acos();
    let f1 = theta * 44100.0 / std::f64::consts::TAU;
    assert!(
        r.stdout.contains(&format!("{f1:.4}")),
        "{f1:.4} missing in\n{}",
        r.stdout
    );
    // JSON parses and agrees
    let r = cordis(
        dir.path(),
        &["modes", "chain.cordis", "--json", "--plot", "m.png"],
    );
    expect_code!(r, 0);
    let doc: serde_json::Value = serde_json::from_str(&r.stdout).unwrap();
    assert_eq!(doc["modes"].as_array().unwrap().len(), 5);
    assert!((doc["modes"][0]["freq_hz"].as_f64().unwrap() - f1).abs() < 1e-9);
    assert_eq!(doc["outputs"][1], "mid");
    assert!(png_size(&dir.path().join("m.png")).0 >= 240);
    // matrices as JSON and CSV
    let r = cordis(dir.path(), &["matrices", "chain.cordis", "-o", "m.json"]);
    expect_code!(r, 0);
    let mj: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.path().join("m.json")).unwrap()).unwrap();
    assert_eq!(mj["order"][0], "s[0]");
    assert_eq!(mj["K"][0][0].as_f64(), Some(0.6));
    assert_eq!(mj["K"][0][1].as_f64(), Some(-0.3));
    assert_eq!(mj["state_space"]["Ad"].as_array().unwrap().len(), 10);
    let r = cordis(dir.path(), &["matrices", "chain.cordis", "--csv", "mx"]);
    expect_code!(r, 0);
    let k = std::fs::read_to_string(dir.path().join("mx/K.csv")).unwrap();
    assert_eq!(k.lines().count(), 5);
    // response: a peak at the first mode
    let r = cordis(
        dir.path(),
        &[
            "response",
            "chain.cordis",
            "--force-at",
            "s[1]",
            "--listen-at",
            "s[0]",
            "--from",
            "100",
            "--to",
            "2000",
            "--points",
            "2000",
            "-o",
            "r.csv",
            "--plot",
            "r.png",
        ],
    );
    expect_code!(r, 0);
    let rows: Vec<Vec<f64>> = std::fs::read_to_string(dir.path().join("r.csv"))
        .unwrap()
        .lines()
        .skip(1)
        .map(|l| l.split(',').map(|v| v.parse().unwrap()).collect())
        .collect();
    assert_eq!(rows.len(), 2000);
    let best = rows.iter().max_by(|a, b| a[1].total_cmp(&b[1])).unwrap();
    assert!(
        (best[0] - f1).abs() / f1 < 0.01,
        "response peak at {} Hz, first mode {f1}",
        best[0]
    );
}

#[test]
fn analysis_bad_input_is_a_clear_error() {
    let dir = tempfile::tempdir().unwrap();
    write(dir.path(), "chain.cordis", CHAIN);
    write(dir.path(), "empty.cordis", "sol g\nsox o g\n");
    let r = cordis(dir.path(), &["modes", "empty.cordis"]);
    expect_code!(r, 1);
    assert!(r.stderr.contains("no mobile module"), "{}", r.stderr);
    let r = cordis(
        dir.path(),
        &[
            "response",
            "chain.cordis",
            "--force-at",
            "s[9]",
            "--listen-at",
            "s[0]",
        ],
    );
    expect_code!(r, 2);
    assert!(
        r.stderr.contains("`s[9]` is not a module of the model")
            && r.stderr.contains("did you mean"),
        "{}",
        r.stderr
    );
    let r = cordis(
        dir.path(),
        &[
            "response",
            "chain.cordis",
            "--force-at",
            "s.left",
            "--listen-at",
            "s[0]",
        ],
    );
    expect_code!(r, 2);
    assert!(r.stderr.contains("fixed module"), "{}", r.stderr);
    let r = cordis(
        dir.path(),
        &[
            "response",
            "chain.cordis",
            "--force-at",
            "s[1]",
            "--listen-at",
            "s[0]",
            "--to",
            "30000",
        ],
    );
    expect_code!(r, 2);
    assert!(r.stderr.contains("Nyquist"), "{}", r.stderr);
    assert!(!r.stderr.contains("panicked"));
}

#[test]
fn graph_and_spice_exports() {
    let dir = tempfile::tempdir().unwrap();
    write(dir.path(), "chain.cordis", CHAIN);
    let r = cordis(dir.path(), &["graph", "chain.cordis", "-o", "g.dot"]);
    expect_code!(r, 0);
    let dot = std::fs::read_to_string(dir.path().join("g.dot")).unwrap();
    assert!(
        dot.contains("digraph") && dot.contains("\"s[0]\"") && dot.contains("REF"),
        "{dot}"
    );
    let r = cordis(
        dir.path(),
        &[
            "export",
            "spice",
            "chain.cordis",
            "--force-at",
            "s[1]",
            "-o",
            "c.cir",
        ],
    );
    expect_code!(r, 0);
    let cir = std::fs::read_to_string(dir.path().join("c.cir")).unwrap();
    assert!(
        cir.contains(".ac dec") && cir.lines().filter(|l| l.starts_with('C')).count() == 5,
        "{cir}"
    );
    let r = cordis(
        dir.path(),
        &["export", "spice", "chain.cordis", "--force-at", "s[7]"],
    );
    expect_code!(r, 2);
    assert!(r.stderr.contains("did you mean"), "{}", r.stderr);
}

/// A network large enough for the engine's threads renders the same bytes on 1 and 2 threads,
/// and with no `--threads`, where on two cores or more the render times both and changes between
/// them (chunks of at most an eighth of the render, so the trial ends within these 300 frames).
#[test]
fn render_threads_give_the_same_bytes() {
    let dir = tempfile::tempdir().unwrap();
    write(
        dir.path(),
        "big.cordis",
        "rate 44100\nduration 300\nmembrane mem rows=120 cols=120 M=1 K=0.1 Z=0.0001 border=fixed\n\
         enf hit mem[3, 4] signal=impulse(at=0, amp=1)\nsox a mem[60, 61]\nsox b mem[7, 100]\n",
    );
    let mut outputs = Vec::new();
    for t in ["1", "2", "auto"] {
        let out = format!("t{t}.f64");
        let mut args = vec!["render", "big.cordis", "-o", &out, "--block", "37"];
        if t != "auto" {
            args.extend(["--threads", t]);
        }
        let r = cordis(dir.path(), &args);
        expect_code!(r, 0);
        let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
        let timed = r.stderr.contains("cordis: stepped on ");
        assert_eq!(timed, t == "auto" && cores > 1, "{t}: {}", r.stderr);
        outputs.push(std::fs::read(dir.path().join(&out)).unwrap());
    }
    assert_eq!(outputs[0].len(), 300 * 2 * 8);
    assert!(outputs[0].iter().any(|&b| b != 0));
    assert!(outputs[0] == outputs[1], "1 and 2 threads differ");
    assert!(
        outputs[0] == outputs[2],
        "1 thread and the timed threads differ"
    );
}
