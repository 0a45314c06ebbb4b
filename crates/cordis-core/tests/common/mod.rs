//! Shared test helpers: a plain reference stepper and seeded network builders.
#![allow(clippy::unwrap_used)] // tests and benches may panic on failure
#![allow(dead_code)]

use cordis_core::{Curve, Interaction, MatId, Material, Network, Output, Probe, Signal};

/// Linear-scan curve evaluation, written independently of `Curve::eval`.
pub fn curve_ref(points: &[(f64, f64)], x: f64) -> f64 {
    if points.is_empty() {
        return 0.0;
    }
    let mut last: Option<usize> = None;
    for (i, p) in points.iter().enumerate() {
        if p.0 <= x {
            last = Some(i);
        }
    }
    match last {
        None => points[0].1,
        Some(i) if i == points.len() - 1 => points[i].1,
        Some(i) => {
            let (x0, y0) = points[i];
            let (x1, y1) = points[i + 1];
            y0 + (x - x0) * ((y1 - y0) / (x1 - x0))
        }
    }
}

/// The plain reference stepper: FORMALISM.md read literally, one module at a time in declaration
/// order. Returns the output frames (interleaved) for `steps` steps.
pub fn reference(net: &Network, steps: usize) -> Vec<f64> {
    let nm = net.materials.len();
    let mut x = vec![0.0; nm];
    let mut xp = vec![0.0; nm];
    for (i, m) in net.materials.iter().enumerate() {
        match m {
            Material::Mas { x0, v0, .. } | Material::Cel { x0, v0, .. } => {
                x[i] = *x0;
                xp[i] = *x0 - *v0;
            }
            Material::Sol { x0 } => {
                x[i] = *x0;
                xp[i] = *x0;
            }
            Material::Enx { signal } => {
                x[i] = signal.at(0);
                xp[i] = signal.at(0);
            }
        }
    }
    type Points = Vec<(f64, f64)>;
    let lk_points: Vec<(Points, Points)> = net
        .links
        .iter()
        .map(|l| match &l.law {
            Interaction::Lnl { lk, lz } => (lk.points().collect(), lz.points().collect()),
            _ => (vec![], vec![]),
        })
        .collect();
    let mut out = Vec::with_capacity(steps * net.outputs.len());
    for n in 0..steps as u64 {
        let mut force = vec![0.0; nm];
        let mut lf = vec![0.0; net.links.len()];
        for (l, link) in net.links.iter().enumerate() {
            let (a, b) = (link.a.index(), link.b.index());
            let d = x[a] - x[b];
            let v = (x[a] - xp[a]) - (x[b] - xp[b]);
            let f = match &link.law {
                Interaction::Res { k } => k * d,
                Interaction::Fro { z } => z * v,
                Interaction::Ref { k, z } => k * d + z * v,
                Interaction::But { k, z, s } => {
                    if x[b] - x[a] < *s {
                        k * (d + s) + z * v
                    } else {
                        0.0
                    }
                }
                Interaction::Lnl { .. } => {
                    curve_ref(&lk_points[l].0, d) + curve_ref(&lk_points[l].1, v)
                }
            };
            force[a] -= f;
            force[b] += f;
            lf[l] = f;
        }
        for fi in &net.forces {
            force[fi.target.index()] += fi.signal.at(n);
        }
        for o in &net.outputs {
            let probe = |p: &Probe| match p {
                Probe::Position(m) => x[m.index()],
                Probe::Force(l) => lf[l.index()],
            };
            out.push(match o {
                Output::Position(m) => x[m.index()],
                Output::Force(l) => lf[l.index()],
                Output::Sum(terms) => {
                    let mut acc = terms[0].0 * probe(&terms[0].1);
                    for (g, p) in &terms[1..] {
                        acc += g * probe(p);
                    }
                    acc
                }
            });
        }
        for (i, m) in net.materials.iter().enumerate() {
            let next = match m {
                Material::Mas { m, .. } => 2.0 * x[i] - xp[i] + force[i] / m,
                Material::Sol { .. } => x[i],
                Material::Cel { m, k, z, r, .. } => {
                    r + (2.0 - (k + z) / m) * (x[i] - r)
                        + (z / m - 1.0) * (xp[i] - r)
                        + force[i] / m
                }
                Material::Enx { signal } => signal.at(n + 1),
            };
            xp[i] = x[i];
            x[i] = next;
        }
    }
    out
}

