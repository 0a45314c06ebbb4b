//! The engine against the plain reference stepper, and its determinism guarantees.
#![allow(clippy::unwrap_used)] // tests and benches may panic on failure

mod common;

use common::*;
use cordis_core::{Curve, Engine, Interaction, MatId, Material, Network, Signal};

#[test]
fn engine_equals_reference_bit_for_bit_on_every_module_type() {
    let net = every_module_network();
    let steps = 20_000;
    let expected = reference(&net, steps);
    let got = render(&net, steps, 256);
    assert_eq!(first_bit_difference(&got, &expected), None);
    // the run is not trivial: every channel moves
    for c in 0..net.outputs.len() {
        let moved = (0..steps).any(|n| got[n * net.outputs.len() + c] != got[c]);
        assert!(moved, "channel {c} never changed");
    }
}

#[test]
fn engine_equals_reference_on_seeded_random_networks() {
    for seed in 1..=8 {
        let net = random_network(seed, 60, 4);
        let expected = reference(&net, 3000);
        let got = render(&net, 3000, 97);
        assert_eq!(first_bit_difference(&got, &expected), None, "seed {seed}");
    }
}

#[test]
fn output_is_independent_of_block_size_and_deterministic() {
    let net = every_module_network();
    let a = render(&net, 5000, 1);
    for block in [2, 7, 64, 1000, 5000] {
        assert_eq!(
            first_bit_difference(&render(&net, 5000, block), &a),
            None,
            "block {block}"
        );
    }
    assert_eq!(
        first_bit_difference(&render(&net, 5000, 64), &render(&net, 5000, 64)),
        None
    );
}

#[test]
fn reset_reproduces_the_run() {
    let net = random_network(42, 40, 3);
    let mut e = Engine::new(&net);
    let ch = e.channels();
    let mut a = vec![0.0; 1000 * ch];
    let mut b = vec![0.0; 1000 * ch];
    e.process(1000, &mut a).unwrap();
    e.reset();
    e.process(1000, &mut b).unwrap();
    assert_eq!(first_bit_difference(&a, &b), None);
}

#[test]
fn sample_zero_is_x0_and_enx_starts_at_rest() {
    let mut net = Network::new();
    let m = net.add_material(Material::Mas {
        m: 2.0,
        x0: 0.25,
        v0: 0.5,
    });
    let e = net.add_material(Material::Enx {
        signal: Signal::Step { at: 0, amp: 3.0 },
    });
    net.add_position_output(m);
    net.add_position_output(e);
    let out = render(&net, 3, 3);
    // x(0) = X0, x(1) = 2 x(0) - x(-1) = X0 + V0, x(2) = X0 + 2 V0
    assert_eq!(out, [0.25, 3.0, 0.75, 3.0, 1.25, 3.0]);
}

#[test]
fn but_orientation_and_threshold() {
    // End 2 below end 1 + S: active; the force pushes end 2 up (+f) and end 1 down (-f).
    let mut net = Network::new();
    let a = net.add_material(Material::Sol { x0: 0.0 });
    let b = net.add_material(Material::Mas {
        m: 1.0,
        x0: 0.05,
        v0: 0.0,
    });
    let l = net.add_link(
        Interaction::But {
            k: 0.1,
            z: 0.0,
            s: 0.1,
        },
        a,
        b,
    );
    net.add_force_output(l);
    net.add_position_output(b);
    let out = render(&net, 2, 1);
    // d = -0.05, f = K (d + S) = 0.1 * 0.05 = 0.005; end 2 moves by +f/M
    assert!((out[0] - 0.005).abs() < 1e-18);
    assert!((out[3] - (0.05 + 0.005)).abs() < 1e-17);
    // Above the threshold there is no force.
    let mut net = Network::new();
    let a = net.add_material(Material::Sol { x0: 0.0 });
    let b = net.add_material(Material::Mas {
        m: 1.0,
        x0: 0.2,
        v0: 0.0,
    });
    let l = net.add_link(
        Interaction::But {
            k: 0.1,
            z: 0.5,
            s: 0.1,
        },
        a,
        b,
    );
    net.add_force_output(l);
    assert_eq!(render(&net, 1, 1), [0.0]);
}

