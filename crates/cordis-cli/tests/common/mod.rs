//! What the black-box CLI tests share: running the real binary in a folder, and checking its exit
//! code with its output shown on failure.
#![allow(dead_code)] // each test file uses its own part

use std::path::Path;
use std::process::{Command, Output};

pub struct Run {
    pub code: i32,
    pub stdout: String,
    pub stderr: String,
}

/// Runs `cordis ARGS` in `dir`.
pub fn cordis(dir: &Path, args: &[&str]) -> Run {
    cordis_with(dir, args, &[])
}

/// Runs `cordis ARGS` in `dir` with the environment variables `vars` set.
pub fn cordis_with(dir: &Path, args: &[&str], vars: &[(&str, &str)]) -> Run {
    let out: Output = Command::new(env!("CARGO_BIN_EXE_cordis"))
        .current_dir(dir)
        .args(args)
        .envs(vars.iter().copied())
        .output()
        .unwrap();
    Run {
        code: out.status.code().unwrap_or(-1),
        stdout: String::from_utf8_lossy(&out.stdout).into_owned(),
        stderr: String::from_utf8_lossy(&out.stderr).into_owned(),
    }
}

/// Asserts a run's exit code, printing its output when it differs.
macro_rules! expect_code {
    ($run:expr, $code:expr) => {{
        let r = &$run;
        assert_eq!(
            r.code, $code,
            "exit code\n--- stdout\n{}\n--- stderr\n{}",
            r.stdout, r.stderr
        );
    }};
}