/// A small deterministic generator (64-bit LCG) so tests need no RNG crate.
pub struct Lcg(pub u64);

impl Lcg {
    pub fn next_f64(&mut self) -> f64 {
        self.0 = self
            .0
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (self.0 >> 11) as f64 / (1u64 << 53) as f64
    }
    pub fn below(&mut self, n: usize) -> usize {
        (self.next_f64() * n as f64) as usize % n
    }
}

/// A network that uses every module type: MAS, SOL, CEL, ENX; RES, FRO, REF, BUT, LNL; ENF; SOX, SOF.
pub fn every_module_network() -> Network {
    let mut net = Network::new();
    let g = net.add_material(Material::Sol { x0: 0.0 });
    let m1 = net.add_material(Material::Mas {
        m: 1.0,
        x0: 0.0,
        v0: 0.0,
    });
    let m2 = net.add_material(Material::Mas {
        m: 1.5,
        x0: 0.2,
        v0: 0.01,
    });
    let c = net.add_material(Material::Cel {
        m: 1.0,
        k: 0.01,
        z: 1e-5,
        x0: 1.0,
        v0: 0.0,
        r: 0.0,
    });
    let hand = net.add_material(Material::Enx {
        signal: Signal::Sine {
            freq: 2.0 / 44100.0,
            amp: 0.3,
            phase: 0.0,
        },
    });
    let m3 = net.add_material(Material::Mas {
        m: 0.7,
        x0: -0.1,
        v0: 0.0,
    });
    let r = net.add_link(Interaction::Ref { k: 0.1, z: 1e-4 }, g, m1);
    net.add_link(Interaction::Res { k: 0.1 }, m1, m2);
    net.add_link(Interaction::Fro { z: 0.001 }, m1, m2);
    net.add_link(
        Interaction::But {
            k: 0.05,
            z: 0.001,
            s: 0.1,
        },
        m1,
        m3,
    );
    let lk = Curve::new(&[(-1.0, 0.0), (-1.0, -0.05), (1.0, 0.05), (1.0, 0.0)]).unwrap();
    let lz = Curve::new(&[(-1.0, -0.01), (1.0, 0.01)]).unwrap();
    let l = net.add_link(Interaction::Lnl { lk, lz }, m2, c);
    net.add_link(Interaction::Ref { k: 0.02, z: 1e-3 }, hand, m3);
    net.add_link(Interaction::Res { k: 0.01 }, c, m3);
    net.add_force(m1, Signal::Impulse { at: 0, amp: 1.0 });
    net.add_force(
        m2,
        Signal::Step {
            at: 100,
            amp: -1e-4,
        },
    );
    net.add_force(m3, Signal::Noise { seed: 3, amp: 1e-3 });
    net.add_position_output(m1);
    net.add_position_output(m3);
    net.add_position_output(c);
    net.add_position_output(hand);
    net.add_force_output(r);
    net.add_force_output(l);
    net.add_sum_output(vec![
        (0.5, Probe::Position(m1)),
        (-2.0, Probe::Position(c)),
        (3.0, Probe::Force(l)),
    ]);
    net
}

/// A seeded random network of `n` masses with about `links_per_mass` links each, mixing every law.
pub fn random_network(seed: u64, n: usize, links_per_mass: usize) -> Network {
    let mut rng = Lcg(seed);
    let mut net = Network::new();
    let mut ids = Vec::new();
    for i in 0..n {
        let m = 0.5 + rng.next_f64();
        let x0 = 0.1 * (rng.next_f64() - 0.5);
        ids.push(if i % 7 == 3 {
            net.add_material(Material::Cel {
                m,
                k: 0.01,
                z: 1e-4,
                x0,
                v0: 0.0,
                r: 0.0,
            })
        } else if i % 11 == 5 {
            net.add_material(Material::Sol { x0 })
        } else {
            net.add_material(Material::Mas {
                m,
                x0,
                v0: 0.01 * (rng.next_f64() - 0.5),
            })
        });
    }
    for _ in 0..n * links_per_mass / 2 {
        let a = ids[rng.below(n)];
        let mut b = ids[rng.below(n)];
        if a == b {
            b = ids[(a.index() + 1) % n];
        }
        // small stiffnesses keep the worst-case eigenvalue well below 4
        let k = 0.02 * rng.next_f64() / links_per_mass as f64;
        let z = 1e-4 * rng.next_f64();
        let law = match rng.below(5) {
            0 => Interaction::Res { k },
            1 => Interaction::Fro { z },
            2 => Interaction::Ref { k, z },
            3 => Interaction::But {
                k,
                z,
                s: 0.01 * (rng.next_f64() - 0.5),
            },
            _ => Interaction::Lnl {
                lk: Curve::new(&[(-0.05, -k * 0.05), (0.0, 0.0), (0.05, 2.0 * k * 0.05)]).unwrap(),
                lz: Curve::new(&[(-1.0, -z), (1.0, z)]).unwrap(),
            },
        };
        let l = net.add_link(law, a, b);
        if l.0.is_multiple_of(13) {
            net.add_force_output(l);
        }
    }
    for i in (0..n).step_by(5) {
        net.add_position_output(ids[i]);
    }
    net.add_force(ids[0], Signal::Impulse { at: 0, amp: 0.5 });
    net
}

