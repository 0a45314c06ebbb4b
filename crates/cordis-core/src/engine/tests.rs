use super::*;

/// An observer that does nothing: `process_observed` through it takes the observing block loop
/// (the same one `process` takes on the gather and compact steps) where `process` would take
/// the pull or grid step.
fn unobserved(_: &StepView<'_>) {}

/// Every vector width this CPU has steps to the same bits as the scalar build, on a string
/// and a membrane whose links come in uniform and varied runs of every law (LNL curves of 2,
/// 3 and 17 points), BUT thresholds of both signs, an ENF input and every output kind.
#[test]
fn every_vector_width_gives_the_same_bits() {
    // (rows of 40 and 43 masses: every loop has a remainder, which AVX-512 computes as one
    // masked block, for some of the rows)
    for (rows, cols) in [(12, 40), (9, 43)] {
        let mut net = Network::new();
        let ids: Vec<MatId> = (0..rows * cols)
            .map(|i| {
                let m = [1.0, 1.5, 0.5][i % 3];
                let v0 = if i == 45 { 0.05 } else { 0.0 };
                net.add_material(Material::Mas { m, x0: 0.0, v0 })
            })
            .collect();
        let g = net.add_material(Material::Sol { x0: 0.0 });
        let seventeen: Vec<(f64, f64)> = (0..17)
            .map(|i| (i as f64 * 0.5 - 4.0, 0.01 * (i as f64 - 8.0)))
            .collect();
        let law = |i: usize| {
            let w = 1.0 + 0.01 * (i % 5) as f64;
            match (i / 24) % 6 {
                0 => Interaction::Ref { k: 0.1, z: 1e-4 },
                1 => Interaction::Ref {
                    k: 0.1 * w,
                    z: 1e-4,
                },
                2 => Interaction::Res { k: 0.08 },
                3 => Interaction::But {
                    k: 0.1,
                    z: 1e-4,
                    s: if i.is_multiple_of(2) { 1e-3 } else { -1e-3 },
                },
                4 => Interaction::Lnl {
                    lk: Curve::new(&[(-0.01, -1e-3), (0.0, 0.0), (0.01, 2e-3)]).unwrap(),
                    lz: Curve::new(&[(-1.0, -1e-4), (1.0, 1e-4)]).unwrap(),
                },
                _ => Interaction::Lnl {
                    lk: Curve::new(&seventeen).unwrap(),
                    lz: Curve::new(&[(-1.0, -1e-4), (1.0, 1e-4)]).unwrap(),
                },
            }
        };
        let mut i = 0;
        for r in 0..rows {
            net.add_link(law(i), g, ids[r * cols]);
            for c in 0..cols - 1 {
                i += 1;
                net.add_link(law(i), ids[r * cols + c], ids[r * cols + c + 1]);
            }
        }
        for c in 0..cols {
            for r in 0..rows - 1 {
                i += 1;
                net.add_link(law(i), ids[r * cols + c], ids[(r + 1) * cols + c]);
            }
            net.add_link(law(i), ids[(rows - 1) * cols + c], g);
        }
        net.add_force(ids[7], Signal::Impulse { at: 3, amp: 0.2 });
        net.add_position_output(ids[rows * cols / 2]);
        net.add_force_output(LinkId(5));
        net.add_sum_output(vec![
            (0.5, Probe::Position(ids[3])),
            (2.0, Probe::Force(LinkId(60))),
        ]);
        let mut widths = vec![Simd::None];
        #[cfg(target_arch = "x86_64")]
        {
            if std::is_x86_feature_detected!("avx2") {
                widths.push(Simd::Avx2);
            }
            if let Some(cpu) = Avx512::detect() {
                widths.push(Simd::Avx512(cpu));
            }
        }
        let render = |simd: Simd| {
            let mut e = Engine::new(&net);
            e.k.simd = simd;
            let mut out = vec![0.0; 3000 * e.channels()];
            e.process(3000, &mut out).unwrap();
            out
        };
        let scalar = render(Simd::None);
        assert!(scalar.iter().any(|v| *v != 0.0));
        for &w in &widths[1..] {
            let out = render(w);
            let same = out
                .iter()
                .zip(&scalar)
                .all(|(a, b)| a.to_bits() == b.to_bits());
            assert!(same, "{w:?} differs from the scalar build");
        }
    }
}

/// A membrane with one ground per missing neighbour (as the benchmark's) and a string between
/// two grounds: the ground links are placed where the border masses' sums continue their
/// progressions, so every mass of a membrane row, and every mass of the string, sums unit-step
/// streams (no mass read through an index list); with exceptions, the membrane is one loop.
#[test]
fn ground_links_join_the_progressions_of_their_row() {
    let (rows, cols) = (6, 40);
    let mut net = Network::new();
    let law = Interaction::Ref { k: 0.1, z: 1e-4 };
    let ids: Vec<MatId> = (0..rows * cols)
        .map(|i| {
            let v0 = if i == 45 { 0.05 } else { 0.0 };
            net.add_material(Material::Mas {
                m: 1.0,
                x0: 0.0,
                v0,
            })
        })
        .collect();
    let at = |r: usize, c: usize| ids[r * cols + c];
    for r in 0..rows {
        let g = net.add_material(Material::Sol { x0: 0.0 });
        net.add_link(law.clone(), g, at(r, 0));
        for c in 0..cols - 1 {
            net.add_link(law.clone(), at(r, c), at(r, c + 1));
        }
        let g = net.add_material(Material::Sol { x0: 0.0 });
        net.add_link(law.clone(), at(r, cols - 1), g);
    }
    for c in 0..cols {
        let g = net.add_material(Material::Sol { x0: 0.0 });
        net.add_link(law.clone(), g, at(0, c));
        for r in 0..rows - 1 {
            net.add_link(law.clone(), at(r, c), at(r + 1, c));
        }
        let g = net.add_material(Material::Sol { x0: 0.0 });
        net.add_link(law.clone(), at(rows - 1, c), g);
    }
    net.add_position_output(at(2, 7));
    // without exceptions, each row is a segment of its own
    let k = Kernel::build(&net, false, false);
    assert_eq!(k.mas_segments.len(), rows, "{:?}", k.mas_segments);
    for seg in &k.mas_segments {
        assert_eq!((seg.degree, seg.mats.len()), (4, cols));
        let streams = &k.streams[seg.streams.clone().expect("streams")];
        assert!(streams.iter().all(|&(_, step)| step == 1), "{streams:?}");
    }
    // with them, the membrane is one: its rows' first MAS are the exceptions (their left
    // ground), and the horizontal links one run with the right grounds as exceptions
    let k = Kernel::new(&net);
    assert_eq!(k.mas_segments.len(), 1, "{:?}", k.mas_segments);
    let seg = &k.mas_segments[0];
    assert_eq!((seg.degree, seg.mats.clone()), (4, 0..rows * cols));
    let streams = &k.streams[seg.streams.clone().expect("streams")];
    assert!(streams.iter().all(|&(_, step)| step == 1), "{streams:?}");
    let firsts: Vec<u32> = (1..rows).map(|r| (r * cols) as u32).collect();
    assert_eq!(k.mas_fix, firsts);
    // every link in a unit-step loop (the grounds of the top and bottom rows too: the SOLs
    // are stored in the order of their links), but the rows' left grounds and the last
    // row's right one
    let runs = &k.whole.runs;
    assert!(
        (runs.iter()).all(|r| match r.ends {
            Ends::Step { sa, sb, .. } => (sa, sb) == (1, 1),
            _ => r.ends == Ends::Indexed,
        }),
        "{runs:?}"
    );
    let indexed = (runs.iter().filter(|r| r.ends == Ends::Indexed))
        .map(|r| r.end - r.start)
        .sum::<usize>();
    assert_eq!(indexed, rows + 1, "{runs:?}");
    assert_eq!(k.link_fix.len(), rows - 1);
    for &l in &k.link_fix {
        let (a, b) = (k.la[l as usize], k.lb[l as usize]);
        assert!((a as usize + 1).is_multiple_of(cols) && b as usize >= k.n_mce);
        let run = k
            .whole
            .runs
            .iter()
            .find(|r| (r.start..r.end).contains(&(l as usize)));
        assert!(matches!(
            run.map(|r| r.ends),
            Some(Ends::Step { sa: 1, sb: 1, .. })
        ));
    }

    let mut string = Network::new();
    let g0 = string.add_material(Material::Sol { x0: 0.0 });
    let masses: Vec<MatId> = (0..100)
        .map(|i| {
            string.add_material(Material::Mas {
                m: 1.0,
                x0: 0.0,
                v0: if i == 3 { 0.1 } else { 0.0 },
            })
        })
        .collect();
    let g1 = string.add_material(Material::Sol { x0: 0.0 });
    let chain: Vec<MatId> = std::iter::once(g0).chain(masses).chain([g1]).collect();
    for w in chain.windows(2) {
        string.add_link(law.clone(), w[0], w[1]);
    }
    string.add_position_output(chain[50]);
    let k = Kernel::new(&string);
    assert_eq!(k.mas_segments.len(), 1, "{:?}", k.mas_segments);
    assert!(k.mas_segments[0].streams.is_some());
}

/// Moves each SOL of `net` to its own place off zero (1 to 7 thousandths), so that a link
/// to a ground computed from any other position than the SOL's gives other bits.
fn displace_grounds(net: &mut Network) {
    for (i, mat) in net.materials.iter_mut().enumerate() {
        if let Material::Sol { x0 } = mat {
            *x0 = 1e-3 * (1 + i % 7) as f64;
        }
    }
}

/// `strings` strings of `n` MAS, each declared as the language's `string` generator does (its
/// MAS, a left SOL and its link, the inner links, a right SOL and its link), string `s` with
/// the law `law(s)`; struck and observed on the first.
fn bank(strings: usize, n: usize, law: impl Fn(usize) -> Interaction) -> Network {
    let mut net = Network::new();
    for s in 0..strings {
        let ids: Vec<MatId> = (0..n)
            .map(|i| {
                let v0 = if i == n / 4 { 0.01 } else { 0.0 };
                net.add_material(Material::Mas {
                    m: 1.0,
                    x0: 0.0,
                    v0,
                })
            })
            .collect();
        let left = net.add_material(Material::Sol { x0: 0.0 });
        net.add_link(law(s), left, ids[0]);
        for w in ids.windows(2) {
            net.add_link(law(s), w[0], w[1]);
        }
        let right = net.add_material(Material::Sol { x0: 0.0 });
        net.add_link(law(s), ids[n - 1], right);
    }
    net.add_position_output(MatId(n as u32 / 2));
    net
}

/// Short strings, each of its own stiffness: their inner links and right grounds are one
/// progression over all the strings (of varied parameters, the right grounds its exceptions:
/// see [`joined`]), and their MAS one segment (the first MAS of each string but the first an
/// exception), as one long string's; long strings keep their uniform loops.
#[test]
fn short_strings_of_their_own_stiffnesses_are_one_progression() {
    let (strings, n) = (12, 40);
    let k_of = |s: usize| 0.1 * (1.0 + s as f64 / 100.0);
    let net = bank(strings, n, |s| Interaction::Ref {
        k: k_of(s),
        z: 1e-4,
    });
    // (with AVX-512 or AVX2 the grid step takes them, each a string of its own: the gather
    // step's storage is `choose`'s)
    let grid = Kernel::new(&net).grid;
    let sheets = strings * usize::from(Simd::detect() != Simd::None);
    assert_eq!(grid.map_or(0, |g| g.sheets()), sheets);
    let k = Kernel::choose(&net);
    assert!(k.grid.is_none() && !k.compact, "the gather step");
    let runs = &k.whole.runs;
    let steps: Vec<&Run> = runs.iter().filter(|r| r.ends != Ends::Indexed).collect();
    assert_eq!(steps.len(), 1, "{runs:?}");
    let run = steps[0];
    assert!(
        !run.uniform && run.end - run.start == strings * n - 1,
        "{run:?}"
    );
    assert!(matches!(run.ends, Ends::Step { sa: 1, sb: 1, .. }));
    let indexed = (runs.iter().filter(|r| r.ends == Ends::Indexed))
        .map(|r| r.end - r.start)
        .sum::<usize>();
    assert_eq!(indexed, strings + 1, "{runs:?}");
    assert_eq!(k.link_fix.len(), strings - 1);
    for &l in &k.link_fix {
        // a right ground, its K its string's
        let (a, b, l) = (k.la[l as usize], k.lb[l as usize], l as usize);
        assert!((a as usize + 1).is_multiple_of(n) && b as usize >= k.n_mce);
        assert_eq!(k.lk[l].to_bits(), k_of(a as usize / n).to_bits());
    }
    assert_eq!(k.mas_segments.len(), 1, "{:?}", k.mas_segments);
    assert_eq!(k.mas_segments[0].mats, 0..strings * n);
    let firsts: Vec<u32> = (1..strings).map(|s| (s * n) as u32).collect();
    assert_eq!(k.mas_fix, firsts);
    // two long strings keep a uniform loop each
    let net = bank(2, 2 * JOIN_MAX, |s| Interaction::Ref {
        k: k_of(s),
        z: 1e-4,
    });
    let k = Kernel::new(&net);
    let steps: Vec<&Run> = (k.whole.runs.iter())
        .filter(|r| r.ends != Ends::Indexed)
        .collect();
    assert_eq!(steps.len(), 2, "{:?}", k.whole.runs);
    assert!(steps.iter().all(|r| r.uniform));
}

#[test]
fn split_covers_everything_in_order_and_balances_cost() {
    for (len, parts) in [(0, 3), (1, 4), (10, 2), (1000, 3), (7, 7)] {
        let r = split(len, parts, |i| 1 + (i % 3) as u64);
        assert_eq!(r.len(), parts);
        assert_eq!(r[0].start, 0);
        assert_eq!(r[parts - 1].end, len);
        for w in r.windows(2) {
            assert_eq!(w[0].end, w[1].start);
        }
    }
    let r = split(1000, 2, |_| 1);
    assert_eq!(r, [0..500, 500..1000]);
    let r = split(4, 2, |i| if i == 0 { 3 } else { 1 });
    assert_eq!(r, [0..1, 1..4]);
}

/// A small network of every module type, stepped on 1, 2 and 3 threads: small enough for
/// `cargo +nightly miri test -p cordis-core --lib`, which checks the threaded path (the
/// `SharedBuf` phase discipline of `Job`) for data races and aliasing violations.
#[test]
fn threads_give_the_single_thread_output_on_a_small_network() {
    let mut net = Network::new();
    let g = net.add_material(Material::Sol { x0: 0.0 });
    // (an envelope rather than a sine: Miri perturbs `sin` at random, as platforms may differ)
    let hand = net.add_material(Material::Enx {
        signal: Signal::Envelope(
            Curve::new(&[(0.0, 0.0), (10.0, 0.1), (30.0, -0.05)]).unwrap_or_default(),
        ),
    });
    let mut prev = g;
    let mut ids = Vec::new();
    for i in 0..12 {
        let m = if i % 5 == 2 {
            net.add_material(Material::Cel {
                m: 1.5,
                k: 0.01,
                z: 1e-3,
                x0: 0.1,
                v0: 0.0,
                r: 0.0,
            })
        } else {
            net.add_material(Material::Mas {
                m: 1.0 + 0.25 * (i % 3) as f64,
                x0: 0.0,
                v0: 0.01 * i as f64,
            })
        };
        let law = match i % 5 {
            0 => Interaction::Ref { k: 0.1, z: 1e-3 },
            1 => Interaction::Res { k: 0.05 },
            2 => Interaction::Fro { z: 1e-2 },
            3 => Interaction::But {
                k: 0.1,
                z: 1e-3,
                s: 0.01,
            },
            _ => Interaction::Lnl {
                lk: Curve::new(&[(-1.0, -0.1), (1.0, 0.1)]).unwrap_or_default(),
                lz: Curve::zero(),
            },
        };
        let l = net.add_link(law, prev, m);
        net.add_force_output(l);
        net.add_position_output(m);
        ids.push(m);
        prev = m;
    }
    net.add_link(Interaction::Ref { k: 0.1, z: 1e-3 }, hand, ids[6]);
    net.add_force(ids[3], Signal::Noise { seed: 1, amp: 1e-3 });
    let steps = 40;
    let render = |threads: usize, block: usize| {
        let mut e = Engine::new(&net);
        e.set_parallel_threshold(0);
        e.set_threads(threads);
        assert_eq!(e.is_parallel(), threads > 1);
        let ch = e.channels();
        let mut out = vec![0.0; steps * ch];
        for chunk in out.chunks_mut(block * ch) {
            assert!(e.process(chunk.len() / ch, chunk).is_ok());
        }
        out.iter().map(|v| v.to_bits()).collect::<Vec<_>>()
    };
    let one = render(1, steps);
    for threads in [2, 3] {
        for block in [1, 7, steps] {
            assert!(
                one == render(threads, block),
                "{threads} threads, block {block}"
            );
        }
    }
}

/// A seeded irregular network of `n` MAS (three inertias, one not a power of two), two CEL,
/// an ENX and two SOL: every MAS tied to two others drawn at random and to a SOL, in blocks of
/// one law each (REF, RES, FRO, BUT with both signs of S, LNL), ENF inputs, and every output
/// kind. Its links are read through index lists: the compact step's kind of network.
fn irregular(seed: u64, n: usize) -> Network {
    let mut state = seed
        .wrapping_mul(6364136223846793005)
        .wrapping_add(1442695040888963407);
    let mut draw = |below: usize| {
        state = state
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        ((state >> 33) % below as u64) as usize
    };
    let mut net = Network::new();
    let mut ids: Vec<MatId> = (0..n)
        .map(|i| {
            let m = [1.0, 0.5, 1.5][i % 3];
            let v0 = if i % 7 == 3 { 0.01 } else { 0.0 };
            net.add_material(Material::Mas { m, x0: 0.0, v0 })
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
        signal: Signal::Envelope(
            Curve::new(&[(0.0, 0.0), (50.0, 0.02), (200.0, -0.01)]).unwrap_or_default(),
        ),
    });
    let grounds = [0.0, 0.5].map(|x0| net.add_material(Material::Sol { x0 }));
    let law = |block: usize, i: usize| match block {
        0 => Interaction::Ref { k: 0.05, z: 1e-3 },
        1 => Interaction::Res { k: 0.03 },
        2 => Interaction::Fro { z: 2e-3 },
        3 => Interaction::But {
            k: 0.08,
            z: 1e-3,
            s: if i.is_multiple_of(2) { 0.01 } else { -0.01 },
        },
        _ => Interaction::Lnl {
            lk: Curve::new(&[(-1.0, -0.05), (0.0, 0.0), (1.0, 0.08)]).unwrap_or_default(),
            lz: Curve::new(&[(-1.0, -1e-3), (1.0, 1e-3)]).unwrap_or_default(),
        },
    };
    let total = ids.len();
    for block in 0..5 {
        for i in 0..total {
            if block < 2 || draw(3) == 0 {
                let other = ids[(i + 1 + draw(total - 1)) % total];
                net.add_link(law(block, i), ids[i], other);
            }
        }
    }
    for (i, &m) in ids.iter().enumerate() {
        net.add_link(Interaction::Fro { z: 1e-4 }, m, grounds[i % 2]);
    }
    net.add_link(Interaction::Ref { k: 0.02, z: 0.0 }, hand, ids[1]);
    net.add_force(ids[2], Signal::Impulse { at: 5, amp: 0.05 });
    net.add_force(ids[2], Signal::Noise { seed, amp: 1e-4 });
    net.add_force(ids[n], Signal::Impulse { at: 9, amp: -0.02 });
    net.add_position_output(ids[n / 2]);
    net.add_force_output(LinkId(3));
    net.add_sum_output(vec![
        (0.5, Probe::Position(ids[1])),
        (-2.0, Probe::Force(LinkId(7))),
    ]);
    net
}

/// `strings` short strings of `n` MAS, each from its own anchor (SOL) to a free end, every
/// mass also damped towards its anchor, the free ends tied by a spring (as the reconfigurable
/// instrument is built), and an ENF on the first string.
fn short_strings(strings: usize, n: usize) -> Network {
    let mut net = Network::new();
    let mut all = Vec::new();
    for s in 0..strings {
        let anchor = net.add_material(Material::Sol { x0: s as f64 });
        let ids: Vec<MatId> = (0..n)
            .map(|i| {
                let v0 = if i == 2 { 0.01 } else { 0.0 };
                net.add_material(Material::Mas {
                    m: 1.0,
                    x0: s as f64,
                    v0,
                })
            })
            .collect();
        all.push((anchor, ids));
    }
    for (s, (anchor, ids)) in all.iter().enumerate() {
        let k = 0.05 * (1.0 + s as f64 / 4.0);
        let mut prev = *anchor;
        for &m in ids {
            net.add_link(Interaction::Ref { k, z: 1e-3 * k }, prev, m);
            prev = m;
        }
    }
    for (anchor, ids) in &all {
        for &m in ids {
            net.add_link(Interaction::Fro { z: 1e-4 }, m, *anchor);
        }
    }
    let ends: Vec<MatId> = all.iter().map(|(_, ids)| ids[n - 1]).collect();
    for w in ends.windows(2) {
        net.add_link(Interaction::Res { k: 1e-3 }, w[0], w[1]);
    }
    net.add_force(MatId(3), Signal::Impulse { at: 2, amp: 0.03 });
    net.add_position_output(ends[0]);
    net
}

/// `n` MAS of inertia 1 at rest at 0.
fn masses_at_rest(net: &mut Network, n: usize) -> Vec<MatId> {
    let mas = Material::Mas {
        m: 1.0,
        x0: 0.0,
        v0: 0.0,
    };
    (0..n).map(|_| net.add_material(mas.clone())).collect()
}

/// Every position and link force after each of `steps` steps, and the outputs, as bits.
fn trace(e: &mut Engine, net: &Network, steps: usize) -> Vec<u64> {
    let mut bits = Vec::new();
    let mut out = vec![0.0; steps * e.channels()];
    let mut observe = |v: &StepView<'_>| {
        bits.extend((0..net.materials.len()).map(|m| v.position(MatId(m as u32)).to_bits()));
        bits.extend((0..net.links.len()).map(|l| v.link_force(LinkId(l as u32)).to_bits()));
    };
    assert!(e.process_observed(steps, &mut out, &mut observe).is_ok());
    bits.extend(out.iter().map(|v| v.to_bits()));
    bits
}

