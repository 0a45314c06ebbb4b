//! Exports for other tools: the network as a Graphviz graph ([`graph_dot`]) and the linearised
//! network as a SPICE netlist of its electrical analogue ([`spice_netlist`]), with a reader for the
//! response ngspice writes ([`parse_spice_ac`]).
//!
//! ## The mobility analogue
//!
//! In the mobility (admittance) analogue a node voltage is a velocity and a branch current a force
//! (Kontogeorgakopoulos & Cadoz, SMC 2007, III.C): a mass `m` is a capacitor `C = m` to ground, a
//! spring `k` an inductor `L = 1/k`, a damper `z` a resistor `R = 1/z`, and a force a current
//! source. Kirchhoff's current law at a node is then Newton's law `m a + z v + k x = F`. The
//! netlist is the continuous-time network in physical units (SI with masses in kilograms and
//! positions in metres):
//!
//! | mechanical | GENESIS | physical | electrical |
//! | --- | --- | --- | --- |
//! | inertia | `M` | `m = M` kg | `C = m` F |
//! | stiffness | `K` | `k = K Fs²` N/m | `L = 1/k` H |
//! | viscosity | `Z` | `z = Z Fs` N·s/m | `R = 1/z` Ω |
//! | force | `F` | `F Fs²` N | current, A |
//! | velocity | `V` (per sample) | `V Fs` m/s | voltage, V |
//!
//! The discrete scheme and the continuous network agree at low frequency: the inertia term differs
//! by `O((ωT)²)` and the backward-difference damper by `O(ωT)` (relative to the damping term), so
//! the responses agree well below about `Fs/200` and part ways towards Nyquist.

use std::collections::BTreeMap;
use std::fmt::Write as _;

use cordis_core::{Interaction, Material, Output, Probe, Signal};
use cordis_model::Model;
use faer::c64;

use crate::linear::LinearSystem;
use crate::AnalysisError;

/// Quotes a string for the DOT language: `"` and `\` escaped, line breaks as `\n`.
fn dot_quote(s: &str) -> String {
    let mut out = String::with_capacity(s.len() + 2);
    out.push('"');
    out.push_str(&dot_escape(s));
    out.push('"');
    out
}

/// Escapes a string for use inside a DOT quoted string (without the quotes).
fn dot_escape(s: &str) -> String {
    let mut out = String::with_capacity(s.len());
    for c in s.chars() {
        match c {
            '"' => out.push_str("\\\""),
            '\\' => out.push_str("\\\\"),
            '\n' => out.push_str("\\n"),
            '\r' => {}
            c => out.push(c),
        }
    }
    out
}

/// A number for a label: six significant digits, trailing zeros trimmed, an exponent outside
/// `[1e-3, 1e5)` (`0.1`, `1e-4`, `44100`, `2.5e7`).
fn num(x: f64) -> String {
    if x == 0.0 {
        return "0".into();
    }
    if !x.is_finite() {
        return format!("{x}");
    }
    let a = x.abs();
    if (1e-3..1e5).contains(&a) {
        let digits = (5 - a.log10().floor() as i32).clamp(0, 8) as usize;
        let s = format!("{x:.digits$}");
        if s.contains('.') {
            s.trim_end_matches('0').trim_end_matches('.').to_string()
        } else {
            s
        }
    } else {
        let s = format!("{x:.5e}");
        match s.split_once('e') {
            Some((m, e)) => {
                let m = if m.contains('.') {
                    m.trim_end_matches('0').trim_end_matches('.')
                } else {
                    m
                };
                format!("{m}e{e}")
            }
            None => s,
        }
    }
}

