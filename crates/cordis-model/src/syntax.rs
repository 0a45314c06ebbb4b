//! Stage 1, parse: text → statements. One statement per line, `#` starts a comment.
//!
//! The lexer keeps byte spans so every later stage can point at the exact text.

use std::cell::Cell;

use crate::error::{did_you_mean, Diagnostic, ErrorKind, Span};

/// A word of the source with its span (identifiers, keywords, parameter keys).
#[derive(Clone, Debug, PartialEq)]
pub struct Word {
    /// The text as written.
    pub text: String,
    /// Where it is.
    pub span: Span,
}

/// A binary operator.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum BinOp {
    /// `+`
    Add,
    /// `-`
    Sub,
    /// `*`
    Mul,
    /// `/`
    Div,
    /// `^`
    Pow,
}

/// An argument of a call: positional or `key=value`.
#[derive(Clone, Debug, PartialEq)]
pub struct Arg {
    /// The key, for a named argument.
    pub key: Option<Word>,
    /// The value.
    pub value: Expr,
}

/// A value expression.
#[derive(Clone, Debug, PartialEq)]
pub enum ExprKind {
    /// A number literal, with an optional unit written right after it (`440Hz`).
    Num(f64),
    /// A quoted string (file paths).
    Str(String),
    /// A bare name: a `let` value, `pi`, or a word such as `fixed`.
    Name(String),
    /// `-e`.
    Neg(Box<Expr>),
    /// `a op b`.
    Bin(BinOp, Box<Expr>, Box<Expr>),
    /// `name(args)`: a math function or a signal generator.
    Call(Word, Vec<Arg>),
    /// `(a, b, ...)` with two or more items: a curve point.
    Tuple(Vec<Expr>),
    /// `[(x, y) (x, y) ...]`: a curve.
    Curve(Vec<Expr>),
    /// `a, b, ...` at the top of a parameter value: a list of words (`ends=fixed,free`).
    List(Vec<Expr>),
    /// `e` followed by a unit (`(2*k)N/m`, `10ms`).
    Unit(Box<Expr>, Word),
}

/// An expression with its span.
#[derive(Clone, Debug, PartialEq)]
pub struct Expr {
    /// What it is.
    pub kind: ExprKind,
    /// Where it is.
    pub span: Span,
}

/// A reference to a module: `m1`, `s[3]`, `mem[2,5]`, `dev.S1.L`.
#[derive(Clone, Debug, PartialEq)]
pub struct Ref {
    /// The parts, each a name with optional index expressions.
    pub parts: Vec<(Word, Vec<Expr>)>,
    /// Where it is.
    pub span: Span,
}

/// A `key=value` parameter.
#[derive(Clone, Debug, PartialEq)]
pub struct Param {
    /// The key as written.
    pub key: Word,
    /// The value.
    pub value: Expr,
}

/// One statement (one line).
#[derive(Clone, Debug, PartialEq)]
pub enum Statement {
    /// `let NAME = EXPR`.
    Let {
        /// The name.
        name: Word,
        /// Its value.
        value: Expr,
        /// The whole line.
        span: Span,
    },
    /// `rate EXPR` or `duration EXPR`.
    Setting {
        /// `rate` or `duration` (lower case).
        keyword: Word,
        /// The value.
        value: Expr,
        /// The whole line.
        span: Span,
    },
    /// `sox NAME TERM (+|- TERM)...` or `sof ...`: one output channel, the weighted sum of its
    /// terms; a term is `[GAIN *] REF` with GAIN a number or a parenthesised expression.
    Probe {
        /// `sox` or `sof` (lower case).
        keyword: Word,
        /// The channel's name.
        name: Ref,
        /// `(gain, module)`; the gain is `None` for an implicit 1 (a leading `-` makes it `-1`).
        terms: Vec<(Option<Expr>, bool, Ref)>,
        /// Parameters (none are accepted; kept for the error message).
        params: Vec<Param>,
        /// The whole line.
        span: Span,
    },
    /// Every other statement: `KEYWORD ref... key=value...`.
    Module {
        /// The keyword, lower-cased in `text`.
        keyword: Word,
        /// Names and module references before the parameters.
        refs: Vec<Ref>,
        /// The parameters.
        params: Vec<Param>,
        /// The whole line.
        span: Span,
    },
}

