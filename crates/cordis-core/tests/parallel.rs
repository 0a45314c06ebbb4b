//! Threads (`Engine::set_threads`): the output is the single-thread engine's and the reference
//! stepper's, bit for bit, for every thread count and block size; blow-ups are reported alike.
#![allow(clippy::unwrap_used)] // tests and benches may panic on failure

mod common;

use common::*;
use cordis_core::{
    BlowUp, Curve, Engine, Interaction, LinkId, MatId, Material, Network, Probe, Signal,
};

const THREADS: [usize; 4] = [1, 2, 3, 4];
const BLOCKS: [usize; 3] = [1, 7, 1024];

/// An engine on `threads` threads, whatever the network's size.
fn engine(net: &Network, threads: usize) -> Engine {
    let mut e = Engine::new(net);
    e.set_parallel_threshold(0);
    e.set_threads(threads);
    assert_eq!(e.threads(), threads);
    assert_eq!(e.is_parallel(), threads > 1);
    e
}

/// Renders `steps` frames on `threads` threads in blocks of `block`.
fn render_threads(net: &Network, steps: usize, block: usize, threads: usize) -> Vec<f64> {
    render_with(engine(net, threads), steps, block)
}

/// Every thread count and block size gives `expected` (the single-thread engine's output, itself
/// checked against the reference stepper by the caller), bit for bit.
fn check_all(net: &Network, steps: usize, expected: &[f64], what: &str) {
    for threads in THREADS {
        for block in BLOCKS {
            let got = render_threads(net, steps, block, threads);
            assert_eq!(
                first_bit_difference(&got, expected),
                None,
                "{what}: {threads} threads, block {block}"
            );
        }
    }
}

/// How the inertias of a grid are chosen: each selects one of the engine's MAS update forms.
#[derive(Clone, Copy, Debug)]
enum Inertia {
    /// all 1 (one reciprocal, multiplied)
    UniformPowerOfTwo,
    /// all 1.5 (one inertia, divided)
    Uniform,
    /// 0.5, 1, 2 (per-mass reciprocals)
    PowersOfTwo,
    /// 0.75, 1, 1.25 (per-mass inertias)
    Mixed,
}

impl Inertia {
    fn of(self, i: usize) -> f64 {
        match self {
            Inertia::UniformPowerOfTwo => 1.0,
            Inertia::Uniform => 1.5,
            Inertia::PowersOfTwo => [0.5, 1.0, 2.0][i % 3],
            Inertia::Mixed => [0.75, 1.0, 1.25][i % 3],
        }
    }
}

/// The law of the `i`-th link of a grid: long uniform stretches (the engine's uniform runs) and
/// stretches of varying parameters, over every interaction type.
fn law(i: usize) -> Interaction {
    let w = 1.0 + 0.01 * (i % 7) as f64; // parameters vary in stretch 2 of every 5
    let k = 0.1 * if (i / 50) % 5 == 2 { w } else { 1.0 };
    let z = 1e-4 * if (i / 50) % 5 == 2 { w } else { 1.0 };
    match (i / 10) % 10 {
        0..=3 => Interaction::Ref { k, z },
        4 => Interaction::Res { k },
        5 => Interaction::Ref { k: 0.5 * k, z: 0.1 },
        6 | 7 => Interaction::But {
            k,
            z,
            s: if i.is_multiple_of(3) { 1e-3 } else { -1e-3 },
        },
        _ => Interaction::Lnl {
            lk: Curve::new(&[(-0.01, -k * 0.01), (0.0, 0.0), (0.01, 2.0 * k * 0.01)]).unwrap(),
            lz: Curve::new(&[(-1.0, -z), (1.0, z)]).unwrap(),
        },
    }
}