/// Renders with the engine in blocks of `block` frames.
pub fn render(net: &Network, steps: usize, block: usize) -> Vec<f64> {
    render_with(cordis_core::Engine::new(net), steps, block)
}

/// Renders `steps` frames with `e` in blocks of `block` frames.
pub fn render_with(mut e: cordis_core::Engine, steps: usize, block: usize) -> Vec<f64> {
    let ch = e.channels();
    let mut out = vec![0.0; steps * ch];
    let mut done = 0;
    while done < steps {
        let frames = block.min(steps - done);
        e.process(frames, &mut out[done * ch..(done + frames) * ch])
            .expect("stable network");
        done += frames;
    }
    assert_eq!(e.step_index(), steps as u64);
    out
}

/// First index where two renders differ in their bits, if any.
pub fn first_bit_difference(a: &[f64], b: &[f64]) -> Option<usize> {
    assert_eq!(a.len(), b.len());
    a.iter()
        .zip(b)
        .position(|(x, y)| x.to_bits() != y.to_bits())
}

/// A MAS inertia of kind `inertia`: 0 one, 1 one and a half, 2 a power of two drawn from 0.5 to
/// 4, else any drawn from 0.5 to 1.5.
fn inertia_of(rng: &mut Lcg, inertia: u8) -> f64 {
    match inertia {
        0 => 1.0,
        1 => 1.5,
        2 => [0.5, 1.0, 2.0, 4.0][rng.below(4)],
        _ => 0.5 + rng.next_f64(),
    }
}

/// A seeded network of springs and dampers only (RES, FRO, REF: the pull step's kind), without
/// locality: `n` MAS each tied to about `links_per_mass` others drawn at random, two CEL, two
/// SOL, an ENX, a link tying a MAS to itself and one between the two SOL, ENF inputs (two on one
/// MAS), a SOX on every material, a SOF on every link and a sum output. `inertia`: 0 every MAS
/// of inertia 1, 1 every MAS 1.5, 2 powers of two (0.5 to 4), 3 any. `uniform`: every link a REF
/// with the same K and Z (else the three laws with drawn parameters).
pub fn spring_network(
    seed: u64,
    n: usize,
    links_per_mass: usize,
    inertia: u8,
    uniform: bool,
) -> Network {
    let mut rng = Lcg(seed);
    let mut net = Network::new();
    let mut ids: Vec<_> = (0..n)
        .map(|i| {
            let m = inertia_of(&mut rng, inertia);
            let v0 = if i % 5 == 1 {
                0.01 * (rng.next_f64() - 0.5)
            } else {
                0.0
            };
            net.add_material(Material::Mas {
                m,
                x0: 0.01 * (rng.next_f64() - 0.5),
                v0,
            })
        })
        .collect();
    for r in [0.0, 0.02] {
        ids.push(net.add_material(Material::Cel {
            m: 2.0,
            k: 0.05,
            z: 1e-3,
            x0: 0.01,
            v0: 0.0,
            r,
        }));
    }
    let hand = net.add_material(Material::Enx {
        signal: Signal::Sine {
            freq: 30.0 / 44100.0,
            amp: 0.02,
            phase: 0.3,
        },
    });
    let grounds = [0.0, 0.5].map(|x0| net.add_material(Material::Sol { x0 }));
    let total = ids.len();
    for i in 0..total * links_per_mass / 2 {
        let a = ids[i % total];
        let b = ids[(i % total + 1 + rng.below(total - 1)) % total];
        let (k, z) = (
            0.05 * rng.next_f64() / links_per_mass as f64,
            1e-3 * rng.next_f64(),
        );
        let law = match (uniform, rng.below(3)) {
            (true, _) => Interaction::Ref {
                k: 0.1 / links_per_mass as f64,
                z: 1e-4,
            },
            (false, 0) => Interaction::Res { k },
            (false, 1) => Interaction::Fro { z },
            (false, _) => Interaction::Ref { k, z },
        };
        net.add_link(law, a, b);
    }
    let law = |k: f64, z: f64| {
        if uniform {
            Interaction::Ref {
                k: 0.1 / links_per_mass as f64,
                z: 1e-4,
            }
        } else {
            Interaction::Ref { k, z }
        }
    };
    net.add_link(law(0.01, 1e-4), grounds[0], ids[0]);
    net.add_link(law(0.02, 0.0), hand, ids[1]);
    net.add_link(law(0.03, 1e-3), ids[2], ids[2]);
    net.add_link(law(0.04, 1e-3), grounds[0], grounds[1]);
    net.add_link(law(0.01, 1e-4), ids[n - 1], grounds[1]);
    net.add_force(ids[2], Signal::Impulse { at: 5, amp: 0.05 });
    net.add_force(ids[2], Signal::Noise { seed, amp: 1e-4 });
    net.add_force(ids[n - 1], Signal::Impulse { at: 9, amp: -0.02 });
    net.add_force(ids[n], Signal::Impulse { at: 3, amp: 0.01 }); // a CEL
    net.add_force(grounds[1], Signal::Impulse { at: 1, amp: 1.0 }); // acts on nothing
    for m in 0..net.materials.len() {
        net.add_position_output(cordis_core::MatId(m as u32));
    }
    for l in 0..net.links.len() {
        net.add_force_output(cordis_core::LinkId(l as u32));
    }
    net.add_sum_output(vec![
        (0.5, Probe::Position(ids[1])),
        (-2.0, Probe::Force(cordis_core::LinkId(3))),
    ]);
    net
}