/// Statement keywords the language knows (for did-you-mean).
pub const KEYWORDS: &[&str] = &[
    "rate", "duration", "let", "mas", "sol", "cel", "enx", "res", "fro", "ref", "but", "lnl",
    "enf", "sox", "sof", "string", "membrane", "init", "stick", "bond",
];

/// Units that may follow a number or a parenthesised expression.
pub const UNITS: &[&str] = &[
    "Hz", "kHz", "s", "ms", "us", "N/m", "Ns/m", "N.s/m", "m/s", "samples",
];

const MAX_DEPTH: usize = 64;

#[derive(Clone, Copy, Debug, PartialEq)]
enum Tok<'a> {
    Ident(&'a str),
    Num(f64),
    Unit(&'static str),
    Str(&'a str),
    Sym(char),
}

#[derive(Clone, Copy, Debug)]
struct Token<'a> {
    tok: Tok<'a>,
    span: Span,
}

struct LineLexer<'a> {
    text: &'a str,
    base: usize,
    line: usize,
    /// Length of the longest all-ASCII prefix of `text`: a column there is the byte offset + 1.
    ascii: usize,
    /// A byte offset past `ascii` and the number of characters before it: columns further on are
    /// counted from there (tokens come in order, so a line is counted once).
    mark: Cell<(usize, usize)>,
}