#[test]
fn a_blow_up_names_the_first_module_and_step() {
    // K/M = 5 > 4: the explicit scheme diverges.
    let mut net = Network::new();
    let g = net.add_material(Material::Sol { x0: 0.0 });
    let quiet = net.add_material(Material::Mas {
        m: 1.0,
        x0: 0.0,
        v0: 0.0,
    });
    let m = net.add_material(Material::Mas {
        m: 1.0,
        x0: 1.0,
        v0: 0.0,
    });
    net.add_link(Interaction::Res { k: 5.0 }, g, m);
    net.add_position_output(m);
    net.add_position_output(quiet);
    // independently: the first step where the reference stepper's output is not finite
    let steps = 2000;
    let refout = reference(&net, steps);
    let first_bad = refout
        .chunks(2)
        .position(|f| !f[0].is_finite())
        .expect("diverges") as u64;
    for block in [1, 64, 4096] {
        let mut e = Engine::new(&net);
        let mut out = vec![0.0; block * 2];
        let mut err = None;
        for _ in 0..(steps / block + 2) {
            if let Err(b) = e.process(block, &mut out) {
                err = Some(b);
                break;
            }
        }
        let b = err.expect("the engine must report the blow-up");
        assert_eq!(b.step, first_bad, "block {block}");
        assert_eq!(b.material.index(), 2);
        // and refuses to go on
        assert!(e.process(1, &mut [0.0, 0.0]).is_err());
    }
}

#[test]
fn link_force_and_positions_are_observable() {
    let net = every_module_network();
    let mut e = Engine::new(&net);
    let mut out = vec![0.0; 10 * e.channels()];
    e.process(10, &mut out).unwrap();
    assert_eq!(e.step_index(), 10);
    let sof = out[9 * e.channels() + 4];
    assert_eq!(
        e.link_force(cordis_core::LinkId(0)).to_bits(),
        sof.to_bits()
    );
    assert!(e.position(cordis_core::MatId(0)) == 0.0);
}

#[test]
fn curves_agree_with_the_linear_scan() {
    let pts = [
        (-1.0, 0.5),
        (-0.5, -0.5),
        (-0.5, 0.2),
        (0.3, 0.9),
        (2.0, -1.0),
    ];
    let c = cordis_core::Curve::new(&pts).unwrap();
    let mut rng = Lcg(9);
    for _ in 0..10_000 {
        let x = 6.0 * rng.next_f64() - 3.0;
        assert_eq!(c.eval(x).to_bits(), curve_ref(&pts, x).to_bits(), "x = {x}");
    }
    for &(x, _) in &pts {
        assert_eq!(c.eval(x).to_bits(), curve_ref(&pts, x).to_bits());
    }
}

#[test]
#[should_panic(expected = "refers to material")]
fn engine_refuses_foreign_ids() {
    // The fields of `Network` are public, so a caller can push a link whose end does not exist;
    // `Engine::new` must refuse it before any (unchecked) step can read out of bounds.
    let mut net = Network::new();
    let a = net.add_material(Material::Mas {
        m: 1.0,
        x0: 0.0,
        v0: 0.0,
    });
    net.links.push(cordis_core::Link {
        law: Interaction::Res { k: 0.1 },
        a,
        b: cordis_core::MatId(7),
    });
    let _ = Engine::new(&net);
}

