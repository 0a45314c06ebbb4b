//! The stability check of `cordis check`: exact bounds for every CEL, and the largest eigenvalue
//! of `M^-1 K` of the linear part of the network against 4 (FORMALISM.md).
//!
//! The eigenvalue is found by power iteration on the symmetric `M^-1/2 K M^-1/2` (sparse, so any
//! model size), bracketed by a Gershgorin upper bound. BUT and LNL links enter at their stiffest
//! (a BUT as if in contact, an LNL at its steepest segment), so the verdict is a worst case.

use cordis_core::{Interaction, Material};

use crate::Model;

/// One CEL's verdict.
#[derive(Clone, Debug, PartialEq)]
pub struct CelCheck {
    /// The CEL's name.
    pub name: String,
    /// `Z / M`, must be in `[0, 2)`.
    pub z_over_m: f64,
    /// `(K + 2 Z) / M`, must be below 4.
    pub k2z_over_m: f64,
    /// Both bounds hold.
    pub stable: bool,
}

/// The network's verdict.
#[derive(Clone, Debug, PartialEq)]
pub struct StabilityReport {
    /// One entry per CEL, in declaration order.
    pub cels: Vec<CelCheck>,
    /// Largest eigenvalue of `M^-1 K` over the mobile modules (0 if there are none).
    pub lambda_max: f64,
    /// An upper bound on it (Gershgorin).
    pub lambda_bound: f64,
    /// Modules where the mode of `lambda_max` concentrates, or whose Gershgorin row exceeds 4,
    /// with their row value: the ones to soften or make heavier.
    pub offenders: Vec<(String, f64)>,
    /// Whether nonlinear links (BUT, LNL) entered at their stiffest.
    pub includes_nonlinear: bool,
    /// Every bound holds.
    pub stable: bool,
}

fn stiffness(law: &Interaction) -> (f64, bool) {
    match law {
        Interaction::Res { k } | Interaction::Ref { k, .. } => (*k, false),
        Interaction::Fro { .. } => (0.0, false),
        Interaction::But { k, .. } => (*k, true),
        Interaction::Lnl { lk, .. } => (lk.max_abs_slope(), true),
    }
}

/// Checks a model's stability.
pub fn check(model: &Model) -> StabilityReport {
    let net = &model.network;
    let n = net.materials.len();
    let mut cels = Vec::new();
    let mut mass = vec![0.0; n];
    let mut diag = vec![0.0; n];
    let mut mobile = vec![false; n];
    for (i, m) in net.materials.iter().enumerate() {
        match m {
            Material::Mas { m, .. } => {
                mass[i] = *m;
                mobile[i] = true;
            }
            Material::Cel { m, k, z, .. } => {
                mass[i] = *m;
                mobile[i] = true;
                diag[i] += k;
                let zm = z / m;
                let kzm = (k + 2.0 * z) / m;
                cels.push(CelCheck {
                    name: model.materials[i].name.clone(),
                    z_over_m: zm,
                    k2z_over_m: kzm,
                    stable: (0.0..2.0).contains(&zm) && kzm < 4.0 && *k >= 0.0,
                });
            }
            _ => {}
        }
    }
    // Off-diagonal entries between mobile modules; links to fixed modules only add to the diagonal.
    let mut edges: Vec<(usize, usize, f64)> = Vec::new();
    let mut includes_nonlinear = false;
    for l in &net.links {
        let (k, nonlinear) = stiffness(&l.law);
        if k == 0.0 {
            continue;
        }
        includes_nonlinear |= nonlinear;
        let (a, b) = (l.a.index(), l.b.index());
        if mobile[a] {
            diag[a] += k;
        }
        if mobile[b] {
            diag[b] += k;
        }
        if mobile[a] && mobile[b] {
            edges.push((a, b, k));
        }
    }
    // Gershgorin rows of M^-1 K.
    let mut row = vec![0.0; n];
    for i in 0..n {
        if mobile[i] {
            row[i] = diag[i].abs();
        }
    }
    for &(a, b, k) in &edges {
        row[a] += k.abs();
        row[b] += k.abs();
    }
    let mut bound = 0.0f64;
    for i in 0..n {
        if mobile[i] {
            row[i] /= mass[i];
            bound = bound.max(row[i]);
        }
    }
    // Power iteration on S = M^-1/2 K M^-1/2, shifted by the bound so the largest algebraic
    // eigenvalue dominates even with negative stiffnesses.
    let isq: Vec<f64> = (0..n)
        .map(|i| if mobile[i] { 1.0 / mass[i].sqrt() } else { 0.0 })
        .collect();
    let apply = |v: &[f64], out: &mut [f64]| {
        for i in 0..n {
            out[i] = diag[i] * isq[i] * isq[i] * v[i];
        }
        for &(a, b, k) in &edges {
            let s = k * isq[a] * isq[b];
            out[a] -= s * v[b];
            out[b] -= s * v[a];
        }
    };
    let mut v: Vec<f64> = (0..n)
        .map(|i| {
            if mobile[i] {
                1.0 + ((i * 7919) % 101) as f64 / 101.0
            } else {
                0.0
            }
        })
        .collect();
    let mut w = vec![0.0; n];
    let norm = |v: &[f64]| v.iter().map(|x| x * x).sum::<f64>().sqrt();
    let mut lambda = 0.0;
    let nv = norm(&v);
    if nv > 0.0 && bound > 0.0 {
        v.iter_mut().for_each(|x| *x /= nv);
        for it in 0..3000 {
            apply(&v, &mut w);
            let rq: f64 = v.iter().zip(&w).map(|(a, b)| a * b).sum();
            for i in 0..n {
                w[i] += bound * v[i];
            }
            let nw = norm(&w);
            if nw == 0.0 {
                break;
            }
            w.iter_mut().for_each(|x| *x /= nw);
            std::mem::swap(&mut v, &mut w);
            let converged = (rq - lambda).abs() <= 1e-12 * bound;
            lambda = rq;
            if it > 20 && converged {
                break;
            }
            // Clear verdicts need no more digits.
            if it > 200 && (lambda > 4.0 * 1.001 || bound < 4.0) {
                break;
            }
        }
    }
    let mut offenders: Vec<(String, f64)> = Vec::new();
    if lambda >= 4.0 {
        // where the top mode lives
        let peak = v.iter().map(|x| x.abs()).fold(0.0, f64::max);
        let mut idx: Vec<usize> = (0..n).filter(|&i| mobile[i] && row[i] >= 4.0).collect();
        if idx.is_empty() {
            idx = (0..n)
                .filter(|&i| mobile[i] && v[i].abs() >= 0.5 * peak)
                .collect();
        }
        idx.sort_by(|&a, &b| row[b].total_cmp(&row[a]));
        offenders = idx
            .into_iter()
            .take(8)
            .map(|i| (model.materials[i].name.clone(), row[i]))
            .collect();
    }
    let stable = lambda < 4.0 && cels.iter().all(|c| c.stable);
    StabilityReport {
        cels,
        lambda_max: lambda,
        lambda_bound: bound,
        offenders,
        includes_nonlinear,
        stable,
    }
}