/// A short description of a signal.
fn signal_label(s: &Signal) -> String {
    match s {
        Signal::Constant(v) => format!("constant {}", num(*v)),
        Signal::Impulse { at, amp } => format!("impulse at={at} amp={}", num(*amp)),
        Signal::Step { at, amp } => format!("step at={at} amp={}", num(*amp)),
        Signal::Sine { freq, amp, .. } => format!("sine f={} amp={}", num(*freq), num(*amp)),
        Signal::Noise { amp, seed } => format!("noise amp={} seed={seed}", num(*amp)),
        Signal::Envelope(c) => format!("envelope ({} points)", c.len()),
        Signal::Samples { data, gain } => {
            format!("samples ({}) gain={}", data.len(), num(*gain))
        }
    }
}

/// `NAME: X0=.. V0=..` parts that are not zero.
fn initial(x0: f64, v0: f64) -> String {
    let mut s = String::new();
    if x0 != 0.0 {
        let _ = write!(s, " X0={}", num(x0));
    }
    if v0 != 0.0 {
        let _ = write!(s, " V0={}", num(v0));
    }
    s
}

/// The network as a Graphviz `digraph`, in the model's declaration order (so the text is the same
/// for the same model).
///
/// - Material modules are nodes named by their module names, labelled with their type and
///   parameters (GENESIS units): MAS an ellipse, CEL a double ellipse, SOL a grey box, ENX a
///   diamond.
/// - Interactions are edges from end 1 to end 2, labelled `name: TYPE parameters` (BUT with its
///   threshold `S`, LNL with the number of points of its curves).
/// - Force inputs (ENF) are small note nodes with a dashed edge to their module; outputs (SOX, SOF,
///   sums) are note nodes with dashed edges from what they record (an SOF from both ends of its
///   interaction).
///
/// The modules of sticking devices appear as the modules they are (`NAME.L`, `NAME.B1`...).
/// Render it with `dot -Tsvg net.dot -o net.svg`.
pub fn graph_dot(model: &Model) -> String {
    let net = &model.network;
    let mut out = String::new();
    let _ = writeln!(
        out,
        "// cordis network {}: {} material modules, {} interactions, {} inputs, {} outputs",
        model.path.display().to_string().replace(['\n', '\r'], " "),
        net.materials.len(),
        net.links.len(),
        net.forces.len(),
        net.outputs.len()
    );
    let _ = writeln!(
        out,
        "// parameters in GENESIS units at Fs = {} Hz (K = k/Fs^2, Z = z/Fs, forces N/Fs^2)",
        num(model.rate)
    );
    out.push_str("digraph \"cordis\" {\n");
    out.push_str("  graph [rankdir=LR, fontname=\"Helvetica\", fontsize=10];\n");
    out.push_str("  node [fontname=\"Helvetica\", fontsize=10];\n");
    out.push_str("  edge [fontname=\"Helvetica\", fontsize=9];\n");
    for (i, m) in net.materials.iter().enumerate() {
        let name = &model.materials[i].name;
        let (params, attrs) = match m {
            Material::Mas { m, x0, v0 } => (
                format!("MAS M={}{}", num(*m), initial(*x0, *v0)),
                "shape=ellipse, style=filled, fillcolor=\"#dbe9f6\"",
            ),
            Material::Cel { m, k, z, x0, v0, r } => {
                let mut p = format!("CEL M={} K={} Z={}", num(*m), num(*k), num(*z));
                if *r != 0.0 {
                    let _ = write!(p, " R={}", num(*r));
                }
                p.push_str(&initial(*x0, *v0));
                (
                    p,
                    "shape=ellipse, peripheries=2, style=filled, fillcolor=\"#fdf0c8\"",
                )
            }
            Material::Sol { x0 } => (
                format!("SOL{}", initial(*x0, 0.0)),
                "shape=box, style=filled, fillcolor=\"#c8c8c8\"",
            ),
            Material::Enx { signal } => (
                format!("ENX {}", signal_label(signal)),
                "shape=diamond, style=filled, fillcolor=\"#f6d5d0\"",
            ),
        };
        let _ = writeln!(
            out,
            "  {} [label=\"{}\\n{}\", {attrs}];",
            dot_quote(name),
            dot_escape(name),
            dot_escape(&params)
        );
    }
    for (l, link) in net.links.iter().enumerate() {
        let name = &model.links[l].name;
        let (params, colour) = match &link.law {
            Interaction::Res { k } => (format!("RES K={}", num(*k)), "black"),
            Interaction::Fro { z } => (format!("FRO Z={}", num(*z)), "\"#1f5fa8\""),
            Interaction::Ref { k, z } => (format!("REF K={} Z={}", num(*k), num(*z)), "black"),
            Interaction::But { k, z, s } => (
                format!("BUT K={} Z={} S={}", num(*k), num(*z), num(*s)),
                "\"#b03020\"",
            ),
            Interaction::Lnl { lk, lz } => {
                let pts = |c: &cordis_core::Curve| {
                    if c.is_empty() {
                        "none".to_string()
                    } else {
                        format!("{} points", c.len())
                    }
                };
                (
                    format!("LNL LK: {}, LZ: {}", pts(lk), pts(lz)),
                    "\"#2a7a2a\"",
                )
            }
        };
        let _ = writeln!(
            out,
            "  {} -> {} [label=\"{}: {}\", color={colour}];",
            dot_quote(&model.materials[link.a.index()].name),
            dot_quote(&model.materials[link.b.index()].name),
            dot_escape(name),
            dot_escape(&params)
        );
    }
    for (f, fi) in net.forces.iter().enumerate() {
        let id = dot_quote(&format!("enf#{f}"));
        let _ = writeln!(
            out,
            "  {id} [label=\"{}\\nENF {}\", shape=note, fontsize=8];",
            dot_escape(&model.forces[f].name),
            dot_escape(&signal_label(&fi.signal))
        );
        let _ = writeln!(
            out,
            "  {id} -> {} [style=dashed];",
            dot_quote(&model.materials[fi.target.index()].name)
        );
    }
    for (c, o) in net.outputs.iter().enumerate() {
        let id = dot_quote(&format!("out#{c}"));
        let mut sources: Vec<(String, Option<String>)> = Vec::new();
        let mut probe = |p: &Probe, gain: Option<f64>| match p {
            Probe::Position(m) => sources.push((
                model.materials[m.index()].name.clone(),
                gain.map(|g| format!("x * {}", num(g))),
            )),
            Probe::Force(l) => {
                let link = &net.links[l.index()];
                let label = match gain {
                    Some(g) => format!("f({}) * {}", model.links[l.index()].name, num(g)),
                    None => format!("f({})", model.links[l.index()].name),
                };
                sources.push((
                    model.materials[link.a.index()].name.clone(),
                    Some(label.clone()),
                ));
                sources.push((model.materials[link.b.index()].name.clone(), Some(label)));
            }
        };
        let kind = match o {
            Output::Position(m) => {
                probe(&Probe::Position(*m), None);
                "SOX"
            }
            Output::Force(l) => {
                probe(&Probe::Force(*l), None);
                "SOF"
            }
            Output::Sum(terms) => {
                for (g, p) in terms {
                    probe(p, Some(*g));
                }
                "sum"
            }
        };
        let _ = writeln!(
            out,
            "  {id} [label=\"{}\\n{kind}\", shape=note, fontsize=8];",
            dot_escape(&model.outputs[c].name)
        );
        for (from, label) in sources {
            match label {
                Some(l) => {
                    let _ = writeln!(
                        out,
                        "  {} -> {id} [style=dashed, label=\"{}\", fontsize=8];",
                        dot_quote(&from),
                        dot_escape(&l)
                    );
                }
                None => {
                    let _ = writeln!(out, "  {} -> {id} [style=dashed];", dot_quote(&from));
                }
            }
        }
    }
    out.push_str("}\n");
    out
}