/// The compact step is chosen for small irregular networks, and gives the gather step's
/// bits at every step (positions, link forces, outputs), whether the first storage order
/// already kept each material's links in declaration order or the kernel had to be rebuilt
/// in it.
#[test]
fn the_compact_step_gives_the_gathers_bits() {
    let mut rebuilt = 0;
    // (Miri, which checks the accumulators' unchecked accesses, runs a smaller version)
    let (count, steps) = if cfg!(miri) { (3, 30) } else { (10, 400) };
    let nets = (0..count)
        .map(|seed| irregular(seed, 12 + 9 * seed as usize))
        .chain([short_strings(3, 10), short_strings(6, 12)]);
    for (seed, net) in nets.enumerate() {
        let mut compact = Engine::new(&net);
        assert!(compact.k.compact, "network {seed}");
        if !Kernel::build(&net, false, true).in_declaration_order() {
            rebuilt += 1;
        }
        assert!(compact.k.in_declaration_order());
        let mut gather = compact.clone();
        gather.k.compact = false;
        let a = trace(&mut compact, &net, steps);
        let b = trace(&mut gather, &net, steps);
        assert!(a.iter().any(|&v| f64::from_bits(v) != 0.0));
        assert!(
            a == b,
            "network {seed}: the compact step differs from the gather"
        );
    }
    // (both ways to a compact kernel are taken)
    assert!(rebuilt > 0 && rebuilt < count + 2, "{rebuilt} rebuilt");
}

/// A seeded network of springs and dampers without locality (the pull step's kind): `n` MAS
/// of inertias 1, 0.5 and 1.5, a CEL, an ENX and a SOL, every MAS tied to two others drawn
/// at random (REF, RES, FRO in turn) and damped towards the SOL, ENF inputs, and a SOX and
/// a SOF. `law` replaces the law of link 5 (to make a network the pull step refuses).
fn springs(seed: u64, n: usize, law: Option<Interaction>) -> Network {
    let mut state = seed.wrapping_mul(0x9e37_79b9_7f4a_7c15) | 1;
    let mut draw = |below: usize| {
        state = state
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        ((state >> 33) % below as u64) as usize
    };
    let mut net = Network::new();
    let mut ids: Vec<MatId> = (0..n)
        .map(|i| {
            let v0 = if i % 7 == 3 { 0.01 } else { 0.0 };
            let m = [1.0, 0.5, 1.5][i % 3];
            net.add_material(Material::Mas { m, x0: 0.0, v0 })
        })
        .collect();
    let (cel, hand) = cel_and_hand(&mut net);
    ids.push(cel);
    let ground = net.add_material(Material::Sol { x0: 0.0 });
    let total = ids.len();
    for i in 0..2 * total {
        let other = ids[(i % total + 1 + draw(total - 1)) % total];
        let law = match i % 3 {
            0 => Interaction::Ref { k: 0.05, z: 1e-3 },
            1 => Interaction::Res { k: 0.03 },
            _ => Interaction::Fro { z: 2e-3 },
        };
        net.add_link(law, ids[i % total], other);
    }
    for &m in &ids {
        net.add_link(Interaction::Fro { z: 1e-4 }, m, ground);
    }
    net.add_link(Interaction::Ref { k: 0.02, z: 0.0 }, hand, ids[1]);
    if let Some(law) = law {
        net.links[5].law = law;
    }
    net.add_force(ids[2], Signal::Impulse { at: 5, amp: 0.05 });
    net.add_force(ids[n], Signal::Impulse { at: 9, amp: -0.02 });
    net.add_position_output(ids[n / 2]);
    net.add_force_output(LinkId(3));
    net
}

/// A CEL (inertia 2, 0.01 from its rest point) and an ENX (a slow sine), in this order.
fn cel_and_hand(net: &mut Network) -> (MatId, MatId) {
    let cel = net.add_material(Material::Cel {
        m: 2.0,
        k: 0.05,
        z: 1e-3,
        x0: 0.01,
        v0: 0.0,
        r: 0.0,
    });
    let hand = net.add_material(Material::Enx {
        signal: Signal::Sine {
            freq: 0.001,
            amp: 0.01,
            phase: 0.0,
        },
    });
    (cel, hand)
}

/// [`springs`] with every link a REF (of one `K` and `Z`, or each its own) and MAS of one
/// inertia law: `inertia` 0, one power of two (multiplied); 1, one other inertia (divided);
/// 2, powers of two (each its own reciprocal); 3, any.
fn ref_springs(seed: u64, n: usize, inertia: usize, uniform: bool) -> Network {
    let mut net = springs(seed, n, None);
    for (i, link) in net.links.iter_mut().enumerate() {
        let w = if uniform {
            1.0
        } else {
            1.0 + 0.01 * (i % 7) as f64
        };
        link.law = Interaction::Ref {
            k: 0.04 * w,
            z: 1e-3 / w,
        };
    }
    for (i, mat) in net.materials.iter_mut().enumerate() {
        if let Material::Mas { m, .. } = mat {
            *m = match inertia {
                0 => 0.5,
                1 => 1.5,
                2 => [1.0, 0.5, 2.0][i % 3],
                _ => [1.0, 0.7, 1.5][i % 3],
            };
        }
    }
    net
}

/// On a CPU with AVX2 but not AVX-512, networks of REF links take the pull step four lanes
/// at a time (`engine/pull/avx2.rs`), and it gives the other steps' bits at every step, on
/// one thread or two, for every inertia law, links of one `K` and `Z` or each its own, whole
/// and partial groups; so do networks of RES, FRO and REF links, whose rows mask their
/// springs and dampers.
#[cfg(target_arch = "x86_64")]
#[test]
fn the_avx2_pull_step_gives_the_other_steps_bits() {
    if !std::is_x86_feature_detected!("avx2") {
        return;
    }
    for (seed, n) in [(1, 16), (2, 40), (3, 123), (4, 500)] {
        let net = springs(seed, n, None);
        the_avx2_pull_step_gives_the_scalar_bits(&net, &format!("springs {seed}"));
    }
    for (seed, n) in [(1, 16), (2, 43), (3, 123), (4, 500)] {
        for inertia in 0..4 {
            for uniform in [true, false] {
                let what = format!("network {seed}, inertia {inertia}, uniform {uniform}");
                let net = ref_springs(seed, n, inertia, uniform);
                let pulled = Engine::new_for(&net, Simd::Avx2);
                assert!(pulled.k.pull.is_some(), "{what}");
                assert_eq!(pulled.k.pull.as_ref().unwrap().shared_params(), uniform);
                the_avx2_pull_step_gives_the_scalar_bits(&net, &what);
            }
        }
    }
}

/// `net`, which takes the AVX2 pull step, gives the bits of the scalar build (the compact or
/// gather step) at every block, on one thread and on two, through `process` and
/// `process_observed` (the other steps), in its outputs and its positions.
#[cfg(target_arch = "x86_64")]
fn the_avx2_pull_step_gives_the_scalar_bits(net: &Network, what: &str) {
    the_pull_step_of_gives_the_scalar_bits(net, Simd::Avx2, what);
}

/// [`the_avx2_pull_step_gives_the_scalar_bits`] with the pull step compiled for `simd`.
#[cfg(target_arch = "x86_64")]
fn the_pull_step_of_gives_the_scalar_bits(net: &Network, simd: Simd, what: &str) {
    let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
    let mut pulled = Engine::new_for(net, simd);
    assert!(pulled.k.pull.is_some(), "{what}");
    let mut other = pulled.clone();
    let mut threaded = pulled.clone();
    threaded.set_parallel_threshold(0);
    threaded.set_threads(2);
    assert!(threaded.is_parallel());
    let mut scalar = Engine::new_for(net, Simd::None);
    assert!(scalar.k.pull.is_none());
    let ch = pulled.channels();
    let mut moved = false;
    for (i, block) in [1, 7, 300, 64, 1024].into_iter().enumerate() {
        let mut out = [(); 4].map(|()| vec![0.0; block * ch]);
        let [a, b, c, d] = &mut out;
        assert!(pulled.process(block, a).is_ok());
        assert!(other.process_observed(block, b, &mut unobserved).is_ok());
        assert!(threaded.process(block, c).is_ok());
        assert!(scalar.process(block, d).is_ok());
        for (j, o) in [&*b, &*c, &*d].into_iter().enumerate() {
            assert_eq!(bits(a), bits(o), "{what}, block {i}, engine {j}");
        }
        moved |= a.iter().any(|&v| v != a[0]);
    }
    assert!(moved, "{what}");
    for m in (0..net.materials.len() as u32).map(MatId) {
        let (x, xp) = (scalar.position(m), scalar.previous_position(m));
        for e in [&pulled, &threaded] {
            assert_eq!(e.position(m).to_bits(), x.to_bits(), "{what}");
            assert_eq!(e.previous_position(m).to_bits(), xp.to_bits());
        }
    }
    // `f(n-1)`, computed from the positions after a pull block, stored after the others; 0
    // after a reset
    let forces = |e: &Engine| {
        (0..net.links.len() as u32)
            .map(|l| e.link_force(LinkId(l)).to_bits())
            .collect::<Vec<_>>()
    };
    assert!(forces(&scalar).iter().any(|&f| f != 0), "{what}");
    for e in [&pulled, &threaded, &other] {
        assert_eq!(forces(e), forces(&scalar), "{what}");
    }
    pulled.reset();
    assert!(forces(&pulled).iter().all(|&f| f == 0), "{what}");
}

/// [`ref_springs`] with LNL links of `pair`: every link (`every` 1), or every third (2:
/// rows of REF, LNL and padding lanes), the MAS at either end, some tied to the CEL, the
/// SOL or the ENX.
fn lnl_ref_springs(
    seed: u64,
    n: usize,
    inertia: usize,
    pair: &Interaction,
    every: usize,
) -> Network {
    let mut net = ref_springs(seed, n, inertia, false);
    for (i, link) in net.links.iter_mut().enumerate() {
        if every == 1 || i % 3 == 1 {
            link.law = pair.clone();
        }
    }
    net
}

/// On a CPU with AVX2 but not AVX-512, networks of REF links and LNL links of one pair of
/// curves of at most 16 points take the pull step four lanes at a time (`avx2::Curves4`), and
/// give the scalar build's bits: pairs of 4 and 3 points, with a jump, drawn (7 and 3, padded
/// to 8 and 4), finely drawn (11 and 2, padded to 16 and 2) and with a zero viscous curve;
/// every link LNL or every third, rows computing their REF terms in full or not, every
/// inertia law, whole and partial groups. So do networks of REF and BUT links
/// (`avx2::Buts4`): every fourth link a BUT, in and out of contact, thresholds of both signs
/// and zero, or one BUT (a hammer's), rows computing their BUTs in full or not. Both kinds
/// among RES, FRO and REF links too (their springs and dampers masked). So do networks of
/// BUTs and LNLs of one pair, among REF links or among RES, FRO and REF links; and of several
/// pairs, short and long, by row or mixed in some rows, with a BUT among them, and mixed in
/// every row, each storing its forces pair by pair; of twelve pairs of three links each,
/// which do not store them (`avx2::CurveTable4`; a pair for each link, mixed in every row,
/// keeps the other steps);
/// and of long pairs alone, one (`avx2::Long4`) or several.
#[cfg(target_arch = "x86_64")]
#[test]
fn the_avx2_pull_step_takes_but_and_lnl_networks() {
    if !std::is_x86_feature_detected!("avx2") {
        return;
    }
    // (the rows computed the other way: every row its REF or BUT terms, or only those that
    // have one)
    let toggled_gives_the_scalar_bits = |net: &Network, what: &str| {
        let mut toggled = Engine::new_for(net, Simd::Avx2);
        let pull = toggled.k.pull.as_mut().unwrap();
        let full = pull.has_full_rows();
        pull.toggle_full_rows();
        let mut scalar = Engine::new_for(net, Simd::None);
        let [mut a, mut b] = [(); 2].map(|()| vec![0.0; 700 * scalar.channels()]);
        assert!(toggled.process(700, &mut a).is_ok());
        assert!(scalar.process(700, &mut b).is_ok());
        let same = a.iter().zip(&b).all(|(x, y)| x.to_bits() == y.to_bits());
        assert!(same, "{what}, the rows the other way");
        full
    };
    let mut seen_full = [false; 2];
    for (seed, n, inertia, every) in [
        (5, 16, 0, true),
        (6, 43, 1, false),
        (7, 123, 2, true),
        (8, 500, 3, true),
        (9, 500, 1, false),
    ] {
        let what = format!("BUT network {seed}, every {every}");
        let mut net = ref_springs(seed, n, inertia, false);
        for (i, link) in net.links.iter_mut().enumerate() {
            if if every { i % 4 == 1 } else { i == 1 } {
                link.law = but_of(i);
            }
        }
        the_avx2_pull_step_gives_the_scalar_bits(&net, &what);
        seen_full[usize::from(toggled_gives_the_scalar_bits(&net, &what))] = true;
        // (and among RES, FRO and REF links, with a CEL and an ENX at their ends)
        let net = but_springs(seed, n, every);
        the_avx2_pull_step_gives_the_scalar_bits(&net, &format!("{what}, springs"));
        toggled_gives_the_scalar_bits(&net, &what);
    }
    assert_eq!(seen_full, [true, true]);
    // (LNL networks of one pair among RES, FRO and REF links: `lnl_springs`'s mixes 0, 1, 2,
    // 4 and 6)
    for (seed, n, mix) in [
        (11, 16, 0),
        (12, 123, 1),
        (13, 500, 2),
        (14, 43, 4),
        (15, 500, 6),
    ] {
        let what = format!("LNL springs {seed}, mix {mix}");
        let net = lnl_springs(seed, n, mix);
        the_avx2_pull_step_gives_the_scalar_bits(&net, &what);
        toggled_gives_the_scalar_bits(&net, &what);
    }
    let [four, _, _, jump] = lnl_pairs();
    let [drawn, _, fine] = drawn_pairs();
    let zero = Interaction::Lnl {
        lk: Curve::new(&[(-0.01, -6e-4), (0.01, 5e-4)]).unwrap(),
        lz: Curve::zero(),
    };
    let pairs = [four.clone(), jump, drawn, fine, zero];
    seen_full = [false; 2];
    for (p, pair) in pairs.iter().enumerate() {
        for (seed, n, inertia, every) in
            [(1, 16, 0, 1), (2, 43, 1, 2), (3, 123, 2, 1), (4, 500, 3, 2)]
        {
            let what = format!("pair {p}, network {seed}, every {every}");
            let net = lnl_ref_springs(seed + 10 * p as u64, n, inertia, pair, every);
            the_avx2_pull_step_gives_the_scalar_bits(&net, &what);
            let pulled = Engine::new_for(&net, Simd::Avx2);
            let pull = pulled.k.pull.unwrap();
            assert_eq!(pull.curve_pairs(), 1, "{what}");
            assert!(pull.stores_forces(), "{what}");
            seen_full[usize::from(toggled_gives_the_scalar_bits(&net, &what))] = true;
        }
    }
    assert_eq!(seen_full, [true, true]);
    // (BUTs among LNLs of one pair: every fifth link that is not an LNL a BUT, or one BUT;
    // and a pair of more than 16 points, `avx2::Long4`, with BUTs or not)
    seen_full = [false; 2];
    for (pair, long) in [(&four, false), (&sampled_pair(), true)] {
        for (seed, n, inertia, every) in
            [(1, 16, 0, 1), (2, 43, 1, 2), (3, 123, 2, 1), (4, 500, 3, 2)]
        {
            let what = format!("long {long}, network {seed}, every {every}");
            let net = lnl_ref_springs(seed + 60, n, inertia, pair, every);
            let mut but = net.clone();
            for (i, link) in but.links.iter_mut().enumerate() {
                let lnl = matches!(link.law, Interaction::Lnl { .. });
                if if every == 1 {
                    i == 3
                } else {
                    !lnl && i % 5 == 0
                } {
                    link.law = but_of(i);
                }
            }
            let what = format!("{what}, with BUTs");
            if long {
                the_avx2_pull_step_gives_the_scalar_bits(&net, &format!("{what}, without"));
                toggled_gives_the_scalar_bits(&net, &what);
                let pull = Engine::new_for(&net, Simd::Avx2).k.pull.unwrap();
                assert_eq!((pull.curve_pairs(), pull.long_pairs()), (0, 1), "{what}");
                assert!(pull.stores_forces(), "{what}");
            }
            assert!(Engine::new_for(&but, Simd::Avx2)
                .k
                .pull
                .unwrap()
                .stores_forces());
            the_avx2_pull_step_gives_the_scalar_bits(&but, &what);
            seen_full[usize::from(toggled_gives_the_scalar_bits(&but, &what))] = true;
        }
    }
    assert_eq!(seen_full, [true, true]);
    // (among RES, FRO and REF links: `but_lnl_springs`, rows of BUT, LNL, spring and damper
    // lanes)
    for (seed, n) in [(21, 16), (22, 123), (23, 500)] {
        let what = format!("BUTs and LNLs among springs {seed}");
        let net = but_lnl_springs(seed, n, false);
        the_avx2_pull_step_gives_the_scalar_bits(&net, &what);
        toggled_gives_the_scalar_bits(&net, &what);
    }
    // (several pairs, `avx2::CurveTable4`: `lnl_springs`'s mixes 3, 5, 7, 9, 10 and 11, short
    // and long pairs in rows of one pair and rows of several, long pairs in runs of their
    // own, `avx2::Long4`; and the same with a BUT)
    for (seed, n, mix) in [
        (41, 40, 3),
        (42, 500, 3),
        (43, 123, 5),
        (44, 500, 7),
        (45, 500, 9),
        (46, 123, 10),
        (47, 500, 11),
    ] {
        let what = format!("pairs {seed}, mix {mix}");
        let net = lnl_springs(seed, n, mix);
        the_avx2_pull_step_gives_the_scalar_bits(&net, &what);
        toggled_gives_the_scalar_bits(&net, &what);
        let pull = Engine::new_for(&net, Simd::Avx2).k.pull.unwrap();
        assert!(pull.curve_pairs() + pull.long_pairs() > 1, "{what}");
        assert!(pull.stores_forces(), "{what}");
    }
    // (pairs mixed in every row, which a step that does not store the forces refuses: taken
    // when they are stored, four pairs of many links each; refused when each link has a pair
    // of its own, whose chunks would be mostly padding)
    let mixed = |seed: u64, n: usize, pairs: usize| {
        let mut net = lnl_springs(seed, n, 1);
        for (i, link) in net.links.iter_mut().enumerate() {
            let slope = 0.01 * (1 + i % pairs) as f64;
            link.law = Interaction::Lnl {
                lk: Curve::new(&[(-1.0, -slope), (0.0, 0.0), (1.0, 2.0 * slope)]).unwrap(),
                lz: Curve::new(&[(-1.0, -1e-3 * slope), (1.0, 1e-3 * slope)]).unwrap(),
            };
        }
        net
    };
    for (seed, n) in [(51, 40), (52, 200), (53, 500)] {
        let what = format!("four pairs in every row {seed}");
        let net = mixed(seed, n, 4);
        the_avx2_pull_step_gives_the_scalar_bits(&net, &what);
        toggled_gives_the_scalar_bits(&net, &what);
        let pull = Engine::new_for(&net, Simd::Avx2).k.pull.unwrap();
        assert_eq!(pull.curve_pairs(), 4, "{what}");
        assert!(pull.stores_forces(), "{what}");
        let own = mixed(seed, n, usize::MAX);
        assert!(Engine::new_for(&own, Simd::Avx2).k.pull.is_none(), "{what}");
    }
    // (twelve pairs of three links each among REF links: their chunks would be mostly
    // padding, so the forces are not stored, and the rows read the table,
    // `avx2::CurveTable4`; the MAS of a pair are stored together, so few rows mix pairs)
    for seed in [54, 55] {
        let what = format!("twelve pairs of three links each {seed}");
        let mut net = ref_springs(seed, 500, 1, false);
        let few = (5..net.links.len()).step_by(37).take(36);
        for (j, i) in few.enumerate() {
            let slope = 0.01 * (1 + j / 3) as f64;
            net.links[i].law = Interaction::Lnl {
                lk: Curve::new(&[(-1.0, -slope), (0.0, 0.0), (1.0, 2.0 * slope)]).unwrap(),
                lz: Curve::new(&[(-1.0, -1e-3), (1.0, 1e-3)]).unwrap(),
            };
        }
        the_avx2_pull_step_gives_the_scalar_bits(&net, &what);
        let pull = Engine::new_for(&net, Simd::Avx2).k.pull.unwrap();
        assert_eq!(pull.curve_pairs(), 12, "{what}");
        assert!(!pull.stores_forces(), "{what}");
    }
    for (seed, n) in [(49, 40), (50, 500)] {
        let what = format!("pairs {seed} and a BUT");
        let net = but_lnl_springs(seed, n, true);
        the_avx2_pull_step_gives_the_scalar_bits(&net, &what);
        toggled_gives_the_scalar_bits(&net, &what);
    }
    // (long pairs alone, `lnl_springs`'s mixes 8 and 12)
    for mix in [8, 12] {
        let what = format!("long pairs alone, mix {mix}");
        let net = lnl_springs(48, 500, mix);
        the_avx2_pull_step_gives_the_scalar_bits(&net, &what);
        toggled_gives_the_scalar_bits(&net, &what);
        let pull = Engine::new_for(&net, Simd::Avx2).k.pull.unwrap();
        assert_eq!(pull.curve_pairs(), 0, "{what}");
    }
}