impl<'a> LineLexer<'a> {
    fn new(text: &'a str, base: usize, line: usize) -> LineLexer<'a> {
        let ascii = text
            .bytes()
            .position(|b| !b.is_ascii())
            .unwrap_or(text.len());
        LineLexer {
            text,
            base,
            line,
            ascii,
            mark: Cell::new((ascii, ascii)),
        }
    }

    fn span(&self, start: usize, end: usize) -> Span {
        // counting the characters from the start of the line for every token would make a long
        // line quadratic
        let col = if start <= self.ascii {
            start + 1
        } else {
            let (from, chars) = match self.mark.get() {
                (at, n) if at <= start => (at, n),
                _ => (self.ascii, self.ascii),
            };
            let chars = chars + self.text[from..start].chars().count();
            self.mark.set((start, chars));
            chars + 1
        };
        Span {
            start: self.base + start,
            end: self.base + end,
            line: self.line,
            col,
        }
    }

    /// The tokens of the line, into `toks` (cleared first).
    fn lex(&self, toks: &mut Vec<Token<'a>>) -> Result<(), Diagnostic> {
        let bytes = self.text.as_bytes();
        toks.clear();
        let mut i = 0;
        while i < bytes.len() {
            let c = self.text[i..].chars().next().unwrap_or(' ');
            if c == '#' {
                break;
            }
            if c.is_whitespace() {
                i += c.len_utf8();
                continue;
            }
            let start = i;
            // letters glued to a number or to `)` are a unit: `440Hz`, `(2*k)N/m`
            let unit_here = matches!(toks.last(), Some(Token { tok: Tok::Num(_) | Tok::Sym(')'), span }) if span.end == self.base + i);
            if c.is_ascii_digit()
                || (c == '.' && bytes.get(i + 1).is_some_and(|b| b.is_ascii_digit()))
            {
                while i < bytes.len() && (bytes[i].is_ascii_digit() || bytes[i] == b'.') {
                    i += 1;
                }
                if i < bytes.len() && (bytes[i] == b'e' || bytes[i] == b'E') {
                    let mut j = i + 1;
                    if j < bytes.len() && (bytes[j] == b'+' || bytes[j] == b'-') {
                        j += 1;
                    }
                    if j < bytes.len() && bytes[j].is_ascii_digit() {
                        while j < bytes.len() && bytes[j].is_ascii_digit() {
                            j += 1;
                        }
                        i = j;
                    }
                }
                let text = &self.text[start..i];
                let v: f64 = text.parse().map_err(|_| {
                    Diagnostic::error(
                        ErrorKind::Syntax,
                        self.span(start, i),
                        format!("`{text}` is not a number"),
                    )
                    .with_hint("numbers look like 12, 0.5, 1e-4 or 2.5E3")
                })?;
                toks.push(Token {
                    tok: Tok::Num(v),
                    span: self.span(start, i),
                });
                continue;
            }
            if unit_here && c.is_ascii_alphabetic() {
                let (u, end) = self.lex_unit(i)?;
                toks.push(Token {
                    tok: Tok::Unit(u),
                    span: self.span(i, end),
                });
                i = end;
                continue;
            }
            if c.is_ascii_alphabetic() || c == '_' {
                while i < bytes.len() && (bytes[i].is_ascii_alphanumeric() || bytes[i] == b'_') {
                    i += 1;
                }
                toks.push(Token {
                    tok: Tok::Ident(&self.text[start..i]),
                    span: self.span(start, i),
                });
                continue;
            }
            if c == '"' {
                let rest = &self.text[i + 1..];
                match rest.find('"') {
                    Some(end) => {
                        toks.push(Token {
                            tok: Tok::Str(&rest[..end]),
                            span: self.span(start, i + 2 + end),
                        });
                        i += end + 2;
                    }
                    None => {
                        return Err(Diagnostic::error(
                            ErrorKind::Syntax,
                            self.span(start, self.text.len()),
                            "unterminated string",
                        )
                        .with_hint("close the quoted text with `\"` on the same line"))
                    }
                }
                continue;
            }
            if "=()[],+-*/^.".contains(c) {
                toks.push(Token {
                    tok: Tok::Sym(c),
                    span: self.span(start, start + 1),
                });
                i += 1;
                continue;
            }
            return Err(Diagnostic::error(
                ErrorKind::Syntax,
                self.span(start, start + c.len_utf8()),
                format!("unexpected character `{c}`"),
            )
            .with_hint("statements use names, numbers, `key=value`, ( ) [ ] , and + - * / ^"));
        }
        Ok(())
    }

    fn lex_unit(&self, start: usize) -> Result<(&'static str, usize), Diagnostic> {
        let bytes = self.text.as_bytes();
        let mut i = start;
        let word = |i: &mut usize| {
            while *i < bytes.len() && bytes[*i].is_ascii_alphabetic() {
                *i += 1;
            }
        };
        word(&mut i);
        // N.s/m
        if i + 1 < bytes.len() && bytes[i] == b'.' && bytes[i + 1].is_ascii_alphabetic() {
            let mut j = i + 1;
            word(&mut j);
            if j < bytes.len() && bytes[j] == b'/' {
                i = j;
            }
        }
        if i + 1 < bytes.len() && bytes[i] == b'/' && bytes[i + 1].is_ascii_alphabetic() {
            i += 1;
            word(&mut i);
        }
        let text = &self.text[start..i];
        match UNITS.iter().find(|u| u.eq_ignore_ascii_case(text)) {
            Some(u) => Ok((u, i)),
            None => Err(Diagnostic::error(
                ErrorKind::Syntax,
                self.span(start, i),
                format!("unknown unit `{text}`"),
            )
            .with_hint_opt(did_you_mean(text, UNITS.iter().copied()))
            .with_hint_opt(Some(format!(
                "units are {}; put a space or an operator between a number and a name",
                UNITS.join(", ")
            )))),
        }
    }
}

/// The lines of a text: `(line number from 1, byte offset of the line, the line without its
/// end-of-line characters)`.
pub(crate) fn lines(text: &str) -> impl Iterator<Item = (usize, usize, &str)> {
    text.split_inclusive('\n')
        .enumerate()
        .scan(0, |base, (n, raw)| {
            let start = *base;
            *base += raw.len();
            Some((n + 1, start, raw.trim_end_matches(['\n', '\r'])))
        })
}

/// The statement keyword a line starts with, as written (empty when it starts otherwise): what
/// [`LineParser::parse_line`] would take for the keyword, without lexing the rest of the line.
pub(crate) fn first_word(line: &str) -> &str {
    let t = line.trim_start();
    match t.bytes().next() {
        Some(b) if b.is_ascii_alphabetic() || b == b'_' => {
            let end = t
                .bytes()
                .position(|b| !(b.is_ascii_alphanumeric() || b == b'_'))
                .unwrap_or(t.len());
            &t[..end]
        }
        _ => "",
    }
}

/// Parses lines one at a time, reusing one token buffer (a model is parsed a line at a time and
/// each statement resolved before the next line is read, so no line outlives its resolution).
pub(crate) struct LineParser<'a> {
    toks: Vec<Token<'a>>,
}

