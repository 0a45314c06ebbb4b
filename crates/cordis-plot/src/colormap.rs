//! The magma colour map: perceptually uniform, black for silence, pale yellow for the peak.

/// Magma (matplotlib) sampled at nine evenly spaced points; linear interpolation in between.
const MAGMA: [[f64; 3]; 9] = [
    [0.0, 0.0, 4.0],
    [28.0, 16.0, 68.0],
    [79.0, 18.0, 123.0],
    [129.0, 37.0, 129.0],
    [181.0, 54.0, 122.0],
    [229.0, 80.0, 100.0],
    [251.0, 135.0, 97.0],
    [254.0, 194.0, 135.0],
    [252.0, 253.0, 191.0],
];

/// The colour of `x` in `[0, 1]` (clamped; NaN reads as 0).
pub(crate) fn magma(x: f64) -> [u8; 3] {
    let x = if x.is_nan() { 0.0 } else { x.clamp(0.0, 1.0) };
    let pos = x * (MAGMA.len() - 1) as f64;
    let i = (pos.floor() as usize).min(MAGMA.len() - 2);
    let frac = pos - i as f64;
    let (a, b) = (MAGMA[i], MAGMA[i + 1]);
    let mix = |c: usize| (a[c] + (b[c] - a[c]) * frac).round().clamp(0.0, 255.0) as u8;
    [mix(0), mix(1), mix(2)]
}

#[cfg(test)]
mod tests {
    use super::magma;

    #[test]
    fn ends_and_clamping() {
        assert_eq!(magma(0.0), [0, 0, 4]);
        assert_eq!(magma(1.0), [252, 253, 191]);
        assert_eq!(magma(-3.0), magma(0.0));
        assert_eq!(magma(7.0), magma(1.0));
        assert_eq!(magma(f64::NAN), magma(0.0));
        // Brightness rises monotonically.
        let luma = |c: [u8; 3]| 0.3 * c[0] as f64 + 0.59 * c[1] as f64 + 0.11 * c[2] as f64;
        for i in 0..100 {
            assert!(luma(magma(i as f64 / 100.0)) <= luma(magma((i + 1) as f64 / 100.0)));
        }
    }
}
