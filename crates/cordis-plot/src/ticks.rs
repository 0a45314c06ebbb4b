//! Tick positions and labels that read well: 1, 2, 5 steps; 100, 1k, 10k on a log axis.

/// A step of 1, 2 or 5 times a power of ten giving about `target` intervals over `span`.
pub(crate) fn nice_step(span: f64, target: usize) -> f64 {
    let raw = span / target.max(1) as f64;
    if !(raw.is_finite() && raw > 0.0) {
        return 1.0;
    }
    let mag = 10f64.powf(raw.log10().floor());
    let norm = raw / mag;
    let m = if norm < 1.5 {
        1.0
    } else if norm < 3.5 {
        2.0
    } else if norm < 7.5 {
        5.0
    } else {
        10.0
    };
    m * mag
}

/// Multiples of `step` within `[lo, hi]`.
pub(crate) fn linear_ticks(lo: f64, hi: f64, step: f64) -> Vec<f64> {
    let mut out = Vec::new();
    let eps = step * 1e-9;
    let mut k = (lo / step - 1e-9).ceil();
    loop {
        let v = k * step;
        if v > hi + eps || out.len() > 1000 {
            break;
        }
        // Avoid "-0".
        out.push(if v.abs() < eps { 0.0 } else { v });
        k += 1.0;
    }
    out
}

/// Decimals needed to print multiples of `step` exactly.
pub(crate) fn decimals(step: f64) -> usize {
    if !(step.is_finite() && step > 0.0) {
        return 0;
    }
    (-step.log10().floor()).clamp(0.0, 9.0) as usize
}

/// Ticks for a log axis over `[lo, hi]` (both > 0) drawn at `px_per_decade`: the labelled
/// (major) ticks are decades, else 1-2-5, else 1..9 times a power of ten, the richest set whose
/// ticks stay `min_gap_px` apart (a richer one if that leaves fewer than two); the minor ticks
/// are the 1..9 multiples not labelled, when they stay 3 pixels apart.
pub(crate) fn log_ticks(
    lo: f64,
    hi: f64,
    px_per_decade: f64,
    min_gap_px: f64,
) -> (Vec<f64>, Vec<f64>) {
    const ALL: [f64; 9] = [1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0, 8.0, 9.0];
    // Each set with its smallest gap in decades.
    let sets: [(&[f64], f64); 3] = [(&[1.0], 1.0), (&[1.0, 2.0, 5.0], 0.301), (&ALL, 0.0457)];
    let candidates = |mults: &[f64]| {
        let mut out = Vec::new();
        let first = lo.log10().floor() as i32;
        let last = hi.log10().ceil() as i32;
        for e in first..=last {
            let p = 10f64.powi(e);
            for m in mults {
                let v = m * p;
                if v >= lo * (1.0 - 1e-9) && v <= hi * (1.0 + 1e-9) {
                    out.push(v);
                }
            }
        }
        out
    };
    let mut major = candidates(sets[0].0);
    for (mults, gap) in &sets[1..] {
        if gap * px_per_decade >= min_gap_px || major.len() < 2 {
            major = candidates(mults);
        } else {
            break;
        }
    }
    let minor = if 0.0457 * px_per_decade >= 3.0 {
        candidates(&ALL)
            .into_iter()
            .filter(|v| !major.iter().any(|m| (m - v).abs() <= 1e-9 * v))
            .collect()
    } else {
        Vec::new()
    };
    (major, minor)
}

/// `v` with at most `decimals` decimals, trailing zeros removed.
pub(crate) fn trim(v: f64, decimals: usize) -> String {
    let s = format!("{v:.decimals$}");
    let s = if s.contains('.') {
        s.trim_end_matches('0').trim_end_matches('.').to_string()
    } else {
        s
    };
    if s == "-0" {
        "0".to_string()
    } else {
        s
    }
}

/// A frequency label: `440`, `1k`, `2.5k`, `20k`.
pub(crate) fn hz(f: f64) -> String {
    if f.abs() >= 1000.0 {
        format!("{}k", trim(f / 1000.0, 2))
    } else if f.abs() >= 10.0 {
        trim(f, 1)
    } else {
        trim(f, 2)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn steps_and_labels() {
        assert_eq!(nice_step(10.0, 5), 2.0);
        assert_eq!(nice_step(24_000.0, 8), 2000.0);
        assert_eq!(nice_step(0.3, 6), 0.05);
        assert_eq!(
            linear_ticks(0.0, 1.0, 0.25),
            vec![0.0, 0.25, 0.5, 0.75, 1.0]
        );
        assert_eq!(decimals(0.05), 2);
        assert_eq!(decimals(2.0), 0);
        assert_eq!(trim(1.50, 2), "1.5");
        assert_eq!(trim(2.0, 0), "2");
        assert_eq!(hz(10f64.powf(200f64.log10())), "200");
        assert_eq!(hz(2500.0), "2.5k");
        assert_eq!(hz(20_000.0), "20k");
        assert_eq!(
            log_ticks(20.0, 24_000.0, 160.0, 40.0).0,
            vec![20.0, 50.0, 100.0, 200.0, 500.0, 1000.0, 2000.0, 5000.0, 10_000.0, 20_000.0]
        );
        let (major, minor) = log_ticks(20.0, 24_000.0, 80.0, 40.0);
        assert_eq!(major, vec![100.0, 1000.0, 10_000.0]);
        assert!(minor.contains(&20.0) && minor.contains(&3000.0) && !minor.contains(&1000.0));
        // A narrow range falls back to 1..9 multiples so that it has at least two labels.
        assert_eq!(log_ticks(300.0, 900.0, 1000.0, 40.0).0.len(), 7);
    }
}