/// On an AVX-512 CPU, LNL networks store their links' forces before the rows, as the AVX2 step
/// does (`Pull::store_forces_avx512`), and give the scalar build's bits at every block, on one
/// thread and on two: one pair of curves (of 4 and 3 points, with a jump, drawn, finely drawn,
/// with a zero viscous curve, sticking springs), on every link or every third among REF links,
/// with BUTs among them or not; a pair of 40 points; several pairs, short and long, by row or
/// mixed in some rows, or four mixed in every row; long pairs alone. Twelve pairs of three links each, whose chunks would be
/// mostly padding, do not store them, and read the table.
#[cfg(target_arch = "x86_64")]
#[test]
fn the_avx512_pull_step_stores_the_lnl_forces() {
    let Some(cpu) = Avx512::detect() else {
        return;
    };
    let simd = Simd::Avx512(cpu);
    let stores = |net: &Network, what: &str| {
        let pull = Engine::new_for(net, simd).k.pull;
        assert!(pull.expect(what).stores_forces(), "{what}");
        the_pull_step_of_gives_the_scalar_bits(net, simd, what);
    };
    let [four, _, _, jump] = lnl_pairs();
    let [drawn, _, fine] = drawn_pairs();
    let zero = Interaction::Lnl {
        lk: Curve::new(&[(-0.01, -6e-4), (0.01, 5e-4)]).unwrap(),
        lz: Curve::zero(),
    };
    let pairs = [
        four,
        jump,
        drawn,
        fine,
        zero,
        sticking_pair(),
        sampled_pair(),
    ];
    for (p, pair) in pairs.iter().enumerate() {
        for (seed, n, inertia, every) in [(1, 16, 0, 1), (2, 43, 1, 2), (4, 500, 3, 2)] {
            // (the sticking springs' curve has a jump first: taken from `JUMPS_PULL_MIN` MAS)
            let n = if p == 5 { n.max(JUMPS_PULL_MIN) } else { n };
            let what = format!("pair {p}, network {seed}, every {every}");
            let net = lnl_ref_springs(seed + 10 * p as u64, n, inertia, pair, every);
            stores(&net, &what);
            let mut but = net.clone();
            for (i, link) in but.links.iter_mut().enumerate() {
                if !matches!(link.law, Interaction::Lnl { .. }) && i % 5 == 0 {
                    link.law = but_of(i);
                }
            }
            if but
                .links
                .iter()
                .any(|l| matches!(l.law, Interaction::But { .. }))
            {
                stores(&but, &format!("{what}, with BUTs"));
            }
        }
    }
    // (`lnl_springs`'s mixes 0 to 13: one pair, several by row and mixed in some rows, long
    // pairs among others and alone, sticking springs)
    for mix in 0..=13 {
        stores(
            &lnl_springs(70 + u64::from(mix), 500, mix),
            &format!("mix {mix}"),
        );
    }
    for (seed, n) in [(81, 40), (82, 500)] {
        stores(
            &but_lnl_springs(seed, n, true),
            &format!("pairs {seed} and a BUT"),
        );
    }
    let mut every_row = lnl_springs(83, 500, 1);
    for (i, link) in every_row.links.iter_mut().enumerate() {
        let slope = 0.01 * (1 + i % 4) as f64;
        link.law = Interaction::Lnl {
            lk: Curve::new(&[(-1.0, -slope), (0.0, 0.0), (1.0, 2.0 * slope)]).unwrap(),
            lz: Curve::new(&[(-1.0, -1e-3 * slope), (1.0, 1e-3 * slope)]).unwrap(),
        };
    }
    stores(&every_row, "four pairs in every row");
    let mut few = ref_springs(84, 500, 1, false);
    for (j, i) in (5..few.links.len()).step_by(37).take(36).enumerate() {
        let slope = 0.01 * (1 + j / 3) as f64;
        few.links[i].law = Interaction::Lnl {
            lk: Curve::new(&[(-1.0, -slope), (0.0, 0.0), (1.0, 2.0 * slope)]).unwrap(),
            lz: Curve::new(&[(-1.0, -1e-3), (1.0, 1e-3)]).unwrap(),
        };
    }
    let pull = Engine::new_for(&few, simd).k.pull.expect("a pull step");
    assert_eq!(pull.curve_pairs(), 12);
    assert!(!pull.stores_forces());
    the_pull_step_of_gives_the_scalar_bits(&few, simd, "twelve pairs of three links each");
}

/// Networks of springs and dampers, with BUTs or LNLs among them, take the pull step on an
/// AVX-512 CPU (not with curves that do not evaluate eight at a time or do not pad to one
/// point count), and it gives
/// the bits of the compact or gather step at every step: positions, outputs, and the
/// link forces `link_force` reads after each block, whether `process` and `process_observed`
/// take turns on one engine or not. The BUTs come into and out of contact, with the MAS and
/// the CEL at either end. A BUT or LNL network's rows give the same bits whether every row
/// computes the terms only some rows have (BUTs; springs and dampers) or only the rows that
/// have one.
#[test]
fn the_pull_step_gives_the_other_steps_bits() {
    let avx512 = Avx512::detect().is_some();
    // (a CPU with AVX2 alone takes the pull step too, for the networks of `two`)
    let pulls = Simd::detect() != Simd::None;
    // refused: a zero curve with curves that are not, a curve with a jump first in fewer
    // than `JUMPS_PULL_MIN` MAS; taken: two pairs of curves of other point counts, pairs of
    // curves mixed in every row, and a curve with a jump first in as many MAS
    let mut two = lnl_springs(1, 40, 0);
    two.links[5].law = Interaction::Lnl {
        lk: Curve::new(&[(-1.0, -0.01), (1.0, 0.01)]).unwrap(),
        lz: Curve::new(&[(-1.0, 0.0), (1.0, 0.0)]).unwrap(),
    };
    let mut zero = two.clone();
    zero.links[5].law = Interaction::Lnl {
        lk: Curve::new(&[(-1.0, -0.01), (1.0, 0.01)]).unwrap(),
        lz: Curve::zero(),
    };
    let mut every_row = lnl_springs(1, 200, 1);
    for (i, link) in every_row.links.iter_mut().enumerate() {
        let slope = [0.01, 0.02, 0.03, 0.04][i % 4];
        link.law = Interaction::Lnl {
            lk: Curve::new(&[(-1.0, -slope), (1.0, slope)]).unwrap(),
            lz: Curve::zero(),
        };
    }
    assert_eq!(
        Engine::new(&two).k.pull.map(|p| p.curve_pairs()),
        pulls.then_some(2)
    );
    let jump = |n| {
        springs(
            1,
            n,
            Some(Interaction::Lnl {
                lk: Curve::new(&[(0.0, -0.01), (0.0, 0.01), (1.0, 0.02)]).unwrap(),
                lz: Curve::new(&[]).unwrap(),
            }),
        )
    };
    let taken = Engine::new(&jump(JUMPS_PULL_MIN)).k.pull.is_some();
    assert_eq!(taken, pulls);
    for net in [zero, jump(JUMPS_PULL_MIN - 1)] {
        assert!(Engine::new(&net).k.pull.is_none());
    }
    // (the step stores the forces, and no row evaluates a pair: it takes `every_row`; built
    // not to store them, it refuses it)
    assert_eq!(Engine::new(&every_row).k.pull.is_some(), pulls);
    let k = Kernel::new_for(&every_row, Simd::detect());
    assert!(pull::Pull::unstored(&k).is_none());
    assert!(Engine::new(&springs(1, 8, None)).k.pull.is_none()); // (fewer than PULL_MIN MAS)
    let mut toggled = 0;
    let mut read_laws = Vec::new();
    // (kinds: 0 springs and dampers, 1 BUTs among them, 2 to 5 LNL networks of `mix` 0 to 3,
    // 6 one BUT among springs and dampers, 7 BUTs and LNLs among them, 8 an LNL network of
    // four pairs of curves and one BUT, 9 to 12 LNL networks of `mix` 4 to 7: curves
    // drawn point by point, 13 to 17 of `mix` 8 to 12: pairs of 40 points, with others, 18
    // of `mix` 13: sticking springs)
    for (seed, n, kind) in [
        (1, 16, 0),
        (2, 40, 0),
        (3, 123, 0),
        (4, 500, 0),
        (5, 16, 1),
        (6, 40, 1),
        (7, 123, 1),
        (8, 500, 1),
        (9, 16, 2),
        (10, 123, 2),
        (11, 500, 2),
        (12, 17, 3),
        (13, 123, 3),
        (14, 500, 3),
        (15, 40, 4),
        (16, 500, 4),
        (19, 40, 5),
        (20, 123, 5),
        (21, 500, 5),
        (17, 40, 6),
        (18, 500, 6),
        (22, 16, 7),
        (23, 123, 7),
        (24, 500, 7),
        (25, 40, 8),
        (26, 500, 8),
        (27, 40, 9),
        (28, 500, 9),
        (29, 123, 10),
        (30, 500, 10),
        (31, 40, 11),
        (32, 500, 11),
        (33, 123, 12),
        (34, 500, 12),
        (35, 40, 13),
        (36, 500, 13),
        (37, 40, 14),
        (38, 500, 14),
        (39, 123, 15),
        (40, 500, 15),
        (41, 123, 16),
        (42, 500, 16),
        (43, 40, 17),
        (44, 500, 17),
        (46, 500, 18),
    ] {
        let mut net = match kind {
            0 => springs(seed, n, None),
            1 | 6 => but_springs(seed, n, kind == 1),
            7 | 8 => but_lnl_springs(seed, n, kind == 8),
            9..=18 => lnl_springs(seed, n, kind - 5),
            _ => lnl_springs(seed, n, kind - 2),
        };
        // (the outputs read the last link of each law the network has and the links to
        // the CEL, alone and summed: `Kernel::record_with`)
        let mut read: Vec<LinkId> = Vec::new();
        let mut laws = Vec::new();
        let cel = MatId(n as u32);
        for (i, link) in net.links.iter().enumerate().rev() {
            let law = std::mem::discriminant(&link.law);
            if !laws.contains(&law) || link.a == cel || link.b == cel {
                read.push(LinkId(i as u32));
            }
            if !laws.contains(&law) {
                laws.push(law);
            }
        }
        assert!(
            read.len() > laws.len(),
            "network {seed}: no link to the CEL"
        );
        for law in laws {
            if !read_laws.contains(&law) {
                read_laws.push(law);
            }
        }
        for &l in &read {
            net.add_force_output(l);
        }
        let read = read.into_iter().map(|l| (0.5, Probe::Force(l))).collect();
        net.add_sum_output(read);
        // (the links whose force is zero some of the time: the BUTs, and the sticking springs
        // of zero viscous curve)
        let but_links: Vec<LinkId> = (0..net.links.len() as u32)
            .map(LinkId)
            .filter(|l| match &net.links[l.index()].law {
                Interaction::But { .. } => true,
                Interaction::Lnl { lz, .. } => kind == 18 && lz.is_empty(),
                _ => false,
            })
            .collect();
        // (whether each of those forces has been zero, and non-zero, after a block)
        let mut seen = vec![[false; 2]; but_links.len()];
        let mut pulled = Engine::new(&net);
        // (a CPU with AVX2 alone takes some of them too:
        // `the_avx2_pull_step_takes_but_and_lnl_networks`)
        assert!(pulled.k.pull.is_some() || !avx512, "network {seed}");
        let mut compact = pulled.clone();
        let mut turns = pulled.clone();
        // (the rows computing the terms only some rows have the other way, every row or
        // only those that have one: a BUT network's BUTs, an LNL network's springs)
        let mut other_way = pulled.clone();
        // (which rows evaluate one pair, which several: where the step stores the LNL
        // forces, none, so those of the step built not to store them)
        let rows_of_pairs = |pull: &pull::Pull| {
            if pull.stores_forces() {
                assert_eq!(pull.rows_of_pairs(), (0, 0), "network {seed}");
                let unstored = pull::Pull::unstored(&pulled.k);
                unstored.expect("a pull step").rows_of_pairs()
            } else {
                pull.rows_of_pairs()
            }
        };
        if let Some(pull) = other_way.k.pull.as_mut().filter(|_| kind >= 1) {
            // (every link LNL, or every link but the FROs to the SOL, of one `Z`)
            assert_eq!(
                pull.shared_params(),
                (3..=5).contains(&kind) || kind >= 9,
                "network {seed}"
            );
            // (four pairs of curves, in rows of one pair and rows of several)
            if kind == 5 || kind == 8 {
                assert_eq!(pull.curve_pairs(), 4, "network {seed}");
                let (one, several) = rows_of_pairs(pull);
                assert!(one > 0 && (n < 500 || several > 0), "network {seed}");
            }
            // (pairs of curves of more points, evaluated as they are: one alone, with one
            // other pair by region, with three in rows of one pair and rows of several; two
            // and another by region; two alone)
            let longs = [1, 1, 1, 2, 2].get(usize::from(kind).wrapping_sub(13));
            assert_eq!(pull.long_pairs(), *longs.unwrap_or(&0), "network {seed}");
            if (13..=17).contains(&kind) {
                let pairs = [0, 1, 3, 1, 0][usize::from(kind - 13)];
                assert_eq!(pull.curve_pairs(), pairs, "network {seed}");
            }
            if kind == 15 && n >= 500 {
                let (one, several) = rows_of_pairs(pull);
                assert!(one > 0 && several > 0, "network {seed}");
            }
            // (curves drawn point by point, padded to 8 or 16 points: one pair, or two)
            if (9..=12).contains(&kind) {
                let k = usize::from(kind - 9);
                assert_eq!(pull.curve_pairs(), k % 2 + 1, "network {seed}");
                let points = [(8, 3), (8, 8), (16, 2), (16, 16)][k];
                assert_eq!(pull.curve_points(), Some(points), "network {seed}");
            }
            // (one pair of a sticking spring, with its jumps, and the zero curve)
            if kind == 18 {
                assert_eq!(pull.curve_pairs(), 1, "network {seed}");
                assert_eq!(pull.curve_points(), Some((3, 0)), "network {seed}");
            }
            // (rows with BUT and LNL lanes both)
            if kind == 7 || kind == 8 {
                assert!(pull.rows_of_buts_and_curves() > 0, "network {seed}");
            }
            // (no row has a spring; one row in many has the BUT)
            if kind == 3 || (kind == 6 && n >= 500) {
                assert!(!pull.has_full_rows(), "network {seed}");
            }
            pull.toggle_full_rows();
        }
        let ch = pulled.channels();
        let mut moved = false;
        for (i, block) in [1, 7, 300, 64, 1, 1024].into_iter().enumerate() {
            let mut a = vec![0.0; block * ch];
            let mut b = vec![0.0; block * ch];
            let mut c = vec![0.0; block * ch];
            let mut d = vec![0.0; block * ch];
            assert!(pulled.process(block, &mut a).is_ok());
            assert!(other_way.process(block, &mut d).is_ok());
            assert!(compact
                .process_observed(block, &mut b, &mut unobserved)
                .is_ok());
            let turn = if i % 2 == 0 {
                turns.process(block, &mut c)
            } else {
                turns.process_observed(block, &mut c, &mut unobserved)
            };
            assert!(turn.is_ok());
            let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
            assert_eq!(bits(&a), bits(&b), "network {seed}, block {i}");
            assert_eq!(bits(&d), bits(&b), "network {seed}, block {i}, other way");
            assert_eq!(
                bits(&c),
                bits(&b),
                "network {seed}, block {i}, taking turns"
            );
            for e in [&pulled, &turns, &other_way] {
                for m in (0..net.materials.len() as u32).map(MatId) {
                    assert_eq!(e.position(m).to_bits(), compact.position(m).to_bits());
                    assert_eq!(
                        e.previous_position(m).to_bits(),
                        compact.previous_position(m).to_bits()
                    );
                }
                for l in (0..net.links.len() as u32).map(LinkId) {
                    assert_eq!(e.link_force(l).to_bits(), compact.link_force(l).to_bits());
                }
            }
            for (s, &l) in seen.iter_mut().zip(&but_links) {
                s[usize::from(compact.link_force(l) != 0.0)] = true;
            }
            moved |= a.iter().any(|&v| v != a[0]);
        }
        assert!(moved);
        let caught = seen.iter().filter(|s| s[0] && s[1]).count();
        assert!(
            kind != 18 || caught > 0,
            "network {seed}: no spring caught and let go"
        );
        toggled += caught;
    }
    assert!(toggled >= 10, "{toggled} BUTs came into and out of contact");
    assert_eq!(read_laws.len(), 5, "outputs read links of every law");
}

