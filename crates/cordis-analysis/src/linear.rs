//! The linearised network: inertia, stiffness and damping matrices over the mobile modules.

use cordis_core::{Interaction, MatId, Material, Output, Probe};
use cordis_model::Model;

use crate::AnalysisError;

/// A symmetric sparse matrix over the degrees of freedom, as its diagonal and its upper
/// off-diagonal entries `(i, j, value)` with `i < j` (each pair once, summed).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct SymSparse {
    /// Diagonal entries.
    pub diag: Vec<f64>,
    /// Off-diagonal entries `(i, j, v)`, `i < j`; the matrix holds `v` at `(i, j)` and `(j, i)`.
    pub off: Vec<(usize, usize, f64)>,
}

impl SymSparse {
    fn new(n: usize) -> SymSparse {
        SymSparse {
            diag: vec![0.0; n],
            off: Vec::new(),
        }
    }

    /// A link of stiffness (or viscosity) `k` between dofs `a` and `b` (`None`: a fixed point).
    fn link(&mut self, a: Option<usize>, b: Option<usize>, k: f64) {
        if k == 0.0 {
            return;
        }
        if let Some(i) = a {
            self.diag[i] += k;
        }
        if let Some(j) = b {
            self.diag[j] += k;
        }
        if let (Some(i), Some(j)) = (a, b) {
            let (i, j) = if i < j { (i, j) } else { (j, i) };
            self.off.push((i, j, -k));
        }
    }

    /// The dense matrix.
    pub fn dense(&self) -> faer::Mat<f64> {
        let n = self.diag.len();
        let mut m = faer::Mat::<f64>::zeros(n, n);
        for (i, &d) in self.diag.iter().enumerate() {
            m[(i, i)] = d;
        }
        for &(i, j, v) in &self.off {
            m[(i, j)] += v;
            m[(j, i)] += v;
        }
        m
    }

    /// `y = A x` (real or complex `x`).
    pub fn mul<T>(&self, x: &[T], y: &mut [T])
    where
        T: Copy + std::ops::Mul<f64, Output = T> + std::ops::AddAssign,
    {
        for (i, (yi, &xi)) in y.iter_mut().zip(x).enumerate() {
            *yi = xi * self.diag[i];
        }
        for &(i, j, v) in &self.off {
            y[i] += x[j] * v;
            y[j] += x[i] * v;
        }
    }

    /// True when every entry is zero.
    pub fn is_zero(&self) -> bool {
        self.diag.iter().all(|&d| d == 0.0) && self.off.iter().all(|&(_, _, v)| v == 0.0)
    }
}

/// The network linearised at its rest state (the initial positions), over its mobile modules.
///
/// `M x(n+1) + (K + R - 2M) x(n) + (M - R) x(n-1) = F(n) + b`, where `x` holds the positions of the
/// MAS and CEL modules (the degrees of freedom, in declaration order), SOL and ENX are fixed points
/// at their initial positions, and `b` the constant forces the fixed points, the CEL rest points and
/// the linearised nonlinear links exert.
#[derive(Clone, Debug)]
pub struct LinearSystem {
    /// Sample rate, Hz.
    pub rate: f64,
    /// The material module of each degree of freedom.
    pub dofs: Vec<MatId>,
    /// Their names.
    pub names: Vec<String>,
    /// Inertias (the diagonal of M).
    pub mass: Vec<f64>,
    /// Stiffness matrix (GENESIS units).
    pub k: SymSparse,
    /// Damping matrix (GENESIS units).
    pub r: SymSparse,
    /// Constant forces (fixed points, CEL rest points, linearisation offsets).
    pub b: Vec<f64>,
    /// Initial positions `x(0)` and `x(-1)` of the dofs.
    pub x0: Vec<f64>,
    /// `x(-1)`.
    pub xm1: Vec<f64>,
    /// Impulse inputs: `(step, dof, force)` (ENF impulses on mobile modules).
    pub impulses: Vec<(u64, usize, f64)>,
    /// Output rows: each SOX channel as `(name, [(gain, dof)])`; a channel on a fixed point has no
    /// terms.
    pub outputs: Vec<(String, Vec<(f64, usize)>)>,
    /// What was linearised, and what the analysis leaves out, in words.
    pub notes: Vec<String>,
    /// Groups of dofs with no path of springs to a fixed point (each has a rigid mode at 0 Hz).
    pub free_parts: Vec<Vec<usize>>,
}