/// What [`spice_netlist`] writes besides the network.
#[derive(Clone, Debug, PartialEq)]
pub struct SpiceOptions {
    /// The dof (index into [`LinearSystem::dofs`]) that receives the 1 A (1 N) AC current source.
    pub force_at: usize,
    /// The netlist's title (its first line; line breaks are replaced by spaces).
    pub title: String,
    /// Points per decade of the `.ac dec` sweep.
    pub points_per_decade: u32,
    /// First frequency of the sweep, Hz.
    pub f_start: f64,
    /// Last frequency of the sweep, Hz (at most Nyquist makes sense: the discrete model it stands
    /// for has nothing above).
    pub f_stop: f64,
    /// The dofs whose node voltages are written to `data_file` (`None`: every dof).
    pub probes: Option<Vec<usize>>,
    /// The file the `.control` block writes the response to (ngspice `wrdata`), relative to
    /// ngspice's working directory; a name without spaces.
    pub data_file: String,
}

impl SpiceOptions {
    /// A 1 A source at `force_at`, 20 points per decade from 10 Hz to Nyquist (`rate / 2`), every
    /// node voltage written to `cordis_ac.txt`.
    pub fn new(force_at: usize, rate: f64, title: &str) -> SpiceOptions {
        SpiceOptions {
            force_at,
            title: title.to_string(),
            points_per_decade: 20,
            f_start: 10.0,
            f_stop: rate / 2.0,
            probes: None,
            data_file: "cordis_ac.txt".into(),
        }
    }
}

