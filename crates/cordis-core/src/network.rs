//! The editing side: a network addressed by typed ids.

use crate::{Curve, Signal};

/// A material module's id: its position in declaration order among material modules.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
#[repr(transparent)]
pub struct MatId(pub u32);

/// An interaction's id: its position in declaration order among interactions.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
#[repr(transparent)]
pub struct LinkId(pub u32);

impl MatId {
    /// The id as an index.
    pub fn index(self) -> usize {
        self.0 as usize
    }
}

impl LinkId {
    /// The id as an index.
    pub fn index(self) -> usize {
        self.0 as usize
    }
}

/// A material module (`<MAT>`): a point with a position `x(n)`.
///
/// All parameters are in GENESIS units: inertia `M`, stiffness `K = k/Fs^2`, viscosity
/// `Z = z/Fs`, velocity `V0 = v/Fs` (length per sample). Initial conditions:
/// `x(0) = X0`, `x(-1) = X0 - V0`.
#[derive(Clone, Debug, PartialEq)]
pub enum Material {
    /// Ideal mass: `x(n+1) = 2 x(n) - x(n-1) + F(n) / M`.
    Mas {
        /// Inertia, > 0.
        m: f64,
        /// Initial position.
        x0: f64,
        /// Initial velocity (length per sample).
        v0: f64,
    },
    /// Fixed point: `x(n+1) = x(n)`. Forces on it are discarded.
    Sol {
        /// Its position.
        x0: f64,
    },
    /// Damped oscillator: a mass tied to the rest point `R` by a spring `K` and a damper `Z`:
    /// `x(n+1) = R + (2 - (K+Z)/M)(x(n)-R) + (Z/M - 1)(x(n-1)-R) + F(n)/M`.
    Cel {
        /// Inertia, > 0.
        m: f64,
        /// Stiffness to the rest point.
        k: f64,
        /// Viscosity to the rest point.
        z: f64,
        /// Initial position.
        x0: f64,
        /// Initial velocity (length per sample).
        v0: f64,
        /// Rest point.
        r: f64,
    },
    /// Position input: `x(n) = signal(n)`, `x(-1) = signal(0)`. Forces on it are discarded.
    Enx {
        /// The imposed position.
        signal: Signal,
    },
}

/// An interaction (`<LIA>`) law. With `d = x1(n) - x2(n)` and
/// `v = (x1(n) - x1(n-1)) - (x2(n) - x2(n-1))`, it computes `f(n)`; end 1 receives `-f(n)` and
/// end 2 receives `+f(n)`.
#[derive(Clone, Debug, PartialEq)]
pub enum Interaction {
    /// Spring of null length: `f = K d`.
    Res {
        /// Stiffness.
        k: f64,
    },
    /// Damper: `f = Z v`.
    Fro {
        /// Viscosity.
        z: f64,
    },
    /// Spring and damper: `f = K d + Z v`.
    Ref {
        /// Stiffness.
        k: f64,
        /// Viscosity.
        z: f64,
    },
    /// Conditional spring and damper (contact, buffer), oriented:
    /// `f = K (d + S) + Z v` while `x2 - x1 < S`, else 0.
    But {
        /// Stiffness.
        k: f64,
        /// Viscosity.
        z: f64,
        /// Threshold.
        s: f64,
    },
    /// User-defined nonlinear law: `f = LK(d) + LZ(v)`.
    Lnl {
        /// Elastic curve over `d`.
        lk: Curve,
        /// Viscous curve over `v`.
        lz: Curve,
    },
}