#[test]
fn non_power_of_two_masses_match_the_reference_too() {
    // Masses of 1 (multiplied by the exact reciprocal) and of 0.7, 1.5 (divided) both match.
    for seed in [11, 12] {
        let net = random_network(seed, 30, 3);
        assert_eq!(
            first_bit_difference(&render(&net, 2000, 33), &reference(&net, 2000)),
            None
        );
    }
    let mut net = Network::new();
    let g = net.add_material(Material::Sol { x0: 0.0 });
    let mut prev = g;
    for i in 0..20 {
        let m = net.add_material(Material::Mas {
            m: [1.0, 2.0, 0.5, 4.0][i % 4],
            x0: 0.0,
            v0: 0.0,
        });
        net.add_link(Interaction::Ref { k: 0.1, z: 1e-4 }, prev, m);
        net.add_position_output(m);
        prev = m;
    }
    net.add_force(prev, Signal::Noise { seed: 1, amp: 1.0 });
    assert_eq!(
        first_bit_difference(&render(&net, 5000, 100), &reference(&net, 5000)),
        None
    );
}

/// Sticking springs (4-point elastic curves with jumps, zero viscous curve) and dampers of every
/// curve size the engine evaluates with selects, in runs long enough to be uniform: two strings
/// that swing past each other, so the springs catch, stretch and let go.
#[test]
fn sticking_springs_and_small_curves_match_the_reference() {
    let mut net = Network::new();
    let n = 24;
    let mut ends = Vec::new();
    for side in 0..2 {
        let g = net.add_material(Material::Sol { x0: 0.0 });
        let mut prev = g;
        for i in 0..n {
            let v0 = if side == 0 { 0.02 } else { -0.02 } * (1.0 + (i % 3) as f64);
            let m = net.add_material(Material::Mas {
                m: 1.0,
                x0: 0.001 * side as f64,
                v0,
            });
            net.add_link(Interaction::Ref { k: 0.05, z: 1e-4 }, prev, m);
            prev = m;
            ends.push(m);
        }
    }
    let (s, k) = (0.01, 0.02);
    let stick = cordis_core::Curve::new(&[(-s, 0.0), (-s, -k * s), (s, k * s), (s, 0.0)]).unwrap();
    let curves: Vec<cordis_core::Curve> = [
        vec![],
        vec![(-1.0, -1e-4), (1.0, 1e-4)],
        vec![(-1.0, -2e-4), (0.0, 0.0), (1.0, 1e-4)],
        vec![(-1.0, -2e-4), (-0.1, 0.0), (0.1, 0.0), (1.0, 1e-4)],
    ]
    .iter()
    .map(|p| cordis_core::Curve::new(p).unwrap())
    .collect();
    let mut springs = Vec::new();
    for (i, z) in curves.iter().enumerate() {
        // a uniform run of 10 sticking springs per viscous curve, between the two strings
        for j in 0..10 {
            let (a, b) = (ends[(i * 5 + j) % n], ends[n + (i * 7 + j) % n]);
            springs.push(cordis_core::LinkId(net.links.len() as u32));
            net.add_link(
                Interaction::Lnl {
                    lk: stick.clone(),
                    lz: z.clone(),
                },
                a,
                b,
            );
        }
        // and the viscous curve alone, with an elastic one of another size
        for j in 0..10 {
            net.add_link(
                Interaction::Lnl {
                    lk: curves[(i + 1) % 4].clone(),
                    lz: z.clone(),
                },
                ends[(j * 3 + i) % n],
                ends[n + (j * 5 + i) % n],
            );
        }
    }
    for m in ends.iter().step_by(5) {
        net.add_position_output(*m);
    }
    let steps = 8000;
    let expected = reference(&net, steps);
    let got = render(&net, steps, 333);
    assert_eq!(first_bit_difference(&got, &expected), None);
    assert!(got.iter().any(|v| *v != 0.0));
    // the springs do catch and let go: count the steps where one starts or stops pulling
    let mut e = Engine::new(&net);
    let mut out = vec![0.0; steps * e.channels()];
    let mut pulling = vec![false; springs.len()];
    let mut changes = 0;
    e.process_observed(steps, &mut out, &mut |v| {
        for (p, &l) in pulling.iter_mut().zip(&springs) {
            let now = v.link_force(l) != 0.0;
            changes += usize::from(now != *p);
            *p = now;
        }
    })
    .unwrap();
    assert!(changes >= 2, "the sticking springs never caught and let go");
}

