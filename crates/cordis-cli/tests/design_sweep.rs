//! `cordis design` and `cordis sweep` as a user runs them, in temporary folders.
#![allow(clippy::unwrap_used)] // tests may panic on failure

#[macro_use]
mod common;

use std::path::Path;

use common::cordis;

fn wav(path: &Path) -> (Vec<f32>, u32) {
    let mut rd = hound::WavReader::open(path).unwrap();
    let rate = rd.spec().sample_rate;
    (rd.samples::<f32>().map(Result::unwrap).collect(), rate)
}

const SWEPT: &str = "rate 8000\nduration 50ms\nlet k = 0.05\nlet z = 1e-4\nsol g\nmas m M=1 X0=0.5\nref r g m K=k Z=z\nsox o m\n";

#[test]
fn sweep_renders_every_variant_with_a_summary() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("osc.cordis"), SWEPT).unwrap();
    let r = cordis(
        dir.path(),
        &[
            "sweep",
            "osc.cordis",
            "--set",
            "k=0.01..0.09:3",
            "--set",
            "z=0,1e-3",
            "-o",
            "out",
        ],
    );
    expect_code!(r, 0);
    let out = dir.path().join("out");
    let mut files: Vec<String> = std::fs::read_dir(&out)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    files.sort();
    assert_eq!(
        files,
        [
            "index.csv",
            "osc_0.wav",
            "osc_1.wav",
            "osc_2.wav",
            "osc_3.wav",
            "osc_4.wav",
            "osc_5.wav"
        ]
    );
    // each variant is the model rendered with its values: compare with `render --set`
    let index = std::fs::read_to_string(out.join("index.csv")).unwrap();
    let rows: Vec<&str> = index.lines().collect();
    assert_eq!(rows[0], "index,k,z,status,peak,rms,file,message");
    assert_eq!(rows.len(), 7);
    for (i, row) in rows[1..].iter().enumerate() {
        let f: Vec<&str> = row.split(',').collect();
        assert_eq!(f[3], "ok", "{row}");
        let r = cordis(
            dir.path(),
            &[
                "render",
                "osc.cordis",
                "--set",
                &format!("k={}", f[1]),
                "--set",
                &format!("z={}", f[2]),
                "-o",
                "one.wav",
            ],
        );
        expect_code!(r, 0);
        assert_eq!(
            wav(&dir.path().join("one.wav")).0,
            wav(&out.join(format!("osc_{i}.wav"))).0
        );
    }
    // the first axis varies slowest; the ends are exact
    assert!(rows[1].starts_with("0,1e-2,0,"), "{}", rows[1]);
    assert!(rows[6].starts_with("5,9e-2,1e-3,"), "{}", rows[6]);
    assert!(r.stdout.is_empty() || !r.stdout.contains("invalid"));
}

#[test]
fn sweep_reports_bad_variants_and_bad_grids() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("osc.cordis"), SWEPT).unwrap();
    // an unstable variant: k = 50 blows up (K/M > 4), the others render
    let r = cordis(
        dir.path(),
        &["sweep", "osc.cordis", "--set", "k=0.1,50", "-o", "out"],
    );
    expect_code!(r, 3);
    assert!(r.stdout.contains("blew up"), "{}", r.stdout);
    assert!(dir.path().join("out/osc_0.wav").exists());
    assert!(!dir.path().join("out/osc_1.wav").exists());
    let index = std::fs::read_to_string(dir.path().join("out/index.csv")).unwrap();
    assert!(index.contains("blew up"), "{index}");
    // a value the model refuses: invalid, exit 1
    let r = cordis(
        dir.path(),
        &[
            "sweep",
            "osc.cordis",
            "--set",
            "z=1e-4,banana",
            "-o",
            "out2",
        ],
    );
    expect_code!(r, 1);
    assert!(r.stdout.contains("invalid"), "{}", r.stdout);
    // grid syntax errors are usage errors with a hint
    for bad in ["k=0.1..0.5", "k=1Hz..2s:3", "k=0..1:3:log", "k=1..2:0"] {
        let r = cordis(
            dir.path(),
            &["sweep", "osc.cordis", "--set", bad, "-o", "x"],
        );
        expect_code!(r, 2);
    }
    // a model with errors is reported once, in full
    std::fs::write(dir.path().join("bad.cordis"), "mas m M=\n").unwrap();
    let r = cordis(
        dir.path(),
        &["sweep", "bad.cordis", "--set", "k=1,2", "-o", "x"],
    );
    expect_code!(r, 1);
    assert!(r.stderr.contains("bad.cordis:1:"), "{}", r.stderr);
}

fn modes_of(dir: &Path, model: &str) -> Vec<f64> {
    let r = cordis(dir, &["modes", model, "--json"]);
    expect_code!(r, 0);
    let v: serde_json::Value = serde_json::from_str(&r.stdout).unwrap();
    v["modes"]
        .as_array()
        .unwrap()
        .iter()
        .filter(|m| m["kind"] == "oscillating")
        .map(|m| m["freq_hz"].as_f64().unwrap())
        .collect()
}

