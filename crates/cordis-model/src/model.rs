//! Stages 2 and 3, resolve and validate: statements → a checked [`Model`] with a named network.

use std::borrow::Cow;
use std::cell::OnceCell;
use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::sync::Arc;

use cordis_core::{Curve, Engine, Interaction, LinkId, MatId, Material, Network, Probe, Signal};

use crate::devices::{Activity, Device, Tracked};
use crate::error::{did_you_mean, Diagnostic, ErrorKind, LoadError, Severity, Span};
use crate::eval::{Env, Kind, Value};
use crate::names::{Decl, Entity, Names, MAX_INDEX};
use crate::signals;
use crate::syntax::{self, Expr, ExprKind, Param, Ref, Statement, Word};

/// Caps that keep hostile or mistaken input from exhausting memory or time.
#[derive(Clone, Debug, PartialEq)]
pub struct Limits {
    /// Most modules (materials, interactions, inputs and outputs) in one model.
    pub max_modules: usize,
    /// Longest render, in seconds.
    pub max_duration_s: f64,
    /// Highest sample rate, in Hz.
    pub max_rate: f64,
    /// Most points in one curve or envelope.
    pub max_curve_points: usize,
}

impl Default for Limits {
    fn default() -> Limits {
        Limits {
            max_modules: 2_000_000,
            max_duration_s: 600.0,
            max_rate: 1_000_000.0,
            max_curve_points: 10_000,
        }
    }
}

/// How to load a model: command-line overrides and limits.
#[derive(Clone, Debug, Default)]
pub struct Options {
    /// Overrides the model's `rate` (an expression, e.g. `48000` or `48kHz`).
    pub rate: Option<String>,
    /// Overrides the model's `duration` (e.g. `3s` or `132300`).
    pub duration: Option<String>,
    /// `NAME=VALUE` overrides of `let` values, in order.
    pub sets: Vec<(String, String)>,
    /// Size and time caps.
    pub limits: Limits,
}

/// A module's name and the statement that declared it.
#[derive(Clone, Debug, PartialEq)]
pub struct Named {
    /// The name, as other statements refer to it (`m1`, `s[3]`, `mem.h[2,5]`).
    pub name: String,
    /// The declaring statement (for a generated module, the generator's).
    pub span: Span,
}

/// A loaded, resolved and validated model: the network, its names, its rate and duration.
///
/// Only this type can be compiled into an [`Engine`] ([`Model::compile`]), so an engine is never
/// built from unchecked input.
#[derive(Clone, Debug)]
pub struct Model {
    /// The model file.
    pub path: PathBuf,
    /// Its text (for rendering diagnostics).
    pub source: Arc<str>,
    /// Sample rate, Hz.
    pub rate: f64,
    /// Render length, samples.
    pub duration: u64,
    /// The network, in declaration order.
    pub network: Network,
    /// Names of the materials, indexed by `MatId`.
    pub materials: Vec<Named>,
    /// Names of the interactions, indexed by `LinkId`.
    pub links: Vec<Named>,
    /// Names of the force inputs, in order.
    pub forces: Vec<Named>,
    /// Names of the output channels, in order.
    pub outputs: Vec<Named>,
    /// Sticking devices (`stick`, `bond`), in declaration order.
    pub devices: Vec<Device>,
    /// Links whose activity the event log follows: every BUT, every sticking spring, and every
    /// LNL declared with `track=yes`, in declaration order of the links.
    pub tracked: Vec<Tracked>,
    /// Warnings found while loading (never errors: a `Model` has none).
    pub warnings: Vec<Diagnostic>,
}

impl Model {
    /// Compiles the network into a ready-to-step engine.
    pub fn compile(&self) -> Engine {
        Engine::new(&self.network)
    }

    /// The name of a material module.
    pub fn material_name(&self, m: MatId) -> &str {
        &self.materials[m.index()].name
    }

    /// The interactions attached to a material module.
    pub fn links_of(&self, m: MatId) -> Vec<LinkId> {
        (0..self.network.links.len())
            .filter(|&l| self.network.links[l].a == m || self.network.links[l].b == m)
            .map(|l| LinkId(l as u32))
            .collect()
    }
}

/// Loads a model file: parse, resolve, validate.
pub fn load_file(path: &Path, opts: &Options) -> Result<Model, LoadError> {
    match std::fs::read_to_string(path) {
        // one copy of the text while loading: the file's string is dropped once copied
        Ok(text) => load_source(path, Arc::from(text), opts),
        Err(e) => Err(LoadError {
            path: path.to_path_buf(),
            source: Arc::from(""),
            diagnostics: vec![Diagnostic::error(
                ErrorKind::Io,
                None,
                format!("cannot read the model file: {e}"),
            )
            .with_hint("check the path; model files usually end in .cordis")],
        }),
    }
}

/// Loads a model from text; `path` names it in messages and anchors relative signal-file paths.
///
/// The text is read a line at a time: each statement is parsed, resolved and dropped before the
/// next line is read, so no syntax tree of the whole file is ever held (a model of 100,000
/// modules would need hundreds of megabytes for it). A first, cheap pass reads only the first
/// word of every line: to find the `rate` (every unit depends on it) and to count the modules of
/// each kind, so that the network and its names are allocated once, at their final size. As
/// before, a file with syntax errors reports those only.
pub fn load_str(path: &Path, text: &str, opts: &Options) -> Result<Model, LoadError> {
    load_source(path, Arc::from(text), opts)
}

fn load_source(path: &Path, source: Arc<str>, opts: &Options) -> Result<Model, LoadError> {
    let text: &str = &source;
    let mut b = Builder::new(path, opts, text);
    b.begin();
    let mut syntax_errors = Vec::new();
    let mut parser = syntax::LineParser::new();
    for (n, base, line) in syntax::lines(text) {
        match parser.parse_line(line, base, n) {
            Some(Ok(s)) if syntax_errors.is_empty() => b.statement(&s),
            Some(Err(e)) => syntax_errors.push(e),
            _ => {}
        }
    }
    let mut diags = if syntax_errors.is_empty() {
        b.finish();
        std::mem::take(&mut b.diags)
    } else {
        syntax_errors
    };
    let has_errors = diags.iter().any(|d| d.severity == Severity::Error);
    diags.sort_by_key(|d| (d.severity != Severity::Error, d.span.map_or(0, |s| s.start)));
    if has_errors {
        return Err(LoadError {
            path: path.to_path_buf(),
            source: Arc::clone(&source),
            diagnostics: diags,
        });
    }
    let mut net = b.net;
    net.materials.shrink_to_fit();
    net.links.shrink_to_fit();
    net.forces.shrink_to_fit();
    net.outputs.shrink_to_fit();
    let mut names = b.names;
    names.shrink_lists();
    Ok(Model {
        path: path.to_path_buf(),
        source: Arc::clone(&source),
        rate: b.fs,
        duration: b.duration,
        network: net,
        materials: names.materials,
        links: names.links,
        forces: names.forces,
        outputs: names.outputs,
        devices: b.devices,
        tracked: {
            let mut t = b.tracked;
            t.sort_by_key(|t| t.link);
            t
        },
        warnings: diags,
    })
}