/// How [`grid_membrane`] declares its links: every layout the grid step takes
/// (`engine/grid.rs`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum GridLayout {
    /// As the C baseline kit: each row's links from its left SOL to its right one, then each
    /// column's from its top SOL to its bottom one (every MAS sums left, right, up, down).
    Kit,
    /// As the language's `membrane` generator (docs/LANGUAGE.md): the horizontal links row by
    /// row, the vertical links row by row, then a link from a SOL (end 1) to each edge MAS per
    /// missing neighbour, row by row: the edge MAS sum their SOL terms last.
    Rimmed,
    /// The SOL links of every other row's first MAS first, declared MAS to SOL (the SOL end 2);
    /// then the horizontal and vertical links; then the SOL links of the top row (SOL to MAS),
    /// the last column and the bottom row (MAS to SOL), and the other rows' first MAS (SOL to
    /// MAS).
    Mixed,
}

/// What [`grid_membrane`] puts around its membrane: every setting the grid step takes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Around {
    /// Nothing: the membrane alone, every border MAS tied to SOL.
    Nothing,
    /// A free top row and left column: their MAS tied to nothing in place of their missing
    /// neighbours (the right column and bottom row to SOL).
    FreeEdges,
    /// An instrument: a hammer (a MAS of inertia 4, declared before the membrane, falling onto
    /// MAS (1, 5) through a BUT link), a CEL and an ENX declared after it and tied to two MAS,
    /// and a link between two MAS of the membrane that are not neighbours.
    Instrument,
    /// A second membrane declared after it (wider by 5 and one row more, of another inertia,
    /// layout and rim, with its own inputs and outputs), a MAS declared between the two falling
    /// onto the second through a BUT link, and a REF link tying one MAS of each.
    Pair,
}

/// Multiplies the inertia of the `i`-th MAS of `net` (in declaration order) by `factors[i %
/// factors.len()]`: per-MAS inertias, all powers of two times the old ones or not.
pub fn vary_inertias(net: &mut Network, factors: &[f64]) {
    let masses = net.materials.iter_mut().filter_map(|m| match m {
        Material::Mas { m, .. } => Some(m),
        _ => None,
    });
    for (i, m) in masses.enumerate() {
        *m *= factors[i % factors.len()];
    }
}