impl Interaction {
    /// The GENESIS name of the law (`"REF"`, ...).
    pub fn kind(&self) -> &'static str {
        match self {
            Interaction::Res { .. } => "RES",
            Interaction::Fro { .. } => "FRO",
            Interaction::Ref { .. } => "REF",
            Interaction::But { .. } => "BUT",
            Interaction::Lnl { .. } => "LNL",
        }
    }

    /// The force for elongation `d` and relative velocity `v`, with the exact arithmetic of the
    /// formalism (the engine computes the same expressions, in bulk).
    #[inline]
    pub fn force(&self, x1: f64, x2: f64, d: f64, v: f64) -> f64 {
        match self {
            Interaction::Res { k } => k * d,
            Interaction::Fro { z } => z * v,
            Interaction::Ref { k, z } => k * d + z * v,
            Interaction::But { k, z, s } => {
                if x2 - x1 < *s {
                    k * (d + s) + z * v
                } else {
                    0.0
                }
            }
            Interaction::Lnl { lk, lz } => lk.eval(d) + lz.eval(v),
        }
    }
}

impl Material {
    /// The GENESIS name of the module (`"MAS"`, ...).
    pub fn kind(&self) -> &'static str {
        match self {
            Material::Mas { .. } => "MAS",
            Material::Sol { .. } => "SOL",
            Material::Cel { .. } => "CEL",
            Material::Enx { .. } => "ENX",
        }
    }

    /// `(x(0), x(-1))`.
    pub fn initial_state(&self) -> (f64, f64) {
        match self {
            Material::Mas { x0, v0, .. } | Material::Cel { x0, v0, .. } => (*x0, x0 - v0),
            Material::Sol { x0 } => (*x0, *x0),
            Material::Enx { signal } => (signal.at(0), signal.at(0)),
        }
    }

    /// True for modules whose position the forces move (MAS, CEL).
    pub fn is_mobile(&self) -> bool {
        matches!(self, Material::Mas { .. } | Material::Cel { .. })
    }
}

/// An interaction placed between two material modules.
#[derive(Clone, Debug, PartialEq)]
pub struct Link {
    /// Its law.
    pub law: Interaction,
    /// End 1 (receives `-f`).
    pub a: MatId,
    /// End 2 (receives `+f`).
    pub b: MatId,
}

/// A force input (ENF) on one material module.
#[derive(Clone, Debug, PartialEq)]
pub struct ForceInput {
    /// The module that receives the force.
    pub target: MatId,
    /// The force, one value per step.
    pub signal: Signal,
}

/// What a recorder reads: the position of a material module or the force of an interaction.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Probe {
    /// `x(n)` of a material module.
    Position(MatId),
    /// `f(n)` of an interaction.
    Force(LinkId),
}

/// A recorder: one output channel.
#[derive(Clone, Debug, PartialEq)]
pub enum Output {
    /// SOX: the position `x(n)` of a material module.
    Position(MatId),
    /// SOF: the force `f(n)` of an interaction.
    Force(LinkId),
    /// A weighted sum of probes, `g1 p1 + g2 p2 + ...`, evaluated left to right starting from
    /// `g1 p1` (so a single term with gain 1 is exactly its probe).
    Sum(Vec<(f64, Probe)>),
}

/// A network under construction: materials, links, force inputs and outputs, in declaration order.
///
/// Ids are handed out by the `add_*` methods and are only valid for the network that made them;
/// using a foreign id is a programmer error and panics.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Network {
    /// Material modules in declaration order (`MatId` indexes this).
    pub materials: Vec<Material>,
    /// Interactions in declaration order (`LinkId` indexes this).
    pub links: Vec<Link>,
    /// Force inputs, applied in this order after the interactions.
    pub forces: Vec<ForceInput>,
    /// Output channels, in this order.
    pub outputs: Vec<Output>,
}

impl Network {
    /// An empty network.
    pub fn new() -> Network {
        Network::default()
    }

    /// Adds a material module.
    pub fn add_material(&mut self, m: Material) -> MatId {
        let id = MatId(u32::try_from(self.materials.len()).expect("more than 2^32 materials"));
        self.materials.push(m);
        id
    }