/// The SPICE node name of each dof: `n<dof>_<name>`, lower case, characters other than ASCII
/// letters and digits replaced by `_` (`s[3]` of dof 4 is `n4_s_3_`). SPICE names are
/// case-insensitive; the dof number keeps them unique.
pub fn spice_node_names(sys: &LinearSystem) -> Vec<String> {
    sys.names
        .iter()
        .enumerate()
        .map(|(d, name)| {
            let s: String = name
                .chars()
                .map(|c| {
                    if c.is_ascii_alphanumeric() {
                        c.to_ascii_lowercase()
                    } else {
                        '_'
                    }
                })
                .collect();
            format!("n{d}_{s}")
        })
        .collect()
}

/// A value for SPICE: Rust's shortest round-trip form (`1e-5`, `0.25`, `2.5e5`), which SPICE
/// reads exactly.
fn spice_num(x: f64) -> String {
    let a = x.abs();
    if a != 0.0 && !(1e-3..1e6).contains(&a) {
        format!("{x:e}")
    } else {
        format!("{x}")
    }
}

/// The linearised network as a SPICE netlist of its mobility analogue (see the module
/// documentation), in physical units and continuous time, with an AC sweep that ngspice runs in
/// batch mode (`ngspice -b net.cir`) and whose node voltages (velocities, m/s per N) it writes to
/// `opts.data_file` (read it with [`parse_spice_ac`]).
///
/// The network is read from the matrices of `sys`, so linearised BUT and LNL links follow the rules
/// of the analysis: an off-diagonal entry `-k` between dofs `i` and `j` of `K` (or `R`) is a spring
/// (damper) `k` between their nodes, and a row's diagonal plus its off-diagonal entries (the
/// diagonal minus the sum of the springs, when all are positive) is the stiffness (viscosity) to
/// ground: springs to fixed points and a CEL's own spring and damper. A value whose magnitude is
/// below `1e-10` of the row's diagonal is rounding and is left out, as are zero values. Negative
/// values (falling LNL curves, the sticking devices' negative BUT) give negative elements, which
/// ngspice accepts in an AC analysis. `model` supplies the module types and the model's path for
/// the comments.
///
/// The sweep is `.ac dec` without an operating point (`.options noopac`: the circuit is linear, and
/// a free-floating part has no DC path to ground), with a pivoting threshold `pivrel=1e-6` instead
/// of 1e-3: the small inductances of typical springs otherwise make ngspice's sparse solver refuse
/// diagonal pivots and fill in (a 40 × 40 membrane took 130 s instead of 2 s, for the same result to
/// 1e-11).
pub fn spice_netlist(
    sys: &LinearSystem,
    model: &Model,
    opts: &SpiceOptions,
) -> Result<String, AnalysisError> {
    let n = sys.len();
    if n == 0 {
        return Err(AnalysisError::NoMobileModule);
    }
    let bad_dof = |d: usize| AnalysisError::UnknownModule {
        name: format!("dof {d}"),
        hint: format!("the model has {n} mobile modules, dofs 0 to {}", n - 1),
    };
    if opts.force_at >= n {
        return Err(bad_dof(opts.force_at));
    }
    let probes: Vec<usize> = match &opts.probes {
        Some(p) => p.clone(),
        None => (0..n).collect(),
    };
    if let Some(&d) = probes.iter().find(|&&d| d >= n) {
        return Err(bad_dof(d));
    }
    let fs = sys.rate;
    let nodes = spice_node_names(sys);
    let mut out = String::new();
    let title = opts.title.replace(['\n', '\r'], " ");
    let _ = writeln!(
        out,
        "{}",
        if title.trim().is_empty() {
            "cordis"
        } else {
            &title
        }
    );
    let _ = writeln!(
        out,
        "* cordis: mobility analogue of {} linearised at rest (continuous time, physical units)",
        model.path.display().to_string().replace(['\n', '\r'], " ")
    );
    out.push_str(concat!(
        "* voltage = velocity (m/s), current = force (N)\n",
        "* C = m (F = kg): a mass, to ground\n",
        "* L = 1/k (H = m/N): a spring, k = K Fs^2 (N/m)\n",
        "* R = 1/z (ohm = m/(N s)): a damper, z = Z Fs (N s/m)\n",
        "* a force F N is F / Fs^2 in GENESIS units (1 A here = 1 N)\n",
    ));
    let _ = writeln!(out, "* Fs = {} Hz", spice_num(fs));
    for note in &sys.notes {
        let _ = writeln!(out, "* note: {}", note.replace(['\n', '\r'], " "));
    }
    out.push_str("*\n* nodes\n");
    for (d, node) in nodes.iter().enumerate() {
        let m = &model.network.materials[sys.dofs[d].index()];
        let _ = writeln!(out, "* {node}: {} {}", m.kind(), sys.names[d]);
    }
    out.push_str("*\n* masses\n");
    for (d, &m) in sys.mass.iter().enumerate() {
        let _ = writeln!(out, "C{d} {} 0 {}", nodes[d], spice_num(m));
    }
    // (element letter, what, matrix, GENESIS to physical factor); the element value is 1/physical
    for (letter, what, matrix, scale) in [
        ("L", "springs", &sys.k, fs * fs),
        ("R", "dampers", &sys.r, fs),
    ] {
        let mut pairs: BTreeMap<(usize, usize), f64> = BTreeMap::new();
        let mut ground: Vec<f64> = matrix.diag.clone();
        for &(i, j, v) in &matrix.off {
            let (i, j) = if i < j { (i, j) } else { (j, i) };
            if i == j {
                ground[i] += v;
                continue;
            }
            *pairs.entry((i, j)).or_insert(0.0) += v;
            ground[i] += v;
            ground[j] += v;
        }
        let _ = writeln!(out, "*\n* {what} between modules");
        let mut count = 0usize;
        for (&(i, j), &v) in &pairs {
            let k = -v * scale;
            if k == 0.0 || !k.is_finite() {
                continue;
            }
            let _ = writeln!(
                out,
                "{letter}{count} {} {} {}",
                nodes[i],
                nodes[j],
                spice_num(1.0 / k)
            );
            count += 1;
        }
        let _ = writeln!(out, "* {what} to ground (fixed points, CEL)");
        for (d, &g) in ground.iter().enumerate() {
            if g == 0.0 || g.abs() <= 1e-10 * matrix.diag[d].abs() {
                continue;
            }
            let k = g * scale;
            let _ = writeln!(out, "{letter}{count} {} 0 {}", nodes[d], spice_num(1.0 / k));
            count += 1;
        }
    }
    let _ = writeln!(
        out,
        "*\n* a force of 1 N (1 A) into the node of {}\nI0 0 {} DC 0 AC 1",
        sys.names[opts.force_at], nodes[opts.force_at]
    );
    out.push_str(concat!(
        "*\n* noopac: the circuit is linear, no operating point (a free part has no DC path)\n",
        "* pivrel: the springs' small inductances make the default pivoting threshold (1e-3)\n",
        "* reject diagonal pivots, and the factorisation fills in (a 40 x 40 membrane: 130 s\n",
        "* instead of 2 s, with the same result to 1e-11)\n",
        ".options noopac pivrel=1e-6\n",
    ));
    let _ = writeln!(
        out,
        ".ac dec {} {} {}",
        opts.points_per_decade.max(1),
        spice_num(opts.f_start),
        spice_num(opts.f_stop)
    );
    let vectors: Vec<String> = probes.iter().map(|&d| format!("v({})", nodes[d])).collect();
    let _ = writeln!(
        out,
        "* (for simulators without .control) velocity magnitude (m/s per N) and phase (rad)"
    );
    let _ = writeln!(
        out,
        ".print ac {}",
        probes
            .iter()
            .map(|&d| format!("vm({0}) vp({0})", nodes[d]))
            .collect::<Vec<_>>()
            .join(" ")
    );
    out.push_str(".control\n");
    out.push_str("set wr_singlescale\nset wr_vecnames\noption numdgt=15\nrun\n");
    let _ = writeln!(
        out,
        "* columns: frequency (Hz), then Re and Im of each voltage"
    );
    let _ = writeln!(out, "wrdata {} {}", opts.data_file, vectors.join(" "));
    out.push_str("quit\n.endc\n.end\n");
    Ok(out)
}

