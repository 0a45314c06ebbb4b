//! Watching a simulation step by step: the event log (when links become active or inactive) and
//! the energy meter (kinetic, potential, dissipated, input, total). Both are observers for
//! `Engine::process_observed`.

use cordis_core::{Interaction, LinkId, Material, StepView};

use crate::devices::Activity;
use crate::Model;

/// A followed link changed state at `step`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Event {
    /// The step `n` whose positions first show the new state.
    pub step: u64,
    /// The link.
    pub link: LinkId,
    /// True: became active; false: became inactive.
    pub active: bool,
}

/// The event log: one [`Event`] per change of state of every followed link (`Model::tracked`: every
/// BUT, every sticking spring, every LNL with `track=yes`). Every link counts as inactive before
/// step 0, so the links active at the start appear as events at step 0.
#[derive(Clone, Debug)]
pub struct EventLog {
    items: Vec<(LinkId, Activity, cordis_core::MatId, cordis_core::MatId)>,
    state: Vec<bool>,
    /// The events, in order of step, then of link.
    pub events: Vec<Event>,
}

impl EventLog {
    /// A log following the model's tracked links.
    pub fn new(model: &Model) -> EventLog {
        let items: Vec<_> = model
            .tracked
            .iter()
            .map(|t| {
                let l = &model.network.links[t.link.index()];
                (t.link, t.activity, l.a, l.b)
            })
            .collect();
        EventLog {
            state: vec![false; items.len()],
            items,
            events: Vec::new(),
        }
    }

    /// Records the changes of step `view.step()`.
    pub fn observe(&mut self, view: &StepView<'_>) {
        for (i, &(link, activity, a, b)) in self.items.iter().enumerate() {
            let active =
                activity.is_active(view.position(a), view.position(b), view.link_force(link));
            if active != self.state[i] {
                self.state[i] = active;
                self.events.push(Event {
                    step: view.step(),
                    link,
                    active,
                });
            }
        }
    }
}

/// One line of the energy log, at step `n` (see [`EnergyMeter`] for the definitions).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct EnergyRow {
    /// The step.
    pub step: u64,
    /// Kinetic energy.
    pub kinetic: f64,
    /// Potential energy of springs, CELs, active BUTs and LNL curves.
    pub potential: f64,
    /// Work dissipated by dampers since the start (cumulative).
    pub dissipated: f64,
    /// Work put in by ENF forces and ENX positions since the start (cumulative).
    pub input: f64,
    /// `kinetic + potential + dissipated - input`.
    pub total: f64,
}

/// Energy of the network, per step (GENESIS units: inertia × (length per sample)²).
///
/// At step `n` the meter knows `x(n-1)`, `x(n)`, `x(n+1)`, and uses the half-step forms under which
/// the explicit scheme conserves energy exactly for linear modules (so `total` is constant, to
/// rounding, in a linear network, and its changes show exactly what the nonlinear modules do):
///
/// - kinetic: `1/2 M (x(n+1) - x(n))^2` per MAS and CEL;
/// - potential: `1/2 K d(n) d(n+1)` per RES and REF, `1/2 K (d(n)+S)(d(n+1)+S)` per BUT active at
///   step n, `1/2 K (x(n)-R)(x(n+1)-R)` per CEL, and for an LNL `U(d(n)) + LK(d(n)) (d(n+1)-d(n))/2`
///   with `U(d)` the integral of LK from 0 to d. A followed LNL (a sticking spring, or `track=yes`)
///   holds potential energy only while it is active: a spring that is not connected stores nothing,
///   so a connection shows as a jump of `1/2 KL d^2`, the paper's claim;
/// - dissipated (cumulative): `Z v(n) (v(n) + v(n+1)) / 2` per FRO, REF and active BUT, with
///   `v(n) = d(n) - d(n-1)`; `Z (x(n)-x(n-1)) (x(n+1)-x(n-1)) / 2` per CEL; `LZ(v(n)) (v(n) + v(n+1)) / 2` per LNL;
/// - input (cumulative): `F(n) (x(n+1) - x(n-1)) / 2` per ENF on a MAS or CEL, and, per ENX, minus
///   the force the network exerts on it times `(x(n+1) - x(n-1)) / 2`.
#[derive(Clone, Debug)]
pub struct EnergyMeter<'m> {
    model: &'m Model,
    /// `x(n-1)` by material.
    prev: Vec<f64>,
    /// per link: its activity rule if it is followed
    rule: Vec<Option<Activity>>,
    /// scratch: force on each ENX this step, by material (0 elsewhere)
    enx_force: Vec<f64>,
    dissipated: f64,
    input: f64,
    every: u64,
    /// The rows recorded (every `every` steps, from step 0).
    pub rows: Vec<EnergyRow>,
}

