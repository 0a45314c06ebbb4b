//! Spectrograms: from the CLI's options to `cordis-plot`.

use std::path::Path;

use anyhow::{Context, Result};
use cordis_plot::SpectrogramOptions;

use crate::SpecArgs;

impl SpecArgs {
    /// The plot crate's options, with a title.
    pub fn options(&self, title: String) -> SpectrogramOptions {
        SpectrogramOptions {
            window: self.window,
            hop: self.hop.unwrap_or((self.window / 4).max(1)),
            max_freq: self.max_freq,
            min_freq: self.min_freq,
            log_freq: self.log_freq,
            db_range: self.db_range,
            width: self.size.0,
            height: self.size.1,
            title: Some(title),
        }
    }
}

/// Draws `samples` to `path` (`cordis-plot` writes a temporary file and renames it when complete).
pub fn draw(samples: &[f64], rate: f64, spec: &SpecArgs, title: String, path: &Path) -> Result<()> {
    cordis_plot::spectrogram_png(samples, rate, &spec.options(title), path)
        .with_context(|| format!("cannot draw the spectrogram {}", path.display()))?;
    Ok(())
}

/// Reads one channel of a WAV file as f64 samples, and its rate.
pub fn read_wav_channel(path: &Path, channel: usize) -> Result<(Vec<f64>, f64)> {
    // a spectrogram of up to an hour at 192 kHz
    let (data, rate) =
        cordis_model::read_wav_channel(path, channel, 3600 * 192_000).map_err(|(msg, hint)| {
            anyhow::anyhow!(
                "{}: {msg}{}",
                path.display(),
                hint.map(|h| format!(" (hint: {h})")).unwrap_or_default()
            )
        })?;
    Ok((data, f64::from(rate)))
}
