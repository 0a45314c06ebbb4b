//! Renders a synthetic test figure: a decaying chord with harmonics, then an exponential chirp.
//!
//! `cargo run -p cordis-plot --example spectro_example -- out.png [--log] [--size WxH] [--seconds S]`
use std::f64::consts::PI;
use std::path::PathBuf;

use cordis_plot::{spectrogram_png, SpectrogramOptions};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut args = std::env::args().skip(1);
    let path = PathBuf::from(args.next().unwrap_or_else(|| "spectro_example.png".into()));
    let rest: Vec<String> = args.collect();
    let log_freq = rest.iter().any(|a| a == "--log");
    let value = |flag: &str| {
        rest.iter()
            .position(|a| a == flag)
            .and_then(|i| rest.get(i + 1))
            .cloned()
    };
    let (width, height) = match value("--size") {
        Some(s) => {
            let (w, h) = s.split_once('x').ok_or("--size takes WxH")?;
            (w.parse()?, h.parse()?)
        }
        None => (1200, 600),
    };
    let seconds: f64 = value("--seconds").map_or(Ok(4.0), |s| s.parse())?;
    let rate = 48_000.0;
    let n = (seconds * rate) as usize;
    let mut x = vec![0.0; n];
    // A major chord struck at t = 0.1 s, each note with six decaying harmonics.
    for f0 in [220.0, 277.18, 329.63] {
        for h in 1..=6 {
            let f = f0 * h as f64;
            let amp = 0.2 / h as f64;
            let tau = 1.2 / h as f64;
            for (i, s) in x.iter_mut().enumerate().skip((0.1 * rate) as usize) {
                let t = i as f64 / rate - 0.1;
                *s += amp * (-t / tau).exp() * (2.0 * PI * f * t).sin();
            }
        }
    }
    // An exponential chirp from 100 Hz to 12 kHz between 2 s and 3.8 s.
    let (t0, t1, f_a, f_b) = (2.0, 3.8, 100.0f64, 12_000.0f64);
    let k = (f_b / f_a).ln() / (t1 - t0);
    for (i, s) in x.iter_mut().enumerate() {
        let t = i as f64 / rate;
        if (t0..t1).contains(&t) {
            let phase = 2.0 * PI * f_a * (((t - t0) * k).exp() - 1.0) / k;
            *s += 0.1 * phase.sin();
        }
    }
    let opts = SpectrogramOptions {
        log_freq,
        max_freq: if log_freq { None } else { Some(16_000.0) },
        width,
        height,
        title: Some("decaying A major chord, then a 100 Hz to 12 kHz chirp".into()),
        ..Default::default()
    };
    let start = std::time::Instant::now();
    let spec = spectrogram_png(&x, rate, &opts, &path)?;
    println!(
        "{}: {} columns x {} bins in {:.2?}",
        path.display(),
        spec.times_s.len(),
        spec.freqs_hz.len(),
        start.elapsed()
    );
    Ok(())
}
