//! Every class of bad input gives an error with a location, a message and a hint; none panics.
#![allow(clippy::unwrap_used)] // tests and benches may panic on failure

use cordis_model::{load_str, Diagnostic, ErrorKind, Limits, Options};

fn errors_with(text: &str, opts: &Options) -> Vec<Diagnostic> {
    match load_str("bad.cordis".as_ref(), text, opts) {
        Ok(_) => panic!("expected an error for:\n{text}"),
        Err(e) => e.errors().cloned().collect(),
    }
}

fn first_error(text: &str) -> Diagnostic {
    errors_with(text, &Options::default()).remove(0)
}

/// Asserts kind, line:col, a message fragment and a hint fragment.
fn check(d: &Diagnostic, kind: ErrorKind, line: usize, col: usize, msg: &str, hint: &str) {
    assert_eq!(d.kind, kind, "{d:?}");
    let s = d.span.unwrap_or_else(|| panic!("no span: {d:?}"));
    assert_eq!((s.line, s.col), (line, col), "{d:?}");
    assert!(
        d.message.contains(msg),
        "message {:?} lacks {msg:?}",
        d.message
    );
    let h = d.hint.clone().unwrap_or_default();
    assert!(h.contains(hint), "hint {h:?} lacks {hint:?}");
}

#[test]
fn unknown_statement_suggests_the_keyword() {
    let d = first_error("mas m1 M=1\nmass m2 M=1\n");
    check(
        &d,
        ErrorKind::UnknownStatement,
        2,
        1,
        "unknown statement `mass`",
        "did you mean `mas`?",
    );
}

#[test]
fn unknown_parameter_suggests_the_key() {
    let d = first_error("mas m1 M=1 XO=1\n");
    check(
        &d,
        ErrorKind::UnknownParameter,
        1,
        12,
        "no parameter `XO`",
        "did you mean `X0`?",
    );
}

#[test]
fn missing_and_misspelled_names() {
    let d = first_error("mas mass1 M=1\nsol g\nref r g mas1 K=0.1\n");
    check(
        &d,
        ErrorKind::UnknownName,
        3,
        9,
        "no module is named `mas1`",
        "did you mean `mass1`?",
    );
    let d = first_error("sol g\nref r g m K=0.1\nmas m M=1\n");
    check(
        &d,
        ErrorKind::UnknownName,
        2,
        9,
        "used before it is declared (at line 3)",
        "move its declaration",
    );
    let d = first_error("let k = 0.1\nsol g\nmas m M=1\nref r g m K=kk\n");
    check(
        &d,
        ErrorKind::UnknownName,
        4,
        13,
        "unknown value `kk`",
        "did you mean `k`?",
    );
    let d = first_error("string s n=4 M=1 K=0.1\nsox o s\n");
    check(&d, ErrorKind::WrongKind, 2, 7, "whole string", "s[0]");
}

#[test]
fn duplicate_names() {
    let d = first_error("mas m M=1\nmas m M=2\n");
    check(
        &d,
        ErrorKind::DuplicateName,
        2,
        1,
        "`m` is already defined at line 1",
        "own name",
    );
    let d = first_error("let k = 1\nlet k = 2\n");
    check(&d, ErrorKind::DuplicateName, 2, 5, "already defined", "");
}

#[test]
fn interaction_ends_must_be_material_modules() {
    let d = first_error("mas a M=1\nmas b M=1\nres r a b K=0.1\nres r2 a r K=0.1\n");
    check(
        &d,
        ErrorKind::WrongKind,
        4,
        10,
        "end 2 must be a material module",
        "",
    );
    let d = first_error("mas a M=1\nres r a a K=0.1\n");
    check(&d, ErrorKind::WrongKind, 2, 9, "two different modules", "");
    let d = first_error("mas a M=1\nsof f a\n");
    check(&d, ErrorKind::WrongKind, 2, 7, "not an interaction", "sof");
}

#[test]
fn inertia_must_be_positive() {
    let d = first_error("mas m M=0\n");
    check(&d, ErrorKind::OutOfRange, 1, 9, "must be > 0", "sol");
    let d = first_error("cel c M=-1 K=0.1\n");
    check(&d, ErrorKind::OutOfRange, 1, 9, "must be > 0", "sol");
    let d = first_error("mas m X0=1\n");
    check(
        &d,
        ErrorKind::MissingParameter,
        1,
        1,
        "inertia `M` is required",
        "M=1",
    );
}