/// [`springs`] with LNL links of one pair of curves, neither odd, the viscous one not zero
/// at zero: `mix` 0, every fourth link (MAS to MAS, some to the CEL), a MAS's link to the
/// SOL and the ENX's link; 1, every link; 2, every link but the FROs that tie each MAS to
/// the SOL (all of one `Z`; a row has one or none); 3, as 2 with four pairs of curves of
/// other point counts (padded to one), each third of the links of its own pair but every
/// seventh link, of the fourth; 4, as 2 with one pair of curves drawn point by point (7 and
/// 3 points, padded to 8 and 4); 5, as 4 with the last third of the links of a second pair of
/// 5 and 6 points (the table's pairs padded to 8 and 8); 6, as 2 with a finely drawn pair
/// (11 and 2 points, padded to 16 and 2); 7, as 6 with the last third of the links of 5's
/// second pair (padded to 16 and 16); 8, as 2 with a pair of 40 and 3 points
/// ([`sampled_pair`]); 9, as 8 with the last third of the links of 3's second pair; 10, as 3
/// with 8's pair first; 11, as 9 with the middle third of a second pair of more than 16
/// points ([`resampled_pair`]); 12, as 8 with the last two thirds of that second pair; 13, as
/// 2 with the sticking device's pair ([`sticking_pair`]).
fn lnl_springs(seed: u64, n: usize, mix: u8) -> Network {
    let mut net = springs(seed, n, None);
    let [mut lnl, mut others @ ..] = lnl_pairs();
    let [first, second, fine] = drawn_pairs();
    // (the finely drawn stiffness curve has an exact grid: its segment is guessed with
    // AVX-512, `WideCurve::eval`)
    if let Interaction::Lnl { lk, .. } = &fine {
        assert!(ExactCurve::<16>::fitted(lk).unwrap().guesses());
    }
    match mix {
        4 | 5 => [lnl, others[0]] = [first, second],
        6 | 7 => [lnl, others[0]] = [fine, second],
        8..=12 => lnl = sampled_pair(),
        13 => lnl = sticking_pair(),
        _ => {}
    }
    let count = net.links.len();
    for (i, link) in net.links.iter_mut().enumerate() {
        let grounding = link.law == Interaction::Fro { z: 1e-4 };
        if match mix {
            0 => i % 4 == 1 || i == count - 2 || i == count - 1,
            1 => true,
            _ => !grounding,
        } {
            link.law = match (mix, i % 7, i * 3 / count) {
                (3 | 10, 3, _) => others[2].clone(),
                (3 | 10, _, 1 | 2) => others[i * 3 / count - 1].clone(),
                (5 | 7 | 9 | 11, _, 2) => others[0].clone(),
                (11, _, 1) | (12, _, 1 | 2) => resampled_pair(),
                _ => lnl.clone(),
            };
        }
    }
    net
}

/// [`springs`] with BUTs: every fourth link (MAS to MAS, some to the CEL, thresholds of both
/// signs and zero, one in three viscous only), a MAS's link to the SOL and the ENX's link;
/// or (not `every`) one BUT, link 1, between two MAS, as a hammer's.
fn but_springs(seed: u64, n: usize, every: bool) -> Network {
    let mut net = springs(seed, n, None);
    let count = net.links.len();
    for (i, link) in net.links.iter_mut().enumerate() {
        let but = if every {
            i % 4 == 1 || i == count - 2 || i == count - 1
        } else {
            i == 1
        };
        if but {
            link.law = but_of(i);
        }
    }
    net
}

/// The BUT of [`but_springs`]'s link `i`: thresholds of both signs and zero, one in three
/// viscous only.
fn but_of(i: usize) -> Interaction {
    let s = [0.0, 0.004, -0.004, 0.01, -0.01][i % 5];
    let k = if i.is_multiple_of(3) { 0.0 } else { 0.04 };
    Interaction::But { k, z: 1e-3, s }
}

/// [`lnl_springs`] with BUTs: of `mix` 0 (every fourth link LNL), every fourth link but
/// those, from link 3 (MAS to MAS, some to the CEL), so that rows have BUT, LNL, spring and
/// damper lanes; or (`hammer`) of `mix` 3 (four pairs of curves), link 1, between two MAS.
fn but_lnl_springs(seed: u64, n: usize, hammer: bool) -> Network {
    let mut net = lnl_springs(seed, n, if hammer { 3 } else { 0 });
    for (i, link) in net.links.iter_mut().enumerate() {
        let lnl = matches!(link.law, Interaction::Lnl { .. });
        if (hammer && i == 1) || (!hammer && !lnl && i % 4 == 3) {
            link.law = but_of(i);
        }
    }
    net
}

/// A network that takes the pull step is stored with each MAS near its neighbours
/// ([`Mobiles::Local`]): a chain of 3,000 MAS declared in a shuffled order (with a CEL, an
/// ENX and two SOLs on it) has its links' ends under three slots apart on average, where the
/// degree order of the other steps leaves them hundreds apart; each kind keeps its slots, the
/// SOLs their declaration order, and the MAS of a window are sorted by degree.
#[test]
fn the_pull_step_stores_each_mas_near_its_neighbours() {
    let n = 3000;
    let mut state = 0x2545_f491_4f6c_dd1du64;
    let mut draw = |below: usize| {
        state = state
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        ((state >> 33) % below as u64) as usize
    };
    // place `p` of the chain is declared `at[p]`-th
    let mut at: Vec<usize> = (0..n).collect();
    for i in (1..n).rev() {
        at.swap(i, draw(i + 1));
    }
    let mut net = Network::new();
    let grounds = [0.0, 1.0].map(|x0| net.add_material(Material::Sol { x0 }));
    let mut chain = vec![MatId(0); n];
    let mut by_decl: Vec<usize> = (0..n).collect();
    by_decl.sort_by_key(|&p| at[p]);
    for &p in &by_decl {
        chain[p] = net.add_material(Material::Mas {
            m: 1.0,
            x0: 0.0,
            v0: if p == n / 3 { 0.01 } else { 0.0 },
        });
    }
    let (cel, hand) = cel_and_hand(&mut net);
    let spring = Interaction::Ref { k: 0.1, z: 1e-3 };
    for &p in &by_decl {
        if p + 1 < n {
            net.add_link(spring.clone(), chain[p], chain[p + 1]);
        }
    }
    net.add_link(spring.clone(), grounds[1], chain[0]);
    net.add_link(spring.clone(), chain[n - 1], grounds[0]);
    net.add_link(spring.clone(), cel, chain[n / 2]);
    net.add_link(spring, hand, chain[n / 4]);
    net.add_position_output(chain[n / 5]);

    let apart = |k: &Kernel| {
        let d: Vec<usize> = (k.la.iter().zip(&k.lb))
            .filter(|&(&a, &b)| (a as usize) < k.n_mas && (b as usize) < k.n_mas)
            .map(|(&a, &b)| a.abs_diff(b) as usize)
            .collect();
        assert_eq!(d.len(), n - 1);
        (
            d.iter().sum::<usize>() as f64 / d.len() as f64,
            d.into_iter().max(),
        )
    };
    // (as `Kernel::new_for` builds it: links in declaration order)
    let local = Kernel::build_with(&net, true, Joins::Off, Mobiles::Local);
    let by_degree = Kernel::build_with(&net, false, Joins::Rows, Mobiles::ByDegree);
    let (mean, max) = apart(&local);
    assert!(mean < 3.0 && max <= Some(WINDOW), "{mean} {max:?}");
    assert!(apart(&by_degree).0 > 500.0);
    for k in [&local, &by_degree] {
        assert_eq!((k.n_mas, k.n_mc, k.n_mce, k.nm), (n, n + 1, n + 2, n + 4));
        // the CEL and the ENX after the MAS, the SOLs last, in declaration order
        let slot = |m: MatId| k.slot[m.index()] as usize;
        assert_eq!(
            [cel, hand, grounds[0], grounds[1]].map(slot),
            [n, n + 1, n + 2, n + 3]
        );
    }
    // within a window, by degree: the MAS tied to the CEL and to the ENX have one link more
    let deg = |k: &Kernel, s: usize| k.eoff[s + 1] - k.eoff[s];
    for w in (0..n).step_by(WINDOW) {
        let slots = w..(w + WINDOW).min(n);
        assert!(slots
            .clone()
            .zip(slots.skip(1))
            .all(|(a, b)| deg(&local, a) <= deg(&local, b)));
    }
    let e = Engine::new(&net);
    assert_eq!(e.k.pull.is_some(), Simd::detect() != Simd::None);
    if e.k.pull.is_some() {
        let slots = |k: &Kernel| chain.iter().map(|m| k.slot[m.index()]).collect::<Vec<_>>();
        assert_eq!(slots(&e.k), slots(&local));
    }
}

/// A network whose links' kinds are mixed ([`term_kinds`]) is stored with its MAS sorted
/// by the kinds of their terms within windows of [`WIDE_WINDOW`]: in a random network of
/// 3,000 MAS whose links to MAS of odd index are BUT, the others LNL (or LNL of a second
/// pair of curves), the MAS are in one window, sorted by degree then kinds (with two pairs,
/// first by whether their LNL terms have the first pair, the second, or both), and with AVX-512
/// the pull step's rows of BUT and LNL lanes (of two pairs) are under a quarter of those of
/// the MAS ordered by degree alone. A network of one kind is not mixed.
#[test]
fn the_pull_step_stores_mas_of_one_kind_of_terms_together() {
    let n = 3000;
    let lnl = |steep: f64| Interaction::Lnl {
        lk: Curve::new(&[(-0.01, -8e-4 * steep), (0.0, 0.0), (0.02, 3e-3 * steep)]).unwrap(),
        lz: Curve::new(&[(-0.002, -4e-6), (0.003, 1e-5)]).unwrap(),
    };
    assert!(!term_kinds(&springs(3, n, Some(lnl(1.0)))).mixed);
    assert!(!term_kinds(&ref_springs(3, n, 0, false)).mixed);
    for pairs in [false, true] {
        let mut net = springs(5, n, None);
        for link in &mut net.links {
            let odd = link.b.index() < n && link.b.index() % 2 == 1;
            if link.a.index() < n && link.b.index() < n {
                link.law = match (odd, pairs) {
                    (true, false) => Interaction::But {
                        k: 0.04,
                        z: 1e-3,
                        s: 0.0,
                    },
                    (true, true) => lnl(1.1),
                    (false, _) => lnl(1.0),
                };
            }
        }
        let tk = term_kinds(&net);
        assert!(tk.mixed);
        let local = Kernel::build_with(&net, true, Joins::Off, Mobiles::Local);
        let by_degree = Kernel::build_with(&net, true, Joins::Off, Mobiles::ByDegree);
        // (one window: every MAS by the pair of its LNL terms when there are two pairs, by
        // degree, then by its terms' kinds)
        assert!(n <= WIDE_WINDOW);
        let mut degree = vec![0; net.materials.len()];
        for link in &net.links {
            degree[link.a.index()] += 1;
            degree[link.b.index()] += 1;
        }
        let mut by_slot = vec![(0, 0, 0); n];
        for (i, m) in net.materials.iter().enumerate() {
            if matches!(m, Material::Mas { .. }) {
                by_slot[local.slot[i] as usize] = (tk.pair(i), degree[i], tk.kinds[i]);
            }
        }
        assert!(by_slot.windows(2).all(|w| w[0] <= w[1]));
        assert!(by_slot
            .windows(2)
            .any(|w| w[0].0 == w[1].0 && w[0].1 == w[1].1 && w[0].2 < w[1].2));
        // (with two pairs: MAS of the first pair only, of the second only, and of both)
        let pairs_of = |p: u8| by_slot.iter().filter(|b| b.0 == p).count();
        if pairs {
            assert!(pairs_of(2) > 50 && pairs_of(3) > 50 && pairs_of(16) > n / 2);
        } else {
            assert_eq!(pairs_of(0), n);
        }
        let Simd::Avx512(cpu) = Simd::detect() else {
            continue;
        };
        let mixed_rows = |mut k: Kernel| {
            k.simd = Simd::Avx512(cpu);
            // (built not to store the LNL forces, so that its rows evaluate their pairs)
            let p = pull::Pull::unstored(&k).expect("a pull step");
            if pairs {
                p.rows_of_pairs().1
            } else {
                p.rows_of_buts_and_curves()
            }
        };
        let (sorted, unsorted) = (mixed_rows(local), mixed_rows(by_degree));
        assert!(
            unsorted > 150 && 4 * sorted < unsorted,
            "{sorted} {unsorted}"
        );
    }
}

/// The test networks' four pairs of LNL curves, of 2 to 4 points, neither curve odd, the
/// viscous ones not zero at zero ([`lnl_springs`], [`lnl_halves`]).
fn lnl_pairs() -> [Interaction; 4] {
    let pair = |k: &[(f64, f64)], z: &[(f64, f64)]| Interaction::Lnl {
        lk: Curve::new(k).unwrap(),
        lz: Curve::new(z).unwrap(),
    };
    [
        pair(
            &[(-0.01, -8e-4), (0.0, 0.0), (0.004, 1e-4), (0.02, 3e-3)],
            &[(-0.002, -4e-6), (0.001, 1e-6), (0.003, 0.0)],
        ),
        pair(
            &[(-0.01, -5e-4), (0.0, 1e-6), (0.01, 6e-4)],
            &[(-0.002, -3e-6), (0.002, 2e-6)],
        ),
        pair(
            &[(-0.02, -1e-3), (0.03, 2e-3)],
            &[(-0.001, -2e-6), (0.0, 1e-7), (0.004, 5e-6)],
        ),
        pair(
            &[(-0.01, -6e-4), (0.0, -1e-5), (0.0, 1e-5), (0.01, 7e-4)],
            &[(-0.003, -1e-6), (0.003, 1e-6)],
        ),
    ]
}

/// The simple sticking device's LNL (FORMALISM.md): a spring of stiffness 0.05 that exists
/// only while the elongation is within ±0.004 (4 points, a jump at the first and at the
/// last), and the zero viscous curve.
fn sticking_pair() -> Interaction {
    let (s, k) = (0.004, 0.05);
    Interaction::Lnl {
        lk: Curve::new(&[(-s, 0.0), (-s, -k * s), (s, k * s), (s, 0.0)]).unwrap(),
        lz: Curve::zero(),
    }
}

/// A pair of LNL curves of more points than an [`ExactPair`] holds: a spring sampled from a
/// formula (40 points, a jump among them) and a viscous curve of 3 points.
fn sampled_pair() -> Interaction {
    let mut k: Vec<(f64, f64)> = (0..40)
        .map(|i| {
            let x = -0.024 + f64::from(i) * 0.048 / 39.0;
            (x, 0.05 * x + 30.0 * x * x * x)
        })
        .collect();
    k[25].0 = k[24].0;
    Interaction::Lnl {
        lk: Curve::new(&k).unwrap(),
        lz: Curve::new(&[(-0.002, -3e-6), (0.0, 1e-7), (0.003, 4e-6)]).unwrap(),
    }
}

/// A second pair of LNL curves of more points than an [`ExactPair`] holds: [`sampled_pair`]'s
/// spring, 1.2 times as stiff, sampled at 24 points (no jump), and a viscous curve sampled
/// at 20.
fn resampled_pair() -> Interaction {
    let sampled = |n: u32, l: f64, f: &dyn Fn(f64) -> f64| {
        let points: Vec<(f64, f64)> = (0..n)
            .map(|i| {
                let x = -l + f64::from(i) * 2.0 * l / f64::from(n - 1);
                (x, f(x))
            })
            .collect();
        Curve::new(&points).unwrap()
    };
    Interaction::Lnl {
        lk: sampled(24, 0.024, &|x| 1.2 * (0.05 * x + 30.0 * x * x * x)),
        lz: sampled(20, 0.004, &|v| 1e-3 * v + 40.0 * v * v * v),
    }
}

/// Three pairs of LNL curves drawn point by point, as a user draws a hardening spring: 7 and
/// 3 points (the engine's curves of 8 and 3), 5 (with a jump) and 6 points (8 and 8), and,
/// drawn finely, 11 and 2 points (16 and 2).
fn drawn_pairs() -> [Interaction; 3] {
    let pair = |k: &[(f64, f64)], z: &[(f64, f64)]| Interaction::Lnl {
        lk: Curve::new(k).unwrap(),
        lz: Curve::new(z).unwrap(),
    };
    [
        pair(
            &[
                (-0.02, -2e-3),
                (-0.01, -6e-4),
                (-0.004, -1.5e-4),
                (0.0, 1e-6),
                (0.004, 1.2e-4),
                (0.01, 5e-4),
                (0.02, 1.6e-3),
            ],
            &[(-0.002, -3e-6), (0.0, 1e-7), (0.003, 4e-6)],
        ),
        pair(
            &[
                (-0.015, -1e-3),
                (-0.005, -2e-4),
                (0.0, 0.0),
                (0.0, 2e-5),
                (0.012, 9e-4),
            ],
            &[
                (-0.003, -5e-6),
                (-0.001, -1e-6),
                (0.0, 1e-7),
                (0.001, 2e-6),
                (0.002, 3e-6),
                (0.004, 4e-6),
            ],
        ),
        pair(
            &[
                (-0.024, -2.2e-3),
                (-0.016, -1.1e-3),
                (-0.01, -5.5e-4),
                (-0.006, -2.6e-4),
                (-0.003, -1.1e-4),
                (0.0, 2e-6),
                (0.002, 7e-5),
                (0.005, 1.9e-4),
                (0.009, 4e-4),
                (0.015, 9e-4),
                (0.022, 1.7e-3),
            ],
            &[(-0.002, -2.5e-6), (0.003, 3.5e-6)],
        ),
    ]
}

/// [`springs`] in two halves, each of LNL links of a pair of its own (the first half's of 40
/// points when `long`, [`sampled_pair`]): every link between MAS of the two halves is moved
/// into the half of its end 1, but one in 40, which has a third pair (so that some groups
/// have LNL lanes of several pairs). The FROs that tie each MAS to the SOL, and the CEL's
/// links, stay.
fn lnl_halves(seed: u64, n: usize, long: bool) -> Network {
    let mut net = springs(seed, n, None);
    let mut pairs = lnl_pairs();
    if long {
        pairs[0] = sampled_pair();
    }
    let half = |m: MatId| usize::from(m.index() >= n / 2);
    for (i, link) in net.links.iter_mut().enumerate() {
        let (a, b) = (link.a.index(), link.b.index());
        if a >= n || b >= n {
            continue;
        }
        link.law = if half(link.a) == half(link.b) {
            pairs[half(link.a)].clone()
        } else if i % 40 == 0 {
            pairs[2].clone()
        } else {
            // (a MAS of end 1's half, `lo..hi`, other than end 1)
            let (lo, hi) = if half(link.a) == 0 {
                (0, n / 2)
            } else {
                (n / 2, n)
            };
            let mut to = lo + b % (hi - lo);
            if to == a {
                to = lo + (to - lo + 1) % (hi - lo);
            }
            link.b = MatId(to as u32);
            pairs[half(link.a)].clone()
        };
    }
    net
}