/// Networks of springs and dampers without locality (on an AVX-512 CPU they take the pull step,
/// where each MAS computes its own links' forces: see engine/pull.rs) equal the reference at
/// every step, in every position, link force and output, for each way of applying inertias, with
/// uniform and mixed links, BUT links among them (many, or one as a hammer's; coming into and
/// out of contact), LNL links
/// among them (the others of one `K` and `Z`, or each their own) or alone, partial
/// groups of eight, more MAS than a window of the pull step's storage order, and blocks of any
/// size.
#[test]
fn spring_networks_equal_the_reference() {
    for (seed, n) in [(1, 16), (2, 17), (3, 100), (4, 333)] {
        for inertia in 0..4 {
            for uniform in [true, false] {
                let net = spring_network(seed, n, 4, inertia, uniform);
                let what = format!("seed {seed}, {n} MAS, inertia {inertia}, uniform {uniform}");
                let moved = equals_reference_in_blocks(&net, 1500, &what);
                assert!(moved > net.outputs.len() / 2, "{what}");
            }
        }
    }
    // (more MAS than one window of the pull step's storage order holds)
    for (inertia, uniform) in [(0, true), (3, false)] {
        let net = spring_network(5, 700, 4, inertia, uniform);
        let what = format!("700 MAS, inertia {inertia}, uniform {uniform}");
        let moved = equals_reference_in_blocks(&net, 600, &what);
        assert!(moved > net.outputs.len() / 2, "{what}");
    }
    // with BUT links among them (the pull step takes them too), in and out of contact: every
    // third link, or one (a hammer's)
    for (seed, n, inertia, step) in [
        (6, 16, 0, 3),
        (7, 17, 1, 3),
        (8, 100, 2, 3),
        (9, 333, 3, 3),
        (10, 700, 0, 3),
        (18, 100, 1, usize::MAX),
        (19, 333, 2, usize::MAX),
    ] {
        let net = but_network(seed, n, inertia, step);
        let what = format!("BUT, seed {seed}, {n} MAS, inertia {inertia}, every {step}th link");
        let moved = equals_reference_in_blocks(&net, 1500, &what);
        assert!(moved > net.outputs.len() / 2, "{what}");
    }
    // with LNL links of one pair of curves, among the others (each their own `K` and `Z`, or
    // REF of one) or alone
    for (seed, n, inertia, all, uniform) in [
        (11, 16, 0, false, false),
        (12, 17, 1, true, false),
        (13, 100, 2, false, false),
        (14, 333, 3, true, false),
        (15, 700, 0, false, false),
        (16, 100, 1, false, true),
        (17, 333, 3, false, true),
    ] {
        let net = lnl_network(seed, n, inertia, all, uniform);
        let what =
            format!("LNL, seed {seed}, {n} MAS, inertia {inertia}, all {all}, uniform {uniform}");
        let moved = equals_reference_in_blocks(&net, 1500, &what);
        assert!(moved > net.outputs.len() / 2, "{what}");
    }
    // with LNL links of four pairs of curves of different point counts
    for (seed, n, inertia) in [(20, 40, 0), (21, 333, 1), (22, 700, 2)] {
        let net = lnl_pairs_network(seed, n, inertia);
        let what = format!("LNL of four pairs, seed {seed}, {n} MAS, inertia {inertia}");
        let moved = equals_reference_in_blocks(&net, 1500, &what);
        assert!(moved > net.outputs.len() / 2, "{what}");
    }
    // with LNL links of curves drawn point by point (5 to 12 points) or sampled (40), of one pair
    // or several
    for (seed, n, inertia, pairs) in [
        (46, 100, 1, &[3][..]),
        (47, 700, 2, &[3]),
        (48, 333, 3, &[3, 0]),
        (49, 700, 0, &[1, 3, 2]),
        (40, 100, 0, &[0][..]),
        (41, 333, 1, &[0, 1]),
        (42, 700, 3, &[1, 0]),
        (43, 100, 2, &[2]),
        (44, 333, 0, &[2, 0, 1]),
        (45, 700, 1, &[2]),
    ] {
        let net = drawn_lnl_network(seed, n, inertia, pairs);
        let what = format!("LNL drawn, seed {seed}, {n} MAS, inertia {inertia}, pairs {pairs:?}");
        let moved = equals_reference_in_blocks(&net, 1500, &what);
        assert!(moved > net.outputs.len() / 2, "{what}");
    }
    // with BUT and LNL links together: among springs and dampers, or a hammer's BUT on an LNL
    // network of four pairs
    for (seed, n, inertia, hammer) in [
        (23, 16, 0, false),
        (24, 100, 1, false),
        (25, 333, 2, false),
        (26, 700, 3, false),
        (27, 40, 0, true),
        (28, 333, 3, true),
    ] {
        let net = but_lnl_network(seed, n, inertia, hammer);
        let what = format!("BUT and LNL, seed {seed}, {n} MAS, inertia {inertia}, hammer {hammer}");
        let moved = equals_reference_in_blocks(&net, 1500, &what);
        assert!(moved > net.outputs.len() / 2, "{what}");
    }
}