#[test]
fn non_finite_and_out_of_range_values() {
    let d = first_error("mas m M=1/0\n");
    check(
        &d,
        ErrorKind::NonFinite,
        1,
        9,
        "not finite",
        "division by zero",
    );
    let d = first_error("mas m M=sqrt(-1)\n");
    check(&d, ErrorKind::NonFinite, 1, 9, "not finite", "");
    let d = first_error("mas m M=1\nenf e m signal=sine(freq=440, amp=1)\n");
    check(&d, ErrorKind::OutOfRange, 2, 26, "Nyquist", "440Hz");
    let d = first_error("cel c M=1 f=30kHz\n");
    check(&d, ErrorKind::OutOfRange, 1, 13, "Nyquist", "");
    let d = first_error("duration -1s\n");
    check(&d, ErrorKind::OutOfRange, 1, 10, "must not be negative", "");
    let d = first_error("mas m M=1 V0=1kHz\n");
    check(
        &d,
        ErrorKind::UnitMismatch,
        1,
        14,
        "V0 expects a velocity (m/s), but this is a frequency (Hz)",
        "",
    );
}

#[test]
fn malformed_curves() {
    let d = first_error("mas a M=1\nmas b M=1\nlnl l a b LK=[(0,0) (1,1) (0.5,2)]\n");
    check(
        &d,
        ErrorKind::BadCurve,
        3,
        27,
        "smaller abscissa",
        "smallest abscissa",
    );
    let d = first_error("mas a M=1\nmas b M=1\nlnl l a b LK=[(0,0) 3]\n");
    check(&d, ErrorKind::BadCurve, 3, 21, "must be (x, y)", "");
    let d = first_error("mas a M=1\nmas b M=1\nlnl l a b LK=3\n");
    check(&d, ErrorKind::BadCurve, 3, 14, "must be a curve", "");
    let d = first_error("mas a M=1\nmas b M=1\nlnl l a b LK=[(0,0) (1,1)\n");
    check(&d, ErrorKind::Syntax, 3, 26, "expected", "");
}

#[test]
fn unreadable_or_unfit_signal_files() {
    let dir = tempfile::tempdir().unwrap();
    let spec = hound::WavSpec {
        channels: 1,
        sample_rate: 48000,
        bits_per_sample: 16,
        sample_format: hound::SampleFormat::Int,
    };
    let mut w = hound::WavWriter::create(dir.path().join("f48.wav"), spec).unwrap();
    w.write_sample(0i16).unwrap();
    w.finalize().unwrap();
    std::fs::write(dir.path().join("bad.csv"), "1\n2\nthree\n").unwrap();
    std::fs::write(dir.path().join("junk.wav"), "not a wav").unwrap();
    let load = |body: &str| {
        let p = dir.path().join("m.cordis");
        std::fs::write(&p, format!("mas m M=1\n{body}\nsox o m\n")).unwrap();
        match cordis_model::load_file(&p, &Options::default()) {
            Ok(_) => panic!("expected an error"),
            Err(e) => e.errors().next().cloned().unwrap(),
        }
    };
    let d = load("enf e m signal=file(\"missing.wav\")");
    check(&d, ErrorKind::SignalFile, 2, 21, "missing.wav", "");
    let d = load("enf e m signal=file(\"f48.wav\")");
    check(
        &d,
        ErrorKind::SignalFile,
        2,
        21,
        "48000 Hz but the model runs at 44100 Hz",
        "rate 48000",
    );
    let d = load("enf e m signal=file(\"bad.csv\")");
    check(
        &d,
        ErrorKind::SignalFile,
        2,
        21,
        "line 3: `three` is not a number",
        "one number per line",
    );
    let d = load("enf e m signal=file(\"junk.wav\")");
    check(
        &d,
        ErrorKind::SignalFile,
        2,
        21,
        "cannot read it as WAV",
        "",
    );
    let d = load("enf e m signal=file(\"f48.wav\", channel=3)");
    assert_eq!(d.kind, ErrorKind::SignalFile);
    let d = load("enf e m signal=sinus(freq=2Hz)");
    check(
        &d,
        ErrorKind::UnknownName,
        2,
        16,
        "unknown signal `sinus`",
        "did you mean `sine`?",
    );
}

#[test]
fn limits_are_enforced_before_allocating() {
    let d = first_error("string s n=1e9 M=1 K=0.1\n");
    check(
        &d,
        ErrorKind::Limit,
        1,
        12,
        "above the module limit",
        "--max-modules",
    );
    let opts = Options {
        limits: Limits {
            max_modules: 10,
            ..Limits::default()
        },
        ..Options::default()
    };
    let d = errors_with("string s n=8 M=1 K=0.1\n", &opts).remove(0);
    check(
        &d,
        ErrorKind::Limit,
        1,
        1,
        "the limit is 10",
        "--max-modules",
    );
    let d = first_error("duration 3600s\n");
    check(
        &d,
        ErrorKind::Limit,
        1,
        10,
        "above the limit of 600 s",
        "--max-duration",
    );
    let d = first_error("rate 1e9\n");
    check(&d, ErrorKind::Limit, 1, 6, "above the limit", "--max-rate");
    let d = first_error("membrane m rows=100000 cols=100000 M=1 K=0.1\n");
    assert_eq!(d.kind, ErrorKind::Limit);
}