/// With several pairs of LNL curves, the pull step sums each long run of groups whose LNL
/// lanes have one pair as in a network of that pair, its curves in registers, and the other
/// groups with each row's pairs from the table (`Pull::runs`): in [`lnl_halves`] most groups
/// are in runs of one pair and some are not, and the outputs, positions and link forces
/// have the bits of the same engine reading every pair from the table, of the compact step,
/// and of three threads, at every block. So too when one half's pair has 40 points (its runs
/// and its parts of rows evaluate it as it is, `Pull::longs`), on AVX-512 and on AVX2
/// (`avx2::CurveTable4`), each step built not to store the LNL forces; the step each takes
/// otherwise stores them, builds no runs, and gives the same bits.
#[test]
fn the_pull_step_sums_runs_of_one_pair_with_the_curves_in_registers() {
    for (simd, (seed, n, long)) in simd_widths()
        .into_iter()
        .flat_map(|a| [(31, 500, false), (32, 1203, false), (33, 700, true)].map(|t| (a, t)))
    {
        let net = lnl_halves(seed, n, long);
        // (the engine as built, which stores the forces, and one that does not)
        let mut stored = Engine::new_for(&net, simd);
        let pull = stored.k.pull.as_ref().expect("a pull step");
        assert!(pull.stores_forces(), "network {seed}");
        assert_eq!(pull.groups_of_one_pair(), (0, 0), "network {seed}");
        let mut k = Kernel::new_for(&net, simd);
        k.pull = pull::Pull::unstored(&k).map(Box::new);
        let mut pulled = Engine::with_kernel(k);
        let pull = pulled.k.pull.as_ref().expect("a pull step");
        let (one, table) = pull.groups_of_one_pair();
        assert_eq!(one + table, n.div_ceil(8), "network {seed}");
        assert!(
            one > 2 * table && table > 0,
            "network {seed}: {one} {table}"
        );
        assert_eq!(pull.long_pairs(), usize::from(long), "network {seed}");
        let of_long = pull.groups_of_long_pairs();
        assert!(
            if long {
                4 * of_long > one
            } else {
                of_long == 0
            },
            "network {seed}: {of_long} of {one} groups in runs of the long pair"
        );
        let mut from_table = pulled.clone();
        from_table
            .k
            .pull
            .as_mut()
            .unwrap()
            .read_every_pair_from_the_table();
        assert_eq!(
            from_table.k.pull.as_ref().unwrap().groups_of_one_pair(),
            (0, one + table)
        );
        let mut compact = pulled.clone();
        let mut threads = pulled.clone();
        threads.set_parallel_threshold(0);
        threads.set_threads(3);
        assert!(threads.is_parallel());
        let ch = pulled.channels();
        let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
        let mut moved = false;
        for (i, block) in [1, 7, 300, 64, 1024].into_iter().enumerate() {
            let mut out = [(); 4].map(|()| vec![0.0; block * ch]);
            let [a, b, c, d] = &mut out;
            assert!(pulled.process(block, a).is_ok());
            assert!(from_table.process(block, b).is_ok());
            assert!(compact.process_observed(block, c, &mut unobserved).is_ok());
            assert!(threads.process(block, d).is_ok());
            let mut e = vec![0.0; block * ch];
            assert!(stored.process(block, &mut e).is_ok());
            for (j, o) in [&b[..], &c[..], &d[..], &e[..]].into_iter().enumerate() {
                assert_eq!(bits(a), bits(o), "network {seed}, block {i}, engine {j}");
            }
            for e in [&from_table, &compact, &threads, &stored] {
                for m in (0..net.materials.len() as u32).map(MatId) {
                    assert_eq!(e.position(m).to_bits(), pulled.position(m).to_bits());
                }
                for l in (0..net.links.len() as u32).map(LinkId) {
                    assert_eq!(e.link_force(l).to_bits(), pulled.link_force(l).to_bits());
                }
            }
            moved |= a.iter().any(|&v| v != a[0]);
        }
        assert!(moved, "network {seed}");
    }
}

/// The store pass, AVX-512 and AVX2, reads its chunks' pairs unchecked (`Pull::stored_within`):
/// it steps from as many pairs as the network has MAS and SOL, and refuses fewer, whose reads
/// the offsets would overrun.
#[test]
fn the_store_pass_refuses_fewer_pairs_than_its_offsets_need() {
    for simd in simd_widths() {
        let net = lnl_halves(31, 500, false);
        let engine = Engine::new_for(&net, simd);
        let pull = engine.k.pull.as_ref().expect("a pull step");
        assert!(pull.stores_forces());
        let (nm, chunks) = (engine.k.nm, pull.stored_share(0, 1));
        let mut forces = vec![f64::NAN; LANES * chunks.len()];
        let pairs = vec![[0.5, 0.0]; nm];
        pull.store_forces(&pairs, chunks.clone(), &mut forces);
        // (every chunk's eight forces written: the buffer was NaN)
        assert!(forces.iter().all(|f| f.is_finite()), "{forces:?}");
        let short = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
            pull.store_forces(&pairs[..nm - 1], chunks, &mut forces);
        }));
        assert!(short.is_err());
    }
}

/// The AVX2 store pass gives each LNL link the reference's force, `LK(d) + LZ(v)` of
/// `Curve::eval`, bit for bit, for pairs of every shape it evaluates in alternate lanes of
/// one curve (`avx2::store_alternating`: equal counts, and counts of 2 to 4, padded) and of
/// some it evaluates as two (`avx2::Pair4`): curves with jumps inside, at the first point
/// (the sticking spring's) and none; abscissas at the curves' points, beyond their ends,
/// zeros of both signs and between; every link of each chunk, padding lanes included. So does
/// the AVX-512 store pass, which evaluates every shape as two curves.
#[test]
fn the_store_pass_gives_every_shape_the_reference_force() {
    for simd in simd_widths() {
        // (a curve of `n` points over ±w: a hardening spring, with a jump inside from 5
        // points, and the sticking spring's 4 points, jumps at the first and the last)
        let curve = |n: usize, w: f64| -> Curve {
            if n == 0 {
                return Curve::zero();
            }
            if n == 1 {
                let s = w / 2.0;
                return Curve::new(&[(-s, 0.0), (-s, -0.05 * s), (s, 0.05 * s), (s, 0.0)]).unwrap();
            }
            let mut points: Vec<(f64, f64)> = (0..n)
                .map(|i| {
                    let x = -w + 2.0 * w * i as f64 / (n - 1) as f64;
                    (x, 0.05 * x + 3e3 * x * x * x + 1e-7 * (i % 2) as f64)
                })
                .collect();
            if n >= 5 {
                points[2].0 = points[1].0;
            }
            Curve::new(&points).unwrap()
        };
        // (point counts, 1 for the sticking spring's 4; and the shapes they take)
        let shapes = [
            ((2, 2), (2, 2)),
            ((2, 3), (2, 3)),
            ((2, 4), (2, 4)),
            ((3, 2), (3, 2)),
            ((3, 3), (3, 3)),
            ((3, 4), (3, 4)),
            ((4, 2), (4, 2)),
            ((4, 3), (4, 3)),
            ((4, 4), (4, 4)),
            ((1, 3), (3, 3)),
            ((1, 4), (3, 4)),
            ((6, 7), (8, 8)),
            ((13, 9), (16, 16)),
            ((0, 0), (0, 0)),
            ((7, 3), (8, 3)),
            ((11, 2), (16, 2)),
            ((4, 0), (4, 0)),
            ((13, 3), (16, 3)),
            ((3, 7), (3, 8)),
            ((5, 0), (8, 0)),
            ((9, 4), (16, 4)),
        ];
        for (s, ((a, b), shape)) in shapes.into_iter().enumerate() {
            let (lk, lz) = (curve(a, 0.01), curve(b, 0.002));
            let pair = Interaction::Lnl {
                lk: lk.clone(),
                lz: lz.clone(),
            };
            let what = format!("points {a} and {b}");
            // (300 MAS: a sticking spring takes the pull step from 256, `JUMPS_PULL_MIN`)
            let net = lnl_ref_springs(70 + s as u64, 300, 0, &pair, 1);
            let engine = Engine::new_for(&net, simd);
            let pull = (engine.k.pull.as_ref()).unwrap_or_else(|| panic!("{what}: no pull"));
            assert!(pull.stores_forces(), "{what}");
            let stored = pull.stored_chunks();
            assert_eq!(pull.pair_counts(), [shape], "{what}");
            // (each pair's `x` and `v` drawn from the curves' abscissas, beyond them, zeros
            // and between, so that `d` and `v` hit each curve's points exactly: the other
            // end's are often a zero)
            let mut known = vec![0.0, -0.0, 0.03, -0.03, 1e-3, 7e-3];
            known.extend(lk.points().chain(lz.points()).map(|(x, _)| x));
            let mut r = 0x9e37_79b9_7f4a_7c15_u64 ^ s as u64;
            let mut draw = || {
                r = r.wrapping_mul(6_364_136_223_846_793_005).wrapping_add(1);
                let u = (r >> 11) as f64 / (1u64 << 53) as f64;
                if r >> 62 == 0 {
                    0.024 * (2.0 * u - 1.0)
                } else {
                    known[(r >> 40) as usize % known.len()]
                }
            };
            let pairs: Vec<[f64; 2]> = (0..engine.k.nm).map(|_| [draw(), draw()]).collect();
            let chunks = pull.stored_share(0, 1);
            let mut forces = vec![f64::NAN; LANES * chunks.len()];
            pull.store_forces(&pairs, chunks, &mut forces);
            for (c, [ea, eb]) in stored.iter().enumerate() {
                for l in 0..LANES {
                    let (p, q) = (pairs[ea[l] as usize / 16], pairs[eb[l] as usize / 16]);
                    let want = lk.eval(p[0] - q[0]) + lz.eval(p[1] - q[1]);
                    let got = forces[LANES * c + l];
                    assert_eq!(got.to_bits(), want.to_bits(), "{what}: chunk {c}, lane {l}");
                }
            }
        }
    }
}

/// A blow-up in the pull step is reported at the step and module of the other steps.
#[test]
fn a_blow_up_in_the_pull_step_names_the_same_step_and_module() {
    let mut net = springs(7, 60, None);
    for link in net.links.iter_mut().skip(40).take(3) {
        link.law = Interaction::Ref { k: 3.5, z: 0.0 };
    }
    let mut pulled = Engine::new(&net);
    let mut compact = pulled.clone();
    let ch = pulled.channels();
    let (mut a, mut b) = (vec![0.0; 512 * ch], vec![0.0; 512 * ch]);
    let mut blown = None;
    for _ in 0..200 {
        let x = pulled.process(512, &mut a);
        let y = compact.process_observed(512, &mut b, &mut unobserved);
        assert_eq!(x, y);
        assert!(a.iter().zip(&b).all(|(p, q)| p.to_bits() == q.to_bits()));
        if let Err(e) = x {
            blown = Some(e);
            break;
        }
    }
    assert!(blown.is_some(), "the network did not blow up");
}

/// A `rows` x `cols` membrane as the benchmark's, with one SOL per border link, masses of
/// inertia `m(i)` and a strike; REF links.
fn membrane(rows: usize, cols: usize, m: impl Fn(usize) -> f64) -> Network {
    let mut net = Network::new();
    let ids: Vec<MatId> = (0..rows * cols)
        .map(|i| {
            let v0 = if i == cols + 2 { 0.05 } else { 0.0 };
            let m = m(i);
            net.add_material(Material::Mas { m, x0: 0.0, v0 })
        })
        .collect();
    let law = Interaction::Ref { k: 0.1, z: 1e-4 };
    let ground = |net: &mut Network| net.add_material(Material::Sol { x0: 0.0 });
    for r in 0..rows {
        let g = ground(&mut net);
        net.add_link(law.clone(), g, ids[r * cols]);
        for c in 0..cols - 1 {
            net.add_link(law.clone(), ids[r * cols + c], ids[r * cols + c + 1]);
        }
        let g = ground(&mut net);
        net.add_link(law.clone(), ids[r * cols + cols - 1], g);
    }
    for c in 0..cols {
        let g = ground(&mut net);
        net.add_link(law.clone(), g, ids[c]);
        for r in 0..rows - 1 {
            net.add_link(law.clone(), ids[r * cols + c], ids[(r + 1) * cols + c]);
        }
        let g = ground(&mut net);
        net.add_link(law.clone(), ids[(rows - 1) * cols + c], g);
    }
    for &m in ids.iter().step_by(7) {
        net.add_position_output(m);
    }
    net
}

/// [`membrane`] with its links declared as the language's `membrane` generator does (the
/// horizontal links, the vertical links, then a link from one SOL to each edge MAS per missing
/// neighbour), or (`mixed`) with every other row's first MAS's link to the SOL first and from
/// the MAS, and the last column's from the MAS.
fn rimmed(rows: usize, cols: usize, mixed: bool) -> Network {
    let mut net = Network::new();
    let ids: Vec<MatId> = (0..rows * cols)
        .map(|i| {
            let v0 = if i == cols + 2 { 0.05 } else { 0.0 };
            net.add_material(Material::Mas {
                m: 1.0,
                x0: 0.0,
                v0,
            })
        })
        .collect();
    let law = Interaction::Ref { k: 0.1, z: 1e-4 };
    let rim = net.add_material(Material::Sol { x0: 0.0 });
    let at = |r: usize, c: usize| ids[r * cols + c];
    let early = |r: usize| mixed && r.is_multiple_of(2);
    for r in (0..rows).filter(|&r| early(r)) {
        net.add_link(law.clone(), at(r, 0), rim);
    }
    for r in 0..rows {
        for c in 0..cols - 1 {
            net.add_link(law.clone(), at(r, c), at(r, c + 1));
        }
    }
    for r in 0..rows - 1 {
        for c in 0..cols {
            net.add_link(law.clone(), at(r, c), at(r + 1, c));
        }
    }
    for r in 0..rows {
        for c in 0..cols {
            let missing = [r == 0, r + 1 == rows, c == 0 && !early(r), c + 1 == cols];
            for (side, _) in missing.iter().enumerate().filter(|(_, &m)| m) {
                if mixed && side == 3 {
                    net.add_link(law.clone(), at(r, c), rim);
                } else {
                    net.add_link(law.clone(), rim, at(r, c));
                }
            }
        }
    }
    for &m in ids.iter().step_by(7) {
        net.add_position_output(m);
    }
    net
}

/// Membranes whose rows are one loop with exceptions (see [`bridged`]) give, at every step,
/// the bits of the same engine with a loop per row: rows of several lengths modulo the vector
/// width, with each MAS update form, on one thread and on three (whose pieces of the loops
/// start and end anywhere, exceptions included).
#[test]
fn exceptions_give_the_bits_of_a_loop_per_row() {
    let inertias: [fn(usize) -> f64; 4] = [
        |_| 1.0,
        |_| 1.5,
        |i| [0.5, 1.0, 2.0][i % 3],
        |i| [0.75, 1.0, 1.25][i % 3],
    ];
    for (rows, cols) in [(6, 40), (9, 43), (20, 17), (5, 101), (12, 22)] {
        for (j, m) in inertias.iter().enumerate() {
            let net = membrane(rows, cols, m);
            let mut bridged = Engine::new(&net);
            let k = &bridged.k;
            assert!(!k.compact && k.mas_segments.len() == 1, "{rows}x{cols}");
            assert_eq!((k.mas_fix.len(), k.link_fix.len()), (rows - 1, rows - 1));
            let mut rows_apart = bridged.clone();
            rows_apart.k = Kernel::build(&net, false, false);
            assert!(rows_apart.k.mas_segments.len() >= rows);
            let a = trace(&mut bridged, &net, 300);
            assert!(a.iter().any(|&v| f64::from_bits(v) != 0.0));
            let b = trace(&mut rows_apart, &net, 300);
            assert!(a == b, "{rows}x{cols}, inertia {j}");
            // (observed steps stay on the calling thread: the outputs only)
            let outputs = |e: &mut Engine| {
                let mut out = vec![0.0; 300 * e.channels()];
                assert!(e.process(300, &mut out).is_ok());
                out.iter().map(|v| v.to_bits()).collect::<Vec<u64>>()
            };
            let one = outputs(&mut Engine::new(&net));
            assert!(a.ends_with(&one));
            let mut threads = Engine::new(&net);
            threads.set_parallel_threshold(0);
            threads.set_threads(3);
            assert!(threads.is_parallel());
            assert!(one == outputs(&mut threads), "{rows}x{cols}, 3 threads");
        }
    }
}

/// What [`surrounded`] puts around a membrane.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Surround {
    Nothing,
    /// no SOL: every edge MAS tied to nothing in place of its missing neighbours
    Free,
    /// a hammer of inertia 2 declared before the membrane, falling onto MAS (1, 5) through a
    /// BUT link, and a CEL after it tied to the last MAS
    HammerFirst,
    /// the hammer declared after the membrane, falling onto its first MAS (row 0, column
    /// 0), whose links then reach further than a row
    HammerLast,
    /// as `HammerFirst`, and a second membrane after the CEL ([`membrane`], a row more and
    /// three columns wider, of inertia 2), one of its MAS tied to the first membrane's by
    /// a REF link
    Pair,
}

/// [`membrane`] (layout 0) or [`rimmed`] (1, or 2: mixed) of `rows x cols` MAS of inertia 1,
/// with `around` around it.
fn surrounded(rows: usize, cols: usize, layout: usize, around: Surround) -> Network {
    let net = match layout {
        0 => membrane(rows, cols, |_| 1.0),
        _ => rimmed(rows, cols, layout == 2),
    };
    let mut out = Network::new();
    let hammer = Material::Mas {
        m: 2.0,
        x0: 0.02,
        v0: -5e-4,
    };
    let first = matches!(around, Surround::HammerFirst | Surround::Pair)
        .then(|| out.add_material(hammer.clone()));
    let shift = |id: MatId| MatId(id.0 + u32::from(first.is_some()));
    for m in &net.materials {
        out.add_material(m.clone());
    }
    let sol = |id: MatId| matches!(net.materials[id.index()], Material::Sol { .. });
    let links = (net.links.iter()).filter(|l| around != Surround::Free || !sol(l.a) && !sol(l.b));
    for l in links {
        out.add_link(l.law.clone(), shift(l.a), shift(l.b));
    }
    for o in &net.outputs {
        match o {
            Output::Position(m) => out.add_position_output(shift(*m)),
            _ => unreachable!("the membranes record positions"),
        };
    }
    if around == Surround::Free {
        return out;
    }
    let hammer = first.unwrap_or_else(|| out.add_material(hammer));
    let felt = Interaction::But {
        k: 0.05,
        z: 1e-3,
        s: 0.0,
    };
    let struck = match around {
        Surround::HammerLast => MatId(0),
        _ => shift(MatId((cols + 5) as u32)),
    };
    out.add_link(felt, struck, hammer);
    let cel = out.add_material(Material::Cel {
        m: 3.0,
        k: 0.02,
        z: 1e-3,
        x0: 1e-3,
        v0: 0.0,
        r: 0.0,
    });
    let last = shift(MatId((rows * cols - 1) as u32));
    out.add_link(Interaction::Ref { k: 0.07, z: 1e-3 }, last, cel);
    out.add_position_output(hammer);
    if around == Surround::Pair {
        let second = out.append(&membrane(rows + 1, cols + 3, |_| 2.0));
        let tie = Interaction::Ref { k: 0.1, z: 1e-4 };
        out.add_link(tie, shift(MatId(3)), MatId(second.0 + cols as u32 + 9));
    }
    out
}

/// The position buffers and each thread's row buffers start on a cache line (`lines.rs`),
/// for every thread count and in a clone: a whole vector load from a line's start touches
/// one line.
#[test]
fn position_and_row_buffers_start_on_a_line() {
    let on_line = |b: &[f64]| (b.as_ptr() as usize).is_multiple_of(64);
    let mut e = Engine::new(&membrane(5, 37, |_| 1.0));
    for threads in [1, 2, 3, 1] {
        e.set_threads(threads);
        let mut out = vec![0.0; 8 * e.k.channels.len()];
        e.process(8, &mut out).unwrap();
        for st in [&e.st, &e.st.clone()] {
            assert!(st.pos.iter().all(|b| on_line(b)), "{threads} threads");
            if let Some(g) = e.k.grid.as_deref() {
                let len = g.scratch_len();
                assert!(len.is_multiple_of(crate::lines::LINE));
                assert_eq!(st.grid.len(), threads * len);
                assert!(st.grid.chunks(len).all(on_line), "{threads} threads");
            }
        }
    }
}