/// A membrane the grid step takes (`engine/grid.rs`): `rows x cols` MAS of inertia `m`, row by
/// row, each tied by REF links of one K and Z to its four neighbours, and a border MAS to a SOL
/// in place of each missing one, declared as `layout` says, with `around` around it. The SOL
/// sit at seeded positions, one per border link or one for all (`shared_rim`); every MAS starts
/// at a seeded position and some with a velocity. With `inputs`, ENF on two MAS (two on one).
/// Outputs: SOX on five MAS, SOF on a horizontal, a vertical and a border link, and a sum of a
/// position and a force; with an instrument, also SOX on the hammer and SOF on its link.
#[allow(clippy::too_many_arguments)] // the settings the tests vary
pub fn grid_membrane(
    seed: u64,
    rows: usize,
    cols: usize,
    m: f64,
    layout: GridLayout,
    shared_rim: bool,
    inputs: bool,
    around: Around,
) -> Network {
    let mut rng = Lcg(seed);
    let mut net = Network::new();
    let hammer = (around == Around::Instrument).then(|| {
        net.add_material(Material::Mas {
            m: 4.0,
            x0: 3e-3,
            v0: -2e-5,
        })
    });
    // (a free top row and left column: no SOL in place of their missing neighbours)
    let free = around == Around::FreeEdges;
    let ids: Vec<MatId> = (0..rows * cols)
        .map(|i| {
            let v0 = if i % 7 == 3 {
                1e-3 * (rng.next_f64() - 0.5)
            } else {
                0.0
            };
            let x0 = 1e-3 * (rng.next_f64() - 0.5);
            net.add_material(Material::Mas { m, x0, v0 })
        })
        .collect();
    let rim = net.add_material(Material::Sol { x0: 1e-3 });
    let mut ground = |net: &mut Network| {
        if shared_rim {
            rim
        } else {
            let x0 = 1e-3 * (rng.next_f64() - 0.5);
            net.add_material(Material::Sol { x0 })
        }
    };
    let at = |r: usize, c: usize| ids[r * cols + c];
    let law = Interaction::Ref { k: 0.13, z: 2e-3 };
    // a link from a new SOL to `to`, or (`from`) from `to` to it
    let mut grounded = |net: &mut Network, to: MatId, from: bool| {
        let g = ground(net);
        if from {
            net.add_link(law.clone(), to, g)
        } else {
            net.add_link(law.clone(), g, to)
        }
    };
    let (mut horizontal, mut vertical, mut border) = (None, None, None);
    match layout {
        GridLayout::Kit => {
            for r in 0..rows {
                if !free {
                    border = Some(grounded(&mut net, at(r, 0), false));
                }
                for c in 0..cols - 1 {
                    horizontal = Some(net.add_link(law.clone(), at(r, c), at(r, c + 1)));
                }
                grounded(&mut net, at(r, cols - 1), true);
            }
            for c in 0..cols {
                if !free {
                    grounded(&mut net, at(0, c), false);
                }
                for r in 0..rows - 1 {
                    vertical = Some(net.add_link(law.clone(), at(r, c), at(r + 1, c)));
                }
                grounded(&mut net, at(rows - 1, c), true);
            }
        }
        GridLayout::Rimmed | GridLayout::Mixed => {
            let mixed = layout == GridLayout::Mixed;
            if mixed && !free {
                for r in (0..rows).step_by(2) {
                    border = Some(grounded(&mut net, at(r, 0), true));
                }
            }
            for r in 0..rows {
                for c in 0..cols - 1 {
                    horizontal = Some(net.add_link(law.clone(), at(r, c), at(r, c + 1)));
                }
            }
            for r in 0..rows - 1 {
                for c in 0..cols {
                    vertical = Some(net.add_link(law.clone(), at(r, c), at(r + 1, c)));
                }
            }
            if mixed {
                for c in (0..cols).filter(|_| !free) {
                    grounded(&mut net, at(0, c), false);
                }
                for r in 0..rows {
                    grounded(&mut net, at(r, cols - 1), true);
                }
                for c in 0..cols {
                    grounded(&mut net, at(rows - 1, c), true);
                }
                for r in (1..rows).step_by(2).filter(|_| !free) {
                    grounded(&mut net, at(r, 0), false);
                }
            } else {
                for r in 0..rows {
                    for c in 0..cols {
                        let missing = [
                            r == 0 && !free,
                            r == rows - 1,
                            c == 0 && !free,
                            c == cols - 1,
                        ];
                        for _ in missing.iter().filter(|&&m| m) {
                            border = Some(grounded(&mut net, at(r, c), false));
                        }
                    }
                }
            }
        }
    }
    // (with free edges, a link to the right or bottom SOL: the last declared)
    let border = border.unwrap_or(cordis_core::LinkId(net.links.len() as u32 - 1));
    if let Some(hammer) = hammer {
        let felt = Interaction::But {
            k: 0.05,
            z: 1e-3,
            s: 0.0,
        };
        let hit = net.add_link(felt, at(1, 5), hammer);
        let cel = net.add_material(Material::Cel {
            m: 3.0,
            k: 0.02,
            z: 1e-3,
            x0: 1e-3,
            v0: 0.0,
            r: 0.0,
        });
        net.add_link(Interaction::Ref { k: 0.07, z: 1e-3 }, at(rows - 1, 2), cel);
        let enx = net.add_material(Material::Enx {
            signal: Signal::Sine {
                freq: 0.01,
                amp: 1e-3,
                phase: 0.3,
            },
        });
        net.add_link(Interaction::Res { k: 0.03 }, enx, at(0, cols - 3));
        net.add_link(law.clone(), at(1, 2), at(rows - 1, cols - 4));
        net.add_position_output(hammer);
        net.add_force_output(hit);
    }
    if inputs {
        net.add_force(at(rows / 2, 1), Signal::Impulse { at: 3, amp: 0.01 });
        net.add_force(at(rows - 1, cols - 1), Signal::Constant(1e-5));
        net.add_force(
            at(rows - 1, cols - 1),
            Signal::Impulse { at: 40, amp: -0.02 },
        );
    }
    for (r, c) in [
        (0, 0),
        (rows / 2, cols / 2),
        (rows - 1, cols - 1),
        (1, cols - 2),
        (rows / 2, 9),
    ] {
        net.add_position_output(at(r, c));
    }
    let [horizontal, vertical] = [horizontal, vertical].map(Option::unwrap);
    for l in [horizontal, vertical, border] {
        net.add_force_output(l);
    }
    net.add_sum_output(vec![
        (2.0, Probe::Position(at(1, 1))),
        (-0.5, Probe::Force(border)),
    ]);
    if around == Around::Pair {
        let layout = match layout {
            GridLayout::Kit => GridLayout::Rimmed,
            GridLayout::Rimmed => GridLayout::Mixed,
            GridLayout::Mixed => GridLayout::Kit,
        };
        let (r2, c2) = (rows + 1, cols + 5);
        let other = grid_membrane(
            seed + 1000,
            r2,
            c2,
            m * 1.5,
            layout,
            !shared_rim,
            inputs,
            Around::Nothing,
        );
        let ball = net.add_material(Material::Mas {
            m: 2.0,
            x0: 3e-3,
            v0: -3e-5,
        });
        let first = net.append(&other);
        let at2 = |r: usize, c: usize| MatId(first.0 + (r * c2 + c) as u32);
        let felt = Interaction::But {
            k: 0.04,
            z: 1e-3,
            s: 0.0,
        };
        let hit = net.add_link(felt, at2(r2 - 1, 3), ball);
        net.add_link(
            Interaction::Ref { k: 0.05, z: 1e-3 },
            at(1, 2),
            at2(2, c2 - 4),
        );
        net.add_position_output(ball);
        net.add_force_output(hit);
    }
    net
}

