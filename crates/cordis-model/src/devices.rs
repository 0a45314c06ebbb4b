//! The sticking devices of Tache & Cadoz (ICMC 2006, section 3) as statements of the language,
//! and the activity rules of the links the event log follows.
//!
//! - `stick NAME A B KL= S= [Z1=] [buts=yes|no]`, the simple device: an LNL sticking spring
//!   `NAME.L` (the curve `(-S,0) (-S,-KL S) (S,KL S) (S,0)`: a spring `KL d` only while `|d| < S`)
//!   and two viscous-only BUTs, `NAME.B1` (threshold `+S`, viscosity `Z1`) and `NAME.B2`
//!   (threshold `-S`, viscosity `-Z1`), which together damp with `Z1` exactly while
//!   `-S <= x2 - x1 < S`. `Z1` defaults to `2 sqrt(KL m) - KL`, the critical viscosity of a CEL of
//!   inertia `m`, the smaller finite inertia of the two ends.
//! - `bond NAME A B mC= KL= S= KR= [ZR=] [X1=] [X2=] [Z1=] [buts=]`, the complete device:
//!   intermediary masses `NAME.MC1` and `NAME.MC2` of inertia `mC` (at `X1`, `X2`; by default at
//!   the initial positions of `A` and `B`), a simple device `NAME.S1` from `A` to `MC1` and
//!   `NAME.S2` from `MC2` to `B` (their `Z1` computed with `mC`), and the interaction to set,
//!   `NAME.R`, a REF(`KR`, `ZR`) from `MC1` to `MC2`. It breaks when the masses are farther apart
//!   than `S_B = S (KL + 2 KR) / KR`.

use cordis_core::{Curve, Interaction, LinkId, MatId, Material};

use crate::error::{Diagnostic, ErrorKind, Span};
use crate::eval::Kind;
use crate::model::{Builder, Params, R};
use crate::names::Decl;
use crate::syntax::Ref;

/// Simple or complete sticking device.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum DeviceKind {
    /// `stick`: one sticking spring (and its two BUTs) between two modules.
    Simple,
    /// `bond`: two intermediary masses, two simple devices and an interaction R.
    Complete,
}

/// A sticking device as declared, with the values its check reports.
#[derive(Clone, Debug, PartialEq)]
pub struct Device {
    /// The device's name (its modules are `NAME.L`, `NAME.MC1`...).
    pub name: String,
    /// The declaring statement.
    pub span: Span,
    /// Simple or complete.
    pub kind: DeviceKind,
    /// Stiffness of the sticking spring(s).
    pub k_l: f64,
    /// Threshold of the sticking spring(s).
    pub s: f64,
    /// Viscosity of the BUTs (computed or given).
    pub z1: f64,
    /// Whether the BUTs are there (`buts=no` leaves bare springs).
    pub buts: bool,
    /// The inertia `Z1` was computed with (the smaller finite end, or `mC`).
    pub inertia: f64,
    /// For a simple device: the reduced inertia of its two ends (the relative motion's mass).
    pub reduced_inertia: f64,
    /// Complete device: inertia of the intermediary masses.
    pub m_c: f64,
    /// Complete device: stiffness of R.
    pub k_r: f64,
    /// Complete device: viscosity of R.
    pub z_r: f64,
    /// The sticking springs (one, or two for a complete device).
    pub springs: Vec<LinkId>,
}

impl Device {
    /// `S_B = S (KL + 2 KR) / KR`, the distance at which a complete device breaks.
    pub fn breaking_distance(&self) -> Option<f64> {
        (self.kind == DeviceKind::Complete).then(|| self.s * (self.k_l + 2.0 * self.k_r) / self.k_r)
    }

    /// The stability condition as `(left side, bound)`: the device is stable when left < bound.
    ///
    /// Complete: `KL + 2 KR + 2 Z1 < 4 mC` (the intermediary mass between its spring and R; the
    /// paper does not state it). Simple: `KL + 2 Z1 < 4 mu` with `mu` the reduced inertia of the
    /// two ends (the exact CEL bound of their relative motion; without BUTs, `KL < 4 mu`).
    pub fn stability(&self) -> (f64, f64) {
        let z = if self.buts { self.z1 } else { 0.0 };
        match self.kind {
            DeviceKind::Complete => (self.k_l + 2.0 * self.k_r + 2.0 * z, 4.0 * self.m_c),
            DeviceKind::Simple => (self.k_l + 2.0 * z, 4.0 * self.reduced_inertia),
        }
    }

    /// True when the stability condition holds.
    pub fn is_stable(&self) -> bool {
        let (l, b) = self.stability();
        l < b
    }
}