/// Membranes that take the grid step on an AVX-512 CPU (`engine/grid.rs`: every force in
/// registers, row by row) equal the reference at every step, in every output (positions, link
/// forces, a sum), for widths of every remainder of 8, multiplied and divided inertias (one for
/// the membrane, or each MAS its own), SOL at
/// their own positions or one rim, links declared as the C kit, the language's `membrane` or a
/// mix of orders and ends, with and without ENF inputs, alone, with free edges, in an
/// instrument (a hammer, a CEL, an ENX, a link across) or with a second membrane tied to it, in
/// blocks of any size.
#[test]
fn grid_membranes_equal_the_reference() {
    let sizes = [
        (2, 16),
        (3, 17),
        (5, 23),
        (4, 24),
        (6, 31),
        (3, 40),
        (9, 19),
    ];
    for (i, &(rows, cols)) in sizes.iter().enumerate() {
        // (with `varied`, per-MAS inertias: `Some(true)` powers of two, `Some(false)` any)
        for (m, shared_rim, inputs, around, varied) in [
            (1.0, false, true, Around::Nothing, None),
            (0.5, true, false, Around::Nothing, None),
            (1.5, false, false, Around::Nothing, None),
            (1.25, true, true, Around::Nothing, None),
            (1.0, false, true, Around::Instrument, None),
            (1.5, true, false, Around::Instrument, None),
            (0.5, false, true, Around::FreeEdges, None),
            (1.25, true, false, Around::FreeEdges, None),
            (1.0, false, true, Around::Pair, None),
            (0.5, true, false, Around::Pair, None),
            (1.0, false, true, Around::Nothing, Some(true)),
            (1.5, true, true, Around::Instrument, Some(false)),
            (0.5, false, false, Around::Pair, Some(false)),
        ] {
            let layout = [GridLayout::Kit, GridLayout::Rimmed, GridLayout::Mixed][i % 3];
            let seed = i as u64 + 1;
            let mut net = grid_membrane(seed, rows, cols, m, layout, shared_rim, inputs, around);
            match varied {
                Some(true) => vary_inertias(&mut net, &[1.0, 0.5, 2.0, 1.0, 4.0]),
                Some(false) => vary_inertias(&mut net, &[1.0, 0.7, 3.0, 1.25]),
                None => {}
            }
            let steps = 1200;
            let expected = reference(&net, steps);
            for block in [1, 7, 1024] {
                let got = render(&net, steps, block);
                assert_eq!(
                    first_bit_difference(&got, &expected),
                    None,
                    "{rows}x{cols} {layout:?} {around:?}, M {m} {varied:?}, rim {shared_rim}, \
                     inputs {inputs}, block {block}"
                );
            }
            let ch = net.outputs.len();
            let moved = |c: usize| (0..steps).any(|s| expected[s * ch + c] != expected[c]);
            assert!((0..ch).all(moved), "{rows}x{cols}: an output never moved");
        }
    }
}

