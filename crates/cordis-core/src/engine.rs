//! The stepping side: a network compiled into dense struct-of-arrays state.

use crate::{Curve, Interaction, LinkId, MatId, Material, Network, Output, Signal};

/// Links of one law, stored as parallel arrays. `a`/`b` are storage slots of the ends, `out` the
/// link's declaration index (where its force goes in the per-link force array).
#[derive(Clone, Debug, Default)]
struct Group<P> {
    a: Vec<u32>,
    b: Vec<u32>,
    out: Vec<u32>,
    p: Vec<P>,
}

impl<P> Group<P> {
    fn push(&mut self, a: u32, b: u32, out: u32, p: P) {
        self.a.push(a);
        self.b.push(b);
        self.out.push(out);
        self.p.push(p);
    }
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
/// is one tight loop; links are grouped by law. Forces are accumulated onto the materials in the
/// declaration order of the links, then ENF inputs in their order, so the floating-point sums are
/// exactly the ones of the plain, one-module-at-a-time definition.
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
    // links
    res: Group<f64>,
    fro: Group<f64>,
    refs: Group<(f64, f64)>,
    but: Group<(f64, f64, f64)>,
    lnl: Group<(Curve, Curve)>,
    /// per-link force f(n), declaration order
    lf: Vec<f64>,
    /// ends of each link in declaration order (storage slots)
    la: Vec<u32>,
    lb: Vec<u32>,
    // inputs and outputs
    enf_slot: Vec<u32>,
    enf: Vec<Signal>,
    channels: Vec<Channel>,
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
            res: Group::default(),
            fro: Group::default(),
            refs: Group::default(),
            but: Group::default(),
            lnl: Group::default(),
            lf: vec![0.0; net.links.len()],
            la: Vec::with_capacity(net.links.len()),
            lb: Vec::with_capacity(net.links.len()),
            enf_slot: Vec::new(),
            enf: Vec::new(),
            channels: Vec::new(),
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
        let mut groups = (
            Group::default(),
            Group::default(),
            Group::default(),
            Group::default(),
            Group::default(),
        );
        let mut la = Vec::with_capacity(net.links.len());
        let mut lb = Vec::with_capacity(net.links.len());
        for (l, link) in net.links.iter().enumerate() {
            let (a, b, o) = (slot_of(link.a), slot_of(link.b), l as u32);
            la.push(a);
            lb.push(b);
            match &link.law {
                Interaction::Res { k } => groups.0.push(a, b, o, *k),
                Interaction::Fro { z } => groups.1.push(a, b, o, *z),
                Interaction::Ref { k, z } => groups.2.push(a, b, o, (*k, *z)),
                Interaction::But { k, z, s } => groups.3.push(a, b, o, (*k, *z, *s)),
                Interaction::Lnl { lk, lz } => groups.4.push(a, b, o, (lk.clone(), lz.clone())),
            }
        }
        let mut enf_slot = Vec::with_capacity(net.forces.len());
        for fi in &net.forces {
            enf_slot.push(slot_of(fi.target));
        }
        let channels = net
            .outputs
            .iter()
            .map(|o| match *o {
                Output::Position(m) => Channel::Position(slot_of(m)),
                Output::Force(l) => {
                    assert!(
                        l.index() < net.links.len(),
                        "output refers to link #{}",
                        l.0
                    );
                    Channel::Force(l.0)
                }
            })
            .collect();
        (e.res, e.fro, e.refs, e.but, e.lnl) = groups;
        e.la = la;
        e.lb = lb;
        e.enf_slot = enf_slot;
        e.enf = net.forces.iter().map(|f| f.signal.clone()).collect();
        e.channels = channels;
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
        let (x, xp, lf) = (&self.x, &self.xp, &mut self.lf);

        // 1. Interaction forces f(n) from x(n), x(n-1).
        for (((&a, &b), &o), &k) in self
            .res
            .a
            .iter()
            .zip(&self.res.b)
            .zip(&self.res.out)
            .zip(&self.res.p)
        {
            let d = x[a as usize] - x[b as usize];
            lf[o as usize] = k * d;
        }
        for (((&a, &b), &o), &z) in self
            .fro
            .a
            .iter()
            .zip(&self.fro.b)
            .zip(&self.fro.out)
            .zip(&self.fro.p)
        {
            let (a, b) = (a as usize, b as usize);
            let v = (x[a] - xp[a]) - (x[b] - xp[b]);
            lf[o as usize] = z * v;
        }
        for (((&a, &b), &o), &(k, z)) in self
            .refs
            .a
            .iter()
            .zip(&self.refs.b)
            .zip(&self.refs.out)
            .zip(&self.refs.p)
        {
            let (a, b) = (a as usize, b as usize);
            let d = x[a] - x[b];
            let v = (x[a] - xp[a]) - (x[b] - xp[b]);
            lf[o as usize] = k * d + z * v;
        }
        for (((&a, &b), &o), &(k, z, s)) in self
            .but
            .a
            .iter()
            .zip(&self.but.b)
            .zip(&self.but.out)
            .zip(&self.but.p)
        {
            let (a, b) = (a as usize, b as usize);
            lf[o as usize] = if x[b] - x[a] < s {
                let d = x[a] - x[b];
                let v = (x[a] - xp[a]) - (x[b] - xp[b]);
                k * (d + s) + z * v
            } else {
                0.0
            };
        }
        for (((&a, &b), &o), (lk, lz)) in self
            .lnl
            .a
            .iter()
            .zip(&self.lnl.b)
            .zip(&self.lnl.out)
            .zip(&self.lnl.p)
        {
            let (a, b) = (a as usize, b as usize);
            let d = x[a] - x[b];
            let v = (x[a] - xp[a]) - (x[b] - xp[b]);
            lf[o as usize] = lk.eval(d) + lz.eval(v);
        }

        // 2. Accumulate: end 1 gets -f, end 2 gets +f, in declaration order; then ENF inputs.
        let f = &mut self.f;
        for ((&a, &b), &fl) in self.la.iter().zip(&self.lb).zip(lf.iter()) {
            f[a as usize] -= fl;
            f[b as usize] += fl;
        }
        for (&s, sig) in self.enf_slot.iter().zip(&self.enf) {
            f[s as usize] += sig.at(n);
        }

        // 3. Outputs record x(n) and f(n).
        for (o, c) in frame.iter_mut().zip(&self.channels) {
            *o = match *c {
                Channel::Position(s) => self.x[s as usize],
                Channel::Force(l) => lf[l as usize],
            };
        }

        // 4. Materials compute x(n+1).
        let (x, xp) = (&mut self.x, &mut self.xp);
        let nm = self.n_mas;
        for (((xi, xpi), fi), &m) in x[..nm]
            .iter_mut()
            .zip(&mut xp[..nm])
            .zip(&mut f[..nm])
            .zip(&self.mas_m)
        {
            let next = 2.0 * *xi - *xpi + *fi / m;
            *xpi = *xi;
            *xi = next;
            *fi = 0.0;
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