/// The grid step is taken for the membranes it fits (`engine/grid.rs`) and for nothing else,
/// and gives the gather step's bits: every output and, after each block, every link force.
#[test]
fn the_grid_step_takes_only_membranes_and_gives_the_gather_bits() {
    if Simd::detect() == Simd::None {
        // (the grid step needs AVX-512 or AVX2: without them no network takes it)
        assert!(Engine::new(&membrane(4, 20, |_| 1.0)).k.grid.is_none());
        return;
    }
    let taken = |net: &Network| Engine::new(net).k.grid.is_some();
    for (rows, cols) in [(2, 16), (3, 17), (9, 24), (7, 100)] {
        assert!(taken(&membrane(rows, cols, |_| 1.0)), "{rows}x{cols}");
        assert!(taken(&membrane(rows, cols, |_| 1.5)), "{rows}x{cols}");
        assert!(taken(&rimmed(rows, cols, false)), "{rows}x{cols}");
        assert!(taken(&rimmed(rows, cols, true)), "{rows}x{cols}");
    }
    // per-MAS inertias (reciprocals of powers of two, or any); too narrow, one row
    assert!(taken(&membrane(6, 20, |i| [0.5, 1.0][i % 2])));
    assert!(taken(&membrane(6, 20, |i| 1.0 + i as f64 / 7.0)));
    assert!(!taken(&membrane(6, 15, |_| 1.0)));
    assert!(!taken(&membrane(1, 40, |_| 1.0)));
    // one link of another stiffness, of another law; a link more (a hammer's); a free border
    let changed = |at: usize, law: Interaction| {
        let mut net = membrane(6, 20, |_| 1.0);
        net.links[at].law = law;
        net
    };
    assert!(!taken(&changed(50, Interaction::Ref { k: 0.2, z: 1e-4 })));
    assert!(!taken(&changed(3, Interaction::Res { k: 0.1 })));
    let but = Interaction::But {
        k: 0.1,
        z: 1e-4,
        s: 1.0,
    };
    assert!(!taken(&changed(70, but)));
    // what the grid step takes around a membrane: a link across, an ENF input, free edges,
    // a hammer (declared before or after the membrane, of another inertia), a CEL
    let mut extra = membrane(6, 20, |_| 1.0);
    extra.add_link(Interaction::Ref { k: 0.1, z: 1e-4 }, MatId(3), MatId(44));
    assert!(taken(&extra));
    let mut struck = membrane(6, 20, |_| 1.0);
    struck.add_force(MatId(30), Signal::Impulse { at: 9, amp: 0.1 });
    assert!(taken(&struck));
    let mut free = membrane(6, 20, |_| 1.0);
    free.links.remove(0);
    assert!(taken(&free));
    for layout in 0..3 {
        assert!(taken(&surrounded(6, 20, layout, Surround::Free)));
        assert!(taken(&surrounded(6, 20, layout, Surround::HammerFirst)));
        assert!(taken(&surrounded(6, 20, layout, Surround::HammerLast)));
    }
    // several membranes, each a sheet of its own
    let sheets = |net: &Network| Engine::new(net).k.grid.as_ref().map_or(0, |g| g.sheets());
    assert_eq!(sheets(&surrounded(6, 20, 1, Surround::Pair)), 2);
    let mut three = surrounded(3, 17, 0, Surround::Pair);
    three.append(&rimmed(2, 30, true));
    assert_eq!(sheets(&three), 3);
    // (a membrane too narrow for a sheet is what is around the others)
    // (72 modules: 20 MAS and 52 links, at most 120 around the first's 240 MAS)
    let mut narrow = membrane(12, 20, |_| 1.0);
    narrow.append(&membrane(2, 10, |_| 1.0));
    assert_eq!(sheets(&narrow), 1);
    narrow.append(&membrane(2, 10, |_| 1.0));
    assert_eq!(sheets(&narrow), 0);
    // too much around it (a string of 121 MAS, RES links, for 120 in the membrane), a ground
    // link of another stiffness, a link to a neighbour missing
    let mut strung = membrane(6, 20, |_| 1.0);
    let string: Vec<MatId> = (0..121)
        .map(|_| {
            strung.add_material(Material::Mas {
                m: 1.0,
                x0: 0.0,
                v0: 0.0,
            })
        })
        .collect();
    for pair in string.windows(2) {
        strung.add_link(Interaction::Res { k: 0.1 }, pair[0], pair[1]);
    }
    strung.add_link(Interaction::Res { k: 0.1 }, MatId(50), string[0]);
    assert!(!taken(&strung));
    assert!(!taken(&changed(0, Interaction::Ref { k: 0.2, z: 1e-4 })));
    let mut cut = membrane(6, 20, |_| 1.0);
    cut.links.remove(5);
    assert!(!taken(&cut));
    // a link declared from its right MAS to its left; one top MAS (not the first or last of
    // its row) summing its SOL term first, unlike its row
    let mut reversed = membrane(6, 20, |_| 1.0);
    let link = &mut reversed.links[30];
    (link.a, link.b) = (link.b, link.a);
    assert!(!taken(&reversed));
    let mut early = membrane(6, 20, |_| 1.0);
    let top5 = early.links.remove(6 * 21 + 5 * 7);
    early.links.insert(0, top5);
    assert!(!taken(&early));
    let layouts = [
        (3, 17, 1.0, 0, Surround::Nothing),
        (9, 24, 1.5, 1, Surround::Nothing),
        (12, 33, 0.25, 0, Surround::Nothing),
        (7, 100, 1.0, 2, Surround::Nothing),
        (5, 18, 1.0, 1, Surround::Nothing),
        (4, 41, 1.0, 2, Surround::Nothing),
        (3, 17, 1.0, 0, Surround::Free),
        (9, 24, 1.0, 1, Surround::Free),
        (4, 41, 1.0, 2, Surround::Free),
        (6, 31, 1.0, 2, Surround::Nothing),
        (5, 23, 1.0, 0, Surround::Free),
        (5, 18, 1.0, 0, Surround::HammerFirst),
        (9, 24, 1.0, 1, Surround::HammerLast),
        (4, 41, 1.0, 2, Surround::HammerFirst),
        (5, 18, 1.0, 2, Surround::Pair),
        (4, 41, 1.0, 0, Surround::Pair),
    ];
    // (a name, the columns, the network)
    let mut nets: Vec<(String, usize, Network)> = layouts
        .into_iter()
        .map(|(rows, cols, m, layout, around)| {
            let net = match (layout, around) {
                (0, Surround::Nothing) => membrane(rows, cols, |_| m),
                (_, Surround::Nothing) => rimmed(rows, cols, layout == 2),
                _ => surrounded(rows, cols, layout, around),
            };
            (
                format!("{rows}x{cols} {layout} {around:?}, M {m}"),
                cols,
                net,
            )
        })
        .collect();
    // per-MAS inertias: reciprocals of powers of two (multiplied), any (divided); one grid
    // MAS of another inertia among a hammer, a CEL and a second membrane
    let powers = membrane(9, 24, |i| [0.5, 1.0, 4.0][i % 3]);
    nets.push(("9x24, M 1/2^k".into(), 24, powers));
    let ramp = |i: usize| 1.0 + (i % 37) as f64 / 13.0;
    nets.push(("7x100, M any".into(), 100, membrane(7, 100, ramp)));
    nets.push(("6x19, M any".into(), 19, membrane(6, 19, ramp)));
    // grounds off zero, each row's last block of 4 and of 8 columns
    for (rows, cols) in [(7, 100), (9, 24)] {
        let mut net = membrane(rows, cols, |_| 1.0);
        displace_grounds(&mut net);
        nets.push((format!("{rows}x{cols}, grounds displaced"), cols, net));
    }
    let mut heavy = surrounded(5, 18, 1, Surround::Pair);
    heavy.materials[40] = Material::Mas {
        m: 3.0,
        x0: 0.0,
        v0: 0.0,
    };
    nets.push(("5x18 pair, a heavy MAS".into(), 18, heavy));
    for (name, cols, mut net) in nets {
        let last = LinkId(net.links.len() as u32 - 1);
        net.add_force_output(last);
        net.add_force(MatId(cols as u32 + 5), Signal::Impulse { at: 9, amp: 0.1 });
        net.add_force(MatId(cols as u32 + 5), Signal::Constant(1e-4));
        net.add_force(MatId(0), Signal::Impulse { at: 30, amp: -0.1 });
        let pair = name.to_lowercase().contains("pair");
        assert_eq!(sheets(&net), 1 + usize::from(pair), "{name}");
        for simd in simd_widths() {
            let mut grid = Engine::new_for(&net, simd);
            assert!(grid.k.grid.is_some(), "{name}, {simd:?}");
            let mut gather = grid.clone();
            gather.k.grid = None;
            let mut moved = false;
            for block in [1, 97, 1024, 5] {
                let mut a = vec![0.0; block * grid.channels()];
                let mut b = a.clone();
                grid.process(block, &mut a).unwrap();
                gather.process(block, &mut b).unwrap();
                let bits = |v: &[f64]| v.iter().map(|v| v.to_bits()).collect::<Vec<u64>>();
                assert!(bits(&a) == bits(&b), "{name}, {simd:?}, block {block}");
                moved |= a.iter().any(|&v| v != 0.0);
                for l in 0..net.links.len() {
                    let l = LinkId(l as u32);
                    assert_eq!(grid.link_force(l).to_bits(), gather.link_force(l).to_bits());
                }
            }
            assert!(moved, "{name}: the outputs never moved");
        }
    }
}

/// The vector widths the grid and pull steps are compiled for that this CPU has (and
/// `CORDIS_SIMD` allows), widest first: AVX-512, AVX2 (none elsewhere).
fn simd_widths() -> Vec<Simd> {
    #[allow(unused_mut)]
    let mut widths = Vec::new();
    #[cfg(target_arch = "x86_64")]
    {
        if let Some(cpu) = Avx512::detect() {
            widths.push(Simd::Avx512(cpu));
        }
        if Simd::detect() != Simd::None {
            widths.push(Simd::Avx2); // (AVX-512 has AVX2's instructions)
        }
    }
    widths
}

/// With each vector width the CPU has, on one and three threads and in blocks of several
/// sizes, `net` (with two link forces and an input added) takes the grid step and gives the
/// gather step's bits: every output sample, and after each block every link force and
/// position.
fn grid_gives_the_gather_bits(name: &str, net: &mut Network) {
    let last = LinkId(net.links.len() as u32 - 1);
    net.add_force_output(last);
    net.add_force_output(LinkId(1));
    net.add_force(MatId(0), Signal::Impulse { at: 30, amp: -0.1 });
    for simd in simd_widths() {
        let mut grid = Engine::new_for(net, simd);
        assert!(grid.k.grid.is_some(), "{name}, {simd:?}");
        let mut gather = grid.clone();
        gather.k.grid = None;
        let mut threaded = grid.clone();
        threaded.set_parallel_threshold(0);
        threaded.set_threads(3);
        let mut moved = false;
        for block in [1, 97, 1024, 5] {
            let mut a = vec![0.0; block * grid.channels()];
            let (mut b, mut c) = (a.clone(), a.clone());
            grid.process(block, &mut a).unwrap();
            gather.process(block, &mut b).unwrap();
            threaded.process(block, &mut c).unwrap();
            let bits = |v: &[f64]| v.iter().map(|v| v.to_bits()).collect::<Vec<u64>>();
            assert!(bits(&a) == bits(&b), "{name}, {simd:?}, block {block}");
            assert!(
                bits(&c) == bits(&b),
                "{name}, {simd:?}, block {block}, threads"
            );
            moved |= a.iter().any(|&v| v != 0.0);
            for l in 0..net.links.len() {
                let l = LinkId(l as u32);
                let f = gather.link_force(l).to_bits();
                assert_eq!(grid.link_force(l).to_bits(), f);
                assert_eq!(threaded.link_force(l).to_bits(), f, "{name}, threads");
            }
            for m in 0..net.materials.len() {
                let m = MatId(m as u32);
                let at = |e: &Engine| e.position(m).to_bits();
                assert!(
                    at(&grid) == at(&gather),
                    "{name}, {simd:?}, block {block}, {m:?}"
                );
            }
        }
        assert!(moved, "{name}: the outputs never moved");
        // (after a reset, `f(n-1)` is 0 before the first step, as stored)
        grid.reset();
        for l in (0..net.links.len() as u32).map(LinkId) {
            assert_eq!(grid.link_force(l).to_bits(), 0, "{name}");
        }
    }
}

/// Short strings one after the other in storage step as banks, one call each, of one law
/// kind (REF or BUT) each with its own parameters and ends, of unit inertia, of other
/// inertias (each its own) or of per-MAS inertias, fixes among them; LNL strings and long
/// strings alone; and give the gather bits.
#[test]
fn banks_of_short_strings_give_the_gather_bits() {
    if Simd::detect() == Simd::None {
        return;
    }
    let own = |s: usize| Interaction::Ref {
        k: 0.1 + s as f64 / 100.0,
        z: 1e-4 * (1 + s % 3) as f64,
    };
    let but = |s: usize| Interaction::But {
        k: 0.1 + s as f64 / 50.0,
        z: 1e-4,
        s: [0.0, 1e3, -1e-3][s % 3],
    };
    let lnl = |_| Interaction::Lnl {
        lk: Curve::new(&[(-0.004, -4e-4), (0.0, 0.0), (0.004, 4e-4)]).unwrap(),
        lz: Curve::new(&[(-1.0, -1e-4), (1.0, 1e-4)]).unwrap(),
    };
    // strings one after the other: (length, law, edit) each, appended in order
    type Edit = fn(&mut Network);
    let keep: Edit = |_| {};
    let free_ends: Edit = |net| {
        net.links.remove(0);
        net.links.pop();
    };
    let turned: Edit = |net| {
        let n = net.links.len();
        for l in [0, n - 1] {
            let link = &mut net.links[l];
            (link.a, link.b) = (link.b, link.a);
        }
    };
    let heavy: Edit = |net| {
        for mat in &mut net.materials {
            if let Material::Mas { m, .. } = mat {
                *m = 2.5;
            }
        }
    };
    let per_mas: Edit = |net| {
        for (i, mat) in net.materials.iter_mut().enumerate() {
            if let Material::Mas { m, .. } = mat {
                *m = [1.0, 1.3, 2.9][i % 3];
            }
        }
    };
    let input: Edit = |net| net.add_force(MatId(9), Signal::Constant(1e-4));
    type Law = fn(usize) -> Interaction;
    let strings = |parts: &[(usize, Law, Edit)]| {
        let mut net = Network::new();
        for (s, &(n, law, edit)) in parts.iter().enumerate() {
            let mut one = bank(1, n, |_| law(s));
            displace_grounds(&mut one);
            edit(&mut one);
            net.append(&one);
        }
        net
    };
    let (r, b, l): (Law, Law, Law) = (own, but, lnl);
    // (name, network, sheets, units)
    let mut nets: Vec<(&str, Network, usize, usize)> = vec![
        ("12 x 40", bank(12, 40, own), 12, 1),
        (
            "lengths 16 to 57, free ends, grounds turned, inertias",
            strings(&[
                (16, r, keep),
                (17, r, free_ends),
                (23, r, turned),
                (24, r, heavy),
                (31, r, keep),
                (40, r, free_ends),
                (57, r, heavy),
            ]),
            7,
            4,
        ),
        (
            "BUT of their own K and S",
            strings(&[
                (20, b, keep),
                (33, b, free_ends),
                (18, b, keep),
                (45, b, heavy),
            ]),
            4,
            2,
        ),
        (
            "REF, BUT, LNL, per-MAS inertias, a long string, inputs",
            strings(&[
                (20, r, keep),
                (21, r, input),
                (22, b, keep),
                (23, b, input),
                (24, l, keep),
                (25, l, keep),
                (26, r, keep),
                (27, r, per_mas),
                (28, r, per_mas),
                (29, r, keep),
                (1500, r, keep),
                (30, r, keep),
                (31, r, keep),
            ]),
            13,
            9,
        ),
    ];
    // a hammer (declared after the strings) on the third of eight
    let mut struck = bank(8, 30, own);
    let hammer = struck.add_material(Material::Mas {
        m: 3.0,
        x0: 0.5,
        v0: -0.01,
    });
    let blow = Interaction::But {
        k: 0.3,
        z: 1e-3,
        s: 0.0,
    };
    struck.add_link(blow, hammer, MatId(2 * 32 + 11));
    nets.push(("8 x 30, struck", struck, 8, 1));
    for (name, mut net, sheets, units) in nets {
        let grid = Engine::new(&net).k.grid.expect(name);
        assert_eq!((grid.sheets(), grid.units()), (sheets, units), "{name}");
        grid_gives_the_gather_bits(name, &mut net);
    }
}