/// A `rows` x `cols` grid (a string when `rows == 1`) with every module type: MAS and CEL points
/// (every 9th is a CEL), SOL grounds around the border, an ENX hand driving a corner, REF, RES, FRO,
/// BUT and LNL links, ENF inputs (impulse, step, noise), SOX, SOF and summed outputs. A strike
/// (initial velocity) and the inputs excite it; it is stable.
fn every_module_grid(rows: usize, cols: usize, inertia: Inertia) -> Network {
    let mut net = Network::new();
    let mut ids = Vec::with_capacity(rows * cols);
    for i in 0..rows * cols {
        let m = inertia.of(i);
        let v0 = if i == rows * cols / 4 + cols / 3 {
            0.05
        } else {
            0.0
        };
        ids.push(if i % 9 == 4 {
            net.add_material(Material::Cel {
                m,
                k: 0.01,
                z: 1e-4,
                x0: 0.0,
                v0,
                r: 1e-3,
            })
        } else {
            net.add_material(Material::Mas { m, x0: 0.0, v0 })
        });
    }
    let at = |r: usize, c: usize| ids[r * cols + c];
    let ground = net.add_material(Material::Sol { x0: 0.0 });
    let hand = net.add_material(Material::Enx {
        signal: Signal::Sine {
            freq: 3.0 / 44100.0,
            amp: 0.01,
            phase: 0.3,
        },
    });
    let mut count = 0;
    let mut link = |net: &mut Network, a: MatId, b: MatId| {
        count += 1;
        net.add_link(law(count), a, b)
    };
    let mut sof = Vec::new();
    for r in 0..rows {
        link(&mut net, ground, at(r, 0));
        for c in 0..cols - 1 {
            let l = link(&mut net, at(r, c), at(r, c + 1));
            if (r * cols + c) % 4999 == 17 {
                sof.push(l);
            }
        }
        link(&mut net, at(r, cols - 1), ground);
    }
    if rows > 1 {
        for c in 0..cols {
            link(&mut net, ground, at(0, c));
            for r in 0..rows - 1 {
                link(&mut net, at(r, c), at(r + 1, c));
            }
            link(&mut net, at(rows - 1, c), ground);
        }
    }
    for (i, &m) in ids.iter().enumerate().step_by(10) {
        net.add_link(
            Interaction::Fro {
                z: 1e-3 + 1e-6 * i as f64,
            },
            m,
            ground,
        );
    }
    let h = net.add_link(Interaction::Ref { k: 0.05, z: 1e-3 }, hand, at(0, 0));
    net.add_link(Interaction::Res { k: 0.01 }, ground, hand); // both ends fixed: no effect
    let n = ids.len();
    net.add_force(ids[n / 3], Signal::Impulse { at: 5, amp: 0.02 });
    net.add_force(ids[n / 2], Signal::Step { at: 40, amp: 1e-4 });
    for &m in ids.iter().step_by(997) {
        net.add_force(m, Signal::Noise { seed: 5, amp: 1e-4 });
    }
    net.add_force(ids[n / 3], Signal::Constant(-1e-5)); // a second input on the same mass
    net.add_force(ground, Signal::Constant(1.0)); // on a SOL: discarded
    for &m in ids.iter().step_by((n / 7).max(1)) {
        net.add_position_output(m);
    }
    net.add_position_output(hand);
    net.add_force_output(h);
    for l in sof {
        net.add_force_output(l);
    }
    net.add_sum_output(vec![
        (0.5, Probe::Position(ids[n / 2])),
        (-2.0, Probe::Position(ids[n / 5])),
        (3.0, Probe::Force(h)),
    ]);
    net
}

/// The single-thread engine on `net`, checked against the reference stepper.
fn single_thread_checked(net: &Network, steps: usize) -> Vec<f64> {
    let one = render(net, steps, 1024);
    assert_eq!(
        first_bit_difference(&one, &reference(net, steps)),
        None,
        "single-thread engine against the reference"
    );
    one
}

#[test]
fn random_networks_match_on_any_thread_count_and_block_size() {
    for (seed, n, steps) in [(1, 60, 400), (2, 500, 300), (3, 3000, 1100), (4, 7, 100)] {
        let net = random_network(seed, n, 4);
        let expected = single_thread_checked(&net, steps);
        check_all(
            &net,
            steps,
            &expected,
            &format!("random seed {seed}, {n} masses"),
        );
    }
}