#[test]
fn design_cell_and_chain_write_models_that_ring_at_the_targets() {
    let dir = tempfile::tempdir().unwrap();
    let r = cordis(
        dir.path(),
        &[
            "design",
            "cell",
            "--freq",
            "440Hz",
            "--decay",
            "1.5s",
            "-o",
            "a440.cordis",
        ],
    );
    expect_code!(r, 0);
    assert!(r.stdout.contains("wrote a440.cordis"), "{}", r.stdout);
    let f = modes_of(dir.path(), "a440.cordis");
    assert_eq!(f.len(), 1);
    assert!((f[0] - 440.0).abs() < 1e-9, "{f:?}");
    // without -o the model goes to stdout, the report to stderr
    let r = cordis(
        dir.path(),
        &["design", "cell", "--freq", "440", "--decay", "1.5"],
    );
    expect_code!(r, 0);
    assert!(r.stdout.contains("cel cell"), "{}", r.stdout);
    assert!(r.stderr.contains("M = "), "{}", r.stderr);

    let targets = [150.0, 300.0, 450.0, 600.0, 750.0];
    let r = cordis(
        dir.path(),
        &[
            "design",
            "chain",
            "--freqs",
            "150,300,450Hz,600,0.75kHz",
            "--ends",
            "fixed-fixed",
            "--decay",
            "2s",
            "-o",
            "chain.cordis",
        ],
    );
    expect_code!(r, 0);
    assert!(r.stdout.contains("largest frequency error"), "{}", r.stdout);
    let text = std::fs::read_to_string(dir.path().join("chain.cordis")).unwrap();
    assert!(text.contains("mas hammer"), "{text}");
    assert!(text.contains("Command: "), "{text}");
    let f = modes_of(dir.path(), "chain.cordis");
    assert_eq!(f.len(), targets.len());
    for (a, b) in f.iter().zip(targets) {
        assert!((a - b).abs() < 1e-9, "{f:?}");
    }
    // the model renders
    let r = cordis(
        dir.path(),
        &["render", "chain.cordis", "-o", "chain.wav", "--normalize"],
    );
    expect_code!(r, 0);
}

#[test]
fn design_bad_input_is_a_clear_error() {
    let dir = tempfile::tempdir().unwrap();
    for (args, needle) in [
        (vec!["design", "chain", "--freqs", "300,150"], "increasing"),
        (vec!["design", "chain", "--freqs", "150,150"], "twice"),
        (vec!["design", "chain", "--freqs", "0,150"], "0 Hz"),
        (
            vec!["design", "chain", "--freqs", "150,30000"],
            "half the sample rate",
        ),
        (
            vec!["design", "chain", "--freqs", "150,300", "--amps", "1"],
            "amplitude",
        ),
        (
            vec!["design", "chain", "--freqs", "150,300", "--amps", "1,0"],
            "amplitude",
        ),
        (
            vec!["design", "cell", "--freq", "30kHz"],
            "half the sample rate",
        ),
    ] {
        let r = cordis(dir.path(), &args);
        assert!(r.code == 1 || r.code == 2, "{args:?}: {}", r.code);
        let all = format!("{}{}", r.stdout, r.stderr).to_lowercase();
        assert!(all.contains(&needle.to_lowercase()), "{args:?}: {all}");
        assert!(all.contains("hint"), "{args:?}: {all}");
    }
    let r = cordis(dir.path(), &["design", "chain", "--freqs", "1,banana"]);
    expect_code!(r, 2);
}

#[test]
fn design_fit_and_from_audio_as_a_user_runs_them() {
    let dir = tempfile::tempdir().unwrap();
    let model = "rate 44100\nduration 1s\nlet k1 = 0.01\nlet k2 = 0.01\nlet k3 = 0.01\nsol g\nmas m1 M=1\nmas m2 M=1\nmas m3 M=1\nref r1 g m1 K=k1\nref r2 m1 m2 K=k2\nref r3 m2 m3 K=k3\nenf hit m1 signal=impulse(at=0, amp=1)\nsox o m1\n";
    std::fs::write(dir.path().join("three.cordis"), model).unwrap();
    let r = cordis(
        dir.path(),
        &[
            "design",
            "fit",
            "three.cordis",
            "--freqs",
            "100,300,500",
            "--free",
            "k*",
            "-o",
            "tuned.cordis",
        ],
    );
    expect_code!(r, 0);
    assert!(r.stdout.contains("converged"), "{}", r.stdout);
    let tuned = std::fs::read_to_string(dir.path().join("tuned.cordis")).unwrap();
    assert!(
        tuned.contains("ref r2 m1 m2 K=k2"),
        "the rest of the file is kept: {tuned}"
    );
    let f = modes_of(dir.path(), "tuned.cordis");
    for (a, b) in f.iter().zip([100.0, 300.0, 500.0]) {
        assert!((a - b).abs() < 1e-6, "{f:?}");
    }
    // an unknown name: a clear error with a suggestion
    let r = cordis(
        dir.path(),
        &[
            "design",
            "fit",
            "three.cordis",
            "--freqs",
            "100",
            "--free",
            "k4",
        ],
    );
    expect_code!(r, 1);
    assert!(r.stderr.contains("hint"), "{}", r.stderr);

    // from a recording the project renders: a damped chain, then back to a chain
    let r = cordis(
        dir.path(),
        &[
            "design",
            "chain",
            "--freqs",
            "220,470,690,1000",
            "--decay",
            "1s",
            "-o",
            "src.cordis",
        ],
    );
    expect_code!(r, 0);
    let r = cordis(
        dir.path(),
        &["render", "src.cordis", "-o", "src.wav", "--duration", "2s"],
    );
    expect_code!(r, 0);
    let r = cordis(
        dir.path(),
        &[
            "design",
            "from-audio",
            "src.wav",
            "--modes",
            "4",
            "-o",
            "back.cordis",
            "--plot",
            "back.png",
        ],
    );
    expect_code!(r, 0);
    for f in ["back.cordis", "back.wav", "back.png"] {
        assert!(dir.path().join(f).exists(), "{f}: {}", r.stdout);
    }
    let f = modes_of(dir.path(), "back.cordis");
    assert_eq!(f.len(), 4);
    for (a, b) in f.iter().zip([220.0, 470.0, 690.0, 1000.0]) {
        assert!((a - b).abs() < 1e-3, "{f:?}");
    }
}
