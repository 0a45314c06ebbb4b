//! Rendering library diagnostics for a person: codespan snippets on stderr.

use std::io::IsTerminal;

use codespan_reporting::diagnostic::{Diagnostic as Cs, Label};
use codespan_reporting::files::SimpleFile;
use codespan_reporting::term::{
    self,
    termcolor::{ColorChoice, StandardStream},
};
use cordis_model::{Diagnostic, LoadError, Severity};

/// Prints diagnostics that point into `source` (the model file at `path`).
pub fn emit(path: &std::path::Path, source: &str, diags: &[Diagnostic]) {
    let file = SimpleFile::new(path.display().to_string(), source);
    let choice = if std::io::stderr().is_terminal() {
        ColorChoice::Auto
    } else {
        ColorChoice::Never
    };
    let stream = StandardStream::stderr(choice);
    let config = term::Config::default();
    for d in diags {
        let mut cs = match d.severity {
            Severity::Error => Cs::error(),
            Severity::Warning => Cs::warning(),
        }
        .with_message(&d.message);
        if let Some(s) = d.span {
            if s.end <= source.len() && !source.is_empty() {
                cs = cs.with_labels(vec![Label::primary((), s.start..s.end.max(s.start))]);
            }
        }
        let mut notes = Vec::new();
        if let Some(s) = d.span {
            if source.is_empty() {
                notes.push(format!("at {}:{}:{}", path.display(), s.line, s.col));
            }
        } else {
            notes.push(format!("in {}", path.display()));
        }
        if let Some(h) = &d.hint {
            notes.push(format!("hint: {h}"));
        }
        cs = cs.with_notes(notes);
        let mut lock = stream.lock();
        if term::emit_to_write_style(&mut lock, &config, &file, &cs).is_err() {
            eprintln!("{}", d);
        }
    }
}

/// Prints a load failure: every error, then the warnings.
pub fn emit_load_error(e: &LoadError) {
    emit(&e.path, &e.source, &e.diagnostics);
    let n = e.errors().count();
    eprintln!(
        "cordis: {} error{} in {}",
        n,
        if n == 1 { "" } else { "s" },
        e.path.display()
    );
}