/// The thread count changed between blocks, as `cordis render` does when it times both: the
/// pull step (springs, and LNL links whose forces it stores, two barriers a step) and
/// the grid step (strings as the language declares them, each in pieces) give the single-thread
/// bits.
#[test]
fn changing_the_threads_between_blocks_keeps_the_output() {
    // strings of 3,000 and 2,000 MAS, cut into pieces of 1,000 (rows) that the grid step's
    // threads share; the first is plucked at its MAS 1,000, the first of its second piece, which
    // outputs around it read (the bank's own read the strings' ends)
    let mut strings = string_bank(8, &[3000, 2000], 0, |_, k| Interaction::Ref { k, z: 1e-4 });
    let mas: Vec<MatId> = (strings.materials.iter().enumerate())
        .filter(|(_, m)| matches!(m, Material::Mas { .. }))
        .map(|(i, _)| MatId(i as u32))
        .collect();
    for i in [990, 999, 1000, 1001, 1100] {
        strings.add_position_output(mas[i]);
    }
    for (net, what) in [
        (spring_network(6, 3001, 4, 1, false), "springs"),
        (lnl_network(7, 2000, 2, true, true), "LNL links"),
        (strings, "strings"),
    ] {
        let steps = 700;
        let expected = single_thread_checked(&net, steps);
        let ch = net.outputs.len();
        let mut e = engine(&net, 2);
        let mut out = vec![0.0; steps * ch];
        let mut done = 0;
        for (threads, n) in [
            (2, 64),
            (1, 100),
            (1, 36),
            (2, 200),
            (3, 100),
            (1, 50),
            (2, 150),
        ] {
            if threads != e.threads() {
                e.set_threads(threads);
            }
            assert_eq!(e.is_parallel(), threads > 1);
            e.process(n, &mut out[done * ch..(done + n) * ch]).unwrap();
            done += n;
        }
        assert_eq!(done, steps);
        assert_eq!(first_bit_difference(&out, &expected), None, "{what}");
    }
}

/// Networks of springs and dampers (the pull step's kind on an AVX-512 CPU: one barrier per
/// step, each thread its consecutive groups of eight MAS, the last one the CEL and ENX), with
/// every MAS update form, uniform and mixed links, and as many threads as groups or more.
#[test]
fn spring_networks_match_on_any_thread_count_and_block_size() {
    for (seed, n, steps, inertia, uniform) in [
        (1, 16, 400, 0, true),
        (2, 17, 400, 1, false),
        (3, 300, 1100, 2, false),
        (4, 3001, 300, 3, true),
        (5, 20_000, 120, 0, true),
    ] {
        let net = spring_network(seed, n, 4, inertia, uniform);
        let expected = single_thread_checked(&net, steps);
        check_all(
            &net,
            steps,
            &expected,
            &format!("springs {seed}, {n} masses"),
        );
    }
}

#[test]
fn every_module_network_matches_with_more_threads_than_modules_per_kind() {
    // 4 threads on 3 MAS, 1 CEL, 1 ENX and 7 links: some threads get nothing of some kind.
    let net = every_module_network();
    let expected = single_thread_checked(&net, 400);
    check_all(&net, 400, &expected, "every module network");
}

#[test]
fn string_of_10k_masses_with_every_module_type() {
    // more than one block of 1024 once, shorter for the other inertias
    for (inertia, steps) in [(Inertia::UniformPowerOfTwo, 1100), (Inertia::Mixed, 300)] {
        let net = every_module_grid(1, 10_000, inertia);
        let expected = single_thread_checked(&net, steps);
        check_all(&net, steps, &expected, &format!("string 10k {inertia:?}"));
    }
}

#[test]
fn membrane_of_10k_masses_with_every_module_type() {
    for (inertia, steps) in [(Inertia::Uniform, 1100), (Inertia::PowersOfTwo, 300)] {
        let net = every_module_grid(100, 100, inertia);
        let expected = single_thread_checked(&net, steps);
        check_all(
            &net,
            steps,
            &expected,
            &format!("membrane 100x100 {inertia:?}"),
        );
    }
}

#[test]
fn string_and_membrane_of_100k_masses() {
    let string = every_module_grid(1, 100_000, Inertia::Mixed);
    let expected = single_thread_checked(&string, 150);
    check_all(&string, 150, &expected, "string 100k");
    let membrane = every_module_grid(316, 316, Inertia::UniformPowerOfTwo);
    let expected = single_thread_checked(&membrane, 120);
    check_all(&membrane, 120, &expected, "membrane 316x316");
}

#[test]
fn an_engine_with_threads_can_still_move_between_threads() {
    fn send_sync<T: Send + Sync>() {}
    send_sync::<Engine>();
    let net = random_network(9, 300, 4);
    let expected = render(&net, 500, 500);
    let mut e = engine(&net, 2);
    let ch = e.channels();
    let out = std::thread::spawn(move || {
        let mut out = vec![0.0; 500 * ch];
        e.process(500, &mut out).unwrap();
        out
    })
    .join()
    .unwrap();
    assert_eq!(first_bit_difference(&out, &expected), None);
}