/// The grid step takes strings of REF, BUT and LNL links too, each cut into rows (`engine/grid.rs`
/// `Sheet::string_at`), and gives the gather step's bits on one thread and on three: every
/// output and, after each block, every link force and position.
#[test]
fn the_grid_step_takes_strings_and_gives_the_gather_bits() {
    let refs = |_| Interaction::Ref { k: 0.1, z: 1e-4 };
    if Simd::detect() == Simd::None {
        assert!(Engine::new(&bank(1, 100, refs)).k.grid.is_none());
        return;
    }
    let sheets = |net: &Network| Engine::new(net).k.grid.as_ref().map_or(0, |g| g.sheets());
    // `bank(1, n)`'s links: the left ground, the `n - 1` inner ones, the right ground
    let one = |n: usize, edit: &dyn Fn(&mut Network)| {
        let mut net = bank(1, n, refs);
        edit(&mut net);
        net
    };
    let nothing = |_: &mut Network| {};
    // (a string, its length)
    let mut nets: Vec<(String, Network)> = Vec::new();
    for n in [16, 17, 23, 100, 1000, 1025, 3001] {
        nets.push((format!("{n}"), one(n, &nothing)));
    }
    let free_left = |net: &mut Network| drop(net.links.remove(0));
    let free_right = |net: &mut Network| drop(net.links.pop());
    let free_both = |net: &mut Network| {
        free_left(net);
        free_right(net);
    };
    // the grounds' terms before (first MAS) or after (last) the inner link's, and their
    // links declared from the MAS to the SOL
    let swapped = |net: &mut Network| {
        net.links.swap(0, 1);
        let n = net.links.len();
        net.links.swap(n - 2, n - 1);
    };
    let turned = |net: &mut Network| {
        let n = net.links.len();
        for l in [0, n - 1] {
            let link = &mut net.links[l];
            (link.a, link.b) = (link.b, link.a);
        }
    };
    // two inner links declared the other way round: MAS 6 sums its right link first
    let inner = |net: &mut Network| net.links.swap(6, 7);
    type Edit<'a> = &'a dyn Fn(&mut Network);
    let edits: [(&str, Edit); 7] = [
        ("grounds displaced", &displace_grounds),
        ("free left", &free_left),
        ("free right", &free_right),
        ("free ends", &free_both),
        ("grounds swapped", &swapped),
        ("grounds turned", &turned),
        ("inner swapped", &inner),
    ];
    for (name, edit) in edits {
        for n in [17, 24, 2100] {
            nets.push((format!("{n} {name}"), one(n, edit)));
        }
    }
    // per-MAS inertias: reciprocals of powers of two (multiplied), any (divided)
    for (name, m) in [("M 1/2^k", [0.5, 1.0, 4.0]), ("M any", [1.0, 1.3, 2.9])] {
        let inertias = |net: &mut Network| {
            for (i, mat) in net.materials.iter_mut().enumerate() {
                if let Material::Mas { m: mass, .. } = mat {
                    *mass = m[i % 3];
                }
            }
        };
        nets.push((format!("1500 {name}"), one(1500, &inertias)));
    }
    // a hammer (a MAS and a BUT link, around the string), inputs on two MAS (fixes)
    let struck = |net: &mut Network| {
        let hammer = net.add_material(Material::Mas {
            m: 3.0,
            x0: 0.5,
            v0: -0.01,
        });
        let but = Interaction::But {
            k: 0.3,
            z: 1e-3,
            s: 0.0,
        };
        net.add_link(but, hammer, MatId(40));
        net.add_force(MatId(7), Signal::Impulse { at: 9, amp: 0.1 });
        net.add_force(MatId(1200), Signal::Constant(1e-4));
    };
    nets.push(("1300 struck".into(), one(1300, &struck)));
    // BUT strings (in contact where compressed, or always), free ends
    for s in [0.0, 1e3] {
        let but = |_| Interaction::But { k: 0.1, z: 1e-4, s };
        nets.push((format!("17 BUT {s}"), bank(1, 17, but)));
        let mut free = bank(1, 1500, but);
        free_both(&mut free);
        nets.push((format!("1500 BUT {s}, free ends"), free));
    }
    // LNL strings: curves of 0, 2, 3 and 4 points whose abscissas the motion crosses (MAS
    // `n / 4` starts at 0.01 a step), free ends, per-MAS inertias, a hammer and inputs, a
    // hammer's RES link declared among the string's
    let lnl = |k: &'static [(f64, f64)], z: &'static [(f64, f64)]| {
        move |_| Interaction::Lnl {
            lk: Curve::new(k).unwrap(),
            lz: Curve::new(z).unwrap(),
        }
    };
    let spring: &[(f64, f64)] = &[(-0.004, -4e-4), (0.0, 0.0), (0.004, 4e-4)];
    let damper: &[(f64, f64)] = &[(-0.002, -2e-7), (0.0, 0.0), (0.002, 2e-7)];
    let kinked: &[(f64, f64)] = &[(-0.01, -2e-3), (-1e-3, -1e-4), (2e-3, 3e-4), (0.01, 1e-3)];
    let soft: &[(f64, f64)] = &[(-0.003, -3e-4), (0.003, 5e-4)];
    let linear: &[(f64, f64)] = &[(-1.0, -1e-4), (1.0, 1e-4)];
    nets.push(("100 LNL 3 3".into(), bank(1, 100, lnl(spring, damper))));
    nets.push(("1100 LNL 3 3".into(), bank(1, 1100, lnl(spring, damper))));
    nets.push(("700 LNL 4 2".into(), bank(1, 700, lnl(kinked, linear))));
    nets.push(("40 LNL 2 0".into(), bank(1, 40, lnl(soft, &[]))));
    nets.push(("300 LNL 0 3".into(), bank(1, 300, lnl(&[], damper))));
    let mut free = bank(1, 1500, lnl(kinked, damper));
    free_both(&mut free);
    nets.push(("1500 LNL 4 3, free ends".into(), free));
    let mut struck_lnl = bank(1, 1300, lnl(spring, linear));
    struck(&mut struck_lnl);
    swapped(&mut struck_lnl);
    nets.push(("1300 LNL 3 2, struck, grounds swapped".into(), struck_lnl));
    let mut heavy = bank(1, 900, lnl(soft, damper));
    for (i, mat) in heavy.materials.iter_mut().enumerate() {
        if let Material::Mas { m, .. } = mat {
            *m = [1.0, 1.3, 2.9][i % 3];
        }
    }
    nets.push(("900 LNL 2 3, M any".into(), heavy));
    // the sticking spring (FORMALISM.md): 4 points, a jump at the first (as
    // `first_segment` prepares it) and at the last, with a damper (fixed ends) or the zero
    // curve (free ends); the motion crosses the jumps (the struck MAS leaves its springs'
    // window of ±0.012 within two steps, and the others stretch theirs: a spring of zero
    // viscous curve pulls only within its window, so its force is zero at some block's end
    // and not at another's)
    let sticking: &[(f64, f64)] = &[
        (-0.012, 0.0),
        (-0.012, -1.2e-3),
        (0.012, 1.2e-3),
        (0.012, 0.0),
    ];
    nets.push((
        "1000 LNL 4 3, sticking".into(),
        bank(1, 1000, lnl(sticking, damper)),
    ));
    let mut free = bank(1, 600, lnl(sticking, &[]));
    free_both(&mut free);
    let mut e = Engine::new(&free);
    let mut caught = vec![[false; 2]; free.links.len()];
    let mut out = vec![0.0; 5 * e.channels()];
    for _ in 0..200 {
        e.process(5, &mut out).unwrap();
        for (l, c) in caught.iter_mut().enumerate() {
            c[usize::from(e.link_force(LinkId(l as u32)) != 0.0)] = true;
        }
    }
    assert!(caught.iter().filter(|c| c[0] && c[1]).count() > 10);
    nets.push(("600 LNL 4 0, sticking, free ends".into(), free));
    // curves drawn point by point, of 5 to 8 points (padded to 8), with one of 3 (to 4) or 0
    let drawn: &[(f64, f64)] = &[
        (-0.008, -1.2e-3),
        (-0.004, -4e-4),
        (-0.001, -6e-5),
        (0.0, 0.0),
        (0.002, 2e-4),
        (0.002, 2.5e-4),
        (0.006, 9e-4),
    ];
    let drawn_damper: &[(f64, f64)] = &[
        (-0.003, -4e-7),
        (-0.001, -1e-7),
        (0.0, 0.0),
        (0.001, 1e-7),
        (0.003, 5e-7),
    ];
    nets.push(("600 LNL 7 3".into(), bank(1, 600, lnl(drawn, damper))));
    nets.push(("300 LNL 0 5".into(), bank(1, 300, lnl(&[], drawn_damper))));
    let mut free = bank(1, 1100, lnl(drawn, drawn_damper));
    free_both(&mut free);
    nets.push(("1100 LNL 7 5, free ends".into(), free));
    // finely drawn, of 9 to 16 points (padded to 16), with one of 2 or 0, or of 13
    let fine: &[(f64, f64)] = &[
        (-0.009, -1.4e-3),
        (-0.006, -7e-4),
        (-0.004, -3.8e-4),
        (-0.0025, -2e-4),
        (-0.001, -7e-5),
        (0.0, 0.0),
        (0.001, 8e-5),
        (0.002, 1.7e-4),
        (0.002, 2.2e-4),
        (0.0035, 4e-4),
        (0.005, 6.5e-4),
        (0.007, 1e-3),
        (0.009, 1.5e-3),
    ];
    nets.push(("800 LNL 13 2".into(), bank(1, 800, lnl(fine, linear))));
    // (evenly spread, 13 points: an exact grid, the segment guessed with AVX-512; `fine`
    // has a jump inside a bucket and is searched)
    let even: &'static [(f64, f64)] = Vec::leak(
        (0..13)
            .map(|i| {
                let x = (i as f64 - 6.0) * 1.5e-3;
                (x, 0.1 * x + 1e3 * x * x * x)
            })
            .collect(),
    );
    let grids = |c: &[(f64, f64)]| {
        ExactCurve::<16>::fitted(&Curve::new(c).unwrap())
            .unwrap()
            .guesses()
    };
    assert!(grids(even) && !grids(fine));
    nets.push((
        "800 LNL 13 2, evenly".into(),
        bank(1, 800, lnl(even, linear)),
    ));
    nets.push(("300 LNL 9 0".into(), bank(1, 300, lnl(&fine[2..11], &[]))));
    let mut free = bank(1, 900, lnl(drawn, fine));
    free_both(&mut free);
    nets.push(("900 LNL 7 13, free ends".into(), free));
    // sampled from a formula, of more than 16 points (evaluated as they are: `LongCurve`), 40
    // and 3, and 17 and 20 (free ends)
    let sampled: &[(f64, f64)] = (0..40)
        .map(|i| {
            let x = -0.012 + f64::from(i) * 0.024 / 39.0;
            (x, 0.08 * x + 50.0 * x * x * x)
        })
        .collect::<Vec<_>>()
        .leak();
    nets.push(("700 LNL 40 3".into(), bank(1, 700, lnl(sampled, damper))));
    let mut free = bank(1, 500, lnl(&sampled[10..27], &sampled[..20]));
    free_both(&mut free);
    nets.push(("500 LNL 17 20, free ends".into(), free));
    let mut cut = bank(1, 200, lnl(spring, damper));
    let hammer = cut.add_material(Material::Mas {
        m: 2.0,
        x0: 0.1,
        v0: 0.0,
    });
    cut.links.insert(
        100,
        crate::Link {
            law: Interaction::Res { k: 1e-3 },
            a: hammer,
            b: MatId(50),
        },
    );
    nets.push(("200 LNL, a RES link to a hammer".into(), cut));
    // signed zeros: MAS at `+0.0` or `-0.0` moving at `+0.0` or `-0.0`, grounds at either,
    // and MAS 40 to 42 where `(0 + f_left) - f_right` is not `f_left - f_right`: MAS 41 at
    // `-0.0` with `x(n-1) = +0.0` (`x + x - x(n-1) = -0.0`), its left link `-0.0` (both its
    // products underflow), its right link `+0.0` (REF and BUT links keep the `0 +`); an LNL
    // string of curves one of which has a `-0.0` value (its force is never `-0.0`:
    // `StringLaw::NEVER_MINUS_ZERO`)
    let zeros = |net: &mut Network| {
        let tiny = -f64::from_bits(1); // (-5e-324)
        for (i, mat) in net.materials.iter_mut().enumerate() {
            let sign = |k: usize| if k.is_multiple_of(2) { 0.0 } else { -0.0 };
            match mat {
                Material::Mas { x0, v0, .. } => {
                    (*x0, *v0) = match i {
                        40 => (tiny, tiny),
                        41 | 42 => (-0.0, -0.0),
                        _ => (sign(i), sign(i / 2 + i / 5)),
                    }
                }
                Material::Sol { x0 } => *x0 = sign(i / 3),
                _ => {}
            }
        }
    };
    let spring_minus_zero: &[(f64, f64)] = &[(-0.004, -4e-4), (0.0, -0.0), (0.004, 4e-4)];
    for (name, mut net) in [
        ("100 REF", one(100, &nothing)),
        (
            "100 BUT 0",
            bank(1, 100, |_| Interaction::But {
                k: 0.1,
                z: 1e-4,
                s: 0.0,
            }),
        ),
        ("100 LNL -0 3", bank(1, 100, lnl(spring_minus_zero, damper))),
        ("100 LNL 3 -0", bank(1, 100, lnl(damper, spring_minus_zero))),
    ] {
        zeros(&mut net);
        nets.push((format!("{name}, signed zeros"), net));
    }
    // strings of their own stiffnesses, each a sheet; a string and a membrane
    let own = |s: usize| Interaction::Ref {
        k: 0.1 + s as f64 / 100.0,
        z: 1e-4,
    };
    nets.push(("12 x 40".into(), bank(12, 40, own)));
    let mut mixed = bank(3, 200, own);
    mixed.append(&membrane(6, 20, |_| 1.0));
    nets.push(("3 x 200 and a membrane".into(), mixed));
    for (name, mut net) in nets {
        let expected = match name.as_str() {
            "12 x 40" => 12,
            "3 x 200 and a membrane" => 4,
            _ => 1,
        };
        assert_eq!(sheets(&net), expected, "{name}");
        grid_gives_the_gather_bits(&name, &mut net);
    }
    // not strings the grid step takes: an inner link declared from its right MAS to its
    // left, of another law, of another stiffness; a damper on each MAS (`air`)
    let turned_inner = |net: &mut Network| {
        let link = &mut net.links[50];
        (link.a, link.b) = (link.b, link.a);
    };
    assert_eq!(sheets(&one(100, &turned_inner)), 0);
    let res = |net: &mut Network| net.links[50].law = Interaction::Res { k: 0.1 };
    assert_eq!(sheets(&one(100, &res)), 0);
    let stiffer = |net: &mut Network| net.links[50].law = Interaction::Ref { k: 0.2, z: 1e-4 };
    assert_eq!(sheets(&one(100, &stiffer)), 0);
    let air = |net: &mut Network| {
        let ground = MatId(100);
        for i in 0..100 {
            net.add_link(Interaction::Fro { z: 1e-3 }, ground, MatId(i));
        }
    };
    assert_eq!(sheets(&one(100, &air)), 0);
    assert_eq!(sheets(&one(15, &nothing)), 0);
    // a BUT link to a ground with the MAS at the other end than a neighbour's (its force is
    // not odd in its ends); the same for LNL, and LNL curves the grid step does not take (not
    // `ExactCurve::widens` or `LongCurve::widens`: a first value of `-0.0`), or two of them
    let but = |_| Interaction::But {
        k: 0.1,
        z: 1e-4,
        s: 0.0,
    };
    let mut turned_but = bank(1, 100, but);
    turned(&mut turned_but);
    assert_eq!(sheets(&bank(1, 100, but)), 1);
    assert_eq!(sheets(&turned_but), 0);
    let mut turned_lnl = bank(1, 100, lnl(spring, damper));
    turned(&mut turned_lnl);
    assert_eq!(sheets(&turned_lnl), 0);
    // (`(i / 2, (i / 4)^3)` for `i` in `-8..=8`)
    let seventeen: &[(f64, f64)] = &[
        (-4.0, -8.0),
        (-3.5, -5.359375),
        (-3.0, -3.375),
        (-2.5, -1.953125),
        (-2.0, -1.0),
        (-1.5, -0.421875),
        (-1.0, -0.125),
        (-0.5, -0.015625),
        (0.0, 0.0),
        (0.5, 0.015625),
        (1.0, 0.125),
        (1.5, 0.421875),
        (2.0, 1.0),
        (2.5, 1.953125),
        (3.0, 3.375),
        (3.5, 5.359375),
        (4.0, 8.0),
    ];
    assert_eq!(sheets(&bank(1, 100, lnl(seventeen, damper))), 1);
    let seventeen_minus_zero = seventeen.to_vec().leak();
    seventeen_minus_zero[0].1 = -0.0;
    assert_eq!(sheets(&bank(1, 100, lnl(seventeen_minus_zero, damper))), 0);
    assert_eq!(sheets(&bank(1, 100, lnl(&seventeen[1..], damper))), 1);
    assert_eq!(sheets(&bank(1, 100, lnl(&seventeen[4..13], damper))), 1);
    let minus_zero: &[(f64, f64)] = &[(-1.0, -0.0), (1.0, 1.0)];
    assert_eq!(sheets(&bank(1, 100, lnl(spring, minus_zero))), 0);
    // (a `-0.0` value in both curves: the force may be `-0.0`)
    let damper_minus_zero: &[(f64, f64)] = &[(-1.0, -1e-4), (1.0, 1e-4), (2.0, -0.0)];
    let both = bank(1, 100, lnl(spring_minus_zero, damper_minus_zero));
    assert_eq!(sheets(&both), 0);
    assert_eq!(sheets(&bank(1, 100, lnl(spring_minus_zero, linear))), 1);
    let mut two = bank(1, 100, lnl(spring, damper));
    two.links[50].law = lnl(kinked, damper)(0);
    assert_eq!(sheets(&two), 0);
    // (links of one curve in two LNL laws of the kernel are the same law to a string)
    let pair = |k: &[(f64, f64)], z: &[(f64, f64)]| {
        ExactPair::new(&Curve::new(k).unwrap(), &Curve::new(z).unwrap()).unwrap()
    };
    assert!(pair(spring, damper).same_bits(&pair(spring, damper)));
    assert!(!pair(spring, damper).same_bits(&pair(spring, linear)));
    let plus_zero: &[(f64, f64)] = &[(-1.0, 0.0), (1.0, 1.0)];
    assert!(!pair(spring, minus_zero).same_bits(&pair(spring, plus_zero)));
}

/// On threads, the grid's rows are cut into shares of consecutive rows, one per thread, and
/// each share into consecutive chunks (the units the threads claim): about `CHUNK_MAS` MAS
/// each, at least `CHUNKS_MIN` where there are rows enough, and never an empty one but for a
/// thread without rows.
#[test]
fn grid_shares_are_cut_into_chunks_of_consecutive_rows() {
    let check = |net: &Network, threads: usize, counts: &[usize]| {
        let e = Engine::new(net);
        if Simd::detect() == Simd::None {
            assert!(e.k.grid.is_none(), "no grid step without AVX2 or AVX-512");
            return;
        }
        let grid = e.k.grid.as_deref().expect("a grid");
        let shares = grid.partition(threads);
        assert_eq!(shares.len(), threads);
        let mut next = 0;
        for (chunks, &count) in shares.iter().zip(counts) {
            assert_eq!(chunks.len(), count, "{shares:?}");
            for c in chunks {
                assert_eq!(c.start, next, "{shares:?}");
                assert!(c.end > c.start || count == 1, "{shares:?}");
                next = c.end;
            }
        }
        assert_eq!(next, grid.partition(1)[0].last().unwrap().end);
    };
    // 50,000 MAS on one thread: 6 chunks of about 8,192
    check(&membrane(500, 100, |_| 1.0), 1, &[6]);
    // 2 x 2,000 MAS: the fewest chunks, 4 each
    check(&membrane(40, 100, |_| 1.0), 2, &[4, 4]);
    // fewer rows than that: a row each; more threads than rows: an empty share
    check(&membrane(5, 20, |_| 1.0), 2, &[3, 2]);
    check(&membrane(2, 20, |_| 1.0), 3, &[1, 1, 1]);
    // two sheets: the rows of both, one after the other
    check(&surrounded(6, 20, 1, Surround::Pair), 2, &[4, 4]);
}

/// The pull step's shares are cut into chunks of consecutive groups that cover every group
/// once, in storage order, each chunk's slots those of its groups' MAS; the last chunk of the
/// last share also has the CEL and ENX.
#[test]
fn pull_shares_are_cut_into_chunks_of_consecutive_groups() {
    if Simd::detect() == Simd::None {
        return; // (no pull step without AVX2)
    }
    let check = |n: usize, threads: usize, counts: &[usize]| {
        let e = Engine::new(&springs(1, n, None));
        let (k, pull) = (&e.k, e.k.pull.as_deref().expect("a pull step"));
        let shares = pull.partition(k, threads);
        assert_eq!(shares.len(), threads);
        let (mut group, mut slot) = (0, 0);
        for (t, (chunks, &count)) in shares.iter().zip(counts).enumerate() {
            assert_eq!(
                chunks.len(),
                count,
                "{n} MAS, {threads} threads: {shares:?}"
            );
            for (c, chunk) in chunks.iter().enumerate() {
                assert_eq!(chunk.groups.start, group, "{shares:?}");
                assert_eq!(chunk.slots.start, slot, "{shares:?}");
                // (a chunk may have no group where the costs are uneven: a claim for
                // nothing, or for the CEL and ENX alone)
                let mas = (8 * chunk.groups.end).min(k.n_mas);
                let last = t + 1 == threads && c + 1 == count;
                assert_eq!(chunk.slots.end, if last { k.n_mce } else { mas });
                (group, slot) = (chunk.groups.end, mas);
            }
        }
        assert_eq!(8 * group, k.n_mas.next_multiple_of(8));
    };
    // 40,000 MAS on one thread: 9 chunks of about 4,096
    check(40_000, 1, &[9]);
    // 2 x 2,000 MAS: the fewest chunks, 4 each
    check(4_000, 2, &[4, 4]);
    // 5 groups: still 4; 2 groups: a group each; more threads than groups: an empty share
    check(40, 1, &[4]);
    check(16, 1, &[2]);
    check(16, 3, &[1, 1, 1]);
}