    /// Adds an interaction from end 1 `a` to end 2 `b`.
    #[track_caller]
    pub fn add_link(&mut self, law: Interaction, a: MatId, b: MatId) -> LinkId {
        assert!(
            a.index() < self.materials.len() && b.index() < self.materials.len(),
            "foreign MatId"
        );
        let id = LinkId(u32::try_from(self.links.len()).expect("more than 2^32 links"));
        self.links.push(Link { law, a, b });
        id
    }

    /// Adds a force input on `target`.
    #[track_caller]
    pub fn add_force(&mut self, target: MatId, signal: Signal) {
        assert!(target.index() < self.materials.len(), "foreign MatId");
        self.forces.push(ForceInput { target, signal });
    }

    /// Adds a SOX channel recording `x(n)` of `m`; returns the channel index.
    #[track_caller]
    pub fn add_position_output(&mut self, m: MatId) -> usize {
        assert!(m.index() < self.materials.len(), "foreign MatId");
        self.outputs.push(Output::Position(m));
        self.outputs.len() - 1
    }

    /// Adds a channel recording a weighted sum of positions and forces; returns the channel index.
    ///
    /// # Panics
    /// If `terms` is empty or refers to a module the network does not have.
    #[track_caller]
    pub fn add_sum_output(&mut self, terms: Vec<(f64, Probe)>) -> usize {
        assert!(!terms.is_empty(), "a sum output needs at least one term");
        for (_, p) in &terms {
            match p {
                Probe::Position(m) => assert!(m.index() < self.materials.len(), "foreign MatId"),
                Probe::Force(l) => assert!(l.index() < self.links.len(), "foreign LinkId"),
            }
        }
        self.outputs.push(Output::Sum(terms));
        self.outputs.len() - 1
    }

    /// Adds a SOF channel recording `f(n)` of `l`; returns the channel index.
    #[track_caller]
    pub fn add_force_output(&mut self, l: LinkId) -> usize {
        assert!(l.index() < self.links.len(), "foreign LinkId");
        self.outputs.push(Output::Force(l));
        self.outputs.len() - 1
    }

    /// Appends a copy of `other`: its materials, links, force inputs and outputs, declared after
    /// this network's, in their order, each tied to `other`'s modules' copies. Returns the id
    /// here of `other`'s first material: `other`'s `MatId(i)` is `MatId(first.0 + i)` here, and
    /// its `LinkId(j)` is `LinkId(l + j)`, `l` this network's link count before the call.
    ///
    /// # Panics
    /// If the networks together have more than 2^32 materials or links.
    #[track_caller]
    pub fn append(&mut self, other: &Network) -> MatId {
        let (m0, l0) = (self.materials.len(), self.links.len());
        let shift = |n: usize| u32::try_from(n).expect("more than 2^32 modules");
        let mat = |m: MatId| MatId(shift(m0 + m.index()));
        let link = |l: LinkId| LinkId(shift(l0 + l.index()));
        self.materials.extend(other.materials.iter().cloned());
        shift(self.materials.len());
        let links = other.links.iter().map(|l| Link {
            law: l.law.clone(),
            a: mat(l.a),
            b: mat(l.b),
        });
        self.links.extend(links);
        shift(self.links.len());
        let forces = other.forces.iter().map(|f| ForceInput {
            target: mat(f.target),
            signal: f.signal.clone(),
        });
        self.forces.extend(forces);
        let probe = |p: &Probe| match *p {
            Probe::Position(m) => Probe::Position(mat(m)),
            Probe::Force(l) => Probe::Force(link(l)),
        };
        let outputs = other.outputs.iter().map(|o| match o {
            Output::Position(m) => Output::Position(mat(*m)),
            Output::Force(l) => Output::Force(link(*l)),
            Output::Sum(terms) => Output::Sum(terms.iter().map(|(g, p)| (*g, probe(p))).collect()),
        });
        self.outputs.extend(outputs);
        mat(MatId(0))
    }

    /// Number of modules of every kind (materials, links, force inputs, outputs).
    pub fn module_count(&self) -> usize {
        self.materials.len() + self.links.len() + self.forces.len() + self.outputs.len()
    }
}