/// A bank of strings of `lengths[s]` MAS each, declared as the language's `string` generator
/// declares them (its MAS, a left SOL and its link, the inner links, a right SOL and its link):
/// the engine joins short strings of the same law, whatever their parameters, into one loop with
/// exceptions. String `s` has the law `law(s)` and its own stiffness; every third string's right
/// end is free (no right SOL). Each string is plucked; the outputs read the first MAS of every
/// string, the link of every right ground (the loop's exceptions) and a sum of both. `inertia`
/// as in [`spring_network`].
pub fn string_bank(
    seed: u64,
    lengths: &[usize],
    inertia: u8,
    law: impl Fn(usize, f64) -> Interaction,
) -> Network {
    let mut rng = Lcg(seed);
    let mut net = Network::new();
    let mut firsts = Vec::new();
    let mut grounds = Vec::new();
    for (s, &n) in lengths.iter().enumerate() {
        let ids: Vec<MatId> = (0..n)
            .map(|i| {
                let m = inertia_of(&mut rng, inertia);
                let x0 = if i == n / 3 { 0.01 } else { 0.0 };
                net.add_material(Material::Mas { m, x0, v0: 0.0 })
            })
            .collect();
        let k = 0.1 * (1.0 + s as f64 / 16.0);
        let left = net.add_material(Material::Sol { x0: 0.0 });
        net.add_link(law(s, k), left, ids[0]);
        for w in ids.windows(2) {
            net.add_link(law(s, k), w[0], w[1]);
        }
        if s % 3 != 2 {
            let right = net.add_material(Material::Sol { x0: 0.0 });
            grounds.push(net.add_link(law(s, k), ids[n - 1], right));
        }
        firsts.push(ids[0]);
    }
    for &m in &firsts {
        net.add_position_output(m);
    }
    for &l in &grounds {
        net.add_force_output(l);
    }
    net.add_sum_output(vec![
        (0.5, Probe::Position(firsts[firsts.len() / 2])),
        (2.0, Probe::Force(grounds[0])),
    ]);
    net.add_force(firsts[1], Signal::Impulse { at: 5, amp: 0.02 });
    net
}