pub(crate) struct Builder<'a> {
    pub(crate) path: &'a Path,
    pub(crate) opts: &'a Options,
    /// The whole model text (read again only to say where a name used too early is declared).
    text: &'a str,
    pub(crate) fs: f64,
    pub(crate) duration: u64,
    pub(crate) env: Env,
    pub(crate) net: Network,
    pub(crate) names: Names,
    pub(crate) diags: Vec<Diagnostic>,
    pub(crate) set_used: Vec<bool>,
    /// Names whose declaration failed: references to them are not reported again.
    pub(crate) poisoned: std::collections::HashSet<String>,
    /// Every name a statement declares, with its first line (to say "declared later"): built
    /// from the text the first time a name is not found.
    declared_at: OnceCell<HashMap<String, usize>>,
    /// The line of the first `duration`.
    duration_set: Option<usize>,
    /// Set when resolving stops (the rate is wrong, or too many errors).
    stopped: bool,
    pub(crate) devices: Vec<Device>,
    pub(crate) tracked: Vec<Tracked>,
}

/// The parameters of one statement, taken one by one; what is left over is reported.
///
/// Nothing here allocates for a statement of up to 64 parameters whose code asks for up to 16
/// keys: it is made for every statement of the file.
pub(crate) struct Params<'p> {
    pub(crate) list: &'p [Param],
    /// Which parameters were taken: bit `i` for the first 64, then `used_more[i - 64]`.
    used: u64,
    used_more: Vec<bool>,
    /// The keys asked for, in order (for the hint): the first 16 here, the others in
    /// `accepted_more`.
    accepted: [&'static str; 16],
    n_accepted: usize,
    accepted_more: Vec<&'static str>,
}

impl<'p> Params<'p> {
    fn new(list: &'p [Param]) -> Params<'p> {
        Params {
            list,
            used: 0,
            used_more: vec![false; list.len().saturating_sub(64)],
            accepted: [""; 16],
            n_accepted: 0,
            accepted_more: Vec::new(),
        }
    }

    fn is_used(&self, i: usize) -> bool {
        match i.checked_sub(64) {
            None => self.used & (1 << i) != 0,
            Some(j) => self.used_more.get(j).copied().unwrap_or(false),
        }
    }

    fn set_used(&mut self, i: usize) {
        match i.checked_sub(64) {
            None => self.used |= 1 << i,
            Some(j) => {
                if let Some(u) = self.used_more.get_mut(j) {
                    *u = true;
                }
            }
        }
    }

    /// The keys asked for so far, in order.
    fn accepted(&self) -> Vec<&'static str> {
        let n = self.n_accepted.min(self.accepted.len());
        let mut all = self.accepted[..n].to_vec();
        all.extend_from_slice(&self.accepted_more);
        all
    }

    /// The value of `key` (case-insensitive; `aliases` are other accepted spellings).
    pub(crate) fn get(
        &mut self,
        key: &'static str,
        aliases: &[&'static str],
    ) -> Result<Option<&'p Param>, Diagnostic> {
        match self.accepted.get_mut(self.n_accepted) {
            Some(slot) => {
                *slot = key;
                self.n_accepted += 1;
            }
            None => self.accepted_more.push(key),
        }
        let mut found: Option<&'p Param> = None;
        for (i, p) in self.list.iter().enumerate() {
            let k = p.key.text.as_str();
            if k.eq_ignore_ascii_case(key) || aliases.iter().any(|a| k.eq_ignore_ascii_case(a)) {
                if let Some(prev) = found {
                    return Err(Diagnostic::error(
                        ErrorKind::ConflictingParameter,
                        p.key.span,
                        format!(
                            "`{}` is given twice (first at column {})",
                            p.key.text, prev.key.span.col
                        ),
                    ));
                }
                self.set_used(i);
                found = Some(p);
            }
        }
        Ok(found)
    }

    /// Reports the parameters nobody took.
    pub(crate) fn finish(&self, what: &str) -> Result<(), Diagnostic> {
        self.finish_with(|| what.to_string())
    }

    /// [`Params::finish`] for a statement whose name in messages is made only when needed.
    fn finish_with(&self, what: impl FnOnce() -> String) -> Result<(), Diagnostic> {
        let Some(p) = (0..self.list.len())
            .find(|&i| !self.is_used(i))
            .map(|i| &self.list[i])
        else {
            return Ok(());
        };
        let what = what();
        let accepted = self.accepted();
        let hint = did_you_mean(&p.key.text, accepted.iter().copied())
            .unwrap_or_else(|| format!("{what} takes: {}", accepted.join(", ")));
        Err(Diagnostic::error(
            ErrorKind::UnknownParameter,
            p.key.span,
            format!("{what} has no parameter `{}`", p.key.text),
        )
        .with_hint(hint))
    }
}

pub(crate) type R<T> = Result<T, Diagnostic>;