#[test]
fn the_default_threshold_keeps_small_networks_on_one_thread() {
    let small = every_module_grid(1, 100, Inertia::Mixed);
    let mut e = Engine::new(&small);
    assert_eq!((e.threads(), e.is_parallel()), (1, false));
    e.set_threads(2);
    assert!(!e.is_parallel(), "below the default threshold");
    e.set_threads(0);
    assert_eq!(e.threads(), 1);
    let big = every_module_grid(1, Engine::DEFAULT_PARALLEL_THRESHOLD, Inertia::Mixed);
    let mut e = Engine::new(&big);
    e.set_threads(2);
    assert!(e.is_parallel());
    e.set_parallel_threshold(usize::MAX);
    assert!(!e.is_parallel());
}

#[test]
fn networks_without_locality_need_a_larger_size_for_threads() {
    let size = |net: &Network| net.materials.len() + net.links.len();
    // random links: most tie masses far apart in storage
    let mid = random_network(3, 8_000, 4); // 3 modules per mass
    assert!(size(&mid) >= Engine::DEFAULT_PARALLEL_THRESHOLD);
    assert!(size(&mid) < Engine::DEFAULT_PARALLEL_THRESHOLD * Engine::SCATTERED_FACTOR);
    let mut e = Engine::new(&mid);
    e.set_threads(2);
    assert!(
        !e.is_parallel(),
        "a random network of {} modules",
        size(&mid)
    );
    e.set_parallel_threshold(0);
    assert!(e.is_parallel());
    let big = random_network(3, 34_000, 4);
    assert!(size(&big) >= Engine::DEFAULT_PARALLEL_THRESHOLD * Engine::SCATTERED_FACTOR);
    let mut e = Engine::new(&big);
    e.set_threads(2);
    assert!(e.is_parallel());
    // a string of the same size as `mid`, every module type, is local: threads
    let string = every_module_grid(1, size(&mid) / 2, Inertia::Mixed);
    assert!(size(&string) >= Engine::DEFAULT_PARALLEL_THRESHOLD);
    let mut e = Engine::new(&string);
    e.set_threads(2);
    assert!(e.is_parallel());
}

#[test]
fn clones_resets_observers_and_changing_threads_keep_the_output() {
    let net = every_module_grid(40, 50, Inertia::Mixed);
    let steps = 900;
    let expected = single_thread_checked(&net, steps);
    let ch = net.outputs.len();
    let mut e = engine(&net, 2);
    let mut out = vec![0.0; steps * ch];
    e.process(300, &mut out[..300 * ch]).unwrap();
    // a clone (which starts its own threads) goes on from the same state
    let mut c = e.clone();
    let mut out_c = out.clone();
    c.process(600, &mut out_c[300 * ch..]).unwrap();
    assert_eq!(first_bit_difference(&out_c, &expected), None, "clone");
    // more threads in the middle of a run, then an observed block (on the calling thread)
    e.set_threads(3);
    e.process(300, &mut out[300 * ch..600 * ch]).unwrap();
    let mut observed = 0;
    e.process_observed(300, &mut out[600 * ch..], &mut |v| {
        assert_eq!(v.step(), 600 + observed);
        observed += 1;
    })
    .unwrap();
    assert_eq!(observed, 300);
    assert_eq!(first_bit_difference(&out, &expected), None, "3 threads");
    // link forces and positions after a threaded block are those of the single-thread engine
    let mut one = Engine::new(&net);
    let mut scratch = vec![0.0; steps * ch];
    one.process(steps, &mut scratch).unwrap();
    let forces = |e: &Engine| -> Vec<f64> {
        (0..net.links.len() as u32)
            .map(|l| e.link_force(LinkId(l)))
            .collect()
    };
    assert_eq!(first_bit_difference(&forces(&one), &forces(&e)), None);
    for m in 0..net.materials.len() as u32 {
        let m = MatId(m);
        assert_eq!(one.position(m).to_bits(), e.position(m).to_bits());
        assert_eq!(
            one.previous_position(m).to_bits(),
            e.previous_position(m).to_bits()
        );
    }
    // reset: the same run again
    e.reset();
    let mut again = vec![0.0; steps * ch];
    e.process(steps, &mut again).unwrap();
    assert_eq!(first_bit_difference(&again, &expected), None, "after reset");
}

/// A long string that diverges: one link to the ground is too stiff (K/M = 5 > 4).
fn unstable_string(n: usize) -> Network {
    let mut net = every_module_grid(1, n, Inertia::UniformPowerOfTwo);
    let ground = net.add_material(Material::Sol { x0: 0.0 });
    let m = MatId((n / 2) as u32);
    net.add_link(Interaction::Res { k: 5.0 }, ground, m);
    net.add_force(m, Signal::Impulse { at: 3, amp: 1.0 });
    net
}