/// [`spring_network`] (links each their own `K` and `Z`) with every `step`-th link, the first
/// included, made a BUT: thresholds of both signs and zero, one in four viscous only (`K = 0`),
/// so that links come into and out of contact from both ends as the network rings.
pub fn but_network(seed: u64, n: usize, inertia: u8, step: usize) -> Network {
    let mut net = spring_network(seed, n, 4, inertia, false);
    for (i, link) in net.links.iter_mut().enumerate().step_by(step) {
        link.law = but_of(i, &link.law);
    }
    net
}

/// The BUT that [`but_network`] makes of link `i` of law `law`.
fn but_of(i: usize, law: &Interaction) -> Interaction {
    let (k, z) = match *law {
        Interaction::Ref { k, z } => (k, z),
        Interaction::Res { k } => (k, 5e-4),
        Interaction::Fro { z } => (0.01, z),
        _ => (0.01, 1e-4),
    };
    let k = if i % 4 == 3 { 0.0 } else { k };
    let s = [0.0, 0.002, -0.002, 0.006, -0.006, 1e-4][i % 6];
    Interaction::But { k, z, s }
}

/// BUT and LNL links together: [`lnl_network`] (every third link LNL) with every fourth of the
/// other links a BUT as [`but_network`]'s; or (`hammer`) [`lnl_pairs_network`] (every link LNL,
/// of four pairs of curves) with link 1 a BUT, as a hammer's felt.
pub fn but_lnl_network(seed: u64, n: usize, inertia: u8, hammer: bool) -> Network {
    let mut net = if hammer {
        lnl_pairs_network(seed, n, inertia)
    } else {
        lnl_network(seed, n, inertia, false, false)
    };
    for (i, link) in net.links.iter_mut().enumerate() {
        if (hammer && i == 1) || (!hammer && i % 3 != 0 && i % 4 == 1) {
            link.law = but_of(i, &Interaction::Ref { k: 0.02, z: 2e-4 });
        }
    }
    net
}

/// [`spring_network`] with LNL links of one pair of curves, neither odd, the viscous one not
/// zero at zero: every third link, the first included, or (`all`) every link. The other links
/// are REF of one `K` and `Z` when `uniform`, else each their own.
pub fn lnl_network(seed: u64, n: usize, inertia: u8, all: bool, uniform: bool) -> Network {
    let mut net = spring_network(seed, n, 4, inertia, uniform);
    let lnl = Interaction::Lnl {
        lk: Curve::new(&[(-0.01, -4e-4), (0.0, 0.0), (0.004, 5e-5), (0.02, 1.5e-3)])
            .expect("a curve"),
        lz: Curve::new(&[(-0.002, -2e-6), (0.001, 5e-7), (0.003, 0.0)]).expect("a curve"),
    };
    for (i, link) in net.links.iter_mut().enumerate() {
        if all || i % 3 == 0 {
            link.law = lnl.clone();
        }
    }
    net
}

