//! The stepping side: a network compiled into dense struct-of-arrays state.

use crate::{Curve, Interaction, LinkId, MatId, Material, Network, Output, Probe, Signal};

/// The law of a run of consecutive links (in declaration order) that share it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Law {
    Res,
    Fro,
    Ref,
    But,
    Lnl,
}

/// Links `start..end` (declaration order) all have law `law`.
#[derive(Clone, Copy, Debug)]
struct Run {
    law: Law,
    start: usize,
    end: usize,
}

#[derive(Clone, Copy, Debug)]
struct Cel {
    m: f64,
    a: f64,
    b: f64,
    r: f64,
}

#[derive(Clone, Copy, Debug)]
enum Channel {
    Position(u32),
    Force(u32),
    /// terms `start..end` of `Engine::sum_terms`
    Sum(usize, usize),
}

#[derive(Clone, Copy, Debug)]
enum Term {
    Position(u32),
    Force(u32),
}

/// The state right after step `n`, as an observer sees it (see [`Engine::process_observed`]).
#[derive(Clone, Copy, Debug)]
pub struct StepView<'a> {
    n: u64,
    slot: &'a [u32],
    x: &'a [f64],
    xp: &'a [f64],
    lf: &'a [f64],
}

impl StepView<'_> {
    /// The step just computed.
    pub fn step(&self) -> u64 {
        self.n
    }

    /// `x(n)`: the position the interactions of step `n` saw.
    pub fn position(&self, m: MatId) -> f64 {
        self.xp[self.slot[m.index()] as usize]
    }

    /// `x(n+1)`: the position step `n` computed.
    pub fn next_position(&self, m: MatId) -> f64 {
        self.x[self.slot[m.index()] as usize]
    }

    /// `f(n)` of an interaction.
    pub fn link_force(&self, l: LinkId) -> f64 {
        self.lf[l.index()]
    }
}

/// Where and when a simulation blew up.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct BlowUp {
    /// The first sample index `n` at which some position `x(n)` is not finite.
    pub step: u64,
    /// The first material module, in declaration order, whose `x(n)` is not finite at that step.
    pub material: MatId,
    /// How many frames of the block that failed hold valid output (they record `x` up to `step-1`).
    pub valid_frames: usize,
}

impl std::fmt::Display for BlowUp {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "the position of material #{} became non-finite at sample {}",
            self.material.0, self.step
        )
    }
}

impl std::error::Error for BlowUp {}

/// A compiled network, ready to step.
///
/// Lifecycle (as in fundsp and nih-plug): [`Engine::new`] allocates everything; [`Engine::reset`]
/// returns to the initial conditions; [`Engine::process`] steps a block of frames into a caller
/// buffer and never allocates. Output is bit-for-bit deterministic and independent of how the
/// run is cut into blocks.
///
/// Storage: material modules are reordered by kind (MAS, CEL, ENX, SOL) so that each kind's update
/// is one tight loop. Links stay in declaration order, cut into runs of consecutive links with the
/// same law; each run is one loop that computes the force and adds it to both ends at once. Forces
/// therefore reach the materials in the declaration order of the links, then the ENF inputs in
/// theirs: the floating-point sums are exactly those of the plain, one-module-at-a-time definition,
/// and the output equals the reference stepper bit for bit.
#[derive(Clone, Debug)]
pub struct Engine {
    n: u64,
    // material state, storage order
    x: Vec<f64>,
    xp: Vec<f64>,
    f: Vec<f64>,
    x_init: Vec<f64>,
    xp_init: Vec<f64>,
    n_mas: usize,
    n_cel: usize,
    mas_m: Vec<f64>,
    cel: Vec<Cel>,
    enx: Vec<Signal>,
    /// storage slot of each material, by declaration index
    slot: Vec<u32>,
    /// MAS update multiplies by `1/M` instead of dividing by `M`: only when every MAS inertia is a
    /// power of two, where both give the same correctly rounded result.
    mas_inv: Option<Vec<f64>>,
    // links, in declaration order; every `la`/`lb` is < the number of materials (checked in `new`)
    runs: Vec<Run>,
    la: Vec<u32>,
    lb: Vec<u32>,
    lk: Vec<f64>,
    lz: Vec<f64>,
    ls: Vec<f64>,
    /// LNL curves, by declaration index of the link (empty curves for other laws)
    curves: Vec<(Curve, Curve)>,
    /// per-link force f(n), declaration order
    lf: Vec<f64>,
    // inputs and outputs
    enf_slot: Vec<u32>,
    enf: Vec<Signal>,
    channels: Vec<Channel>,
    sum_terms: Vec<(f64, Term)>,
    // blow-up handling
    snap_x: Vec<f64>,
    snap_xp: Vec<f64>,
    blown: Option<BlowUp>,
}