#[test]
fn syntax_errors_point_at_the_text() {
    let d = first_error("mas m M=1 $\n");
    check(&d, ErrorKind::Syntax, 1, 11, "unexpected character `$`", "");
    let d = first_error("enf e m signal=file(\"x.wav)\n");
    check(&d, ErrorKind::Syntax, 1, 21, "unterminated string", "");
    let d = first_error("mas m M=1 K\n");
    check(&d, ErrorKind::Syntax, 1, 11, "expected a parameter", "");
    let d = first_error("mas m M=3furlongs\n");
    check(&d, ErrorKind::Syntax, 1, 10, "unknown unit `furlongs`", "");
    let d = first_error("ref r a M=1\n");
    check(
        &d,
        ErrorKind::Syntax,
        1,
        1,
        "takes 3 names",
        "ref NAME END1 END2",
    );
}

#[test]
fn command_line_overrides_are_checked() {
    let opts = Options {
        sets: vec![("kk".into(), "1".into())],
        ..Options::default()
    };
    let d = errors_with("let k = 1\n", &opts).remove(0);
    assert_eq!(d.kind, ErrorKind::UnknownName);
    assert!(d.message.contains("--set kk"));
    assert!(d.hint.unwrap().contains("did you mean `k`?"));
    let opts = Options {
        duration: Some("2 furlongs".into()),
        ..Options::default()
    };
    let d = errors_with("mas m M=1\n", &opts).remove(0);
    assert!(d.message.contains("--duration"), "{d:?}");
    let opts = Options {
        rate: Some("0".into()),
        ..Options::default()
    };
    let d = errors_with("mas m M=1\n", &opts).remove(0);
    assert_eq!(d.kind, ErrorKind::OutOfRange);
}

#[test]
fn several_errors_are_reported_at_once_without_cascades() {
    let errs = errors_with(
        "mas a M=0\nmas b M=1\nref r a b K=0.1\nmas c M=-2\nsox o zz\n",
        &Options::default(),
    );
    // `a` failed: the ref that uses it is not reported again
    let lines: Vec<usize> = errs.iter().map(|d| d.span.unwrap().line).collect();
    assert_eq!(lines, [1, 4, 5]);
}

/// A small deterministic generator, so the test needs no RNG crate.
struct Lcg(u64);
impl Lcg {
    fn next(&mut self) -> u64 {
        self.0 = self
            .0
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        self.0 >> 33
    }
}

#[test]
fn hostile_text_never_panics_or_hangs() {
    let valid = "rate 44100\nduration 10ms\nlet k = 0.1\nmas m1 M=1 X0=0 V0=0\nsol g X0=0\ncel c M=1 K=0.01 Z=1e-5 X0=1\nref r g m1 K=k Z=1e-4\nbut b m1 c K=0.05 Z=0.001 S=0.1\nlnl l m1 c LK=[(-1,0) (-1,-0.05) (1,0.05) (1,0)]\nenf push m1 signal=impulse(at=0, amp=1)\nenx hand signal=sine(freq=2Hz, amp=1)\nstring s n=4 M=1 K=0.1 ends=fixed,free\nmembrane mem rows=2 cols=2 M=1 K=0.1\nsox out s[3]\nsof f r\nstick st m1 c KL=0.1 S=0.1\nbond bd m1 s[0] mC=0.1 KL=0.1 S=0.1 KR=0.01 X1=-1\nsox mix 0.5*m1 - (2*k)*bd.MC1 + s[2]\nsof fs st.L + bd.R\n";
    assert!(load_str("ok.cordis".as_ref(), valid, &Options::default()).is_ok());
    let alphabet: Vec<char> = "abcdefmnrsxz019 .,=()[]+-*/^#\"\n\t_KMXZS"
        .chars()
        .collect();
    let mut rng = Lcg(1234);
    let start = std::time::Instant::now();
    for _ in 0..3000 {
        let mut text: Vec<char> = valid.chars().collect();
        for _ in 0..(1 + rng.next() % 8) {
            let pos = (rng.next() as usize) % (text.len() + 1);
            match rng.next() % 3 {
                0 if pos < text.len() => {
                    text.remove(pos);
                }
                1 => text.insert(pos, alphabet[(rng.next() as usize) % alphabet.len()]),
                _ if pos < text.len() => {
                    text[pos] = alphabet[(rng.next() as usize) % alphabet.len()]
                }
                _ => {}
            }
        }
        let s: String = text.into_iter().collect();
        // Ok or Err are both fine; a panic fails the test.
        if let Ok(m) = load_str("fuzz.cordis".as_ref(), &s, &Options::default()) {
            let mut e = m.compile();
            let mut out = vec![0.0; 64 * e.channels()];
            let _ = e.process(64, &mut out);
        }
    }
    // a loose bound that only a hang or an explosion of work would break
    assert!(start.elapsed().as_secs() < 120);
}