impl<'a> Builder<'a> {
    fn new(path: &'a Path, opts: &'a Options, text: &'a str) -> Builder<'a> {
        Builder {
            path,
            opts,
            text,
            fs: 44100.0,
            duration: 44100,
            env: Env {
                fs: 44100.0,
                lets: HashMap::new(),
                failed: Default::default(),
            },
            net: Network::new(),
            names: Names::new(),
            diags: Vec::new(),
            set_used: vec![false; opts.sets.len()],
            poisoned: Default::default(),
            declared_at: OnceCell::new(),
            duration_set: None,
            stopped: false,
            devices: Vec::new(),
            tracked: Vec::new(),
        }
    }

    fn cli_error(&mut self, kind: ErrorKind, msg: String, hint: Option<String>) {
        self.diags
            .push(Diagnostic::error(kind, None, msg).with_hint_opt(hint));
    }

    /// Before the statements: the rate (every unit conversion depends on it), and room for the
    /// modules the text declares one per line (generators make room for theirs).
    fn begin(&mut self) {
        let mut rates = Vec::new();
        let mut parser = syntax::LineParser::new();
        let (mut mats, mut links, mut forces, mut outputs) = (0usize, 0usize, 0usize, 0usize);
        for (n, base, line) in syntax::lines(self.text) {
            let word = syntax::first_word(line);
            if word.len() != 3 && word.len() != 4 {
                continue;
            }
            let mut lower = [0u8; 4];
            for (l, c) in lower.iter_mut().zip(word.bytes()) {
                *l = c.to_ascii_lowercase();
            }
            match &lower[..word.len()] {
                b"mas" | b"sol" | b"cel" | b"enx" => mats += 1,
                b"res" | b"fro" | b"ref" | b"but" | b"lnl" => links += 1,
                b"enf" => forces += 1,
                b"sox" | b"sof" => outputs += 1,
                b"rate" => {
                    // a line that does not parse is reported by the main pass, which then
                    // reports nothing else
                    if let Some(Ok(s)) = parser.parse_line(line, base, n) {
                        rates.push(s);
                    }
                }
                _ => {}
            }
        }
        if let Err(e) = self.resolve_rate(&rates) {
            self.diags.push(e);
            self.stopped = true;
            return;
        }
        // the limit bounds what a text can make us allocate; past it, loading fails anyway
        let max = self.opts.limits.max_modules;
        if mats + links + forces + outputs <= max {
            self.net.materials.reserve_exact(mats);
            self.names.materials.reserve_exact(mats);
            self.net.links.reserve_exact(links);
            self.names.links.reserve_exact(links);
            self.net.forces.reserve_exact(forces);
            self.names.forces.reserve_exact(forces);
            self.net.outputs.reserve_exact(outputs);
            self.names.outputs.reserve_exact(outputs);
            self.names.reserve(mats + links + forces + outputs);
        }
    }

    /// Resolves one statement, in file order.
    fn statement(&mut self, s: &Statement) {
        if self.stopped {
            return;
        }
        let r = match s {
            Statement::Let { name, value, .. } => self.let_stmt(name, value),
            Statement::Setting {
                keyword,
                value,
                span,
            } if keyword.text == "duration" => {
                if let Some(first) = self.duration_set {
                    self.diags.push(Diagnostic::error(
                        ErrorKind::DuplicateName,
                        *span,
                        format!("`duration` is set twice (first at line {first})"),
                    ));
                    return;
                }
                self.duration_set = Some(span.line);
                if self.opts.duration.is_none() {
                    self.env
                        .number(value, Kind::Time, "duration")
                        .and_then(|d| self.set_duration(d, value.span.into()))
                } else {
                    Ok(())
                }
            }
            Statement::Setting { .. } => Ok(()), // rate: done
            Statement::Module {
                keyword,
                refs,
                params,
                span,
            } => self.module(keyword, refs, params, *span),
            Statement::Probe {
                keyword,
                name,
                terms,
                params,
                span,
            } => self.probe(keyword, name, terms, params, *span),
        };
        if let Err(e) = r {
            if let Some((w, _)) = declared_name(s) {
                if self.names.get(&w.text).is_none() {
                    self.poisoned.insert(w.text.clone());
                }
            }
            if e.message.is_empty() {
                return; // a reference to a module whose declaration already failed
            }
            self.diags.push(e);
            if self.diags.len() >= 50 {
                self.stopped = true;
            }
        }
    }

    /// After the statements: command-line overrides, and what only the whole model can tell.
    fn finish(&mut self) {
        if self.stopped {
            return;
        }
        if let Some(d) = self.opts.duration.clone() {
            match syntax::parse_expr(&d).and_then(|e| self.env.number(&e, Kind::Time, "--duration"))
            {
                Ok(v) => {
                    if let Err(e) = self.set_duration(v, None) {
                        self.diags.push(e);
                    }
                }
                Err(e) => self.cli_error(
                    e.kind,
                    format!("--duration {d}: {}", e.message),
                    Some("give a time such as 2s, 500ms or 88200 (samples)".into()),
                ),
            }
        } else if self.duration_set.is_none() {
            self.duration = self.fs.round() as u64; // default: one second
        }
        for (i, (name, _)) in self.opts.sets.iter().enumerate() {
            if !self.set_used[i] {
                let hint = did_you_mean(name, self.env.lets.keys().map(String::as_str))
                    .unwrap_or_else(|| {
                        "--set only changes values the model defines with `let`".into()
                    });
                self.cli_error(
                    ErrorKind::UnknownName,
                    format!("--set {name}: the model has no `let {name}`"),
                    Some(hint),
                );
            }
        }
        if self.net.outputs.is_empty() && self.diags.is_empty() {
            self.diags.push(
                Diagnostic::warning(
                    None,
                    "the model has no outputs: a render would write nothing",
                )
                .with_hint(
                    "add `sox NAME MASS` to record a position or `sof NAME LINK` for a force",
                ),
            );
        }
    }

    /// The line where `name` is first declared in the text, if anywhere.
    fn declared_line(&self, name: &str) -> Option<usize> {
        self.declared_at
            .get_or_init(|| {
                let mut at = HashMap::new();
                let mut parser = syntax::LineParser::new();
                for (n, base, line) in syntax::lines(self.text) {
                    if let Some(Ok(s)) = parser.parse_line(line, base, n) {
                        if let Some((w, span)) = declared_name(&s) {
                            at.entry(w.text.clone()).or_insert(span.line);
                        }
                    }
                }
                at
            })
            .get(name)
            .copied()
    }

    fn resolve_rate(&mut self, stmts: &[Statement]) -> R<()> {
        let rate_env = Env {
            fs: 1.0,
            lets: HashMap::new(),
            failed: Default::default(),
        };
        let mut rate = 44100.0;
        let mut seen: Option<Span> = None;
        for s in stmts {
            if let Statement::Setting {
                keyword,
                value,
                span,
            } = s
            {
                if keyword.text == "rate" {
                    if let Some(first) = seen {
                        return Err(Diagnostic::error(
                            ErrorKind::DuplicateName,
                            *span,
                            format!("`rate` is set twice (first at line {})", first.line),
                        ));
                    }
                    seen = Some(*span);
                    rate = rate_env.number(value, Kind::Freq, "rate").map_err(|e| {
                        if e.kind == ErrorKind::UnknownName {
                            e.with_hint("`rate` must be a number (it comes before every `let`)")
                        } else {
                            e
                        }
                    })?;
                    self.check_rate(rate, Some(value.span))?;
                }
            }
        }
        if let Some(r) = &self.opts.rate {
            rate = syntax::parse_expr(r)
                .and_then(|e| rate_env.number(&e, Kind::Freq, "--rate"))
                .map_err(|e| {
                    Diagnostic::error(e.kind, None, format!("--rate {r}: {}", e.message))
                })?;
            self.check_rate(rate, None)?;
        }
        self.fs = rate;
        self.env.fs = rate;
        Ok(())
    }

    fn check_rate(&self, rate: f64, span: Option<Span>) -> R<()> {
        let max = self.opts.limits.max_rate;
        if !(rate >= 1.0) {
            return Err(Diagnostic::error(
                ErrorKind::OutOfRange,
                span,
                format!("the sample rate must be at least 1 Hz, not {rate}"),
            ));
        }
        if rate > max {
            return Err(Diagnostic::error(
                ErrorKind::Limit,
                span,
                format!("a sample rate of {rate} Hz is above the limit of {max} Hz"),
            )
            .with_hint("raise the limit with --max-rate"));
        }
        Ok(())
    }

    fn set_duration(&mut self, samples: f64, span: Option<Span>) -> R<()> {
        if !(samples >= 0.0) {
            return Err(Diagnostic::error(
                ErrorKind::OutOfRange,
                span,
                "the duration must not be negative",
            ));
        }
        let max = self.opts.limits.max_duration_s;
        if samples / self.fs > max {
            return Err(Diagnostic::error(
                ErrorKind::Limit,
                span,
                format!(
                    "a duration of {:.3} s is above the limit of {max} s",
                    samples / self.fs
                ),
            )
            .with_hint("raise the limit with --max-duration SECONDS"));
        }
        self.duration = samples.round() as u64;
        if samples > 0.0 && samples < 100.0 {
            self.diags.push(
                Diagnostic::warning(span, format!("the duration is {} samples", self.duration))
                    .with_hint(format!(
                        "a bare number is in samples; for seconds write {}s",
                        samples
                    )),
            );
        }
        Ok(())
    }

    fn let_stmt(&mut self, name: &Word, value: &Expr) -> R<()> {
        if self.env.lets.contains_key(&name.text) {
            return Err(Diagnostic::error(
                ErrorKind::DuplicateName,
                name.span,
                format!("`{}` is already defined", name.text),
            ));
        }
        if name.text == "pi" {
            return Err(Diagnostic::error(
                ErrorKind::DuplicateName,
                name.span,
                "`pi` is a built-in constant",
            ));
        }
        let set = self.opts.sets.iter().rposition(|(n, _)| *n == name.text);
        if let Some(i) = set {
            self.set_used[i] = true;
        }
        let mut v = self.env.eval(value).inspect_err(|_| {
            self.env.failed.insert(name.text.clone());
        })?;
        if let Some(i) = set {
            let text = &self.opts.sets[i].1;
            v = syntax::parse_expr(text)
                .and_then(|e| self.env.eval(&e))
                .map_err(|e| {
                    Diagnostic::error(
                        e.kind,
                        name.span,
                        format!("--set {}={text}: {}", name.text, e.message),
                    )
                    .with_hint_opt(e.hint)
                })?;
        }
        self.env.lets.insert(name.text.clone(), v);
        Ok(())
    }

    // ---- names -------------------------------------------------------------------------------

    /// Declares a new name; returns its index in the list of its kind.
    pub(crate) fn declare(&mut self, name: String, decl: Decl, span: Span) -> R<u32> {
        let duplicate = |name: &str, first: Span| {
            Diagnostic::error(
                ErrorKind::DuplicateName,
                span,
                format!("`{name}` is already defined at line {}", first.line),
            )
            .with_hint("every module needs its own name")
        };
        let at = self
            .names
            .vacancy(&name)
            .map_err(|first| duplicate(&name, first))?;
        let budget = self.opts.limits.max_modules;
        if self.names.len() >= budget {
            return Err(Diagnostic::error(
                ErrorKind::Limit,
                span,
                format!("the model has more than {budget} modules"),
            )
            .with_hint("raise the limit with --max-modules"));
        }
        if self.names.next_index(decl) >= MAX_INDEX {
            return Err(Diagnostic::error(
                ErrorKind::Limit,
                span,
                format!("the model has more than {MAX_INDEX} modules of one kind"),
            ));
        }
        Ok(self.names.insert(at, name, decl, span))
    }

    fn plain_name<'r>(&self, r: &'r Ref) -> R<&'r Word> {
        match r.parts.as_slice() {
            [(w, idx)] if idx.is_empty() => Ok(w),
            _ => Err(Diagnostic::error(
                ErrorKind::Syntax,
                r.span,
                "a new module's name must be a plain name",
            )
            .with_hint(
                "names like `s[3]` and `dev.M1` are made by generators; pick a name such as `m3`",
            )),
        }
    }

    /// The name a reference stands for, with its indices evaluated (`s[3]`, `mem.h[2,5]`).
    fn ref_text<'r>(&self, r: &'r Ref) -> R<Cow<'r, str>> {
        if let [(w, idx)] = r.parts.as_slice() {
            if idx.is_empty() {
                return Ok(Cow::Borrowed(&w.text));
            }
        }
        let mut out = String::new();
        for (i, (w, idx)) in r.parts.iter().enumerate() {
            if i > 0 {
                out.push('.');
            }
            out.push_str(&w.text);
            if !idx.is_empty() {
                out.push('[');
                for (j, e) in idx.iter().enumerate() {
                    let v = self.env.eval(e)?.v;
                    if v.fract() != 0.0 || v < 0.0 {
                        return Err(Diagnostic::error(
                            ErrorKind::OutOfRange,
                            e.span,
                            format!("an index must be a whole number >= 0, not {v}"),
                        ));
                    }
                    if j > 0 {
                        out.push(',');
                    }
                    out.push_str(&format!("{}", v as u64));
                }
                out.push(']');
            }
        }
        Ok(Cow::Owned(out))
    }

    fn lookup<'r>(&self, r: &'r Ref) -> R<(Cow<'r, str>, Entity)> {
        let name = self.ref_text(r)?;
        if let Some((e, _)) = self.names.get(&name) {
            return Ok((name, e));
        }
        let base = &r.parts[0].0.text;
        if self.poisoned.contains(base) {
            return Err(Diagnostic::error(ErrorKind::UnknownName, r.span, ""));
        }
        let base_entity = self.names.get(base);
        if base_entity.is_none() {
            if let Some(line) = self.declared_line(base) {
                return Err(Diagnostic::error(
                    ErrorKind::UnknownName,
                    r.span,
                    format!("`{base}` is used before it is declared (at line {line})"),
                )
                .with_hint("move its declaration above this line"));
            }
        }
        let hint = match base_entity {
            Some((Entity::Group(kind), _)) if name != *base => Some(format!(
                "`{base}` is a {kind}; its first mass is `{}`",
                first_member(base, kind)
            )),
            _ => did_you_mean(&name, self.names.iter()),
        };
        Err(Diagnostic::error(
            ErrorKind::UnknownName,
            r.span,
            format!("no module is named `{name}`"),
        )
        .with_hint(hint.unwrap_or_else(|| "modules must be declared before they are used".into())))
    }

    pub(crate) fn material(&self, r: &Ref, role: &str) -> R<MatId> {
        match self.lookup(r)? {
            (_, Entity::Mat(m)) => Ok(m),
            (name, Entity::Group(kind)) => Err(Diagnostic::error(
                ErrorKind::WrongKind,
                r.span,
                format!("`{name}` is a whole {kind}, not one module"),
            )
            .with_hint(format!(
                "name one of its masses, e.g. `{}`",
                first_member(&name, kind)
            ))),
            (name, _) => Err(Diagnostic::error(
                ErrorKind::WrongKind,
                r.span,
                format!(
                    "{role} must be a material module (mas, sol, cel, enx), and `{name}` is not"
                ),
            )),
        }
    }

    pub(crate) fn link(&self, r: &Ref) -> R<LinkId> {
        match self.lookup(r)? {
            (_, Entity::Link(l)) => Ok(l),
            (name, _) => Err(Diagnostic::error(
                ErrorKind::WrongKind,
                r.span,
                format!("`{name}` is not an interaction"),
            )
            .with_hint("`sof` records the force of an interaction (res, fro, ref, but, lnl)")),
        }
    }

    pub(crate) fn add_mat(&mut self, name: String, m: Material, span: Span) -> R<MatId> {
        let id = MatId(self.declare(name, Decl::Mat, span)?);
        self.net.add_material(m);
        Ok(id)
    }

    pub(crate) fn add_link(
        &mut self,
        name: String,
        law: Interaction,
        a: MatId,
        b: MatId,
        span: Span,
    ) -> R<LinkId> {
        let id = LinkId(self.declare(name, Decl::Link, span)?);
        if let Interaction::But { s, .. } = law {
            self.tracked.push(Tracked {
                link: id,
                activity: Activity::Below(s),
            });
        }
        self.net.add_link(law, a, b);
        Ok(id)
    }

    // ---- values --------------------------------------------------------------------------------

    /// An optional number of kind `kind`, `default` when absent.
    pub(crate) fn num(
        &self,
        p: &mut Params,
        key: &'static str,
        kind: Kind,
        default: f64,
    ) -> R<f64> {
        match p.get(key, &[])? {
            Some(param) => self.env.number(&param.value, kind, key),
            None => Ok(default),
        }
    }

    /// A parameter the statement cannot do without.
    fn required<'p>(
        &self,
        p: &mut Params<'p>,
        key: &'static str,
        span: Span,
        what: &str,
        hint: String,
    ) -> R<&'p Param> {
        p.get(key, &[])?.ok_or_else(|| {
            Diagnostic::error(
                ErrorKind::MissingParameter,
                span,
                format!("{what}`{key}` is required"),
            )
            .with_hint(hint)
        })
    }

    pub(crate) fn positive(&self, p: &mut Params, key: &'static str, span: Span) -> R<f64> {
        let param = self.required(
            p,
            key,
            span,
            "the inertia ",
            format!("write for example {key}=1"),
        )?;
        let v = self.env.number(&param.value, Kind::Plain, key)?;
        if !(v > 0.0) {
            return Err(Diagnostic::error(
                ErrorKind::OutOfRange,
                param.value.span,
                format!("the inertia {key} must be > 0, not {v}"),
            )
            .with_hint("a module that must not move is a `sol`"));
        }
        Ok(v)
    }

    fn curve(&self, e: &Expr, xk: Kind, yk: Kind, what: &str) -> R<Curve> {
        let ExprKind::Curve(items) = &e.kind else {
            return Err(Diagnostic::error(
                ErrorKind::BadCurve,
                e.span,
                format!("{what} must be a curve: [(x1, y1) (x2, y2) ...]"),
            ));
        };
        if items.len() > self.opts.limits.max_curve_points {
            return Err(Diagnostic::error(
                ErrorKind::Limit,
                e.span,
                format!(
                    "{what} has {} points; the limit is {}",
                    items.len(),
                    self.opts.limits.max_curve_points
                ),
            ));
        }
        let mut pts = Vec::with_capacity(items.len());
        for it in items {
            match &it.kind {
                ExprKind::Tuple(xy) if xy.len() == 2 => {
                    pts.push((
                        self.env.number(&xy[0], xk, what)?,
                        self.env.number(&xy[1], yk, what)?,
                    ));
                }
                _ => {
                    return Err(Diagnostic::error(
                        ErrorKind::BadCurve,
                        it.span,
                        format!("a point of {what} must be (x, y)"),
                    )
                    .with_hint("write points as (abscissa, force), separated by spaces"))
                }
            }
        }
        Curve::new(&pts).map_err(|err| {
            let span = match err {
                cordis_core::CurveError::NonFinite { index } | cordis_core::CurveError::Decreasing { index } => items[index].span,
            };
            Diagnostic::error(ErrorKind::BadCurve, span, format!("{what}: {err}"))
                .with_hint("list the points from the smallest abscissa to the largest; repeat an abscissa for a jump")
        })
    }

    fn signal(&self, p: &mut Params, span: Span) -> R<Signal> {
        let param = p.get("signal", &[])?.ok_or_else(|| {
            Diagnostic::error(ErrorKind::MissingParameter, span, "`signal` is required")
                .with_hint("for example signal=impulse(at=0, amp=1) or signal=file(\"force.wav\")")
        })?;
        signals::build(&self.env, &param.value, self.path, &self.opts.limits)
    }

    // ---- statements ----------------------------------------------------------------------------

    fn module(&mut self, kw: &Word, refs: &[Ref], params: &[Param], span: Span) -> R<()> {
        let k = kw.text.as_str();
        let arity = match k {
            "mas" | "sol" | "cel" | "enx" | "string" | "membrane" | "init" => 1,
            "res" | "fro" | "ref" | "but" | "lnl" | "stick" | "bond" => 3,
            _ => 2, // enf
        };
        if refs.len() != arity {
            let form = match k {
                "res" | "fro" | "ref" | "but" | "lnl" | "stick" | "bond" => {
                    format!("{k} NAME END1 END2 parameters...")
                }
                "enf" => "enf NAME TARGET signal=...".into(),
                "init" => "init MODULE X0=... V0=...".into(),
                _ => format!("{k} NAME parameters..."),
            };
            let at = refs.get(arity).map_or(span, |r| r.span);
            return Err(Diagnostic::error(
                ErrorKind::Syntax,
                at,
                format!(
                    "`{k}` takes {arity} name{} before its parameters, not {}",
                    if arity > 1 { "s" } else { "" },
                    refs.len()
                ),
            )
            .with_hint(format!("write: {form}")));
        }
        let mut p = Params::new(params);
        let what = || format!("`{k}`");
        let name = if k == "init" {
            None
        } else {
            Some(self.plain_name(&refs[0])?)
        };
        let nm = || name.map(|w| w.text.clone()).unwrap_or_default();
        match k {
            "mas" => {
                let m = self.positive(&mut p, "M", span)?;
                let x0 = self.num(&mut p, "X0", Kind::Plain, 0.0)?;
                let v0 = self.num(&mut p, "V0", Kind::Velocity, 0.0)?;
                p.finish_with(what)?;
                self.add_mat(nm(), Material::Mas { m, x0, v0 }, span)?;
            }
            "sol" => {
                let x0 = self.num(&mut p, "X0", Kind::Plain, 0.0)?;
                p.finish_with(what)?;
                self.add_mat(nm(), Material::Sol { x0 }, span)?;
            }
            "cel" => {
                let m = self.positive(&mut p, "M", span)?;
                let kp = p.get("K", &[])?;
                let zp = p.get("Z", &[])?;
                let fp = p.get("f", &["freq"])?;
                let tp = p.get("tau", &["decay"])?;
                let (kk, zz) = if let Some(f) = fp {
                    if let Some(c) = kp.or(zp) {
                        return Err(Diagnostic::error(
                            ErrorKind::ConflictingParameter,
                            c.key.span,
                            "give a cel either K and Z or f and tau, not both",
                        ));
                    }
                    let freq = self.env.number(&f.value, Kind::Freq, "f")?;
                    if !(0.0..0.5).contains(&freq) {
                        let bare = self
                            .env
                            .eval(&f.value)
                            .map(|v| v.kind == Kind::Plain)
                            .unwrap_or(false);
                        return Err(nyquist(f.value.span, freq, self.fs, bare));
                    }
                    let tau = match tp {
                        Some(t) => {
                            let v = self.env.number(&t.value, Kind::Time, "tau")?;
                            if !(v > 0.0) {
                                return Err(Diagnostic::error(
                                    ErrorKind::OutOfRange,
                                    t.value.span,
                                    "the decay time tau must be > 0",
                                ));
                            }
                            v
                        }
                        None => f64::INFINITY,
                    };
                    cel_from_modal(m, freq, tau)
                } else {
                    if let Some(t) = tp {
                        return Err(Diagnostic::error(
                            ErrorKind::ConflictingParameter,
                            t.key.span,
                            "`tau` goes with `f`",
                        )
                        .with_hint("give the cel f=FREQ tau=TIME, or K and Z"));
                    }
                    let kk = match kp {
                        Some(x) => self.env.number(&x.value, Kind::Stiffness, "K")?,
                        None => 0.0,
                    };
                    let zz = match zp {
                        Some(x) => self.env.number(&x.value, Kind::Viscosity, "Z")?,
                        None => 0.0,
                    };
                    (kk, zz)
                };
                let x0 = self.num(&mut p, "X0", Kind::Plain, 0.0)?;
                let v0 = self.num(&mut p, "V0", Kind::Velocity, 0.0)?;
                let r = self.num(&mut p, "R", Kind::Plain, 0.0)?;
                p.finish_with(what)?;
                self.add_mat(
                    nm(),
                    Material::Cel {
                        m,
                        k: kk,
                        z: zz,
                        x0,
                        v0,
                        r,
                    },
                    span,
                )?;
            }
            "enx" => {
                let signal = self.signal(&mut p, span)?;
                p.finish_with(what)?;
                self.add_mat(nm(), Material::Enx { signal }, span)?;
            }
            "res" | "fro" | "ref" | "but" | "lnl" => {
                let a = self.material(&refs[1], "end 1")?;
                let b = self.material(&refs[2], "end 2")?;
                if a == b {
                    return Err(Diagnostic::error(
                        ErrorKind::WrongKind,
                        refs[2].span,
                        "an interaction must join two different modules",
                    ));
                }
                let mut track = false;
                let law = match k {
                    "res" => Interaction::Res {
                        k: self.req(&mut p, "K", Kind::Stiffness, span)?,
                    },
                    "fro" => Interaction::Fro {
                        z: self.req(&mut p, "Z", Kind::Viscosity, span)?,
                    },
                    "ref" => {
                        let kk = self.req(&mut p, "K", Kind::Stiffness, span)?;
                        Interaction::Ref {
                            k: kk,
                            z: self.num(&mut p, "Z", Kind::Viscosity, 0.0)?,
                        }
                    }
                    "but" => {
                        let kk = self.num(&mut p, "K", Kind::Stiffness, 0.0)?;
                        let zz = self.num(&mut p, "Z", Kind::Viscosity, 0.0)?;
                        let s = self.num(&mut p, "S", Kind::Plain, 0.0)?;
                        Interaction::But { k: kk, z: zz, s }
                    }
                    _ => {
                        let lk = match p.get("LK", &[])? {
                            Some(x) => self.curve(&x.value, Kind::Plain, Kind::Plain, "LK")?,
                            None => Curve::zero(),
                        };
                        let lz = match p.get("LZ", &[])? {
                            Some(x) => self.curve(&x.value, Kind::Velocity, Kind::Plain, "LZ")?,
                            None => Curve::zero(),
                        };
                        if lk.is_empty() && lz.is_empty() {
                            return Err(Diagnostic::error(ErrorKind::MissingParameter, span, "an lnl needs a curve LK (force over elongation) or LZ (force over velocity)"));
                        }
                        track = match p.get("track", &[])? {
                            Some(x) => self.yes_no(&x.value)?,
                            None => false,
                        };
                        Interaction::Lnl { lk, lz }
                    }
                };
                p.finish_with(what)?;
                let (ma, mb) = (
                    &self.net.materials[a.index()],
                    &self.net.materials[b.index()],
                );
                if !ma.is_mobile() && !mb.is_mobile() {
                    self.diags.push(Diagnostic::warning(
                        span,
                        format!(
                            "`{}` joins two modules that cannot move ({} and {}): it does nothing",
                            nm(),
                            ma.kind(),
                            mb.kind()
                        ),
                    ));
                }
                let id = self.add_link(nm(), law, a, b, span)?;
                if track {
                    self.tracked.push(Tracked {
                        link: id,
                        activity: Activity::NonZero,
                    });
                }
            }
            "stick" => self.stick_stmt(nm(), &refs[1], &refs[2], &mut p, span)?,
            "bond" => self.bond_stmt(nm(), &refs[1], &refs[2], &mut p, span)?,
            "enf" => {
                let target = self.material(&refs[1], "the target of an enf")?;
                let signal = self.signal(&mut p, span)?;
                p.finish_with(what)?;
                if !self.net.materials[target.index()].is_mobile() {
                    self.diags.push(Diagnostic::warning(
                        refs[1].span,
                        "a force on a sol or enx is discarded: it cannot move it",
                    ));
                }
                self.declare(nm(), Decl::Force, span)?;
                self.net.add_force(target, signal);
            }
            "init" => {
                let target = self.material(&refs[0], "`init`")?;
                let x0 = p
                    .get("X0", &[])?
                    .map(|x| self.env.number(&x.value, Kind::Plain, "X0"))
                    .transpose()?;
                let v0 = p
                    .get("V0", &[])?
                    .map(|x| self.env.number(&x.value, Kind::Velocity, "V0"))
                    .transpose()?;
                p.finish_with(what)?;
                match &mut self.net.materials[target.index()] {
                    Material::Mas { x0: px, v0: pv, .. } | Material::Cel { x0: px, v0: pv, .. } => {
                        if let Some(x) = x0 {
                            *px = x;
                        }
                        if let Some(v) = v0 {
                            *pv = v;
                        }
                    }
                    Material::Sol { x0: px } if v0.is_none() => {
                        if let Some(x) = x0 {
                            *px = x;
                        }
                    }
                    m => {
                        return Err(Diagnostic::error(
                            ErrorKind::WrongKind,
                            refs[0].span,
                            format!("`init` cannot set the state of a {}", m.kind()),
                        )
                        .with_hint("init sets X0 and V0 of a mas or cel (and X0 of a sol)"))
                    }
                }
            }
            "string" => self.string(nm(), &mut p, span)?,
            "membrane" => self.membrane(nm(), &mut p, span)?,
            _ => unreachable!("keyword list and match agree"),
        }
        Ok(())
    }

    pub(crate) fn req(&self, p: &mut Params, key: &'static str, kind: Kind, span: Span) -> R<f64> {
        let param = self.required(p, key, span, "", format!("add {key}=VALUE"))?;
        self.env.number(&param.value, kind, key)
    }

    /// `yes`/`no` (or `true`/`false`, `1`/`0`).
    pub(crate) fn yes_no(&self, e: &Expr) -> R<bool> {
        match &e.kind {
            ExprKind::Name(n)
                if ["yes", "true", "on"].contains(&n.to_ascii_lowercase().as_str()) =>
            {
                Ok(true)
            }
            ExprKind::Name(n)
                if ["no", "false", "off"].contains(&n.to_ascii_lowercase().as_str()) =>
            {
                Ok(false)
            }
            ExprKind::Num(v) if *v == 1.0 || *v == 0.0 => Ok(*v == 1.0),
            _ => Err(Diagnostic::error(
                ErrorKind::Syntax,
                e.span,
                "expected yes or no",
            )),
        }
    }

    /// `sox NAME TERMS` and `sof NAME TERMS`: one output channel.
    fn probe(
        &mut self,
        kw: &Word,
        name: &Ref,
        terms: &[(Option<Expr>, bool, Ref)],
        params: &[Param],
        span: Span,
    ) -> R<()> {
        let name = self.plain_name(name)?;
        let p = Params::new(params);
        p.finish_with(|| format!("`{}`", kw.text))?;
        let mut probes = Vec::with_capacity(terms.len());
        for (gain, negative, r) in terms {
            let g = match gain {
                Some(e) => self.env.number(e, Kind::Plain, "a gain")?,
                None => 1.0,
            };
            let g = if *negative { -g } else { g };
            let probe = if kw.text == "sox" {
                Probe::Position(self.material(r, "what a sox records")?)
            } else {
                Probe::Force(self.link(r)?)
            };
            probes.push((g, probe));
        }
        self.declare(name.text.clone(), Decl::Output, span)?;
        match probes.as_slice() {
            [(g, Probe::Position(m))] if *g == 1.0 => {
                self.net.add_position_output(*m);
            }
            [(g, Probe::Force(l))] if *g == 1.0 => {
                self.net.add_force_output(*l);
            }
            _ => {
                self.net.add_sum_output(probes);
            }
        }
        Ok(())
    }

    fn words(&self, e: &Expr) -> R<Vec<(String, Span)>> {
        let items: Vec<&Expr> = match &e.kind {
            ExprKind::List(l) => l.iter().collect(),
            _ => vec![e],
        };
        items
            .into_iter()
            .map(|it| match &it.kind {
                ExprKind::Name(n) => Ok((n.to_ascii_lowercase(), it.span)),
                _ => Err(Diagnostic::error(
                    ErrorKind::Syntax,
                    it.span,
                    "expected a word (fixed or free)",
                )),
            })
            .collect()
    }

    fn end_kind(&self, w: &(String, Span)) -> R<bool> {
        match w.0.as_str() {
            "fixed" => Ok(true),
            "free" => Ok(false),
            other => Err(Diagnostic::error(
                ErrorKind::OutOfRange,
                w.1,
                format!("`{other}` is not an end condition"),
            )
            .with_hint(
                did_you_mean(other, ["fixed", "free"])
                    .unwrap_or_else(|| "use fixed or free".into()),
            )),
        }
    }

    fn count(&self, p: &mut Params, key: &'static str, span: Span) -> R<usize> {
        let param = self.required(p, key, span, "", format!("add {key}=NUMBER"))?;
        let v = self.env.number(&param.value, Kind::Plain, key)?;
        if v.fract() != 0.0 || v < 1.0 {
            return Err(Diagnostic::error(
                ErrorKind::OutOfRange,
                param.value.span,
                format!("`{key}` must be a whole number >= 1, not {v}"),
            ));
        }
        let max = self.opts.limits.max_modules as f64;
        if v > max {
            return Err(Diagnostic::error(
                ErrorKind::Limit,
                param.value.span,
                format!("`{key}` = {v} is above the module limit of {max}"),
            )
            .with_hint("raise the limit with --max-modules"));
        }
        Ok(v as usize)
    }

    fn budget(&self, extra: usize, span: Span) -> R<()> {
        let max = self.opts.limits.max_modules;
        if self.names.len().saturating_add(extra) > max {
            return Err(Diagnostic::error(
                ErrorKind::Limit,
                span,
                format!(
                    "this would make {} modules; the limit is {max}",
                    self.names.len().saturating_add(extra)
                ),
            )
            .with_hint("raise the limit with --max-modules"));
        }
        Ok(())
    }

    /// Room for `mats` more materials and `links` more links (a generator's, within budget).
    fn reserve(&mut self, mats: usize, links: usize) {
        self.net.materials.reserve(mats);
        self.names.materials.reserve(mats);
        self.net.links.reserve(links);
        self.names.links.reserve(links);
        self.names.reserve(mats + links);
    }

    fn string(&mut self, name: String, p: &mut Params, span: Span) -> R<()> {
        let n = self.count(p, "n", span)?;
        let m = self.positive(p, "M", span)?;
        let k = self.req(p, "K", Kind::Stiffness, span)?;
        let z = self.num(p, "Z", Kind::Viscosity, 0.0)?;
        let ends = match p.get("ends", &["end"])? {
            Some(x) => {
                let w = self.words(&x.value)?;
                match w.as_slice() {
                    [one] => (self.end_kind(one)?, self.end_kind(one)?),
                    [a, b] => (self.end_kind(a)?, self.end_kind(b)?),
                    _ => {
                        return Err(Diagnostic::error(
                            ErrorKind::Syntax,
                            x.value.span,
                            "ends takes one or two words: ends=fixed,free",
                        ))
                    }
                }
            }
            None => (true, true),
        };
        let ends_given = p.list.iter().any(|q| {
            ["ends", "end"]
                .iter()
                .any(|k| q.key.text.eq_ignore_ascii_case(k))
        });
        let anchor_left = self.anchor_param(p, "left")?;
        let anchor_right = self.anchor_param(p, "right")?;
        let mut ends = ends;
        for (given, fixed, side) in [
            (&anchor_left, &mut ends.0, "left"),
            (&anchor_right, &mut ends.1, "right"),
        ] {
            if let Some((_, at)) = given {
                if ends_given && !*fixed {
                    return Err(Diagnostic::error(
                        ErrorKind::ConflictingParameter,
                        *at,
                        format!(
                            "`{side}=` fixes the {side} end to a module, but `ends` makes it free"
                        ),
                    )
                    .with_hint(format!("drop `{side}=`, or make the {side} end fixed")));
                }
                *fixed = true;
            }
        }
        let air = match p.get("air", &[])? {
            Some(x) => Some((
                self.env.number(&x.value, Kind::Viscosity, "air")?,
                x.value.span,
            )),
            None => None,
        };
        if let Some((_, at)) = air {
            if !ends.0 && !ends.1 {
                return Err(Diagnostic::error(
                    ErrorKind::ConflictingParameter,
                    at,
                    "`air` damps every mass against the string's fixed end, and both ends are free",
                )
                .with_hint(
                    "fix an end (ends=fixed,free, or left=MODULE), or write the dampers with `fro`",
                ));
            }
        }
        let base = self.num(p, "X0", Kind::Plain, 0.0)?;
        let pluck = match p.get("pluck", &[])? {
            Some(x) => match &x.value.kind {
                ExprKind::Tuple(t) if t.len() == 2 => {
                    let at = self.env.number(&t[0], Kind::Plain, "pluck")?;
                    if at.fract() != 0.0 || at < 0.0 || at >= n as f64 {
                        return Err(Diagnostic::error(
                            ErrorKind::OutOfRange,
                            t[0].span,
                            format!("the plucked mass must be one of 0..{}", n - 1),
                        ));
                    }
                    Some((at as usize, self.env.number(&t[1], Kind::Plain, "pluck")?))
                }
                _ => {
                    return Err(Diagnostic::error(
                        ErrorKind::Syntax,
                        x.value.span,
                        "pluck=(INDEX, AMPLITUDE)",
                    ))
                }
            },
            None => None,
        };
        p.finish("`string`")?;
        self.budget(3 * n + 3, span)?;
        self.declare(name.clone(), Decl::Group("string"), span)?;
        self.reserve(n + 2, if air.is_some() { 2 * n + 1 } else { n + 1 });
        let mut ids = Vec::with_capacity(n);
        for i in 0..n {
            let x0 = match pluck {
                Some((at, amp)) if i <= at => amp * (i + 1) as f64 / (at + 1) as f64,
                Some((at, amp)) => amp * (n - i) as f64 / (n - at) as f64,
                None => 0.0,
            };
            ids.push(self.add_mat(
                format!("{name}[{i}]"),
                Material::Mas {
                    m,
                    x0: base + x0,
                    v0: 0.0,
                },
                span,
            )?);
        }
        let law = Interaction::Ref { k, z };
        let mut anchor = None;
        if ends.0 {
            let g = match anchor_left {
                Some((g, _)) => g,
                None => self.add_mat(format!("{name}.left"), Material::Sol { x0: base }, span)?,
            };
            self.add_link(format!("{name}.l[0]"), law.clone(), g, ids[0], span)?;
            anchor = Some(g);
        }
        for i in 1..n {
            self.add_link(
                format!("{name}.l[{i}]"),
                law.clone(),
                ids[i - 1],
                ids[i],
                span,
            )?;
        }
        if ends.1 {
            let g = match anchor_right {
                Some((g, _)) => g,
                None => self.add_mat(format!("{name}.right"), Material::Sol { x0: base }, span)?,
            };
            self.add_link(format!("{name}.l[{n}]"), law, ids[n - 1], g, span)?;
            anchor = anchor.or(Some(g));
        }
        if let (Some((z_air, _)), Some(a)) = (air, anchor) {
            for (i, &id) in ids.iter().enumerate() {
                self.add_link(
                    format!("{name}.air[{i}]"),
                    Interaction::Fro { z: z_air },
                    a,
                    id,
                    span,
                )?;
            }
        }
        Ok(())
    }

    /// A generator parameter naming an existing material module (`left=bridge`).
    fn anchor_param(&self, p: &mut Params, key: &'static str) -> R<Option<(MatId, Span)>> {
        let Some(x) = p.get(key, &[])? else {
            return Ok(None);
        };
        let ExprKind::Name(n) = &x.value.kind else {
            return Err(Diagnostic::error(
                ErrorKind::Syntax,
                x.value.span,
                format!("`{key}=` takes the name of a module"),
            )
            .with_hint(
                "a plain name such as `bridge`; give an indexed module a name of its own first",
            ));
        };
        let r = Ref {
            parts: vec![(
                Word {
                    text: n.clone(),
                    span: x.value.span,
                },
                Vec::new(),
            )],
            span: x.value.span,
        };
        Ok(Some((
            self.material(&r, &format!("`{key}=`"))?,
            x.value.span,
        )))
    }

    fn membrane(&mut self, name: String, p: &mut Params, span: Span) -> R<()> {
        let rows = self.count(p, "rows", span)?;
        let cols = self.count(p, "cols", span)?;
        let m = self.positive(p, "M", span)?;
        let k = self.req(p, "K", Kind::Stiffness, span)?;
        let z = self.num(p, "Z", Kind::Viscosity, 0.0)?;
        let fixed = match p.get("border", &[])? {
            Some(x) => {
                let w = self.words(&x.value)?;
                match w.as_slice() {
                    [one] => self.end_kind(one)?,
                    _ => {
                        return Err(Diagnostic::error(
                            ErrorKind::Syntax,
                            x.value.span,
                            "border takes one word: fixed or free",
                        ))
                    }
                }
            }
            None => true,
        };
        p.finish("`membrane`")?;
        let masses = rows.saturating_mul(cols);
        self.budget(masses.saturating_mul(4), span)?;
        self.declare(name.clone(), Decl::Group("membrane"), span)?;
        let links = rows * cols.saturating_sub(1)
            + rows.saturating_sub(1) * cols
            + if fixed { 2 * (rows + cols) } else { 0 };
        self.reserve(masses + 1, links);
        let mut ids = Vec::with_capacity(masses);
        for r in 0..rows {
            for c in 0..cols {
                ids.push(self.add_mat(
                    format!("{name}[{r},{c}]"),
                    Material::Mas {
                        m,
                        x0: 0.0,
                        v0: 0.0,
                    },
                    span,
                )?);
            }
        }
        let at = |r: usize, c: usize| ids[r * cols + c];
        let law = Interaction::Ref { k, z };
        for r in 0..rows {
            for c in 0..cols.saturating_sub(1) {
                self.add_link(
                    format!("{name}.h[{r},{c}]"),
                    law.clone(),
                    at(r, c),
                    at(r, c + 1),
                    span,
                )?;
            }
        }
        for r in 0..rows.saturating_sub(1) {
            for c in 0..cols {
                self.add_link(
                    format!("{name}.v[{r},{c}]"),
                    law.clone(),
                    at(r, c),
                    at(r + 1, c),
                    span,
                )?;
            }
        }
        if fixed {
            let g = self.add_mat(format!("{name}.rim"), Material::Sol { x0: 0.0 }, span)?;
            let mut b = 0;
            for r in 0..rows {
                for c in 0..cols {
                    let missing = usize::from(r == 0)
                        + usize::from(r == rows - 1)
                        + usize::from(c == 0)
                        + usize::from(c == cols - 1);
                    for _ in 0..missing {
                        self.add_link(format!("{name}.b[{b}]"), law.clone(), g, at(r, c), span)?;
                        b += 1;
                    }
                }
            }
        }
        Ok(())
    }
}