impl Engine {
    /// Compiles `net`. All allocation happens here.
    ///
    /// # Panics
    /// If a link, input or output refers to a module the network does not have (ids from another
    /// network): a programmer error. The model crate validates user input before building.
    #[track_caller]
    pub fn new(net: &Network) -> Engine {
        let nm = net.materials.len();
        let rank = |m: &Material| match m {
            Material::Mas { .. } => 0,
            Material::Cel { .. } => 1,
            Material::Enx { .. } => 2,
            Material::Sol { .. } => 3,
        };
        let mut order: Vec<usize> = (0..nm).collect();
        order.sort_by_key(|&i| rank(&net.materials[i])); // stable: declaration order within a kind
        let mut slot = vec![0u32; nm];
        for (s, &i) in order.iter().enumerate() {
            slot[i] = s as u32;
        }
        let mut e = Engine {
            n: 0,
            x: vec![0.0; nm],
            xp: vec![0.0; nm],
            f: vec![0.0; nm],
            x_init: vec![0.0; nm],
            xp_init: vec![0.0; nm],
            n_mas: 0,
            n_cel: 0,
            mas_m: Vec::new(),
            cel: Vec::new(),
            enx: Vec::new(),
            slot,
            mas_inv: None,
            runs: Vec::new(),
            la: Vec::new(),
            lb: Vec::new(),
            lk: Vec::new(),
            lz: Vec::new(),
            ls: Vec::new(),
            curves: Vec::new(),
            lf: vec![0.0; net.links.len()],
            enf_slot: Vec::new(),
            enf: Vec::new(),
            channels: Vec::new(),
            sum_terms: Vec::new(),
            snap_x: vec![0.0; nm],
            snap_xp: vec![0.0; nm],
            blown: None,
        };
        for (s, &i) in order.iter().enumerate() {
            let m = &net.materials[i];
            let (x0, xm1) = m.initial_state();
            e.x_init[s] = x0;
            e.xp_init[s] = xm1;
            match m {
                Material::Mas { m, .. } => {
                    e.n_mas += 1;
                    e.mas_m.push(*m);
                }
                Material::Cel { m, k, z, r, .. } => {
                    e.n_cel += 1;
                    e.cel.push(Cel {
                        m: *m,
                        a: 2.0 - (k + z) / m,
                        b: z / m - 1.0,
                        r: *r,
                    });
                }
                Material::Enx { signal } => e.enx.push(signal.clone()),
                Material::Sol { .. } => {}
            }
        }
        let slot_of = |id: MatId| -> u32 {
            assert!(
                id.index() < nm,
                "link or input refers to material #{} of {nm}",
                id.0
            );
            e.slot[id.index()]
        };
        let nl = net.links.len();
        let (mut la, mut lb) = (Vec::with_capacity(nl), Vec::with_capacity(nl));
        let (mut lk, mut lz, mut ls) = (vec![0.0; nl], vec![0.0; nl], vec![0.0; nl]);
        let mut curves = vec![(Curve::zero(), Curve::zero()); nl];
        let mut runs: Vec<Run> = Vec::new();
        for (l, link) in net.links.iter().enumerate() {
            la.push(slot_of(link.a));
            lb.push(slot_of(link.b));
            let law = match &link.law {
                Interaction::Res { k } => {
                    lk[l] = *k;
                    Law::Res
                }
                Interaction::Fro { z } => {
                    lz[l] = *z;
                    Law::Fro
                }
                Interaction::Ref { k, z } => {
                    (lk[l], lz[l]) = (*k, *z);
                    Law::Ref
                }
                Interaction::But { k, z, s } => {
                    (lk[l], lz[l], ls[l]) = (*k, *z, *s);
                    Law::But
                }
                Interaction::Lnl { lk: ck, lz: cz } => {
                    curves[l] = (ck.clone(), cz.clone());
                    Law::Lnl
                }
            };
            match runs.last_mut() {
                Some(r) if r.law == law => r.end = l + 1,
                _ => runs.push(Run {
                    law,
                    start: l,
                    end: l + 1,
                }),
            }
        }
        let mut enf_slot = Vec::with_capacity(net.forces.len());
        for fi in &net.forces {
            enf_slot.push(slot_of(fi.target));
        }
        let check_link = |l: LinkId| -> u32 {
            assert!(l.index() < nl, "output refers to link #{} of {nl}", l.0);
            l.0
        };
        let mut sum_terms = Vec::new();
        let mut channels = Vec::with_capacity(net.outputs.len());
        for o in &net.outputs {
            channels.push(match o {
                Output::Position(m) => Channel::Position(slot_of(*m)),
                Output::Force(l) => Channel::Force(check_link(*l)),
                Output::Sum(terms) => {
                    assert!(!terms.is_empty(), "a sum output needs at least one term");
                    let start = sum_terms.len();
                    for &(g, p) in terms {
                        sum_terms.push((
                            g,
                            match p {
                                Probe::Position(m) => Term::Position(slot_of(m)),
                                Probe::Force(l) => Term::Force(check_link(l)),
                            },
                        ));
                    }
                    Channel::Sum(start, sum_terms.len())
                }
            });
        }
        (e.runs, e.la, e.lb, e.lk, e.lz, e.ls, e.curves) = (runs, la, lb, lk, lz, ls, curves);
        if e.mas_m.iter().all(|&m| is_power_of_two(m)) {
            e.mas_inv = Some(e.mas_m.iter().map(|m| 1.0 / m).collect());
        }
        e.enf_slot = enf_slot;
        e.enf = net.forces.iter().map(|f| f.signal.clone()).collect();
        e.channels = channels;
        e.sum_terms = sum_terms;
        e.reset();
        e
    }