/// [`chain`] gives each link the force [`LinkLaw::force`] of its ends' positions and velocities,
/// bit for bit, for every law, every length (every remainder of 8, and shorter than one
/// block), with per-link parameters, and writes nothing past the last link.
#[test]
fn chains_give_each_link_the_force_of_its_ends() {
    let Some(cpu) = Avx512::detect() else {
        // (`chain` needs the proof of AVX-512)
        return;
    };
    let mut seed = 0x2545_f491_4f6c_dd1du64;
    let mut draw = move || {
        seed ^= seed << 13;
        seed ^= seed >> 7;
        seed ^= seed << 17;
        (seed >> 11) as f64 / (1u64 << 53) as f64 - 0.5
    };
    for n in 1..=41 {
        let x: Vec<f64> = (0..=n).map(|_| draw()).collect();
        let xp: Vec<f64> = x.iter().map(|&x| x - 1e-3 * draw()).collect();
        let k: Vec<f64> = (0..n).map(|_| 0.1 + 0.01 * draw()).collect();
        let z: Vec<f64> = (0..n).map(|_| 1e-3 * (1.0 + draw())).collect();
        // BUT thresholds of both signs: some links in contact, some not
        let s: Vec<f64> = (0..n).map(|_| 0.5 * draw()).collect();
        type Ends<'a> = (&'a [f64], &'a [f64], &'a [f64], &'a [f64], &'a [f64]);
        fn check<L: LinkLaw>(cpu: Avx512, (x, xp, k, z, s): Ends<'_>) {
            let n = k.len();
            let mut lf = vec![f64::NAN; n + 9];
            let params = PerLink { k, z, s };
            chain(
                cpu,
                x,
                xp,
                &mut lf[..n],
                params,
                |(k, z, s), xa, va, xb, vb| L::force(k, z, s, xa, va, xb, vb),
            );
            for i in 0..n {
                let (va, vb) = (x[i] - xp[i], x[i + 1] - xp[i + 1]);
                let want = L::force(k[i], z[i], s[i], x[i], va, x[i + 1], vb);
                assert_eq!(lf[i].to_bits(), want.to_bits(), "link {i} of {n}");
            }
            assert!(lf[n..].iter().all(|f| f.is_nan()), "written past {n} links");
        }
        let ends = (&x[..], &xp[..], &k[..], &z[..], &s[..]);
        check::<RefLaw>(cpu, ends);
        check::<ResLaw>(cpu, ends);
        check::<FroLaw>(cpu, ends);
        check::<ButLaw>(cpu, ends);
    }
}

/// Strings of each law that [`chain`] steps (uniform, and with a parameter per link), with
/// inertias of every update form and an ENF input, give the scalar build's bits.
#[test]
fn chained_strings_give_the_scalar_bits() {
    let laws: [fn(usize) -> Interaction; 8] = [
        |_| Interaction::Ref { k: 0.1, z: 1e-3 },
        |i| Interaction::Ref {
            k: 0.1 + 1e-4 * i as f64,
            z: 1e-3,
        },
        |_| Interaction::Res { k: 0.1 },
        |i| Interaction::Res {
            k: 0.1 + 1e-4 * i as f64,
        },
        |_| Interaction::Fro { z: 0.02 },
        |i| Interaction::Fro {
            z: 0.02 + 1e-4 * i as f64,
        },
        // (in contact on and off: the string is struck at 0.05 per sample)
        |_| Interaction::But {
            k: 0.1,
            z: 1e-3,
            s: 0.01,
        },
        |i| Interaction::But {
            k: 0.1,
            z: 1e-3,
            s: 0.01 - 1e-4 * i as f64,
        },
    ];
    for n in [40, 67, 300] {
        for (j, law) in laws.iter().enumerate() {
            let mut net = Network::new();
            let g = net.add_material(Material::Sol { x0: 0.0 });
            let ids: Vec<MatId> = (0..n)
                .map(|i| {
                    let m = [1.0, 1.5, 0.5][(i + j) % 3];
                    let v0 = if i == n / 4 { 0.05 } else { 0.0 };
                    net.add_material(Material::Mas { m, x0: 0.0, v0 })
                })
                .collect();
            let h = net.add_material(Material::Sol { x0: 0.0 });
            let mut prev = g;
            for (i, &m) in ids.iter().enumerate() {
                net.add_link(law(i), prev, m);
                prev = m;
            }
            net.add_link(law(n), prev, h);
            net.add_force(ids[3], Signal::Impulse { at: 5, amp: 0.1 });
            net.add_position_output(ids[n / 2]);
            net.add_force_output(LinkId(n as u32 / 3));
            let render = |simd: Simd| {
                let mut e = Engine::new(&net);
                e.k.simd = simd;
                let mut out = vec![0.0; 2000 * e.channels()];
                e.process(2000, &mut out).unwrap();
                out.iter().map(|v| v.to_bits()).collect::<Vec<u64>>()
            };
            let scalar = render(Simd::None);
            assert!(scalar.iter().any(|&v| v != 0));
            if j >= 6 {
                // the BUT of the force output is in contact at some steps, not at others
                let force = scalar.iter().skip(1).step_by(2).map(|&v| f64::from_bits(v));
                let contact = force.clone().filter(|&f| f != 0.0).count();
                assert!(
                    contact > 0 && contact < force.count(),
                    "string {n}, law {j}"
                );
            }
            #[cfg(target_arch = "x86_64")]
            if let Some(cpu) = Avx512::detect() {
                let e = Engine::new(&net);
                let chains =
                    e.k.whole.runs.iter().any(
                        |r| matches!(r.ends, Ends::Step { a0, sa: 1, b0, sb: 1 } if b0 == a0 + 1),
                    );
                assert!(chains, "string {n}, law {j}: no chain");
                assert!(render(Simd::Avx512(cpu)) == scalar, "string {n}, law {j}");
            }
        }
    }
}

/// Two progressions are one across at most [`GAP_MAX`] items only when the second continues
/// the first, steps and values.
#[test]
fn bridged_joins_only_progressions_that_continue() {
    let prog = |r: Range<usize>, st: &[(u32, u32)]| (r, Some(st.to_vec()));
    let gap = |r: Range<usize>| (r, None);
    let a = [(0, 1), (100, 2)];
    // continues across one item, then two; not across three
    let (out, fix) = bridged(vec![
        prog(0..20, &a),
        gap(20..21),
        prog(21..40, &[(21, 1), (142, 2)]),
        gap(40..42),
        prog(42..60, &[(42, 1), (184, 2)]),
        gap(60..63),
        prog(63..80, &[(63, 1), (226, 2)]),
    ]);
    assert_eq!(fix, vec![20, 40, 41]);
    assert_eq!(
        out,
        vec![
            prog(0..60, &a),
            gap(60..63),
            prog(63..80, &[(63, 1), (226, 2)])
        ]
    );
    // another value, another step, or a gap at either end: nothing joined
    for next in [[(21, 1), (143, 2)], [(21, 1), (142, 3)]] {
        let pieces = vec![prog(0..20, &a), gap(20..21), prog(21..40, &next)];
        assert_eq!(bridged(pieces.clone()), (pieces, vec![]));
    }
    let pieces = vec![gap(0..1), prog(1..20, &a), gap(20..21)];
    assert_eq!(bridged(pieces.clone()), (pieces, vec![]));
}

/// Strings and membranes (progressions), a network above [`COMPACT_MAX`], and one whose
/// declaration order would cut its links into more runs, keep the gather step.
#[test]
fn regular_large_and_alternating_networks_keep_the_gather() {
    let chain = |net: &mut Network, n: usize| {
        let g = net.add_material(Material::Sol { x0: 0.0 });
        let ids = masses_at_rest(net, n);
        let law = Interaction::Ref { k: 0.1, z: 1e-4 };
        let mut prev = g;
        for &m in &ids {
            net.add_link(law.clone(), prev, m);
            prev = m;
        }
        net.add_link(law, prev, g);
        ids
    };
    let mut string = Network::new();
    chain(&mut string, 200);
    assert!(!Kernel::new(&string).compact);

    let mut large = irregular(1, COMPACT_MAX + 1);
    assert!(Kernel::build(&large, false, true).mostly_indexed());
    assert!(!Kernel::new(&large).compact);
    large = irregular(1, 300);
    assert!(Kernel::new(&large).compact);

    // short strings whose links are followed by devices of alternating laws, declared one
    // device at a time (as the string ring's bonds): stored by law, they form a few runs;
    // in declaration order, many
    let mut ring = Network::new();
    let ids = chain(&mut ring, 12);
    for i in 0..10 {
        let (a, b) = (ids[i], ids[(i + 5) % 12]);
        ring.add_link(
            Interaction::But {
                k: 0.1,
                z: 1e-3,
                s: 0.5,
            },
            a,
            b,
        );
        ring.add_link(
            Interaction::Lnl {
                lk: Curve::zero(),
                lz: Curve::new(&[(-1.0, -1e-3), (0.0, 0.0), (1.0, 0.0)]).unwrap_or_default(),
            },
            b,
            ids[(i + 2) % 12],
        );
    }
    let first = Kernel::build(&ring, false, false);
    assert!(first.mostly_indexed() && !first.in_declaration_order());
    assert!(Kernel::build(&ring, true, false).whole.runs.len() > first.whole.runs.len());
    assert!(!Kernel::new(&ring).compact);
}

/// A membrane of masses at rest whose rows end in ground links (one ground each), without
/// grounds above and below.
fn grounded_rows(rows: usize, cols: usize) -> Network {
    let mut net = Network::new();
    let m = masses_at_rest(&mut net, rows * cols);
    let law = Interaction::Ref { k: 0.1, z: 1e-4 };
    for r in 0..rows {
        let g = net.add_material(Material::Sol { x0: 0.0 });
        net.add_link(law.clone(), g, m[r * cols]);
        for c in 0..cols - 1 {
            net.add_link(law.clone(), m[r * cols + c], m[r * cols + c + 1]);
        }
        let g = net.add_material(Material::Sol { x0: 0.0 });
        net.add_link(law.clone(), m[r * cols + cols - 1], g);
    }
    for c in 0..cols {
        for r in 0..rows - 1 {
            net.add_link(law.clone(), m[r * cols + c], m[(r + 1) * cols + c]);
        }
    }
    net
}

/// Tiles are cut between the rows of a membrane (MAS segments shorter than a tile), hold at
/// most a tile each, and cover the moving materials in order; a string longer than a tile is
/// cut every tile.
#[test]
fn tiles_are_cut_between_rows() {
    let (rows, cols) = (30, 70);
    let net = grounded_rows(rows, cols);
    // (with exceptions, the rows would be one segment: see `bridged`)
    let k = Kernel::build(&net, false, false);
    let rows_of = |b: usize| b.is_multiple_of(cols);
    // (tiles of 1,024 materials, to cut this small membrane)
    let tile = 1024;
    let bounds = k.tile_bounds(tile);
    assert_eq!((bounds[0], *bounds.last().unwrap()), (0, rows * cols));
    assert!(bounds.len() > 2);
    for w in bounds.windows(2) {
        assert!(w[0] < w[1] && w[1] - w[0] <= tile, "{bounds:?}");
        assert!(rows_of(w[0]) && rows_of(w[1]), "a row is cut: {bounds:?}");
    }
    let bounds = k.tile_bounds(TILE);
    assert!(k
        .tiles
        .iter()
        .map(|t| t.mats.clone())
        .eq(bounds.windows(2).map(|w| w[0]..w[1])));
    // a string of 2,500 masses (one segment): cut every tile
    let mut string = Network::new();
    let s = masses_at_rest(&mut string, 2500);
    let law = Interaction::Ref { k: 0.1, z: 1e-4 };
    for w in s.windows(2) {
        string.add_link(law.clone(), w[0], w[1]);
    }
    let k = Kernel::new(&string);
    // (its two end masses, of degree 1, are a segment of their own, stored first)
    assert_eq!(k.tile_bounds(tile), vec![0, tile, 2 * tile, 2500]);
    assert_eq!(Kernel::new(&Network::new()).tile_bounds(TILE), vec![0, 0]);
}

/// The links of `run` (storage slots), a listed run's from its list.
fn slots_of(k: &Kernel, run: &Run) -> Vec<usize> {
    match run.ends {
        Ends::Listed { from, to } => (k.listed[from as usize..to as usize].iter())
            .map(|&l| l as usize)
            .collect(),
        _ => (run.start..run.end).collect(),
    }
}

/// The tiles compute every link exactly once, each listed run gathering short indexed runs
/// of one law and parameters: a membrane's row-end ground links are one loop per tile.
#[test]
fn short_runs_are_gathered_per_tile() {
    let (rows, cols) = (30, 70);
    let net = grounded_rows(rows, cols);
    let nets = [
        net,
        irregular(3, 40),
        irregular(8, 300),
        short_strings(60, 20),
    ];
    for (i, net) in nets.iter().enumerate() {
        let k = Kernel::build(net, false, true);
        let mut seen = vec![0; k.nl];
        for tile in &k.tiles {
            let runs = &k.tile_runs[tile.runs.clone()];
            for (j, run) in runs.iter().enumerate() {
                for l in slots_of(&k, run) {
                    assert!((run.start..run.end).contains(&l), "network {i}");
                    seen[l] += 1;
                }
                let short = |r: &Run| r.ends == Ends::Indexed && r.end - r.start < STEP_MIN;
                if short(run) || matches!(run.ends, Ends::Listed { .. }) {
                    // no two short or listed runs of one law could have been one
                    let key = |r: &Run| {
                        let bits = |v: &[f64]| v.get(r.start).map(|x| x.to_bits());
                        let params = r.uniform.then(|| (bits(&k.lk), bits(&k.lz)));
                        (r.law, r.uniform, params, k.lnl_of.get(r.start))
                    };
                    let twin = runs[j + 1..].iter().any(|r| {
                        (short(r) || matches!(r.ends, Ends::Listed { .. })) && key(r) == key(run)
                    });
                    assert!(!twin, "network {i}: {runs:?}");
                }
            }
        }
        assert!(seen.iter().all(|&c| c == 1), "network {i}: {seen:?}");
    }
    // the membrane without exceptions (whose rows are then segments and runs of their
    // own): per tile, one listed run of its rows' ground links
    let k = Kernel::build(&nets[0], false, false);
    for tile in &k.tiles {
        let runs = &k.tile_runs[tile.runs.clone()];
        let listed: Vec<&Run> = (runs.iter())
            .filter(|r| matches!(r.ends, Ends::Listed { .. }))
            .collect();
        assert_eq!(listed.len(), 1, "{runs:?}");
        let grounds = slots_of(&k, listed[0]);
        assert_eq!(grounds.len(), 2 * tile.mats.len() / cols);
        assert!(grounds
            .iter()
            .all(|&l| k.la[l].max(k.lb[l]) as usize >= k.n_mce));
        assert!(runs.iter().all(|r| r.ends != Ends::Indexed), "{runs:?}");
    }
}

/// The parts own every link exactly once, in runs that agree with the whole network's, and
/// cut the inputs and the materials into consecutive ranges.
fn check_parts(k: &Kernel, threads: usize) -> Vec<Part> {
    let parts = k.partition(threads, 3);
    assert_eq!(parts.len(), threads);
    let mut owned = vec![0u32; k.nl];
    for p in &parts {
        for r in &p.runs {
            assert!(r.start < r.end);
            let whole = k
                .whole
                .runs
                .iter()
                .find(|w| w.start <= r.start && r.end <= w.end);
            let whole = whole.expect("a piece of one run");
            assert_eq!((r.law, r.uniform), (whole.law, whole.uniform));
            if let Ends::Step { a0, sa, b0, sb } = r.ends {
                for (i, l) in (r.start..r.end).enumerate() {
                    if k.link_fix.binary_search(&(l as u32)).is_ok() {
                        continue; // an exception (see `bridged`)
                    }
                    assert_eq!(k.la[l], a0 + i as u32 * sa);
                    assert_eq!(k.lb[l], b0 + i as u32 * sb);
                }
            }
            for o in &mut owned[r.start..r.end] {
                *o += 1;
            }
        }
    }
    assert!(owned.iter().all(|&c| c == 1), "every link exactly once");
    for p in &parts {
        let mut next = 0;
        for c in &p.link_chunks {
            assert!(c.start == next && c.start < c.end);
            next = c.end;
        }
        assert_eq!(next, p.runs.len(), "the link chunks cover the runs");
        let mut next = p.mats.start;
        for c in &p.mat_chunks {
            assert!(c.start == next && c.start < c.end);
            next = c.end;
        }
        assert!(
            next == p.mats.end || p.mats.is_empty(),
            "the chunks cover the materials"
        );
    }
    let (mut m, mut e) = (0, 0);
    for p in &parts {
        assert_eq!((p.mats.start, p.enf.start), (m, e));
        (m, e) = (p.mats.end, p.enf.end);
    }
    assert_eq!((m, e), (k.n_mce, k.enf.len()));
    parts
}

#[test]
#[allow(clippy::needless_range_loop)] // `l` indexes three arrays
fn parts_own_every_link_once() {
    // a star of 30 links on one mass: by owner, all would go to one thread (contiguous instead)
    let mut net = Network::new();
    let a = net.add_material(Material::Mas {
        m: 1.0,
        x0: 0.0,
        v0: 0.0,
    });
    let b = net.add_material(Material::Sol { x0: 0.0 });
    for i in 0..30 {
        let law = if i < 20 {
            Interaction::Ref { k: 0.1, z: 0.0 }
        } else {
            Interaction::Res { k: 0.1 * i as f64 }
        };
        net.add_link(law, a, b);
    }
    let k = Kernel::new(&net);
    assert_eq!(k.whole.runs.len(), 2);
    assert!(k.whole.runs[0].uniform && !k.whole.runs[1].uniform);
    for threads in 1..=5 {
        let parts = check_parts(&k, threads);
        let links = |p: &Part| p.runs.iter().map(|r| r.end - r.start).sum::<usize>();
        assert!(
            parts.iter().all(|p| links(p) <= 30 / threads + 8),
            "balanced"
        );
    }
    // a membrane: by owner, so that the rows of each thread keep their links
    let (rows, cols) = (40, 60);
    let mut net = Network::new();
    let g = net.add_material(Material::Sol { x0: 0.0 });
    let m = masses_at_rest(&mut net, rows * cols);
    let law = Interaction::Ref { k: 0.1, z: 1e-4 };
    for r in 0..rows {
        net.add_link(law.clone(), g, m[r * cols]);
        for c in 0..cols - 1 {
            net.add_link(law.clone(), m[r * cols + c], m[r * cols + c + 1]);
        }
    }
    for c in 0..cols {
        net.add_link(law.clone(), g, m[c]);
        for r in 0..rows - 1 {
            net.add_link(law.clone(), m[r * cols + c], m[(r + 1) * cols + c]);
        }
    }
    let k = Kernel::new(&net);
    for threads in 1..=4 {
        check_parts(&k, threads);
    }
    // (with 4 threads of 10 rows the cache lines unbalance the threads: contiguous links)
    for threads in 2..=3 {
        let parts = check_parts(&k, threads);
        let mut owner = vec![0; k.nl];
        let (mut local, mut all) = (0, 0);
        for (t, p) in parts.iter().enumerate() {
            for r in &p.runs {
                for l in r.start..r.end {
                    owner[l] = t;
                    all += 1;
                    local += usize::from(p.mats.contains(&(k.lb[l] as usize)));
                }
            }
        }
        // the links of each thread end in its rows, but for a few where a cache line of force
        // slots is shared: then the whole line goes to one thread (`check_parts` used `line` 3)
        assert!(
            local * 100 >= all * 85,
            "{local} of {all} links in their thread's rows"
        );
        for line in owner[5..].chunks(8) {
            assert!(
                line.iter().all(|&t| t == line[0]),
                "a cache line for one thread"
            );
        }
    }
}

/// `all_finite`, the blow-up check's scan, says what `is_finite` says of every value: each
/// length to a few whole chunks and a remainder, each non-finite value at each place among
/// finite ones of every kind (the largest, subnormal, negative zero).
#[test]
fn all_finite_finds_every_non_finite_value() {
    let finite = [f64::MAX, -f64::MAX, f64::MIN_POSITIVE / 4.0, -0.0, 1.5, 0.0];
    for len in 0..=27 {
        let x: Vec<f64> = (0..len).map(|i| finite[i % finite.len()]).collect();
        assert!(all_finite(&x), "length {len}");
        for at in 0..len {
            for bad in [f64::NAN, f64::INFINITY, f64::NEG_INFINITY, -f64::NAN] {
                let mut y = x.clone();
                y[at] = bad;
                assert!(!all_finite(&y), "length {len}, {bad} at {at}");
            }
        }
    }
}
