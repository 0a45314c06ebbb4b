//! The exports: the Graphviz graph (structure, escaping, and `dot` when it is installed) and the
//! SPICE netlist of the mobility analogue, simulated by ngspice and compared with the exact discrete
//! response cordis computes.
#![allow(clippy::unwrap_used)] // tests may panic on failure

use std::path::PathBuf;
use std::process::Command;

use cordis_analysis::{
    graph_dot, parse_spice_ac, spice_netlist, spice_node_names, LinearSystem, ModalAnalysis,
    SpiceOptions,
};
use cordis_model::{load_str, Model, Options};
use faer::c64;

fn load(text: &str) -> Model {
    match load_str("m.cordis".as_ref(), text, &Options::default()) {
        Ok(m) => m,
        Err(e) => panic!("{e}"),
    }
}

/// A fresh folder under Cargo's temporary folder for integration tests.
fn scratch(name: &str) -> PathBuf {
    let dir = PathBuf::from(env!("CARGO_TARGET_TMPDIR"))
        .join(format!("export-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// Every module type, generated names with `[`, `]`, `,` and `.`, a device, every output kind.
const EVERY_MODULE: &str = r#"
rate 44100
sol ground
mas m1 M=1 X0=0.1
mas m2 M=2
cel bell M=1 f=440Hz tau=1.5s R=0.5
enx finger signal=sine(freq=2Hz, amp=0.01)
res r ground m1 K=0.1
fro air ground m2 Z=1e-4
ref spring m1 m2 K=0.01 Z=5N.s/m
but contact finger m2 K=0.2 Z=1e-3 S=0.01
lnl soft m2 bell LK=[(-1, -0.1) (0, 0) (1, 0.2)] LZ=[(-1, -0.001) (1, 0.001)]
string s n=3 M=1 K=0.01 Z=1e-5
membrane mem rows=2 cols=2 M=1 K=0.01
stick glue s[2] mem[1,1] KL=0.01 S=0.1
enf hammer m1 signal=impulse(at=10, amp=0.001)
enf push mem[0,1] signal=step(at=0, amp=1e-6)
sox out m1
sof hit contact
sox pickups s[0] + 0.5*mem[1,0]
"#;

/// Lines of a DOT text that declare a node (`  "id" [label=...]`) and that declare an edge.
fn dot_counts(dot: &str) -> (usize, usize) {
    let nodes = dot
        .lines()
        .filter(|l| l.starts_with("  \"") && !l.contains(" -> ") && l.contains("[label="))
        .count();
    let edges = dot.lines().filter(|l| l.contains(" -> ")).count();
    (nodes, edges)
}

/// `dot` from Graphviz, when it is installed.
fn run_dot(dot: &str, format: &str) -> Option<String> {
    use std::io::Write;
    let mut child = match Command::new("dot")
        .arg(format!("-T{format}"))
        .stdin(std::process::Stdio::piped())
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
    {
        Ok(c) => c,
        Err(_) => return None,
    };
    child
        .stdin
        .take()
        .unwrap()
        .write_all(dot.as_bytes())
        .unwrap();
    let out = child.wait_with_output().unwrap();
    assert!(
        out.status.success(),
        "dot -T{format} rejected the graph: {}\n{dot}",
        String::from_utf8_lossy(&out.stderr)
    );
    Some(String::from_utf8(out.stdout).unwrap())
}

#[test]
fn graph_has_every_module_escaped_and_deterministic() {
    let m = load(EVERY_MODULE);
    let net = &m.network;
    let dot = graph_dot(&m);
    assert_eq!(dot, graph_dot(&load(EVERY_MODULE)), "not deterministic");
    assert!(dot.starts_with("// cordis network"));
    assert!(dot.contains("digraph \"cordis\" {") && dot.ends_with("}\n"));

    // a node per material, input and output; an edge per interaction, one per input, one per
    // probed position and two per probed force
    let probe_edges: usize = net
        .outputs
        .iter()
        .map(|o| match o {
            cordis_core::Output::Position(_) => 1,
            cordis_core::Output::Force(_) => 2,
            cordis_core::Output::Sum(t) => t
                .iter()
                .map(|(_, p)| match p {
                    cordis_core::Probe::Position(_) => 1,
                    cordis_core::Probe::Force(_) => 2,
                })
                .sum(),
        })
        .sum();
    let (nodes, edges) = dot_counts(&dot);
    assert_eq!(
        nodes,
        net.materials.len() + net.forces.len() + net.outputs.len()
    );
    assert_eq!(
        edges,
        net.links.len() + net.forces.len() + probe_edges,
        "{dot}"
    );
    // every material is a quoted node; names with brackets, commas and dots stay whole
    for named in &m.materials {
        assert!(
            dot.contains(&format!("  \"{}\" [label=\"{}\\n", named.name, named.name)),
            "no node for {}",
            named.name
        );
    }
    for needle in [
        "\"mem[1,1]\" [label=\"mem[1,1]\\nMAS M=1\", shape=ellipse",
        "\"ground\" [label=\"ground\\nSOL\", shape=box, style=filled",
        "\"bell\" [label=\"bell\\nCEL M=1 K=0.00392861 Z=3.02339e-5 R=0.5\", shape=ellipse, peripheries=2",
        "\"finger\" [label=\"finger\\nENX sine",
        "\"ground\" -> \"m1\" [label=\"r: RES K=0.1\"",
        "\"ground\" -> \"m2\" [label=\"air: FRO Z=1e-4\"",
        "[label=\"contact: BUT K=0.2 Z=0.001 S=0.01\"",
        "\"m2\" -> \"bell\" [label=\"soft: LNL LK: 3 points, LZ: 2 points\"",
        "\"s[2]\" -> \"mem[1,1]\" [label=\"glue.L: LNL LK: 4 points, LZ: none\"",
        "[label=\"glue.B1: BUT K=0",
        "\"enf#0\" -> \"m1\" [style=dashed]",
        "\"m1\" -> \"out#0\" [style=dashed]",
        "\"finger\" -> \"out#1\" [style=dashed, label=\"f(contact)\"",
        "\"mem[1,0]\" -> \"out#2\" [style=dashed, label=\"x * 0.5\"",
    ] {
        assert!(dot.contains(needle), "missing `{needle}` in\n{dot}");
    }

    // quotes and backslashes in names (not possible in the language, but in a hand-made model)
    let mut odd = m.clone();
    odd.materials[1].name = "we\"ird\\na me".into();
    let odd_dot = graph_dot(&odd);
    assert!(odd_dot.contains("  \"we\\\"ird\\\\na me\" [label=\"we\\\"ird\\\\na me\\nMAS"));
    assert!(odd_dot.contains("\"ground\" -> \"we\\\"ird\\\\na me\" [label=\"r: RES"));

    // Graphviz, when installed, must parse both and find the same numbers of nodes and edges
    match run_dot(&dot, "svg") {
        Some(svg) => {
            assert!(svg.contains("<svg"), "{svg}");
            for d in [&dot, &odd_dot] {
                let plain = run_dot(d, "plain").unwrap();
                let count = |w: &str| plain.lines().filter(|l| l.starts_with(w)).count();
                assert_eq!((count("node "), count("edge ")), dot_counts(d));
            }
            assert!(run_dot(&odd_dot, "plain")
                .unwrap()
                .contains("\"we\\\"ird\\\\na me\""));
        }
        None => eprintln!("graphviz `dot` is not installed: checked the graph's structure only"),
    }
}

#[test]
fn netlist_structure() {
    // a free mass (no spring to ground), a CEL, a chain with fixed ends, an inactive BUT
    let m = load(
        "sol g\nmas a M=2\nmas Bb M=3\ncel c M=1 K=0.01 Z=1e-4\nmas free M=4\n\
         ref k1 g a K=1e-4 Z=1e-6\nres k2 a Bb K=2e-4\nfro z1 Bb c Z=3e-6\nres k3 c g K=1e-4\n\
         but far g free K=1 S=-1\nfro drag free a Z=1e-6\nsox out c\n",
    );
    let sys = LinearSystem::from_model(&m).unwrap();
    let nodes = spice_node_names(&sys);
    assert_eq!(nodes, ["n0_a", "n1_bb", "n2_c", "n3_free"]);
    let net = spice_netlist(&sys, &m, &SpiceOptions::new(1, sys.rate, "chain\ntest")).unwrap();
    let lines: Vec<&str> = net.lines().collect();
    assert_eq!(lines[0], "chain test");
    let elements = |p: char| {
        lines
            .iter()
            .filter(|l| l.starts_with(p))
            .copied()
            .collect::<Vec<_>>()
    };
    let fs2 = 44100.0f64 * 44100.0;
    // (name, node, node, value): values from rows that sum several links carry rounding
    let check = |p: char, want: &[(&str, &str, &str, f64)]| {
        let got = elements(p);
        assert_eq!(got.len(), want.len(), "{got:?}");
        for (line, &(name, n1, n2, v)) in got.iter().zip(want) {
            let f: Vec<&str> = line.split_whitespace().collect();
            assert_eq!((f[0], f[1], f[2]), (name, n1, n2), "{line}");
            let x: f64 = f[3].parse().unwrap();
            assert!((x - v).abs() <= 1e-12 * v.abs(), "{line}: want {v:e}");
        }
    };
    check(
        'C',
        &[
            ("C0", "n0_a", "0", 2.0),
            ("C1", "n1_bb", "0", 3.0),
            ("C2", "n2_c", "0", 1.0),
            ("C3", "n3_free", "0", 4.0),
        ],
    );
    // springs: a-Bb, then to ground from a (k1) and c (k3 and its own K); L = 1/(K Fs^2)
    check(
        'L',
        &[
            ("L0", "n0_a", "n1_bb", 1.0 / (2e-4 * fs2)),
            ("L1", "n0_a", "0", 1.0 / (1e-4 * fs2)),
            ("L2", "n2_c", "0", 1.0 / ((0.01 + 1e-4) * fs2)),
        ],
    );
    // dampers, R = 1/(Z Fs)
    check(
        'R',
        &[
            ("R0", "n0_a", "n3_free", 1.0 / (1e-6 * 44100.0)),
            ("R1", "n1_bb", "n2_c", 1.0 / (3e-6 * 44100.0)),
            ("R2", "n0_a", "0", 1.0 / (1e-6 * 44100.0)),
            ("R3", "n2_c", "0", 1.0 / (1e-4 * 44100.0)),
        ],
    );
    assert_eq!(elements('I'), ["I0 0 n1_bb DC 0 AC 1"]);
    assert!(net.contains("\n.options noopac pivrel=1e-6\n.ac dec 20 10 22050\n"));
    assert!(net.contains("\nwrdata cordis_ac.txt v(n0_a) v(n1_bb) v(n2_c) v(n3_free)\n"));
    assert!(net.contains("* note: but far: inactive at rest"));
    assert!(net.ends_with("quit\n.endc\n.end\n"));
    assert!(spice_netlist(&sys, &m, &SpiceOptions::new(4, sys.rate, "t")).is_err());
    let mut o = SpiceOptions::new(0, sys.rate, "t");
    o.probes = Some(vec![2, 9]);
    assert!(spice_netlist(&sys, &m, &o).is_err());
}

#[test]
fn parse_wrdata() {
    let text = " frequency  v(a)  v(a)  v(b)  v(b)\n 1.0e+01 1 -2 3 4\n 2.0e+01 5 6 7 -8\n";
    let ac = parse_spice_ac(text).unwrap();
    assert_eq!(ac.names, ["v(a)", "v(b)"]);
    assert_eq!(ac.freqs, [10.0, 20.0]);
    assert_eq!(ac.values[1][1], c64::new(7.0, -8.0));
    assert!(parse_spice_ac("").is_err());
    assert!(parse_spice_ac("frequency v(a)\n1 2\n").is_err());
    assert!(parse_spice_ac("frequency v(a) v(a)\n1 2\n").is_err());
}

/// `A^-1` of a small complex matrix (Gauss-Jordan, partial pivoting).
fn inverse(mut a: Vec<Vec<c64>>) -> Vec<Vec<c64>> {
    let n = a.len();
    let mut inv: Vec<Vec<c64>> = (0..n)
        .map(|i| {
            (0..n)
                .map(|j| c64::new(if i == j { 1.0 } else { 0.0 }, 0.0))
                .collect()
        })
        .collect();
    for col in 0..n {
        let p = (col..n)
            .max_by(|&x, &y| a[x][col].norm().total_cmp(&a[y][col].norm()))
            .unwrap();
        a.swap(col, p);
        inv.swap(col, p);
        let d = a[col][col];
        for j in 0..n {
            a[col][j] /= d;
            inv[col][j] /= d;
        }
        for i in 0..n {
            if i != col {
                let f = a[i][col];
                for j in 0..n {
                    let (x, y) = (a[col][j], inv[col][j]);
                    a[i][j] -= f * x;
                    inv[i][j] -= f * y;
                }
            }
        }
    }
    inv
}

/// A damped chain between two fixed ends: four masses of different inertias, REF links, a FRO to
/// the ground, a CEL in the chain and a BUT that is active at rest (so the netlist follows the
/// linearisation), modes from about 40 to 190 Hz.
const CHAIN: &str = "
rate 44100
sol left
sol right
mas a M=0.010
mas b M=0.015
cel c M=0.012 K=3000N/m Z=0.2N.s/m
mas d M=0.020
ref l0 left a K=4000N/m Z=0.3N.s/m
ref l1 a b K=5000N/m Z=0.2N.s/m
ref l2 b c K=3000N/m Z=0.4N.s/m
ref l3 c d K=6000N/m Z=0.2N.s/m
fro air left b Z=0.5N.s/m
but stop d right K=2000N/m Z=0.1N.s/m S=0.01
sox out d
";

/// ngspice's AC response of the mobility analogue against the exact discrete response of cordis.
///
/// Units. GENESIS positions are metres, GENESIS forces are `N / Fs²` (FORMALISM: `K = k/Fs²` makes
/// `K x` a force in those units), so the receptance `H = X/F` cordis computes (metres per GENESIS
/// force) is `H / Fs²` metres per newton. The discrete velocity is the backward difference
/// `(1 - z⁻¹) X` per sample, `Fs (1 - z⁻¹) X` m/s, so the mobility in m/s per N is
/// `Y_d = (1 - z⁻¹) H / Fs`. A backward difference is the velocity half a sample earlier:
/// `1 - z⁻¹ = e^{-iωT/2} · iωT sinc(ωT/2)`, a pure delay times `1 + O((ωT)²)`. We compare the
/// mid-step velocity `e^{iωT/2} (1 - z⁻¹) X = 2i sin(ωT/2) X` (the raw backward difference lags by
/// exactly `ωT/2`, 0.9° at Fs/200, which is a sampling convention, not a model difference).
///
/// Bound. With `s = sin(ωT/2)/(ωT/2)` and physical `m`, `k = K Fs²`, `z = Z Fs`, the discrete
/// dynamic stiffness `Fs² (M (z - 2 + z⁻¹) + K + R (1 - z⁻¹))` is
/// `D_d = k - ω² s² m + iω s e^{-iωT/2} z` and the continuous one `D_c = k - ω² m + iω z`, so
/// `E = D_d - D_c = -ω² (s² - 1) m + iω (s e^{-iωT/2} - 1) z`: `O((ωT)²)` in the inertia but `O(ωT)`
/// in the damping (the backward-difference damper; it amounts to an inertia change of `-zT/2`).
/// `Y_d = iω s D_d⁻¹`, `Y_c = iω D_c⁻¹` and `D_d⁻¹ - D_c⁻¹ = -D_d⁻¹ E D_c⁻¹` give, entrywise and
/// with absolute values taken entry by entry,
/// `|Y_d - Y_c|_ba <= ω (|s - 1| |D_d⁻¹|_ba + (|D_d⁻¹| |E| |D_c⁻¹|)_ba)`: the tolerance at each
/// frequency, plus `1e-9 |Y_c|` for ngspice's own precision (checked separately against `Y_c`, to
/// which it agrees to about 1e-14). Below the modes this is `O((ωT)²)`; near a mode it is about
/// `ωT/2` (the damper's first-order error times the resonance's gain `Q`, with `Z/M = ω₀T/Q`).
#[test]
fn ngspice_agrees_with_the_discrete_response() {
    if Command::new("ngspice").arg("--version").output().is_err() {
        panic!(
            "ngspice is not installed: this test simulates the SPICE export with it. Install it \
             (Debian/Ubuntu: `apt-get install ngspice`; .ci/run installs it on CI)"
        );
    }
    let model = load(CHAIN);
    let sys = LinearSystem::from_model(&model).unwrap();
    let n = sys.len();
    assert_eq!(n, 4);
    let fs = sys.rate;
    let (a, b) = (sys.dof("a").unwrap(), sys.dof("d").unwrap());
    let mut opts = SpiceOptions::new(a, fs, "cordis damped chain");
    opts.points_per_decade = 40;
    opts.f_start = 10.0;
    opts.f_stop = fs / 2.0;
    let netlist = spice_netlist(&sys, &model, &opts).unwrap();
    let dir = scratch("ngspice");
    std::fs::write(dir.join("chain.cir"), &netlist).unwrap();
    let run = Command::new("ngspice")
        .arg("-b")
        .arg("chain.cir")
        .current_dir(&dir)
        .output()
        .unwrap();
    assert!(
        run.status.success(),
        "ngspice failed:\n{}\n{}\n{netlist}",
        String::from_utf8_lossy(&run.stdout),
        String::from_utf8_lossy(&run.stderr)
    );
    let text = std::fs::read_to_string(dir.join(&opts.data_file)).unwrap_or_else(|e| {
        panic!(
            "ngspice wrote no {}: {e}\n{}",
            opts.data_file,
            String::from_utf8_lossy(&run.stdout)
        )
    });
    let ac = parse_spice_ac(&text).unwrap();
    let nodes = spice_node_names(&sys);
    assert_eq!(ac.names.len(), n);
    assert_eq!(ac.names[b], format!("v({})", nodes[b]));
    assert!(ac.freqs.len() > 100, "{} frequencies", ac.freqs.len());

    let ma = ModalAnalysis::compute(&sys).unwrap();
    let i = c64::new(0.0, 1.0);
    let k = sys.k.dense();
    let r = sys.r.dense();
    let (mut worst_low, mut worst_bound, mut worst_spice, mut worst_high) =
        (0.0f64, 0.0f64, 0.0f64, 0.0f64);
    let mut phase_low = 0.0f64;
    let mut worst_modal = 0.0f64;
    let mut low = 0;
    for (fi, &f) in ac.freqs.iter().enumerate() {
        let w = std::f64::consts::TAU * f;
        let wt = w / fs;
        let y_spice = ac.values[b][fi];
        // cordis: exact discrete receptance, GENESIS units, to m/s per N (mid-step velocity)
        let h = ma.receptance(a, b, f, fs);
        let y_d = c64::new(0.0, 2.0 * (wt / 2.0).sin()) * h / fs;
        // continuous and discrete dynamic stiffness in physical units
        let s = (wt / 2.0).sin() / (wt / 2.0);
        let lag = c64::new((wt / 2.0).cos(), -(wt / 2.0).sin());
        let dyn_c = |ii: usize, jj: usize| {
            let m = if ii == jj { sys.mass[ii] } else { 0.0 };
            c64::new(k[(ii, jj)] * fs * fs - w * w * m, w * r[(ii, jj)] * fs)
        };
        let err = |ii: usize, jj: usize| {
            let m = if ii == jj { sys.mass[ii] } else { 0.0 };
            c64::new(-w * w * (s * s - 1.0) * m, 0.0) + i * w * (lag * s - 1.0) * (r[(ii, jj)] * fs)
        };
        let dc: Vec<Vec<c64>> = (0..n)
            .map(|x| (0..n).map(|y| dyn_c(x, y)).collect())
            .collect();
        let e: Vec<Vec<c64>> = (0..n)
            .map(|x| (0..n).map(|y| err(x, y)).collect())
            .collect();
        let dd: Vec<Vec<c64>> = (0..n)
            .map(|x| (0..n).map(|y| dc[x][y] + e[x][y]).collect())
            .collect();
        let (dci, ddi) = (inverse(dc), inverse(dd));
        let y_c = i * w * dci[b][a];
        // the discrete model solved directly agrees with the modal receptance
        let y_direct = i * w * s * ddi[b][a];
        let rel_modal = (y_direct - y_d).norm() / y_d.norm();
        if f <= fs / 200.0 {
            worst_modal = worst_modal.max(rel_modal);
        }
        // ngspice solves the continuous network: its precision
        let rel_spice = (y_spice - y_c).norm() / y_c.norm();
        worst_spice = worst_spice.max(rel_spice);
        assert!(
            rel_spice < 1e-10,
            "{f} Hz: ngspice {y_spice} vs continuous {y_c}"
        );
        let rel = (y_spice - y_d).norm() / y_d.norm();
        if f <= fs / 200.0 {
            low += 1;
            // |D_d⁻¹| |E| |D_c⁻¹| entrywise (absolute values)
            let mut prod = 0.0;
            for p in 0..n {
                for q in 0..n {
                    prod += ddi[b][p].norm() * e[p][q].norm() * dci[q][a].norm();
                }
            }
            let bound = w * ((s - 1.0).abs() * ddi[b][a].norm() + prod) + 1e-9 * y_c.norm();
            assert!(
                (y_spice - y_d).norm() <= bound,
                "{f} Hz: ngspice {y_spice} vs cordis {y_d}: {rel:.3e} > bound {:.3e}",
                bound / y_d.norm()
            );
            worst_low = worst_low.max(rel);
            worst_bound = worst_bound.max(bound / y_d.norm());
            phase_low = phase_low.max((y_spice / y_d).arg().abs());
        } else {
            worst_high = worst_high.max(rel);
        }
    }
    assert!(low >= 50, "{low} frequencies below Fs/200");
    // Measured: 1.51e-2 at 181 Hz near the top modes, where the bound is 1.65e-2; the size is that of
    // the damper's first-order error, ωT/2 = 1.3e-2 there (1.6e-2 at Fs/200). Below the first mode
    // the difference falls as f² (8e-6 at 10 Hz). The modal and the direct discrete solutions
    // agree to 1e-10 in this band.
    assert!(worst_low < 2e-2, "{worst_low}");
    assert!(worst_modal < 1e-8, "{worst_modal}");
    eprintln!(
        "ngspice vs cordis, 10 Hz to Fs/200 ({low} frequencies): max relative difference \
         {worst_low:.3e} (bound up to {worst_bound:.3e}), max phase difference {phase_low:.3e} rad; \
         above Fs/200: {worst_high:.3e}; ngspice vs continuous: {worst_spice:.3e}; \
         modal vs direct discrete: {worst_modal:.3e}"
    );
    let _ = std::fs::remove_dir_all(&dir);
}