    /// Back to the initial conditions, step 0.
    pub fn reset(&mut self) {
        self.n = 0;
        self.x.copy_from_slice(&self.x_init);
        self.xp.copy_from_slice(&self.xp_init);
        self.f.fill(0.0);
        self.lf.fill(0.0);
        self.blown = None;
    }

    /// Number of output channels (SOX and SOF, in declaration order).
    pub fn channels(&self) -> usize {
        self.channels.len()
    }

    /// The index `n` of the next step.
    pub fn step_index(&self) -> u64 {
        self.n
    }

    /// Number of material modules.
    pub fn material_count(&self) -> usize {
        self.x.len()
    }

    /// `x(n)` of a material module, `n` being [`Engine::step_index`].
    pub fn position(&self, m: MatId) -> f64 {
        self.x[self.slot[m.index()] as usize]
    }

    /// `x(n-1)` of a material module.
    pub fn previous_position(&self, m: MatId) -> f64 {
        self.xp[self.slot[m.index()] as usize]
    }

    /// `f(n-1)`: the force the interaction computed at the last step (0 before the first).
    pub fn link_force(&self, l: LinkId) -> f64 {
        self.lf[l.index()]
    }

    /// Steps `frames` times, writing one frame of [`Engine::channels`] values per step into `out`
    /// (frames interleaved over channels). Never allocates.
    ///
    /// After every block the positions are checked; if one is not finite, the block is replayed
    /// from a snapshot to find the first step and module that went bad, and a [`BlowUp`] is
    /// returned. The engine then refuses to step until [`Engine::reset`].
    ///
    /// # Panics
    /// If `out.len() != frames * self.channels()`.
    #[track_caller]
    pub fn process(&mut self, frames: usize, out: &mut [f64]) -> Result<(), BlowUp> {
        self.process_observed(frames, out, &mut |_: &StepView<'_>| {})
    }

    /// [`Engine::process`], calling `observe` after every step with a view of the state (for
    /// event logs and energy meters). With a no-op observer this is exactly `process`.
    ///
    /// The observer sees each step once, in order. When a block blows up it has also seen the
    /// steps of that block up to its end (non-finite values included): discard what it gathered.
    #[track_caller]
    pub fn process_observed<O: FnMut(&StepView<'_>)>(
        &mut self,
        frames: usize,
        out: &mut [f64],
        observe: &mut O,
    ) -> Result<(), BlowUp> {
        let ch = self.channels.len();
        assert_eq!(
            out.len(),
            frames * ch,
            "output buffer must hold frames * channels values"
        );
        if let Some(b) = self.blown {
            return Err(BlowUp {
                valid_frames: 0,
                ..b
            });
        }
        self.snap_x.copy_from_slice(&self.x);
        self.snap_xp.copy_from_slice(&self.xp);
        let n0 = self.n;
        for frame in 0..frames {
            self.step(&mut out[frame * ch..(frame + 1) * ch]);
            observe(&StepView {
                n: self.n - 1,
                slot: &self.slot,
                x: &self.x,
                xp: &self.xp,
                lf: &self.lf,
            });
        }
        if self.x.iter().all(|v| v.is_finite()) {
            return Ok(());
        }
        // Replay the block one step at a time to find the first bad step and module.
        self.n = n0;
        self.x.copy_from_slice(&self.snap_x);
        self.xp.copy_from_slice(&self.snap_xp);
        self.f.fill(0.0);
        for frame in 0..frames {
            self.step(&mut out[frame * ch..(frame + 1) * ch]);
            if let Some(bad) = self.first_non_finite() {
                out[(frame + 1) * ch..].fill(0.0);
                let b = BlowUp {
                    step: self.n,
                    material: bad,
                    valid_frames: frame + 1,
                };
                self.blown = Some(b);
                return Err(b);
            }
        }
        unreachable!("a replay from the same state must reproduce the same non-finite position")
    }

    /// The forces of the links of the last step, in declaration order.
    pub fn link_forces(&self) -> &[f64] {
        &self.lf
    }

    fn first_non_finite(&self) -> Option<MatId> {
        self.slot
            .iter()
            .position(|&s| !self.x[s as usize].is_finite())
            .map(|i| MatId(i as u32))
    }

    /// One step: link forces, accumulation, inputs, outputs, material update.
    #[inline]
    fn step(&mut self, frame: &mut [f64]) {
        let n = self.n;

        // 1-2. Interaction forces f(n) from x(n), x(n-1), added to the ends in declaration order
        // (end 1 gets -f, end 2 gets +f); then the ENF inputs.
        for run in &self.runs {
            let r = run.start..run.end;
            let (la, lb, lf) = (
                &self.la[r.clone()],
                &self.lb[r.clone()],
                &mut self.lf[r.clone()],
            );
            let state = State {
                x: &self.x,
                xp: &self.xp,
            };
            let f = &mut self.f;
            match run.law {
                Law::Res => {
                    for (((&a, &b), out), &k) in la.iter().zip(lb).zip(lf).zip(&self.lk[r]) {
                        let fl = k * state.d(a, b);
                        *out = fl;
                        add(f, a, b, fl);
                    }
                }
                Law::Fro => {
                    for (((&a, &b), out), &z) in la.iter().zip(lb).zip(lf).zip(&self.lz[r]) {
                        let fl = z * state.v(a, b);
                        *out = fl;
                        add(f, a, b, fl);
                    }
                }
                Law::Ref => {
                    for ((((&a, &b), out), &k), &z) in la
                        .iter()
                        .zip(lb)
                        .zip(lf)
                        .zip(&self.lk[r.clone()])
                        .zip(&self.lz[r])
                    {
                        let fl = k * state.d(a, b) + z * state.v(a, b);
                        *out = fl;
                        add(f, a, b, fl);
                    }
                }
                Law::But => {
                    let (lk, lz, ls) = (&self.lk[r.clone()], &self.lz[r.clone()], &self.ls[r]);
                    for (i, ((&a, &b), out)) in la.iter().zip(lb).zip(lf).enumerate() {
                        let (k, z, s) = (lk[i], lz[i], ls[i]);
                        let fl = if state.x(b) - state.x(a) < s {
                            k * (state.d(a, b) + s) + z * state.v(a, b)
                        } else {
                            0.0
                        };
                        *out = fl;
                        add(f, a, b, fl);
                    }
                }
                Law::Lnl => {
                    for (((&a, &b), out), (ck, cz)) in
                        la.iter().zip(lb).zip(lf).zip(&self.curves[r])
                    {
                        let fl = ck.eval(state.d(a, b)) + cz.eval(state.v(a, b));
                        *out = fl;
                        add(f, a, b, fl);
                    }
                }
            }
        }
        let (f, lf) = (&mut self.f, &self.lf);
        for (&s, sig) in self.enf_slot.iter().zip(&self.enf) {
            f[s as usize] += sig.at(n);
        }

        // 3. Outputs record x(n) and f(n).
        let (x, terms) = (&self.x, &self.sum_terms);
        let term = |t: &Term| match *t {
            Term::Position(s) => x[s as usize],
            Term::Force(l) => lf[l as usize],
        };
        for (o, c) in frame.iter_mut().zip(&self.channels) {
            *o = match *c {
                Channel::Position(s) => x[s as usize],
                Channel::Force(l) => lf[l as usize],
                Channel::Sum(a, b) => {
                    let (g0, t0) = &terms[a];
                    let mut acc = g0 * term(t0);
                    for (g, t) in &terms[a + 1..b] {
                        acc += g * term(t);
                    }
                    acc
                }
            };
        }

        // 4. Materials compute x(n+1).
        let (x, xp) = (&mut self.x, &mut self.xp);
        let nm = self.n_mas;
        let mas = x[..nm].iter_mut().zip(&mut xp[..nm]).zip(&mut f[..nm]);
        match &self.mas_inv {
            Some(inv) => {
                for (((xi, xpi), fi), &im) in mas.zip(inv) {
                    let next = 2.0 * *xi - *xpi + *fi * im;
                    *xpi = *xi;
                    *xi = next;
                    *fi = 0.0;
                }
            }
            None => {
                for (((xi, xpi), fi), &m) in mas.zip(&self.mas_m) {
                    let next = 2.0 * *xi - *xpi + *fi / m;
                    *xpi = *xi;
                    *xi = next;
                    *fi = 0.0;
                }
            }
        }
        let cel_end = nm + self.n_cel;
        for (((xi, xpi), fi), c) in x[nm..cel_end]
            .iter_mut()
            .zip(&mut xp[nm..cel_end])
            .zip(&mut f[nm..cel_end])
            .zip(&self.cel)
        {
            let next = c.r + c.a * (*xi - c.r) + c.b * (*xpi - c.r) + *fi / c.m;
            *xpi = *xi;
            *xi = next;
            *fi = 0.0;
        }
        let enx_end = cel_end + self.enx.len();
        for (((xi, xpi), fi), sig) in x[cel_end..enx_end]
            .iter_mut()
            .zip(&mut xp[cel_end..enx_end])
            .zip(&mut f[cel_end..enx_end])
            .zip(&self.enx)
        {
            *xpi = *xi;
            *xi = sig.at(n + 1);
            *fi = 0.0;
        }
        f[enx_end..].fill(0.0); // SOL: forces discarded, position unchanged
        self.n = n + 1;
    }
}

/// True when `m` is a (normal) power of two, so that `f / m == f * (1 / m)` for every `f`: both are
/// the correctly rounded value of the same real number `f * 2^-k`.
fn is_power_of_two(m: f64) -> bool {
    let bits = m.to_bits();
    let exponent = (bits >> 52) & 0x7ff;
    m > 0.0
        && bits & ((1u64 << 52) - 1) == 0
        && exponent != 0
        && exponent != 0x7ff
        && (1.0 / m).is_normal()
}

/// Read access to the positions by storage slot, for the link loops.
///
/// Every slot handed to these methods comes from `Engine::la`/`Engine::lb`, which `Engine::new`
/// fills only with `slot_of(..)` values, each asserted `< materials.len()`; `x` and `xp` have
/// exactly `materials.len()` elements and are never resized. So every access is in bounds, and the
/// unchecked reads below are sound. `tests/engine.rs` (`engine_refuses_foreign_ids`) checks that a
/// network with an out-of-range id is refused by `Engine::new` before any step.
struct State<'a> {
    x: &'a [f64],
    xp: &'a [f64],
}