impl<'a> LineParser<'a> {
    pub(crate) fn new() -> LineParser<'a> {
        LineParser { toks: Vec::new() }
    }

    /// The statement of one line (`None` for a blank or comment line), or its error. `line` is the
    /// text without its end of line, `base` its byte offset in the file, `n` its number from 1.
    pub(crate) fn parse_line(
        &mut self,
        line: &'a str,
        base: usize,
        n: usize,
    ) -> Option<Result<Statement, Diagnostic>> {
        let lexer = LineLexer::new(line, base, n);
        let line_span = lexer.span(0, line.len());
        if let Err(e) = lexer.lex(&mut self.toks) {
            return Some(Err(e));
        }
        if self.toks.is_empty() {
            return None;
        }
        let mut p = Parser {
            toks: &self.toks,
            pos: 0,
            depth: 0,
            eol: lexer.span(line.len(), line.len()),
        };
        Some(p.statement(line_span))
    }
}

/// Parses a whole model text. Returns the statements of the lines that parsed and one error per
/// line that did not (parsing goes on at the next line).
pub fn parse(text: &str) -> (Vec<Statement>, Vec<Diagnostic>) {
    let mut stmts = Vec::new();
    let mut errors = Vec::new();
    let mut parser = LineParser::new();
    for (n, base, line) in lines(text) {
        match parser.parse_line(line, base, n) {
            Some(Ok(s)) => stmts.push(s),
            Some(Err(e)) => errors.push(e),
            None => {}
        }
    }
    (stmts, errors)
}

/// Parses one expression (for `--set NAME=VALUE`, `--duration`, `--rate` on the command line).
pub fn parse_expr(text: &str) -> Result<Expr, Diagnostic> {
    let lexer = LineLexer::new(text, 0, 1);
    let mut toks = Vec::new();
    lexer.lex(&mut toks)?;
    let eol = lexer.span(text.len(), text.len());
    let mut p = Parser {
        toks: &toks,
        pos: 0,
        depth: 0,
        eol,
    };
    let e = p.expr()?;
    if let Some(t) = p.peek() {
        return Err(Diagnostic::error(
            ErrorKind::Syntax,
            t.span,
            "unexpected text after the value",
        ));
    }
    Ok(e)
}

struct Parser<'t, 'a> {
    toks: &'t [Token<'a>],
    pos: usize,
    depth: usize,
    eol: Span,
}