impl LinearSystem {
    /// Number of degrees of freedom.
    pub fn len(&self) -> usize {
        self.dofs.len()
    }

    /// True when there is no mobile module.
    pub fn is_empty(&self) -> bool {
        self.dofs.is_empty()
    }

    /// The dof of a module name, if it is a mobile module.
    pub fn dof(&self, name: &str) -> Option<usize> {
        self.names.iter().position(|n| n == name)
    }

    /// Linearises a model at its initial positions.
    pub fn from_model(model: &Model) -> Result<LinearSystem, AnalysisError> {
        let net = &model.network;
        let mut dof_of: Vec<Option<usize>> = vec![None; net.materials.len()];
        let mut dofs = Vec::new();
        let mut mass = Vec::new();
        let mut x0 = Vec::new();
        let mut xm1 = Vec::new();
        for (i, m) in net.materials.iter().enumerate() {
            if let Material::Mas { m, .. } | Material::Cel { m, .. } = m {
                dof_of[i] = Some(dofs.len());
                dofs.push(MatId(i as u32));
                mass.push(*m);
                let (a, b) = net.materials[i].initial_state();
                x0.push(a);
                xm1.push(b);
            }
        }
        if dofs.is_empty() {
            return Err(AnalysisError::NoMobileModule);
        }
        let n = dofs.len();
        let mut k = SymSparse::new(n);
        let mut r = SymSparse::new(n);
        let mut b = vec![0.0; n];
        let mut notes = Vec::new();
        let pos0: Vec<f64> = net.materials.iter().map(|m| m.initial_state().0).collect();
        // dofs tied by a spring to a fixed point or to their own rest point (CEL)
        let mut grounded = vec![false; n];
        for (i, m) in net.materials.iter().enumerate() {
            match m {
                Material::Cel { k: kc, z, r: rest, .. } => {
                    let d = dof_of[i].unwrap_or_default();
                    k.diag[d] += kc;
                    grounded[d] |= *kc != 0.0;
                    r.diag[d] += z;
                    b[d] += kc * rest;
                }
                Material::Enx { .. } => notes.push(format!(
                    "enx {}: a fixed point at its first value {:.6e} (its motion is an input the analysis leaves out)",
                    model.materials[i].name, pos0[i]
                )),
                _ => {}
            }
        }
        for (l, link) in net.links.iter().enumerate() {
            let (a, bb) = (link.a.index(), link.b.index());
            let (da, db) = (dof_of[a], dof_of[bb]);
            let d0 = pos0[a] - pos0[bb];
            let name = &model.links[l].name;
            // f = f0 + kk (d - d0) + zz v, linearised at d0, v = 0; end 1 gets -f, end 2 +f
            let (kk, zz, f0) = match &link.law {
                Interaction::Res { k } => (*k, 0.0, k * d0),
                Interaction::Fro { z } => (0.0, *z, 0.0),
                Interaction::Ref { k, z } => (*k, *z, k * d0),
                Interaction::But { k, z, s } => {
                    if pos0[bb] - pos0[a] < *s {
                        notes.push(format!("but {name}: active at rest (x2 - x1 = {:.6e} < S = {s}): its K and Z are included", -d0));
                        (*k, *z, k * (d0 + s))
                    } else {
                        notes.push(format!(
                            "but {name}: inactive at rest (x2 - x1 = {:.6e} >= S = {s}): left out",
                            -d0
                        ));
                        (0.0, 0.0, 0.0)
                    }
                }
                Interaction::Lnl { lk, lz } => {
                    let (sk, sz) = (lk.slope(d0), lz.slope(0.0));
                    notes.push(format!("lnl {name}: the slopes of its curves at rest (d = {d0:.6e}): K = {sk:.6e}, Z = {sz:.6e}"));
                    (sk, sz, lk.eval(d0))
                }
            };
            k.link(da, db, kk);
            r.link(da, db, zz);
            if kk != 0.0 {
                match (da, db) {
                    (Some(i), None) | (None, Some(i)) => grounded[i] = true,
                    _ => {}
                }
            }
            // constant part of the linearised force: f0 - kk d0, plus kk x_fixed for a fixed end
            let c = f0 - kk * d0;
            if let Some(i) = da {
                b[i] -= c;
                if db.is_none() {
                    b[i] += kk * pos0[bb];
                }
            }
            if let Some(j) = db {
                b[j] += c;
                if da.is_none() {
                    b[j] += kk * pos0[a];
                }
            }
        }
        let mut impulses = Vec::new();
        for (f, fi) in net.forces.iter().enumerate() {
            let name = &model.forces[f].name;
            match (dof_of[fi.target.index()], &fi.signal) {
                (Some(d), cordis_core::Signal::Impulse { at, amp }) => impulses.push((*at, d, *amp)),
                (None, _) => notes.push(format!("enf {name}: on a fixed point, no effect")),
                (Some(_), _) => notes.push(format!("enf {name}: not an impulse; the mode amplitudes count only initial conditions and impulses")),
            }
        }
        let mut outputs = Vec::new();
        for (c, o) in net.outputs.iter().enumerate() {
            let name = model.outputs[c].name.clone();
            let terms: Vec<(f64, MatId)> = match o {
                Output::Position(m) => vec![(1.0, *m)],
                Output::Sum(t) if t.iter().all(|(_, p)| matches!(p, Probe::Position(_))) => t
                    .iter()
                    .filter_map(|(g, p)| match p {
                        Probe::Position(m) => Some((*g, *m)),
                        Probe::Force(_) => None,
                    })
                    .collect(),
                _ => {
                    notes.push(format!(
                        "output {name}: records forces; the analysis reports positions only"
                    ));
                    continue;
                }
            };
            outputs.push((
                name,
                terms
                    .iter()
                    .filter_map(|&(g, m)| dof_of[m.index()].map(|d| (g, d)))
                    .collect(),
            ));
        }
        let free_parts = free_parts(&k, &grounded);
        Ok(LinearSystem {
            rate: model.rate,
            names: dofs
                .iter()
                .map(|m| model.materials[m.index()].name.clone())
                .collect(),
            dofs,
            mass,
            k,
            r,
            b,
            x0,
            xm1,
            impulses,
            outputs,
            notes,
            free_parts,
        })
    }
}

/// Groups of dofs that no chain of springs ties to a fixed point or to a CEL's rest point.
fn free_parts(k: &SymSparse, grounded: &[bool]) -> Vec<Vec<usize>> {
    let n = grounded.len();
    let mut parent: Vec<usize> = (0..n).collect();
    fn find(p: &mut [usize], mut i: usize) -> usize {
        while p[i] != i {
            p[i] = p[p[i]];
            i = p[i];
        }
        i
    }
    for &(i, j, v) in &k.off {
        if v != 0.0 {
            let (a, b) = (find(&mut parent, i), find(&mut parent, j));
            if a != b {
                parent[a] = b;
            }
        }
    }
    let mut groups: std::collections::BTreeMap<usize, (Vec<usize>, bool)> = Default::default();
    for (i, &g) in grounded.iter().enumerate() {
        let root = find(&mut parent, i);
        let e = groups.entry(root).or_default();
        e.0.push(i);
        e.1 |= g;
    }
    groups
        .into_values()
        .filter(|(_, g)| !g)
        .map(|(v, _)| v)
        .collect()
}