/// An AC response as ngspice's `wrdata` writes it (with `wr_singlescale`).
#[derive(Clone, Debug, PartialEq)]
pub struct SpiceAc {
    /// The vectors' names (`v(n0_a)`), in column order.
    pub names: Vec<String>,
    /// The frequencies, Hz.
    pub freqs: Vec<f64>,
    /// `values[v][f]`: vector `v` at frequency `f`.
    pub values: Vec<Vec<c64>>,
}

/// Reads the data file the netlist's `.control` block writes: a header line (`frequency`, then each
/// vector's name twice), then one line per frequency with the frequency and the real and imaginary
/// parts of each vector.
pub fn parse_spice_ac(text: &str) -> Result<SpiceAc, String> {
    let mut lines = text.lines().filter(|l| !l.trim().is_empty());
    let header: Vec<&str> = lines
        .next()
        .ok_or("the file is empty")?
        .split_whitespace()
        .collect();
    if header.first() != Some(&"frequency") || header.len() % 2 != 1 {
        return Err(format!(
            "the header `{}` is not `frequency` followed by pairs of columns",
            header.join(" ")
        ));
    }
    let names: Vec<String> = header[1..].chunks(2).map(|c| c[0].to_string()).collect();
    let mut freqs = Vec::new();
    let mut values = vec![Vec::new(); names.len()];
    for (l, line) in lines.enumerate() {
        let v: Vec<f64> = line
            .split_whitespace()
            .map(|s| s.parse::<f64>())
            .collect::<Result<_, _>>()
            .map_err(|e| format!("data line {}: {e}", l + 1))?;
        if v.len() != header.len() {
            return Err(format!(
                "data line {} has {} columns, the header {}",
                l + 1,
                v.len(),
                header.len()
            ));
        }
        freqs.push(v[0]);
        for (k, col) in values.iter_mut().enumerate() {
            col.push(c64::new(v[1 + 2 * k], v[2 + 2 * k]));
        }
    }
    Ok(SpiceAc {
        names,
        freqs,
        values,
    })
}
