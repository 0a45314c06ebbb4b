//! Typed diagnostics with locations. Rendering (colours, snippets) happens at the CLI edge.

use std::fmt;
use std::path::PathBuf;
use std::sync::Arc;

/// A byte range of a model file, with the 1-based line and column of its start.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub struct Span {
    /// Byte offset of the first byte.
    pub start: usize,
    /// Byte offset one past the last byte.
    pub end: usize,
    /// 1-based line of `start`.
    pub line: usize,
    /// 1-based column (in characters) of `start`.
    pub col: usize,
}

impl Span {
    /// The smallest span covering both.
    pub fn to(self, other: Span) -> Span {
        if other.end >= self.end {
            Span {
                end: other.end,
                ..self
            }
        } else {
            self
        }
    }
}

/// How bad a diagnostic is.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Severity {
    /// The model cannot be used.
    Error,
    /// The model can be used but probably does not do what was meant.
    Warning,
}

/// What kind of problem a diagnostic reports (stable, for tools and tests).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[non_exhaustive]
pub enum ErrorKind {
    /// The text does not follow the grammar.
    Syntax,
    /// The first word of a statement is not a known statement.
    UnknownStatement,
    /// A `key=value` whose key the statement does not take.
    UnknownParameter,
    /// A parameter the statement needs is absent.
    MissingParameter,
    /// A parameter given twice, or two parameters that exclude each other.
    ConflictingParameter,
    /// A name that nothing defines.
    UnknownName,
    /// A name defined twice.
    DuplicateName,
    /// A name that refers to the wrong kind of module (an interaction end that is not material...).
    WrongKind,
    /// A value outside its allowed range (M <= 0, a frequency above Nyquist...).
    OutOfRange,
    /// A value that is NaN or infinite.
    NonFinite,
    /// A malformed curve.
    BadCurve,
    /// A value with a unit of the wrong kind (a frequency where a stiffness is expected...).
    UnitMismatch,
    /// A signal file that cannot be read, or does not fit the model.
    SignalFile,
    /// A limit on model size, duration or rate was exceeded.
    Limit,
    /// The model file itself cannot be read.
    Io,
    /// A warning about something legal but suspicious.
    Suspicious,
}

/// One problem found in a model, with where it is and how to fix it.
#[derive(Clone, Debug, PartialEq)]
pub struct Diagnostic {
    /// Error or warning.
    pub severity: Severity,
    /// The class of problem.
    pub kind: ErrorKind,
    /// What is wrong, in one sentence.
    pub message: String,
    /// Where (absent for problems of the whole file, or of a command-line override).
    pub span: Option<Span>,
    /// How to fix it (a did-you-mean, an allowed range...).
    pub hint: Option<String>,
}

impl Diagnostic {
    /// An error at `span`.
    pub fn error(
        kind: ErrorKind,
        span: impl Into<Option<Span>>,
        message: impl Into<String>,
    ) -> Diagnostic {
        Diagnostic {
            severity: Severity::Error,
            kind,
            message: message.into(),
            span: span.into(),
            hint: None,
        }
    }

    /// A warning at `span`.
    pub fn warning(span: impl Into<Option<Span>>, message: impl Into<String>) -> Diagnostic {
        Diagnostic {
            severity: Severity::Warning,
            kind: ErrorKind::Suspicious,
            message: message.into(),
            span: span.into(),
            hint: None,
        }
    }

    /// The same diagnostic with a hint.
    pub fn with_hint(mut self, hint: impl Into<String>) -> Diagnostic {
        self.hint = Some(hint.into());
        self
    }

    /// The same diagnostic with a hint if there is one.
    pub fn with_hint_opt(mut self, hint: Option<String>) -> Diagnostic {
        if hint.is_some() {
            self.hint = hint;
        }
        self
    }
}

/// Why a model could not be loaded: every error found (warnings too), and the text they point
/// into, so that the caller can render snippets.
#[derive(Clone, Debug)]
pub struct LoadError {
    /// The model file (or a name given to the text).
    pub path: PathBuf,
    /// The model's text (empty if the file could not be read).
    pub source: Arc<str>,
    /// Errors first, then warnings, each in file order.
    pub diagnostics: Vec<Diagnostic>,
}

impl LoadError {
    /// The errors only.
    pub fn errors(&self) -> impl Iterator<Item = &Diagnostic> {
        self.diagnostics
            .iter()
            .filter(|d| d.severity == Severity::Error)
    }
}

impl fmt::Display for Diagnostic {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let sev = match self.severity {
            Severity::Error => "error",
            Severity::Warning => "warning",
        };
        write!(f, "{sev}: {}", self.message)?;
        if let Some(h) = &self.hint {
            write!(f, " (hint: {h})")?;
        }
        Ok(())
    }
}

impl fmt::Display for LoadError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let mut first = true;
        for d in self.errors() {
            if !first {
                writeln!(f)?;
            }
            first = false;
            match d.span {
                Some(s) => write!(f, "{}:{}:{}: {d}", self.path.display(), s.line, s.col)?,
                None => write!(f, "{}: {d}", self.path.display())?,
            }
        }
        Ok(())
    }
}

impl std::error::Error for LoadError {}

/// The closest candidate to `word`, if close enough to suggest: one edit away, or similar by the
/// Jaro-Winkler measure (case-insensitive).
pub fn did_you_mean<'a>(
    word: &str,
    candidates: impl IntoIterator<Item = &'a str>,
) -> Option<String> {
    let w = word.to_ascii_lowercase();
    let mut best: Option<((usize, f64), &str)> = None;
    for c in candidates {
        let lc = c.to_ascii_lowercase();
        let edits = strsim::levenshtein(&w, &lc);
        let score = strsim::jaro_winkler(&w, &lc);
        if edits > 1 && score < 0.8 {
            continue;
        }
        let key = (edits.min(2), -score);
        // ties go to the alphabetically first candidate, so the hint never depends on hash order
        let better = match best {
            None => true,
            Some((b, bc)) => {
                key.0 < b.0 || (key.0 == b.0 && (key.1 < b.1 || (key.1 == b.1 && c < bc)))
            }
        };
        if better {
            best = Some(((key.0, key.1), c));
        }
    }
    best.map(|(_, c)| format!("did you mean `{c}`?"))
}