/// Steps until the engine reports a blow-up; returns it and the output so far.
fn run_to_blow_up(e: &mut Engine, block: usize, max_steps: usize) -> (BlowUp, Vec<f64>) {
    let ch = e.channels();
    let mut all = Vec::new();
    let mut out = vec![0.0; block * ch];
    while all.len() < max_steps * ch {
        match e.process(block, &mut out) {
            Ok(()) => all.extend_from_slice(&out),
            Err(b) => {
                all.extend_from_slice(&out[..b.valid_frames * ch]);
                return (b, all);
            }
        }
    }
    panic!("no blow-up in {max_steps} steps");
}

#[test]
fn a_blow_up_is_reported_at_the_same_step_and_module_with_threads() {
    let net = unstable_string(20_000);
    let mut one = Engine::new(&net);
    let (expected, expected_out) = run_to_blow_up(&mut one, 1, 5000);
    assert!(expected.step > 100, "diverges slowly enough to span blocks");
    for threads in [2, 3, 4] {
        for block in BLOCKS {
            let mut e = engine(&net, threads);
            let (b, out) = run_to_blow_up(&mut e, block, 5000);
            assert_eq!(
                (b.step, b.material),
                (expected.step, expected.material),
                "{threads} threads, block {block}"
            );
            assert_eq!(first_bit_difference(&out, &expected_out), None);
            // and it refuses to go on until reset
            let mut scratch = vec![0.0; e.channels()];
            assert_eq!(e.process(1, &mut scratch).map_err(|b| b.step), Err(b.step));
            e.reset();
            assert!(e.process(1, &mut scratch).is_ok());
        }
    }
}

/// Membranes of the grid step's kind (on an AVX-512 CPU: one barrier per step, each thread its
/// consecutive rows, the first recomputing the links up from the row above, thread 0 stepping
/// what is around the membrane), as many threads as rows or more; some with per-MAS inertias.
#[test]
fn grid_membranes_match_on_any_thread_count_and_block_size() {
    for (seed, rows, cols, m, steps, layout, around) in [
        (1, 3, 16, 1.0, 300, GridLayout::Kit, Around::Nothing),
        (2, 40, 37, 1.5, 400, GridLayout::Rimmed, Around::Nothing),
        (3, 100, 100, 0.5, 150, GridLayout::Mixed, Around::Nothing),
        (4, 9, 20, 1.0, 200, GridLayout::Rimmed, Around::Nothing),
        (5, 4, 16, 1.0, 300, GridLayout::Kit, Around::Instrument),
        (6, 30, 33, 1.5, 400, GridLayout::Rimmed, Around::Instrument),
        (7, 17, 40, 0.5, 300, GridLayout::Mixed, Around::FreeEdges),
        (8, 5, 24, 1.0, 300, GridLayout::Rimmed, Around::FreeEdges),
        (9, 3, 16, 1.0, 300, GridLayout::Kit, Around::Pair),
        (10, 20, 30, 0.5, 300, GridLayout::Mixed, Around::Pair),
    ] {
        let mut net = grid_membrane(seed, rows, cols, m, layout, seed == 2, true, around);
        if seed % 3 == 0 {
            // (per-MAS inertias, powers of two for seed 3, any for 6 and 9)
            let factors: &[f64] = if seed == 3 {
                &[1.0, 2.0, 0.5]
            } else {
                &[1.0, 1.5, 0.8]
            };
            vary_inertias(&mut net, factors);
        }
        let expected = single_thread_checked(&net, steps);
        check_all(
            &net,
            steps,
            &expected,
            &format!("grid membrane {rows}x{cols} {layout:?} {around:?}"),
        );
    }
}

/// Banks of short strings of their own stiffnesses (one loop over the strings, with exceptions:
/// see `tests/engine.rs`) give the reference's bits on any thread count and block size.
#[test]
fn string_banks_match_on_any_thread_count_and_block_size() {
    let lengths = [24, 40, 17, 33, 300, 50, 20, 28, 64, 19, 45, 30];
    for (inertia, seed) in [(0, 3), (3, 4)] {
        let net = string_bank(seed, &lengths, inertia, |_, k| Interaction::Ref {
            k,
            z: 1e-4 * k,
        });
        let steps = 800;
        let expected = reference(&net, steps);
        assert_eq!(
            first_bit_difference(&render(&net, steps, 64), &expected),
            None
        );
        check_all(
            &net,
            steps,
            &expected,
            &format!("string bank, inertia {inertia}"),
        );
    }
}