#[test]
fn did_you_mean_is_deterministic() {
    // `m1` and `m2` are equally close to `m3`: the hint must not depend on hash order.
    let text = "mas m1 M=1\nmas m2 M=1\nref spring m1 m3 K=0.01\n";
    for _ in 0..20 {
        let d = first_error(text);
        assert_eq!(d.hint.as_deref(), Some("did you mean `m1`?"));
    }
}

#[test]
fn adding_different_units_is_refused() {
    let d = first_error("mas a M=1\nmas b M=1\nres r a b K=1N/m + 1Hz\n");
    check(
        &d,
        ErrorKind::UnitMismatch,
        3,
        13,
        "a stiffness (N/m) and a frequency (Hz)",
        "",
    );
}

#[test]
fn nyquist_hint_fits_what_was_written() {
    let d = first_error("cel c M=1 f=22050Hz\n");
    let h = d.hint.unwrap();
    assert!(
        h.contains("raise the rate above 44100 Hz") && !h.contains("with a unit"),
        "{h}"
    );
    let d = first_error("cel c M=1 f=0.7\n");
    assert!(d.hint.unwrap().contains("0.7Hz"));
    let d = first_error("mas m M=1\nenf e m signal=sine(freq=30kHz)\n");
    assert!(d.hint.unwrap().contains("raise the rate"));
}

#[test]
fn a_failed_let_is_reported_once() {
    let opts = Options {
        sets: vec![("k".into(), "0.3".into())],
        ..Options::default()
    };
    let errs = errors_with(
        "let k = foo\nmas m M=1 X0=k\nmas n M=1 X0=2*k\nsox o m\n",
        &opts,
    );
    assert_eq!(errs.len(), 1, "{errs:?}");
    check(
        &errs[0],
        ErrorKind::UnknownName,
        1,
        9,
        "unknown value `foo`",
        "",
    );
}

#[test]
fn duration_twice_is_an_error_like_rate_twice() {
    let d = first_error("duration 1s\nduration 2s\n");
    check(
        &d,
        ErrorKind::DuplicateName,
        2,
        1,
        "`duration` is set twice (first at line 1)",
        "",
    );
    let d = first_error("rate 44100\nrate 48000\n");
    check(
        &d,
        ErrorKind::DuplicateName,
        2,
        1,
        "`rate` is set twice (first at line 1)",
        "",
    );
}

#[test]
fn device_and_sum_errors() {
    let d = first_error("sol a\nsol b\nstick st a b KL=0.1 S=0.1\n");
    check(
        &d,
        ErrorKind::WrongKind,
        3,
        1,
        "neither end of this device can move",
        "Z1=",
    );
    let d = first_error("mas a M=1\nmas b M=1\nbond bd a b mC=0.1 KL=0.1 S=0.1 KR=0\n");
    check(&d, ErrorKind::OutOfRange, 3, 1, "KR must be > 0", "");
    let d = first_error("mas a M=1\nmas b M=1\nstick st a b KL=0.1 S=-1\n");
    check(
        &d,
        ErrorKind::OutOfRange,
        3,
        1,
        "threshold S must be > 0",
        "",
    );
    let d = first_error("mas a M=1\nmas b M=1\nbond bd a b KL=0.1 S=0.1 KR=0.01\n");
    check(
        &d,
        ErrorKind::MissingParameter,
        3,
        1,
        "`mC` is required",
        "",
    );
    let d = first_error("mas a M=1\nmas b M=1\nstick st a b KL=0.1 S=0.1 buts=maybe\n");
    check(&d, ErrorKind::Syntax, 3, 32, "expected yes or no", "");
    let d = first_error("mas a M=1\nmas b M=1\nstick st a b KL=0.1 S=0.1\nsox o st\n");
    check(
        &d,
        ErrorKind::WrongKind,
        4,
        7,
        "whole sticking device",
        "st.L",
    );
    let d = first_error("mas a M=1\nres r a a2 K=1\n");
    assert_eq!(d.kind, ErrorKind::UnknownName);
    let d = first_error("mas a M=1\nmas b M=1\nres r a b K=1\nsox o a + r\n");
    check(
        &d,
        ErrorKind::WrongKind,
        4,
        11,
        "what a sox records must be a material module",
        "",
    );
    let d = first_error("mas a M=1\nsox o 2 a\n");
    check(
        &d,
        ErrorKind::Syntax,
        2,
        9,
        "`*` between a gain and the module",
        "",
    );
    let d = first_error("mas a M=1\nsox o a +\n");
    check(&d, ErrorKind::Syntax, 2, 10, "expected a module name", "");
}