/// `Network::append` declares a copy of the other network after this one's modules: the two
/// parts, which share no link, step as they do alone, every output of each in its place.
#[test]
fn an_appended_network_steps_as_it_does_alone() {
    let a = every_module_network();
    let b = grid_membrane(
        3,
        4,
        20,
        1.5,
        GridLayout::Mixed,
        false,
        true,
        Around::Instrument,
    );
    let mut both = a.clone();
    let first = both.append(&b);
    assert_eq!(first, MatId(a.materials.len() as u32));
    assert_eq!(both.module_count(), a.module_count() + b.module_count());
    let steps = 300;
    let (ra, rb) = (reference(&a, steps), reference(&b, steps));
    let expected: Vec<f64> = (0..steps)
        .flat_map(|s| {
            let (ca, cb) = (a.outputs.len(), b.outputs.len());
            ra[s * ca..(s + 1) * ca]
                .iter()
                .chain(&rb[s * cb..(s + 1) * cb])
                .copied()
        })
        .collect();
    assert_eq!(
        first_bit_difference(&reference(&both, steps), &expected),
        None
    );
    assert_eq!(
        first_bit_difference(&render(&both, steps, 64), &expected),
        None
    );
}

/// The laws of the string banks: one per string `s` of stiffness `k`.
fn bank_law(kind: usize) -> impl Fn(usize, f64) -> Interaction {
    move |s, k| match (kind, s % 4) {
        (0, _) => Interaction::Ref { k, z: 1e-4 * k },
        (1, 0) => Interaction::Res { k },
        (1, 2) => Interaction::But {
            k,
            z: 1e-4,
            s: if s % 8 == 2 { 1e-3 } else { -1e-3 },
        },
        (1, _) => Interaction::Ref { k, z: 1e-4 },
        (2, _) if s % 2 == 0 => Interaction::Fro { z: 1e-3 * k },
        (2, _) => Interaction::Res { k },
        _ => Interaction::Lnl {
            lk: Curve::new(&[(-1.0, -k), (0.0, 0.0), (0.5, 0.6 * k)]).unwrap(),
            lz: Curve::new(&[(-1.0, -1e-4), (1.0, 1e-4)]).unwrap(),
        },
    }
}

/// Banks of short strings, each of its own stiffness (whose links the engine joins into one loop
/// over the strings, the ground links between them its exceptions), with long strings among them
/// (which keep a loop of their own), free right ends, strings of several laws, every form of
/// inertia and an ENF input, equal the reference at every step in every output, in blocks of any
/// size.
#[test]
fn banks_of_short_strings_equal_the_reference() {
    let lengths = [20, 33, 17, 40, 300, 25, 16, 64, 9, 50, 31, 18, 100];
    for kind in 0..4 {
        for inertia in 0..4 {
            let net = string_bank(kind as u64 + 7, &lengths, inertia, bank_law(kind));
            // (the strings of FRO alone, plucked at rest, do not move)
            let moved = equals_reference_in_blocks(&net, 1500, &format!("laws {kind}, {inertia}"));
            assert!(moved > net.outputs.len() / 3, "laws {kind}");
        }
    }
}

/// Asserts that `net` renders the reference's bits over `steps` steps in blocks of 1, 7 and
/// 1024 frames; returns how many of its outputs moved.
fn equals_reference_in_blocks(net: &Network, steps: usize, what: &str) -> usize {
    let expected = reference(net, steps);
    for block in [1, 7, 1024] {
        let got = render(net, steps, block);
        assert_eq!(
            first_bit_difference(&got, &expected),
            None,
            "{what}, block {block}"
        );
    }
    let ch = net.outputs.len();
    let moved = |c: usize| (0..steps).any(|s| expected[s * ch + c] != expected[c]);
    (0..ch).filter(|&c| moved(c)).count()
}