/// [`spring_network`] with LNL links of curves drawn point by point, two links in three, of the
/// pairs `pairs` (indexes, taken in turn): 0, a softening then hardening spring (8 points, and a
/// viscous curve of 2); 1, a spring of 6 points, a jump among them, and a viscous curve of 5; 2,
/// a finely drawn spring (12 points) and a viscous curve of 3; 3, a spring sampled from a formula
/// (40 points, more than the engine's fixed shapes hold) and a viscous curve of 3. The engine pads
/// several pairs to one shape: 0 and 1 to 8 and 8, 2 alone to 16 and 4, 2 with another to 16 and
/// 16; 3 it evaluates as it is, alone or among others.
pub fn drawn_lnl_network(seed: u64, n: usize, inertia: u8, pairs: &[usize]) -> Network {
    let mut net = spring_network(seed, n, 4, inertia, false);
    let pair = |k: &[(f64, f64)], z: &[(f64, f64)]| Interaction::Lnl {
        lk: Curve::new(k).expect("a curve"),
        lz: Curve::new(z).expect("a curve"),
    };
    let drawn = [
        pair(
            &[
                (-0.03, -2.4e-3),
                (-0.015, -9e-4),
                (-0.006, -3e-4),
                (-0.001, -4e-5),
                (0.002, 8e-5),
                (0.008, 2.5e-4),
                (0.016, 8e-4),
                (0.025, 2e-3),
            ],
            &[(-0.003, -6e-6), (0.003, 5e-6)],
        ),
        pair(
            &[
                (-0.02, -1.5e-3),
                (-0.008, -4e-4),
                (0.0, -1e-5),
                (0.0, 1e-5),
                (0.009, 5e-4),
                (0.02, 1.4e-3),
            ],
            &[
                (-0.004, -6e-6),
                (-0.001, -2e-6),
                (0.0, 0.0),
                (0.002, 3e-6),
                (0.005, 7e-6),
            ],
        ),
        pair(
            &[
                (-0.028, -2.1e-3),
                (-0.02, -1.2e-3),
                (-0.013, -6e-4),
                (-0.008, -3.1e-4),
                (-0.004, -1.4e-4),
                (-0.001, -3e-5),
                (0.001, 3.5e-5),
                (0.003, 1e-4),
                (0.007, 2.6e-4),
                (0.012, 5.5e-4),
                (0.018, 1.1e-3),
                (0.026, 1.9e-3),
            ],
            &[(-0.002, -3e-6), (0.0, 0.0), (0.003, 5e-6)],
        ),
        pair(
            &(0..40)
                .map(|i| {
                    let x = -0.03 + f64::from(i) * 0.06 / 39.0;
                    (x, 0.06 * x + 20.0 * x * x * x)
                })
                .collect::<Vec<_>>(),
            &[(-0.002, -3e-6), (0.0, 0.0), (0.003, 5e-6)],
        ),
    ];
    let mut turn = pairs.iter().cycle();
    for (i, link) in net.links.iter_mut().enumerate() {
        if i % 3 != 0 {
            link.law = drawn[*turn.next().expect("a pair")].clone();
        }
    }
    net
}

/// [`spring_network`] with every link LNL, of four pairs of curves of different point counts:
/// the links of each third of the declaration order of its own pair (so that many rows of the
/// pull step have one pair), and every 29th link of a fourth (so that some have several).
pub fn lnl_pairs_network(seed: u64, n: usize, inertia: u8) -> Network {
    let mut net = spring_network(seed, n, 4, inertia, false);
    let pair = |k: &[(f64, f64)], z: &[(f64, f64)]| Interaction::Lnl {
        lk: Curve::new(k).expect("a curve"),
        lz: Curve::new(z).expect("a curve"),
    };
    // (point counts 3 and 2, 2 and 4, 4 and 3, 2 and 2: every curve padded to 4 points)
    let pairs = [
        pair(
            &[(-0.012, -5e-4), (0.0, 2e-6), (0.012, 4e-4)],
            &[(-0.004, -5e-6), (0.004, 3e-6)],
        ),
        pair(
            &[(-0.03, -1.2e-3), (0.02, 1e-3)],
            &[
                (-0.002, -4e-6),
                (-0.001, -1e-6),
                (0.001, 2e-6),
                (0.003, 4e-6),
            ],
        ),
        pair(
            &[(-0.008, -3e-4), (0.0, 0.0), (0.004, 6e-5), (0.016, 1e-3)],
            &[(-0.002, -2e-6), (0.001, 5e-7), (0.003, 0.0)],
        ),
        pair(
            &[(-0.05, -2e-3), (0.05, 2e-3)],
            &[(-0.01, -1e-5), (0.01, 1e-5)],
        ),
    ];
    let count = net.links.len();
    for (i, link) in net.links.iter_mut().enumerate() {
        let p = if i % 29 == 3 { 3 } else { i * 3 / count };
        link.law = pairs[p].clone();
    }
    net
}