fn first_member(base: &str, kind: &str) -> String {
    match kind {
        "membrane" => format!("{base}[0,0]"),
        "sticking device" => format!("{base}.L (or {base}.MC1 for a bond)"),
        _ => format!("{base}[0]"),
    }
}

pub(crate) fn nyquist(span: Span, freq: f64, fs: f64, bare: bool) -> Diagnostic {
    let d = Diagnostic::error(
        ErrorKind::OutOfRange,
        span,
        format!(
            "a frequency of {} cycles per sample ({} Hz) is not between 0 and the Nyquist frequency {} Hz",
            freq,
            freq * fs,
            fs / 2.0
        ),
    );
    if bare {
        d.with_hint(format!(
            "a bare number is in cycles per sample; for hertz write it with a unit, e.g. {freq}Hz"
        ))
    } else {
        d.with_hint(format!(
            "frequencies must stay below half the sample rate; raise the rate above {} Hz",
            2.0 * freq * fs
        ))
    }
}

/// `(K, Z)` of a CEL of inertia `m` ringing at `freq` cycles per sample with amplitude decay time
/// `tau` samples (FORMALISM.md closed form; `tau = inf` gives Z = 0).
pub fn cel_from_modal(m: f64, freq: f64, tau: f64) -> (f64, f64) {
    let theta = std::f64::consts::TAU * freq;
    let r = (-1.0 / tau).exp();
    let z = m * (1.0 - r * r);
    let s = (theta / 2.0).sin();
    let k = m * ((1.0 - r) * (1.0 - r) + 4.0 * r * s * s);
    (k, z)
}

