//! Renders the mode and response figures from synthetic data: a struck stiff string (decaying
//! partials, two of them undamped) against its predicted modes, and the receptance, mobility
//! and accelerance of a three-mode resonator.
//!
//! `cargo run -p cordis-plot --example figures_example -- modes.png response.png [--log] [--size WxH]`
use std::f64::consts::PI;
use std::path::PathBuf;

use cordis_plot::{
    modes_png, response_png, spectrum, ModeMark, ModesPlotOptions, ResponseCurve,
    ResponsePlotOptions,
};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let modes_path = PathBuf::from(args.first().map_or("modes_example.png", |s| s.as_str()));
    let resp_path = PathBuf::from(args.get(1).map_or("response_example.png", |s| s.as_str()));
    let log_freq = args.iter().any(|a| a == "--log");
    let (width, height) = match args.iter().position(|a| a == "--size") {
        Some(i) => {
            let s = args.get(i + 1).ok_or("--size takes WxH")?;
            let (w, h) = s.split_once('x').ok_or("--size takes WxH")?;
            (w.parse()?, h.parse()?)
        }
        None => (1200, 700),
    };

    // A stiff string: f_n = n f0 sqrt(1 + B n^2); the render is slightly sharp of the
    // prediction, as a discretised string is.
    let rate = 48_000.0;
    let (f0, b) = (196.0, 4e-4);
    let mut modes = Vec::new();
    let mut x = vec![0.0; 48_000];
    for n in 1..=16 {
        let nf = n as f64;
        let f = nf * f0 * (1.0 + b * nf * nf).sqrt();
        let t60 = if n == 5 || n == 11 {
            f64::INFINITY
        } else {
            6.0 / (1.0 + 0.35 * nf * nf)
        };
        modes.push(ModeMark {
            freq_hz: f,
            t60_s: t60,
            label: Some(n.to_string()),
        });
        let played = f * 1.003;
        let decay = if t60.is_finite() { 6.91 / t60 } else { 0.0 };
        let amp = 1.0 / nf;
        for (i, s) in x.iter_mut().enumerate() {
            let t = i as f64 / rate;
            *s += amp * (-decay * t).exp() * (2.0 * PI * played * t).sin();
        }
    }
    let spec = spectrum(&x, rate, 16_384)?;
    let opts = ModesPlotOptions {
        max_freq: if log_freq { None } else { Some(4000.0) },
        log_freq,
        width,
        height,
        title: Some("stiff string: predicted modes against a 1 s render".into()),
        ..Default::default()
    };
    modes_png(&spec, &modes, &opts, &modes_path)?;
    println!("{}", modes_path.display());

    // Three modes: receptance alpha = sum a_k / (w_k^2 - w^2 + 2 i zeta_k w_k w).
    let n = 2000;
    let freqs: Vec<f64> = (0..n)
        .map(|i| 10f64.powf(1.0 + 3.0 * i as f64 / (n - 1) as f64))
        .collect();
    let modes = [(120.0, 0.02, 1.0), (450.0, 0.01, 0.6), (2300.0, 0.03, 0.8)];
    let (mut rec, mut mob, mut acc) = (Vec::new(), Vec::new(), Vec::new());
    for &f in &freqs {
        let w = 2.0 * PI * f;
        let (mut re, mut im) = (0.0, 0.0);
        for (fk, zeta, a) in modes {
            let wk = 2.0 * PI * fk;
            let (dr, di) = (wk * wk - w * w, 2.0 * zeta * wk * w);
            let d2 = dr * dr + di * di;
            re += a * dr / d2;
            im -= a * di / d2;
        }
        let (mag, phase) = ((re * re + im * im).sqrt(), im.atan2(re));
        rec.push((mag, phase));
        mob.push((mag * w, phase + PI / 2.0));
        acc.push((mag * w * w, phase + PI));
    }
    let resp = ResponseCurve {
        freqs_hz: freqs,
        series: vec![
            ("receptance (m/N)".into(), rec),
            ("mobility (m/s/N)".into(), mob),
            ("accelerance (m/s\u{b2}/N)".into(), acc),
        ],
    };
    let opts = ResponsePlotOptions {
        width,
        height,
        title: Some("three-mode resonator, driving point".into()),
        ..Default::default()
    };
    response_png(&resp, &opts, &resp_path)?;
    println!("{}", resp_path.display());
    Ok(())
}