impl State<'_> {
    #[inline(always)]
    fn x(&self, i: u32) -> f64 {
        debug_assert!((i as usize) < self.x.len());
        // SAFETY: `i` is a validated storage slot (see the type's documentation).
        unsafe { *self.x.get_unchecked(i as usize) }
    }

    #[inline(always)]
    fn xp(&self, i: u32) -> f64 {
        debug_assert!((i as usize) < self.xp.len());
        // SAFETY: as for `x`; `xp` has the same length.
        unsafe { *self.xp.get_unchecked(i as usize) }
    }

    /// `d = x1(n) - x2(n)`.
    #[inline(always)]
    fn d(&self, a: u32, b: u32) -> f64 {
        self.x(a) - self.x(b)
    }

    /// `v = (x1(n) - x1(n-1)) - (x2(n) - x2(n-1))`.
    #[inline(always)]
    fn v(&self, a: u32, b: u32) -> f64 {
        (self.x(a) - self.xp(a)) - (self.x(b) - self.xp(b))
    }
}

/// End 1 receives `-fl`, end 2 receives `+fl`.
#[inline(always)]
fn add(f: &mut [f64], a: u32, b: u32, fl: f64) {
    debug_assert!((a as usize) < f.len() && (b as usize) < f.len());
    // SAFETY: `a` and `b` are validated storage slots (see `State`), and `f` has one element per
    // material, like `x`.
    unsafe {
        *f.get_unchecked_mut(a as usize) -= fl;
        *f.get_unchecked_mut(b as usize) += fl;
    }
}