/// The frequency (cycles per sample) and decay time (samples, to 1/e) of a free CEL, from its
/// poles (FORMALISM.md). `None` when the poles are real (no oscillation).
pub fn cel_modal(m: f64, k: f64, z: f64) -> Option<(f64, f64)> {
    let r2 = 1.0 - z / m;
    if !(r2 > 0.0) {
        return None;
    }
    let r = r2.sqrt();
    let c = (2.0 - (k + z) / m) / (2.0 * r);
    if !(-1.0..=1.0).contains(&c) {
        return None;
    }
    let theta = c.acos();
    Some((theta / std::f64::consts::TAU, -1.0 / r.ln()))
}

/// A value written as text on the command line, evaluated at `fs` (used for `--set`).
pub fn eval_text(text: &str, fs: f64) -> Result<Value, Diagnostic> {
    let e = syntax::parse_expr(text)?;
    Env {
        fs,
        lets: HashMap::new(),
        failed: Default::default(),
    }
    .eval(&e)
}

/// The name a statement declares, if any (for "declared later" and for poisoning).
fn declared_name(s: &Statement) -> Option<(&Word, Span)> {
    match s {
        Statement::Module {
            keyword,
            refs,
            span,
            ..
        } if keyword.text != "init" => match refs.first()?.parts.first()? {
            (w, idx) if idx.is_empty() => Some((w, *span)),
            _ => None,
        },
        Statement::Probe { name, span, .. } => match name.parts.first()? {
            (w, idx) if idx.is_empty() => Some((w, *span)),
            _ => None,
        },
        _ => None,
    }
}
