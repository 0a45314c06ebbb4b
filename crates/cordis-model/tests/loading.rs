//! The loader reads a model a line at a time (`load_str`): what that must not change.
#![allow(clippy::unwrap_used)] // tests and benches may panic on failure

use std::fmt::Write as _;

use cordis_core::{Interaction, Material};
use cordis_model::{load_str, ErrorKind, Options};

fn load(text: &str) -> Result<cordis_model::Model, cordis_model::LoadError> {
    load_str("load.cordis".as_ref(), text, &Options::default())
}

#[test]
fn a_rate_written_last_still_converts_every_unit() {
    let m = load("mas m M=1\nsol g\nres r g m K=1000N/m\nsox o m\nrate 1000\n").unwrap();
    assert_eq!(m.rate, 1000.0);
    assert_eq!(m.network.links[0].law, Interaction::Res { k: 1e-3 });
    assert_eq!(m.duration, 1000);
}

#[test]
fn a_syntax_error_anywhere_hides_the_other_errors() {
    // line 1 cannot resolve, but the file does not parse: only the syntax error is reported
    let e = load("mas a M=0\nmas b M=1\nsox o b\nmas c M=1 X0=$\n").unwrap_err();
    let errs: Vec<_> = e.errors().collect();
    assert_eq!(errs.len(), 1, "{errs:?}");
    assert_eq!(errs[0].kind, ErrorKind::Syntax);
    assert_eq!(errs[0].span.unwrap().line, 4);
}

#[test]
fn columns_count_characters_after_non_ascii_text() {
    let e = load("mas m M=1\nenf f m signal=file(\"dé.wav\") $\n").unwrap_err();
    let d = e.errors().next().unwrap();
    let s = d.span.unwrap();
    assert_eq!((s.line, s.col), (2, 31), "{d:?}");
    assert_eq!(&e.source[s.start..s.end], "$");
}

/// A ring of `n` masses, one statement per module.
fn ring(n: usize) -> String {
    let mut t = String::from("sol g\n");
    for i in 0..n {
        writeln!(t, "mas m{i} M=1").unwrap();
    }
    writeln!(t, "ref rg g m0 K=0.1").unwrap();
    for i in 0..n {
        writeln!(t, "ref r{i} m{i} m{} K=0.1 Z=0.0001", (i + 1) % n).unwrap();
    }
    t.push_str("sox out m7\n");
    t
}

#[test]
fn a_large_model_is_allocated_at_its_final_size() {
    let m = load(&ring(5000)).unwrap();
    let net = &m.network;
    assert_eq!((net.materials.len(), net.links.len()), (5001, 5001));
    assert_eq!(net.materials.capacity(), net.materials.len());
    assert_eq!(net.links.capacity(), net.links.len());
    assert_eq!(m.materials.capacity(), m.materials.len());
    assert_eq!(m.links.capacity(), m.links.len());
    assert_eq!(m.materials[4321].name, "m4320");
    assert_eq!(m.links[5000].name, "r4999");
    assert_eq!(
        (net.links[5000].a.index(), net.links[5000].b.index()),
        (5000, 1)
    );
    assert!(matches!(net.materials[1], Material::Mas { m, .. } if m == 1.0));

    let s = load("string s n=3000 M=1 K=0.1 air=0.001\nsox o s[1500]\n").unwrap();
    assert_eq!(s.network.materials.capacity(), s.network.materials.len());
    assert_eq!(s.network.links.capacity(), s.network.links.len());
    assert_eq!(s.links.capacity(), s.links.len());
}

#[test]
fn a_name_declared_further_down_is_found_in_a_large_file() {
    let mut text = ring(3000);
    let at = text.find("ref r10 ").unwrap();
    text.insert_str(at, "sox early later\n");
    text.push_str("mas later M=1\n");
    let line = text.lines().count();
    let e = load(&text).unwrap_err();
    let d = e.errors().next().unwrap();
    assert_eq!(d.kind, ErrorKind::UnknownName);
    assert!(
        d.message
            .contains(&format!("used before it is declared (at line {line})")),
        "{d:?}"
    );
}

#[test]
fn members_of_generators_are_names_like_any_other() {
    let text = "string s n=4 M=1 K=0.1\nmembrane mem rows=3 cols=3 M=1 K=0.1\nmas s2 M=1\nref x s[3] mem[1,1] K=0.1\nsof f s.l[4] - mem.v[1,2]\nsox o s2\n";
    let m = load(text).unwrap();
    assert_eq!(m.links.last().unwrap().name, "x");
    let e = load(&format!("{text}mas mem M=1\n")).unwrap_err();
    let d = e.errors().next().unwrap();
    assert_eq!(d.kind, ErrorKind::DuplicateName);
    assert!(
        d.message.contains("`mem` is already defined at line 2"),
        "{d:?}"
    );
    let e = load(&format!("{text}sox bad s[4]\n")).unwrap_err();
    let d = e.errors().next().unwrap();
    assert!(d.message.contains("no module is named `s[4]`"), "{d:?}");
}