impl<'a> Parser<'_, 'a> {
    fn peek(&self) -> Option<&Token<'a>> {
        self.toks.get(self.pos)
    }

    fn peek_sym(&self, c: char) -> bool {
        matches!(self.peek(), Some(Token { tok: Tok::Sym(s), .. }) if *s == c)
    }

    fn peek_at_sym(&self, k: usize, c: char) -> bool {
        matches!(self.toks.get(self.pos + k), Some(Token { tok: Tok::Sym(s), .. }) if *s == c)
    }

    fn here(&self) -> Span {
        self.peek().map_or(self.eol, |t| t.span)
    }

    fn prev_span(&self) -> Span {
        self.toks[self.pos.saturating_sub(1)].span
    }

    fn expect_sym(&mut self, c: char, what: &str) -> Result<Span, Diagnostic> {
        if self.peek_sym(c) {
            self.pos += 1;
            Ok(self.prev_span())
        } else {
            Err(self.unexpected(what))
        }
    }

    fn unexpected(&self, what: &str) -> Diagnostic {
        match self.peek() {
            Some(t) => Diagnostic::error(
                ErrorKind::Syntax,
                t.span,
                format!("expected {what}, found {}", describe(&t.tok)),
            ),
            None => Diagnostic::error(
                ErrorKind::Syntax,
                self.here(),
                format!("expected {what}, found the end of the line"),
            ),
        }
    }

    fn ident(&mut self, what: &str) -> Result<Word, Diagnostic> {
        match self.peek() {
            Some(Token {
                tok: Tok::Ident(s),
                span,
            }) => {
                let w = Word {
                    text: s.to_string(),
                    span: *span,
                };
                self.pos += 1;
                Ok(w)
            }
            _ => Err(self.unexpected(what)),
        }
    }

    fn statement(&mut self, line: Span) -> Result<Statement, Diagnostic> {
        let (kw, kw_span) = match self.peek() {
            Some(&Token {
                tok: Tok::Ident(s),
                span,
            }) => (s, span),
            _ => return Err(self.unexpected("a statement keyword (mas, ref, sox, ...)")),
        };
        self.pos += 1;
        enum Form {
            Let,
            Setting,
            Probe,
            Module,
        }
        let lower = kw.to_ascii_lowercase();
        let form = match lower.as_str() {
            "let" => Form::Let,
            "rate" | "duration" => Form::Setting,
            "sox" | "sof" => Form::Probe,
            k if KEYWORDS.contains(&k) => Form::Module,
            _ => {
                return Err(Diagnostic::error(
                    ErrorKind::UnknownStatement,
                    kw_span,
                    format!("unknown statement `{kw}`"),
                )
                .with_hint(
                    did_you_mean(kw, KEYWORDS.iter().copied())
                        .unwrap_or_else(|| format!("statements are: {}", KEYWORDS.join(", "))),
                ))
            }
        };
        let keyword = Word {
            text: lower,
            span: kw_span,
        };
        let stmt = match form {
            Form::Let => {
                let name = self.ident("a name after `let`")?;
                self.expect_sym('=', "`=` after the name")?;
                let value = self.expr()?;
                Statement::Let {
                    name,
                    value,
                    span: line,
                }
            }
            Form::Setting => {
                let value = self.expr()?;
                Statement::Setting {
                    keyword,
                    value,
                    span: line,
                }
            }
            Form::Probe => {
                let name = self.reference()?;
                let mut terms = Vec::new();
                let mut negative = false;
                loop {
                    if self.peek_sym('-') || self.peek_sym('+') {
                        negative = self.peek_sym('-');
                        self.pos += 1;
                    }
                    let gain = match self.peek().map(|t| &t.tok) {
                        Some(Tok::Num(_)) | Some(Tok::Sym('(')) => {
                            let g = self.postfix()?;
                            self.expect_sym('*', "`*` between a gain and the module it scales")?;
                            Some(g)
                        }
                        _ => None,
                    };
                    terms.push((gain, negative, self.reference()?));
                    negative = false;
                    if !(self.peek_sym('+') || self.peek_sym('-')) {
                        break;
                    }
                }
                let params = self.params("`+`, `-` or the end of the line")?;
                Statement::Probe {
                    keyword,
                    name,
                    terms,
                    params,
                    span: line,
                }
            }
            Form::Module => {
                let mut refs = Vec::new();
                while matches!(
                    self.peek(),
                    Some(Token {
                        tok: Tok::Ident(_),
                        ..
                    })
                ) && !self.peek_at_sym(1, '=')
                {
                    refs.push(self.reference()?);
                }
                let params = self.params("a parameter `key=value`")?;
                Statement::Module {
                    keyword,
                    refs,
                    params,
                    span: line,
                }
            }
        };
        if let Some(t) = self.peek() {
            return Err(Diagnostic::error(
                ErrorKind::Syntax,
                t.span,
                format!("unexpected {} here", describe(&t.tok)),
            )
            .with_hint("one statement per line; parameters are written key=value"));
        }
        Ok(stmt)
    }

    /// `key=value` parameters up to the end of the line; `expected` says what else could stand there.
    fn params(&mut self, expected: &str) -> Result<Vec<Param>, Diagnostic> {
        let mut params = Vec::new();
        while self.peek().is_some() {
            if !(matches!(self.peek().map(|t| &t.tok), Some(Tok::Ident(_)))
                && self.peek_at_sym(1, '='))
            {
                return Err(self.unexpected(expected));
            }
            let key = self.ident("a parameter")?;
            self.pos += 1; // '='
            let value = self.param_value()?;
            params.push(Param { key, value });
        }
        Ok(params)
    }

    fn reference(&mut self) -> Result<Ref, Diagnostic> {
        let mut parts = Vec::new();
        let start = self.here();
        loop {
            let w = self.ident("a module name")?;
            let mut idx = Vec::new();
            if self.peek_sym('[') && self.peek().is_some_and(|t| t.span.start == w.span.end) {
                self.pos += 1;
                loop {
                    idx.push(self.expr()?);
                    if self.peek_sym(',') {
                        self.pos += 1;
                        continue;
                    }
                    self.expect_sym(']', "`]` or `,` in an index")?;
                    break;
                }
            }
            parts.push((w, idx));
            if self.peek_sym('.') {
                self.pos += 1;
                continue;
            }
            break;
        }
        Ok(Ref {
            parts,
            span: start.to(self.prev_span()),
        })
    }

    fn param_value(&mut self) -> Result<Expr, Diagnostic> {
        let first = self.expr()?;
        if !self.peek_sym(',') {
            return Ok(first);
        }
        let mut items = vec![first];
        while self.peek_sym(',') {
            self.pos += 1;
            items.push(self.expr()?);
        }
        let span = items[0].span.to(items[items.len() - 1].span);
        Ok(Expr {
            kind: ExprKind::List(items),
            span,
        })
    }

    /// One level deeper into an expression; refused past `MAX_DEPTH` (no stack overflow).
    fn deeper(&mut self) -> Result<(), Diagnostic> {
        self.depth += 1;
        if self.depth > MAX_DEPTH {
            return Err(Diagnostic::error(
                ErrorKind::Limit,
                self.here(),
                "expression nested too deeply",
            )
            .with_hint(format!(
                "at most {MAX_DEPTH} levels of parentheses and operators"
            )));
        }
        Ok(())
    }

    fn expr(&mut self) -> Result<Expr, Diagnostic> {
        self.deeper()?;
        let r = self.binary(0);
        self.depth -= 1;
        r
    }

    fn binary(&mut self, min_prec: u8) -> Result<Expr, Diagnostic> {
        let mut lhs = self.unary()?;
        loop {
            let (op, prec, right_assoc) = match self.peek().map(|t| &t.tok) {
                Some(Tok::Sym('+')) => (BinOp::Add, 1, false),
                Some(Tok::Sym('-')) => (BinOp::Sub, 1, false),
                Some(Tok::Sym('*')) => (BinOp::Mul, 2, false),
                Some(Tok::Sym('/')) => (BinOp::Div, 2, false),
                Some(Tok::Sym('^')) => (BinOp::Pow, 4, true),
                _ => break,
            };
            if prec < min_prec {
                break;
            }
            self.pos += 1;
            self.deeper()?;
            let rhs = if right_assoc {
                self.binary_pow_rhs()?
            } else {
                self.binary(prec + 1)?
            };
            self.depth -= 1;
            let span = lhs.span.to(rhs.span);
            lhs = Expr {
                kind: ExprKind::Bin(op, Box::new(lhs), Box::new(rhs)),
                span,
            };
        }
        Ok(lhs)
    }

    fn binary_pow_rhs(&mut self) -> Result<Expr, Diagnostic> {
        // right-associative, binds tighter than unary minus on its left: -2^2 = -4, 2^-1 = 0.5
        self.binary(4)
    }

    fn unary(&mut self) -> Result<Expr, Diagnostic> {
        if self.peek_sym('-') || self.peek_sym('+') {
            let neg = self.peek_sym('-');
            let start = self.here();
            self.pos += 1;
            self.deeper()?;
            let inner = self.binary(3)?;
            self.depth -= 1;
            let span = start.to(inner.span);
            return Ok(if neg {
                Expr {
                    kind: ExprKind::Neg(Box::new(inner)),
                    span,
                }
            } else {
                inner
            });
        }
        self.postfix()
    }

    fn postfix(&mut self) -> Result<Expr, Diagnostic> {
        let mut e = self.primary()?;
        if let Some(Token {
            tok: Tok::Unit(u),
            span,
        }) = self.peek()
        {
            let w = Word {
                text: u.to_string(),
                span: *span,
            };
            self.pos += 1;
            let span = e.span.to(w.span);
            e = Expr {
                kind: ExprKind::Unit(Box::new(e), w),
                span,
            };
        }
        Ok(e)
    }

    fn primary(&mut self) -> Result<Expr, Diagnostic> {
        let Some(t) = self.peek().copied() else {
            return Err(self.unexpected("a value"));
        };
        match t.tok {
            Tok::Num(v) => {
                self.pos += 1;
                Ok(Expr {
                    kind: ExprKind::Num(v),
                    span: t.span,
                })
            }
            Tok::Str(s) => {
                self.pos += 1;
                Ok(Expr {
                    kind: ExprKind::Str(s.to_string()),
                    span: t.span,
                })
            }
            Tok::Ident(name) => {
                self.pos += 1;
                if self.peek_sym('(') {
                    let w = Word {
                        text: name.to_string(),
                        span: t.span,
                    };
                    self.pos += 1;
                    let mut args = Vec::new();
                    if !self.peek_sym(')') {
                        loop {
                            let key = if matches!(
                                self.peek(),
                                Some(Token {
                                    tok: Tok::Ident(_),
                                    ..
                                })
                            ) && self.peek_at_sym(1, '=')
                            {
                                let k = self.ident("an argument name")?;
                                self.pos += 1;
                                Some(k)
                            } else {
                                None
                            };
                            let value = self.expr()?;
                            args.push(Arg { key, value });
                            if self.peek_sym(',') {
                                self.pos += 1;
                                continue;
                            }
                            break;
                        }
                    }
                    let end = self.expect_sym(')', "`)` or `,` in the argument list")?;
                    return Ok(Expr {
                        kind: ExprKind::Call(w, args),
                        span: t.span.to(end),
                    });
                }
                Ok(Expr {
                    kind: ExprKind::Name(name.to_string()),
                    span: t.span,
                })
            }
            Tok::Sym('(') => {
                self.pos += 1;
                let first = self.expr()?;
                if self.peek_sym(',') {
                    let mut items = vec![first];
                    while self.peek_sym(',') {
                        self.pos += 1;
                        items.push(self.expr()?);
                    }
                    let end = self.expect_sym(')', "`)` to close the point")?;
                    return Ok(Expr {
                        kind: ExprKind::Tuple(items),
                        span: t.span.to(end),
                    });
                }
                let end = self.expect_sym(')', "`)`")?;
                Ok(Expr {
                    span: t.span.to(end),
                    ..first
                })
            }
            Tok::Sym('[') => {
                self.pos += 1;
                let mut points = Vec::new();
                while !self.peek_sym(']') {
                    if self.peek().is_none() {
                        return Err(self.unexpected("`]` to close the curve"));
                    }
                    points.push(self.expr()?);
                    if self.peek_sym(',') {
                        self.pos += 1;
                    }
                }
                let end = self.expect_sym(']', "`]`")?;
                Ok(Expr {
                    kind: ExprKind::Curve(points),
                    span: t.span.to(end),
                })
            }
            _ => Err(self.unexpected("a value")),
        }
    }
}