/// When a followed link counts as active (evaluated on the positions of step n).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Activity {
    /// A BUT: active while `x2 - x1 < S`.
    Below(f64),
    /// A sticking spring: active while `|x1 - x2| < S`.
    Within(f64),
    /// An LNL declared with `track=yes`: active while its force is not zero.
    NonZero,
}

impl Activity {
    /// Whether the link is active, given its ends' positions and its force at step n.
    pub fn is_active(&self, x1: f64, x2: f64, force: f64) -> bool {
        match *self {
            Activity::Below(s) => x2 - x1 < s,
            Activity::Within(s) => (x1 - x2).abs() < s,
            Activity::NonZero => force != 0.0,
        }
    }
}

/// A link the event log follows, and how.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Tracked {
    /// The link.
    pub link: LinkId,
    /// Its activity rule.
    pub activity: Activity,
}

/// The sticking curve `(-S,0) (-S,-KL S) (S,KL S) (S,0)`.
pub fn sticking_curve(k_l: f64, s: f64) -> Curve {
    Curve::new(&[(-s, 0.0), (-s, -k_l * s), (s, k_l * s), (s, 0.0)]).unwrap_or_default()
}

/// `2 sqrt(KL m) - KL`.
pub fn critical_z1(k_l: f64, m: f64) -> f64 {
    2.0 * (k_l * m).sqrt() - k_l
}

fn inertia(m: &Material) -> Option<f64> {
    match m {
        Material::Mas { m, .. } | Material::Cel { m, .. } => Some(*m),
        _ => None,
    }
}

struct StickParams {
    k_l: f64,
    s: f64,
    z1: Option<f64>,
    buts: bool,
}

