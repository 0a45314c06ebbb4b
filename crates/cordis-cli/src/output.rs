//! Writing rendered channels: WAV (hound), CSV and raw f64, always through a temporary file that
//! is renamed into place only when everything was written.

use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};

use anyhow::{bail, Context, Result};

/// An output file format, chosen from the file's extension.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Format {
    /// WAV, samples as chosen by [`SampleFormat`].
    Wav,
    /// Text: a header of channel names, one row per sample, 17 significant digits.
    Csv,
    /// Raw little-endian float64, frames interleaved over channels.
    F64,
}

/// WAV sample format.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum SampleFormat {
    /// 16-bit integer PCM.
    I16,
    /// 24-bit integer PCM.
    I24,
    /// 32-bit float.
    F32,
}

impl Format {
    /// The format for a path, from its extension.
    pub fn from_path(p: &Path) -> Result<Format> {
        match p
            .extension()
            .and_then(|e| e.to_str())
            .map(str::to_ascii_lowercase)
            .as_deref()
        {
            Some("wav") => Ok(Format::Wav),
            Some("csv") => Ok(Format::Csv),
            Some("f64") | Some("raw") => Ok(Format::F64),
            _ => bail!(
                "cannot tell the output format of {}: name it .wav, .csv or .f64",
                p.display()
            ),
        }
    }
}

/// A file being written next to its final path and renamed into place when complete; dropped
/// without `commit`, it is removed. A destination that exists and is not a regular file (a device
/// such as `/dev/stdout`, a pipe) is written directly: renaming over it would replace it.
pub struct Pending {
    tmp: PathBuf,
    dest: PathBuf,
    done: bool,
}

impl Pending {
    /// A temporary path beside `dest` (or `dest` itself for a special file).
    pub fn new(dest: &Path) -> Pending {
        if std::fs::metadata(dest).is_ok_and(|m| !m.is_file()) {
            return Pending {
                tmp: dest.to_path_buf(),
                dest: dest.to_path_buf(),
                done: true,
            };
        }
        let name = dest
            .file_name()
            .map(|n| n.to_string_lossy().into_owned())
            .unwrap_or_default();
        let tmp = dest.with_file_name(format!(".{name}.partial-{}", std::process::id()));
        Pending {
            tmp,
            dest: dest.to_path_buf(),
            done: false,
        }
    }

    /// Where to write.
    pub fn path(&self) -> &Path {
        &self.tmp
    }

    /// Moves the finished file into place.
    pub fn commit(mut self) -> Result<()> {
        if self.tmp != self.dest {
            std::fs::rename(&self.tmp, &self.dest).with_context(|| {
                format!("cannot move the finished file to {}", self.dest.display())
            })?;
        }
        self.done = true;
        Ok(())
    }
}

impl Drop for Pending {
    fn drop(&mut self) {
        if !self.done {
            let _ = std::fs::remove_file(&self.tmp);
        }
    }
}

/// Writes interleaved frames as WAV.
pub fn write_wav(
    path: &Path,
    data: &[f64],
    channels: usize,
    rate: u32,
    fmt: SampleFormat,
) -> Result<()> {
    let (bits, sample_format) = match fmt {
        SampleFormat::I16 => (16, hound::SampleFormat::Int),
        SampleFormat::I24 => (24, hound::SampleFormat::Int),
        SampleFormat::F32 => (32, hound::SampleFormat::Float),
    };
    let spec = hound::WavSpec {
        channels: u16::try_from(channels)
            .context("too many channels for a WAV file (at most 65535)")?,
        sample_rate: rate,
        bits_per_sample: bits,
        sample_format,
    };
    let mut w = hound::WavWriter::create(path, spec)
        .with_context(|| format!("cannot create {}", path.display()))?;
    match fmt {
        SampleFormat::F32 => {
            for &v in data {
                w.write_sample(v as f32)?;
            }
        }
        SampleFormat::I16 => {
            for &v in data {
                w.write_sample((v.clamp(-1.0, 1.0) * 32767.0).round() as i16)?;
            }
        }
        SampleFormat::I24 => {
            for &v in data {
                w.write_sample((v.clamp(-1.0, 1.0) * 8_388_607.0).round() as i32)?;
            }
        }
    }
    w.finalize().context("cannot finish the WAV file")?;
    Ok(())
}

/// Writes interleaved frames as CSV with a header of channel names.
pub fn write_csv(path: &Path, data: &[f64], names: &[String]) -> Result<()> {
    let mut w = BufWriter::new(
        File::create(path).with_context(|| format!("cannot create {}", path.display()))?,
    );
    writeln!(w, "{}", names.join(","))?;
    for frame in data.chunks(names.len().max(1)) {
        let mut first = true;
        for v in frame {
            if !first {
                w.write_all(b",")?;
            }
            first = false;
            write!(w, "{v:.16e}")?;
        }
        w.write_all(b"\n")?;
    }
    w.flush()?;
    Ok(())
}

/// Writes interleaved frames as raw little-endian float64.
pub fn write_f64(path: &Path, data: &[f64]) -> Result<()> {
    let mut w = BufWriter::new(
        File::create(path).with_context(|| format!("cannot create {}", path.display()))?,
    );
    for v in data {
        w.write_all(&v.to_le_bytes())?;
    }
    w.flush()?;
    Ok(())
}