fn describe(t: &Tok) -> String {
    match t {
        Tok::Ident(s) => format!("`{s}`"),
        Tok::Num(v) => format!("the number {v}"),
        Tok::Unit(u) => format!("the unit `{u}`"),
        Tok::Str(s) => format!("the text \"{s}\""),
        Tok::Sym(c) => format!("`{c}`"),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parses_the_core_statements() {
        let text = "rate 44100\nlet k = 0.1 # c\nmas m1 M=1 X0=0\nlnl l m1 m2 LK=[(-1,0) (1,0.05)]\nenf p m1 signal=impulse(at=10ms, amp=1)\nstring s n=3 ends=fixed,free\n";
        let (st, errs) = parse(text);
        assert!(errs.is_empty(), "{errs:?}");
        assert_eq!(st.len(), 6);
        match &st[3] {
            Statement::Module { refs, params, .. } => {
                assert_eq!(refs.len(), 3);
                assert!(matches!(&params[0].value.kind, ExprKind::Curve(p) if p.len() == 2));
            }
            s => panic!("{s:?}"),
        }
        match &st[5] {
            Statement::Module { params, .. } => {
                assert!(matches!(&params[1].value.kind, ExprKind::List(l) if l.len() == 2))
            }
            s => panic!("{s:?}"),
        }
    }

    #[test]
    fn spans_point_at_the_text() {
        let (_, errs) = parse("mas m1 M=1\nmas m2 M=$\n");
        assert_eq!(errs.len(), 1);
        let s = errs[0].span.unwrap();
        assert_eq!((s.line, s.col), (2, 10));
    }

    #[test]
    fn units_glue_to_numbers_and_parentheses() {
        let e = parse_expr("(2*3)N/m + 10ms").unwrap();
        assert!(matches!(e.kind, ExprKind::Bin(BinOp::Add, _, _)));
        assert!(parse_expr("2 / m").is_ok());
        assert!(parse_expr("3furlongs").is_err());
    }

    #[test]
    fn deep_nesting_is_refused_not_overflowed() {
        let deep = "(".repeat(10_000) + "1" + &")".repeat(10_000);
        assert!(parse_expr(&deep).is_err());
        let minus = "-".repeat(10_000) + "1";
        assert!(parse_expr(&minus).is_err());
    }
}