impl Builder<'_> {
    fn stick_params(&self, p: &mut Params, span: Span) -> R<StickParams> {
        let k_l = self.req(p, "KL", Kind::Stiffness, span)?;
        let s = self.req(p, "S", Kind::Plain, span)?;
        if !(s > 0.0) {
            return Err(Diagnostic::error(
                ErrorKind::OutOfRange,
                span,
                format!("the threshold S must be > 0, not {s}"),
            ));
        }
        let z1 = match p.get("Z1", &[])? {
            Some(x) => Some(self.env.number(&x.value, Kind::Viscosity, "Z1")?),
            None => None,
        };
        let buts = match p.get("buts", &[])? {
            Some(x) => self.yes_no(&x.value)?,
            None => true,
        };
        Ok(StickParams { k_l, s, z1, buts })
    }

    /// Adds the links of a simple device named `name` from `a` to `b`; returns the spring's id.
    fn add_stick(
        &mut self,
        name: &str,
        a: MatId,
        b: MatId,
        sp: &StickParams,
        z1: f64,
        span: Span,
    ) -> R<LinkId> {
        let l = self.add_link(
            format!("{name}.L"),
            Interaction::Lnl {
                lk: sticking_curve(sp.k_l, sp.s),
                lz: Curve::zero(),
            },
            a,
            b,
            span,
        )?;
        self.tracked.push(Tracked {
            link: l,
            activity: Activity::Within(sp.s),
        });
        if sp.buts {
            self.add_link(
                format!("{name}.B1"),
                Interaction::But {
                    k: 0.0,
                    z: z1,
                    s: sp.s,
                },
                a,
                b,
                span,
            )?;
            self.add_link(
                format!("{name}.B2"),
                Interaction::But {
                    k: 0.0,
                    z: -z1,
                    s: -sp.s,
                },
                a,
                b,
                span,
            )?;
        }
        Ok(l)
    }

    /// The two ends of a device: material modules, and not the same one.
    fn device_ends(&self, ra: &Ref, rb: &Ref) -> R<(MatId, MatId)> {
        let a = self.material(ra, "end 1")?;
        let b = self.material(rb, "end 2")?;
        if a == b {
            return Err(Diagnostic::error(
                ErrorKind::WrongKind,
                rb.span,
                "a sticking device must join two different modules",
            ));
        }
        Ok((a, b))
    }

    /// `stick NAME A B KL= S= [Z1=] [buts=]`.
    pub(crate) fn stick_stmt(
        &mut self,
        name: String,
        ra: &Ref,
        rb: &Ref,
        p: &mut Params,
        span: Span,
    ) -> R<()> {
        let (a, b) = self.device_ends(ra, rb)?;
        let sp = self.stick_params(p, span)?;
        p.finish("`stick`")?;
        let (ia, ib) = (
            inertia(&self.net.materials[a.index()]),
            inertia(&self.net.materials[b.index()]),
        );
        let m = match (ia, ib) {
            (Some(x), Some(y)) => x.min(y),
            (Some(x), None) | (None, Some(x)) => x,
            (None, None) => {
                if sp.z1.is_none() && sp.buts {
                    return Err(Diagnostic::error(
                        ErrorKind::WrongKind,
                        span,
                        "neither end of this device can move, so Z1 has no default",
                    )
                    .with_hint("give Z1=..., or attach the device to a mas or cel"));
                }
                f64::INFINITY
            }
        };
        let reduced = match (ia, ib) {
            (Some(x), Some(y)) => x * y / (x + y),
            (Some(x), None) | (None, Some(x)) => x,
            (None, None) => f64::INFINITY,
        };
        let z1 = sp.z1.unwrap_or_else(|| critical_z1(sp.k_l, m));
        self.declare(name.clone(), Decl::Group("sticking device"), span)?;
        let l = self.add_stick(&name, a, b, &sp, z1, span)?;
        self.push_device(Device {
            name,
            span,
            kind: DeviceKind::Simple,
            k_l: sp.k_l,
            s: sp.s,
            z1,
            buts: sp.buts,
            inertia: m,
            reduced_inertia: reduced,
            m_c: 0.0,
            k_r: 0.0,
            z_r: 0.0,
            springs: vec![l],
        });
        Ok(())
    }

    /// `bond NAME A B mC= KL= S= KR= [ZR=] [X1=] [X2=] [Z1=] [buts=]`.
    pub(crate) fn bond_stmt(
        &mut self,
        name: String,
        ra: &Ref,
        rb: &Ref,
        p: &mut Params,
        span: Span,
    ) -> R<()> {
        let (a, b) = self.device_ends(ra, rb)?;
        let m_c = self.positive(p, "mC", span)?;
        let sp = self.stick_params(p, span)?;
        let k_r = self.req(p, "KR", Kind::Stiffness, span)?;
        if !(k_r > 0.0) {
            return Err(Diagnostic::error(
                ErrorKind::OutOfRange,
                span,
                format!("KR must be > 0 (the device breaks at S (KL + 2 KR) / KR), not {k_r}"),
            ));
        }
        let z_r = self.num(p, "ZR", Kind::Viscosity, 0.0)?;
        let x1 = self.num(
            p,
            "X1",
            Kind::Plain,
            self.net.materials[a.index()].initial_state().0,
        )?;
        let x2 = self.num(
            p,
            "X2",
            Kind::Plain,
            self.net.materials[b.index()].initial_state().0,
        )?;
        p.finish("`bond`")?;
        let z1 = sp.z1.unwrap_or_else(|| critical_z1(sp.k_l, m_c));
        self.declare(name.clone(), Decl::Group("sticking device"), span)?;
        let mc1 = self.add_mat(
            format!("{name}.MC1"),
            Material::Mas {
                m: m_c,
                x0: x1,
                v0: 0.0,
            },
            span,
        )?;
        let mc2 = self.add_mat(
            format!("{name}.MC2"),
            Material::Mas {
                m: m_c,
                x0: x2,
                v0: 0.0,
            },
            span,
        )?;
        let l1 = self.add_stick(&format!("{name}.S1"), a, mc1, &sp, z1, span)?;
        self.add_link(
            format!("{name}.R"),
            Interaction::Ref { k: k_r, z: z_r },
            mc1,
            mc2,
            span,
        )?;
        let l2 = self.add_stick(&format!("{name}.S2"), mc2, b, &sp, z1, span)?;
        self.push_device(Device {
            name,
            span,
            kind: DeviceKind::Complete,
            k_l: sp.k_l,
            s: sp.s,
            z1,
            buts: sp.buts,
            inertia: m_c,
            reduced_inertia: m_c,
            m_c,
            k_r,
            z_r,
            springs: vec![l1, l2],
        });
        Ok(())
    }

    fn push_device(&mut self, d: Device) {
        if !d.is_stable() {
            let (l, bound) = d.stability();
            let cond = match d.kind {
                DeviceKind::Complete => "KL + 2 KR + 2 Z1 < 4 mC",
                DeviceKind::Simple => "KL + 2 Z1 < 4 mu (mu: reduced inertia of the ends)",
            };
            self.diags.push(
                Diagnostic::warning(d.span, format!("the sticking device `{}` is unstable once connected: {cond} fails ({l:.6} >= {bound:.6})", d.name))
                    .with_hint("lower KL or KR, give a smaller Z1, or make the intermediary masses heavier"),
            );
        }
        self.devices.push(d);
    }
}