impl<'m> EnergyMeter<'m> {
    /// A meter recording a row every `every` steps (at least 1).
    pub fn new(model: &'m Model, every: u64) -> EnergyMeter<'m> {
        let mut rule = vec![None; model.network.links.len()];
        for t in &model.tracked {
            rule[t.link.index()] = Some(t.activity);
        }
        EnergyMeter {
            model,
            prev: model
                .network
                .materials
                .iter()
                .map(|m| m.initial_state().1)
                .collect(),
            rule,
            enx_force: vec![0.0; model.network.materials.len()],
            dissipated: 0.0,
            input: 0.0,
            every: every.max(1),
            rows: Vec::new(),
        }
    }

    /// Accounts for step `view.step()`.
    pub fn observe(&mut self, view: &StepView<'_>) {
        let net = &self.model.network;
        let (mut kinetic, mut potential, mut dissipated) = (0.0, 0.0, 0.0);
        let x0 = |m: cordis_core::MatId, prev: &[f64]| prev[m.index()];
        for (l, link) in net.links.iter().enumerate() {
            let (a, b) = (link.a, link.b);
            let d_prev = x0(a, &self.prev) - x0(b, &self.prev);
            let d = view.position(a) - view.position(b);
            let d_next = view.next_position(a) - view.next_position(b);
            let (v, v_next) = (d - d_prev, d_next - d);
            let f = view.link_force(LinkId(l as u32));
            // the force the network exerts on an ENX end (for the work the ENX puts in)
            if let Material::Enx { .. } = net.materials[a.index()] {
                self.enx_force[a.index()] -= f;
            }
            if let Material::Enx { .. } = net.materials[b.index()] {
                self.enx_force[b.index()] += f;
            }
            match &link.law {
                Interaction::Res { k } => potential += 0.5 * k * d * d_next,
                Interaction::Fro { z } => dissipated += z * v * (v + v_next) / 2.0,
                Interaction::Ref { k, z } => {
                    potential += 0.5 * k * d * d_next;
                    dissipated += z * v * (v + v_next) / 2.0;
                }
                Interaction::But { k, z, s } => {
                    if -d < *s {
                        potential += 0.5 * k * (d + s) * (d_next + s);
                        dissipated += z * v * (v + v_next) / 2.0;
                    }
                }
                Interaction::Lnl { lk, lz } => {
                    let holds = match self.rule[l] {
                        Some(rule) => rule.is_active(view.position(a), view.position(b), f),
                        None => true,
                    };
                    if holds {
                        potential += lk.integral_from_zero(d) + lk.eval(d) * (d_next - d) / 2.0;
                    }
                    dissipated += lz.eval(v) * (v + v_next) / 2.0;
                }
            }
        }
        let mut input = 0.0;
        for (i, m) in net.materials.iter().enumerate() {
            let id = cordis_core::MatId(i as u32);
            let (xp, x, xn) = (self.prev[i], view.position(id), view.next_position(id));
            match m {
                Material::Mas { m, .. } => kinetic += 0.5 * m * (xn - x) * (xn - x),
                Material::Cel { m, k, z, r, .. } => {
                    kinetic += 0.5 * m * (xn - x) * (xn - x);
                    potential += 0.5 * k * (x - r) * (xn - r);
                    dissipated += z * (x - xp) * (xn - xp) / 2.0;
                }
                Material::Enx { .. } => {
                    input -= self.enx_force[i] * (xn - xp) / 2.0;
                    self.enx_force[i] = 0.0;
                }
                Material::Sol { .. } => {}
            }
        }
        for fi in &net.forces {
            let t = fi.target;
            if net.materials[t.index()].is_mobile() {
                let (xp, xn) = (self.prev[t.index()], view.next_position(t));
                input += fi.signal.at(view.step()) * (xn - xp) / 2.0;
            }
        }
        self.dissipated += dissipated;
        self.input += input;
        for (i, p) in self.prev.iter_mut().enumerate() {
            *p = view.position(cordis_core::MatId(i as u32));
        }
        if view.step().is_multiple_of(self.every) {
            self.rows.push(EnergyRow {
                step: view.step(),
                kinetic,
                potential,
                dissipated: self.dissipated,
                input: self.input,
                total: kinetic + potential + self.dissipated - self.input,
            });
        }
    }
}
