//! Piecewise-linear curves: the LNL force laws and the envelope signal.

#[cfg(target_arch = "x86_64")]
use crate::wide::Vector;

/// A piecewise-linear function given by points `(abscissa, value)`.
///
/// Rules (FORMALISM.md): abscissas are non-decreasing; the function is linear between points;
/// two points with the same abscissa make a jump, and at the jump's abscissa the later point's
/// value holds; before the first point and after the last the value stays at the end point's
/// value. An empty curve is zero everywhere.
///
/// Evaluation, which every part of cordis must reproduce bit for bit: with `i` the last point whose
/// abscissa is `<= x`, the value is `y[0]` if there is none, `y[last]` if `i` is the last point,
/// and otherwise `y[i] + (x - x[i]) * ((y[i+1] - y[i]) / (x[i+1] - x[i]))`.
#[derive(Clone, Debug, PartialEq, Default)]
pub struct Curve {
    /// `n` points as one allocation (a curve is 16 bytes wherever it is stored): the abscissas
    /// `x[0..n]`, the values `y[0..n]`, the slopes `(y[i+1] - y[i]) / (x[i+1] - x[i])` (`n - 1`,
    /// computed once: the same division, so the same bits as computing it at every evaluation;
    /// unused for jumps), and `∫ from x[0] to x[i]` of the curve (`n`: trapezoids, a jump has no
    /// width) for the antiderivative. Empty for the zero curve.
    table: Box<[f64]>,
}

/// A curve of exactly `N` points (or of fewer, padded to `N`: [`ExactCurve::fitted`]) prepared
/// for the engine's LNL loops: the points and the slopes of [`Curve::eval`], evaluated with `N -
/// 2` selects and two compares, no branch and no indexed load (so a loop over links is
/// vectorised); `N = 0` is the zero curve (a sticking spring's viscous curve). The same bits as
/// `Curve::eval`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct ExactCurve<const N: usize> {
    xs: [f64; N],
    ys: [f64; N],
    /// `slopes[i]` of segment `i` (the last entry unused)
    slopes: [f64; N],
    /// For [`WideCurve::eval`]'s guess, where the curve has an exact [`Grid`] of `N` buckets
    /// (only for `N` of 16, [`ExactCurve::GRIDS`]): each bucket's segment (an index's
    /// bits as an `f64`) and the abscissa after that segment (`x[s + 1]`, NaN for `s = N - 1`),
    /// both by bucket; `0.0` each otherwise
    segs: [f64; N],
    nexts: [f64; N],
    /// The grid's buckets a unit of `x`, `0.0` for no grid
    scale: f64,
}

/// The first abscissa and the first slope of the engine's prepared curves ([`ExactCurve`],
/// [`LongCurve`]) of the points `xs`, `ys` (2 or more) and `slopes`: the curve's own, but for a
/// jump at the first point (`x[0] = x[1]`, as the sticking spring of FORMALISM.md has), which
/// would not widen as it is ([`WideCurve::eval`] raises an abscissa below `x[0]` to `x[0]`, where
/// the value after the jump holds): there the double just below `x[0]`, and a slope of `0.0`.
/// The segment they make holds no abscissa but that double, where it gives `y[0] + 0 * 0.0`,
/// which is `y[0]` unless `y[0]` is `-0.0`, as [`Curve::eval`] gives below `x[0]`; the points
/// after it are the curve's own. So the same bits everywhere, and a first segment of a width: the
/// curve widens ([`ExactCurve::widens`]). A `-0.0` first value, or `x[0]` the least `f64`, keep
/// the curve's own (and do not widen).
fn first_segment(xs: &[f64], ys: &[f64], slopes: &[f64]) -> (f64, f64) {
    let below = xs[0].next_down();
    if xs[0] == xs[1] && below.is_finite() && ys[0].to_bits() != (-0.0f64).to_bits() {
        (below, 0.0)
    } else {
        (xs[0], slopes[0])
    }
}

/// The first `j` of `1..n - 1` whose abscissa is the last one's, `n - 1` if none is, of the
/// sorted abscissas `xs` (`n` of them; 0 for none): [`ExactCurve::cut`].
fn cut_of(xs: &[f64]) -> usize {
    let n = xs.len();
    let last = xs.last().copied().unwrap_or(0.0);
    (1..n.saturating_sub(1))
        .find(|&j| xs[j] >= last)
        .unwrap_or(n.saturating_sub(1))
}

/// How many points [`ExactCurve::kept`] keeps of `c`: `cut + 1` ([`ExactCurve::cut`]), or `c`'s
/// own count for fewer than 2 points.
pub(crate) fn kept_len(c: &Curve) -> usize {
    match c.n() {
        n @ 0..=1 => n,
        _ => cut_of(c.xs()) + 1,
    }
}

/// The point count of the curves that may have a grid ([`ExactCurve::GRIDS`]).
const GRID_POINTS: usize = 16;

/// How many numbers [`ExactCurve::write`] writes for a curve of `n` points (`N = n`): its points
/// and slopes, `3 n`, and for `n` of [`GRID_POINTS`] its grid's `2 n + 1` ([`ExactCurve::LEN`];
/// the pull step lays out its tables of several pairs by it, where `n` is known only at run time).
pub(crate) const fn exact_len(n: usize) -> usize {
    if n >= GRID_POINTS {
        5 * n + 1
    } else {
        3 * n
    }
}

impl<const N: usize> ExactCurve<N> {
    /// `None` unless the curve has exactly `N` points, `N` being 0 or at least 2.
    #[cfg(test)]
    pub(crate) fn new(c: &Curve) -> Option<Self> {
        if c.xs().len() != N {
            return None;
        }
        Self::fit(c.xs(), c.ys(), c.slopes())
    }

    /// The curve `c` of at most `N` points, padded to `N` ([`ExactCurve::padded`]: the same
    /// bits); `None` when it has more, or when one of them is the zero curve and not the other.
    pub(crate) fn fitted(c: &Curve) -> Option<Self> {
        Self::fit(c.xs(), c.ys(), c.slopes())
    }

    /// The curve of points `xs`, `ys` and the slopes of its segments, its last point repeated to
    /// make `N` ([`ExactCurve::padded`]).
    fn fit(xs: &[f64], ys: &[f64], slopes: &[f64]) -> Option<Self> {
        let n = xs.len();
        if N < n || N == 1 || (n == 0) != (N == 0) {
            return None;
        }
        let mut e = ExactCurve {
            xs: [0.0; N],
            ys: [0.0; N],
            slopes: [0.0; N],
            segs: [0.0; N],
            nexts: [0.0; N],
            scale: 0.0,
        };
        let points = e.xs.iter_mut().zip(&mut e.ys).zip(&mut e.slopes);
        for (i, ((x, y), slope)) in points.enumerate() {
            let j = i.min(n.saturating_sub(1));
            (*x, *y) = (xs[j], ys[j]);
            *slope = if i + 1 < n { slopes[i] } else { 0.0 };
        }
        if n >= 2 {
            (e.xs[0], e.slopes[0]) = first_segment(xs, ys, slopes);
        }
        // (the padded abscissas, the last point repeated: the grid's `x[0..P]`, `P = N`)
        let last = e.xs.last().copied().filter(|_| Self::GRIDS);
        if let Some(grid) = last.and_then(|last| Grid::new(&e.xs, last)) {
            for (b, &edge) in grid.edges.iter().enumerate() {
                let s = grid.segment(edge);
                e.segs[b] = f64::from_bits(s as u64);
                e.nexts[b] = e.xs.get(s + 1).copied().unwrap_or(f64::NAN);
            }
            e.scale = grid.scale;
        }
        Some(e)
    }

    /// Whether the curve may have a grid ([`ExactCurve::segs`]): `N` of 16, the size that
    /// [`WideCurve::eval`] looks up in two vectors of eight ([`WideCurve::LOOKS_UP`]). (A curve
    /// of 8 looks up in one vector, 3 halvings; there the guess's operations are as many as the
    /// search's, and `random_lnl_drawn` measured no faster.)
    const GRIDS: bool = N >= GRID_POINTS;

    /// How many numbers [`ExactCurve::write`] writes: [`exact_len`] of `N`.
    pub(crate) const LEN: usize = exact_len(N);

    /// The value at `x`: [`Curve::eval`], bit for bit. With `i` the last point whose abscissa is
    /// `<= x`: no such point gives `y[0]`, the last point `y[N-1]`, and otherwise segment `i`,
    /// chosen by keeping the last `j < N - 1` with `x[j] <= x` (the abscissas are sorted).
    #[inline(always)]
    pub(crate) fn eval(&self, x: f64) -> f64 {
        if N < 2 {
            return 0.0; // (`N` is 0: `new` refuses 1)
        }
        let (mut x0, mut y, mut slope) = (self.xs[0], self.ys[0], self.slopes[0]);
        for j in 1..N - 1 {
            let past = self.xs[j] <= x;
            x0 = if past { self.xs[j] } else { x0 };
            y = if past { self.ys[j] } else { y };
            slope = if past { self.slopes[j] } else { slope };
        }
        let along = y + (x - x0) * slope;
        #[allow(clippy::neg_cmp_op_on_partial_ord)] // deliberate: a NaN `x` is "before" too
        let before = !(self.xs[0] <= x); // (as in `Curve::eval`)
        let after = self.xs[N - 1] <= x;
        let end = if after { self.ys[N - 1] } else { self.ys[0] };
        if before || after {
            end
        } else {
            along
        }
    }
}

impl<const N: usize> ExactCurve<N> {
    /// Whether `other` has the same points (and grid), bit for bit (so the same values
    /// everywhere).
    pub(crate) fn same_bits(&self, other: &Self) -> bool {
        let all = |c: &Self| {
            let grid = c.segs.into_iter().chain(c.nexts).chain([c.scale]);
            c.xs.into_iter().chain(c.ys).chain(c.slopes).chain(grid)
        };
        all(self)
            .zip(all(other))
            .all(|(a, b)| a.to_bits() == b.to_bits())
    }

    /// Whether [`WideCurve::eval`] gives [`ExactCurve::eval`]'s bits: the zero curve does, and
    /// a curve whose first segment has a width (`x[0] < x[1]`), a finite slope, and a first
    /// value other than `-0.0` (see `WideCurve::eval`). Other curves (a jump at the first point,
    /// a slope beyond the largest `f64`) are left to the gather step.
    pub(crate) fn widens(&self) -> bool {
        N < 2
            || (self.xs[0] < self.xs[1]
                && self.slopes[0].is_finite()
                && self.ys[0].to_bits() != (-0.0f64).to_bits())
    }

    /// Whether [`ExactCurve::eval`] (and [`WideCurve::eval`] where the curve widens) never gives
    /// `-0.0`: the zero curve gives `+0.0`, and a curve of no `-0.0` value gives one of its values
    /// or `y[i] + p` for a value `y[i]` and some `p`, which is `-0.0` only when both are (a sum of
    /// two numbers of opposite signs and the same size is `+0.0`). The grid step's LNL strings
    /// rely on it (a link force that is never `-0.0` needs no `0 +` in `F(n)`).
    pub(crate) fn never_minus_zero(&self) -> bool {
        self.ys.iter().all(|y| y.to_bits() != (-0.0f64).to_bits())
    }

    /// The curve as one of `M` points, its last point repeated: the same value everywhere, bit
    /// for bit, in [`ExactCurve::eval`] and [`WideCurve::eval`] (where `x` reaches the last
    /// abscissa both give the last value, the curve's end: the added segment, of no width and
    /// slope `0.0`, is computed there but not chosen; below it, no repeated point is `<= x`, and
    /// the selects and the end test are the `N`-point curve's). `None` when `M < N`, and for the
    /// zero curve unless `M` is 0 (it has no point to repeat). A curve of one point, a constant
    /// ([`ExactCurve::fitted`] pads it to 2 points or more), is `y[0]` everywhere, padded: no
    /// point `<= x` gives `y[0]`, and else `x` reaches the last abscissa, whose value is `y[0]`.
    pub(crate) fn padded<const M: usize>(&self) -> Option<ExactCurve<M>> {
        ExactCurve::<M>::fit(&self.xs, &self.ys, &self.slopes)
    }

    /// The curve as one of `M` points: itself where `M` is `N` (a copy, nothing computed again),
    /// else [`ExactCurve::padded`].
    pub(crate) fn at_points<const M: usize>(&self) -> Option<ExactCurve<M>> {
        match (self as &dyn std::any::Any).downcast_ref::<ExactCurve<M>>() {
            Some(same) => Some(*same),
            None => self.padded(),
        }
    }

    /// The first `j` of `1..N - 1` whose abscissa is the last one's (a point of a padding, or
    /// the first of a jump at the end; the abscissas are sorted), `N - 1` if none is (0 for the
    /// zero curve): the selects of [`WideCurve::eval`] from `cut` on may be skipped, since a
    /// point of the last abscissa is kept only where `x[N-1] <= x`, where the value is `y[N-1]`
    /// whatever was kept ([`ExactCurve::trimmed`]).
    pub(crate) fn cut(&self) -> usize {
        cut_of(&self.xs)
    }

    /// The curve without the points that [`ExactCurve::cut`] finds may be skipped: points
    /// `0..cut` (their slopes too) and the last, `cut + 1` points, padded to `M`
    /// ([`ExactCurve::padded`]; itself, copied, where nothing is skipped and `M` is `N`); `None`
    /// for an `M` below `cut + 1`, and for the zero curve. The same value everywhere, bit for
    /// bit, in [`ExactCurve::eval`] and [`WideCurve::eval`]: below `x[N-1]` both select among
    /// points `0..cut` alone (the points from `cut` on are not `<= x`), with the same numbers,
    /// and at or above it both give `y[N-1]`. A curve of 7 points padded to 8 is one of 7 again,
    /// 5 selects in place of 6; of 13 padded to 16, 11 in place of 14 (with AVX2 each select is
    /// a compare and three blends a lane); the sticking spring, of 4 points, one of 3.
    pub(crate) fn trimmed<const M: usize>(&self) -> Option<ExactCurve<M>> {
        let cut = self.cut();
        if N < 2 || M < cut + 1 {
            return None;
        }
        if cut + 1 == N {
            return self.at_points::<M>();
        }
        // (no allocation: the store pass trims its pair at each call)
        let keep = |a: &[f64; N]| -> [f64; N] {
            std::array::from_fn(|j| if j < cut { a[j] } else { a[N - 1] })
        };
        let (xs, ys, slopes) = (keep(&self.xs), keep(&self.ys), keep(&self.slopes));
        ExactCurve::<M>::fit(&xs[..=cut], &ys[..=cut], &slopes[..=cut])
    }

    /// The curve `c` as [`ExactCurve::trimmed`] keeps it once fitted: its points `0..cut` and
    /// its last ([`kept_len`] of them), padded to `N`, the same bits; `None` where `N` is
    /// fewer, or where one of them is the zero curve and not the other. The engine keeps its
    /// LNL pairs so (`ExactPair::new`): the sticking spring of 4 points is one of 3 on every
    /// path, and a 5-point curve ending in a jump one of 4, not 8.
    pub(crate) fn kept(c: &Curve) -> Option<Self> {
        let n = c.n();
        if n < 2 {
            return Self::fitted(c);
        }
        let cut = cut_of(c.xs());
        let keep =
            |a: &[f64]| -> Vec<f64> { a[..cut].iter().chain([&a[n - 1]]).copied().collect() };
        // (the slope at `cut` is unused: `fit` reads `slopes[i]` for `i + 1 < cut + 1` alone)
        let slopes: Vec<f64> = c.slopes()[..cut].iter().chain([&0.0]).copied().collect();
        Self::fit(&keep(c.xs()), &keep(c.ys()), &slopes)
    }

    /// Appends the curve's [`ExactCurve::LEN`] numbers to `out`, as [`ExactCurve::read`] takes
    /// them back.
    pub(crate) fn write(&self, out: &mut Vec<f64>) {
        out.extend(self.xs.iter().chain(&self.ys).chain(&self.slopes));
        if Self::GRIDS {
            out.extend(self.segs.iter().chain(&self.nexts).chain([&self.scale]));
        }
    }

    /// The curve that [`ExactCurve::write`] wrote at the start of `t`.
    ///
    /// # Panics
    /// If `t` has fewer than [`ExactCurve::LEN`] numbers.
    #[inline(always)]
    pub(crate) fn read(t: &[f64]) -> Self {
        let t = &t[..Self::LEN];
        let at = |i: usize| -> [f64; N] { std::array::from_fn(|j| t[i * N + j]) };
        let grid = |i: usize| if Self::GRIDS { at(i) } else { [0.0; N] };
        ExactCurve {
            xs: at(0),
            ys: at(1),
            slopes: at(2),
            segs: grid(3),
            nexts: grid(4),
            scale: if Self::GRIDS { t[5 * N] } else { 0.0 },
        }
    }

    /// Whether the curve has a grid, so that [`WideCurve::eval`] guesses its segments with
    /// AVX-512 (for the tests).
    #[cfg(test)]
    pub(crate) fn guesses(&self) -> bool {
        self.scale > 0.0
    }

    /// The curve without its grid: [`WideCurve::eval`] searches whatever the curve (for the
    /// tests, which check both).
    #[cfg(test)]
    fn searched(&self) -> Self {
        ExactCurve {
            segs: [0.0; N],
            nexts: [0.0; N],
            scale: 0.0,
            ..*self
        }
    }

    /// The curve with each number broadcast to every lane of `V`, for [`WideCurve::eval`].
    ///
    /// # Safety
    /// The CPU must have `V`'s instructions (see [`Vector`]).
    #[cfg(target_arch = "x86_64")]
    #[inline(always)]
    pub(crate) unsafe fn wide<V: Vector>(&self) -> WideCurve<V, N> {
        // (loops, not `map` and closures: a closure is compiled without the caller's target
        // features, and `map` of 16 was not inlined, so that each broadcast was a call; 4 % of
        // the time of a string of 13-point curves, which builds its curves for each piece)
        let guess = WideCurve::<V, N>::LOOKS_UP && self.scale > 0.0;
        let (scale, top) = (V::splat(self.scale), V::splat(N.saturating_sub(1) as f64));
        let mut w = WideCurve::zeros(guess, scale, top);
        w.cut = self.cut();
        for j in 0..N {
            w.xs[j] = V::splat(self.xs[j]);
            w.ys[j] = V::splat(self.ys[j]);
            w.slopes[j] = V::splat(self.slopes[j]);
        }
        // (the first `2 V::N` of each, two vectors, for `WideCurve::eval`'s look-up)
        let tables = [&self.xs, &self.ys, &self.slopes, &self.segs, &self.nexts];
        let parts = w.table.iter_mut().chain(&mut w.grid);
        for (t, a) in parts.zip(tables).take(if guess { 5 } else { 3 }) {
            let (lo, hi) = a.split_at(N.min(V::N));
            *t = [V::load_part(lo), V::load_part(&hi[..hi.len().min(V::N)])];
        }
        w
    }

    /// This curve and `other` in alternate lanes of `V`, `[self, other, self, other, ...]`, for
    /// [`WideCurve::eval`] of abscissas that alternate the same way: each lane evaluates its own
    /// curve, to the bits [`ExactCurve::wide`] gives it, since every operation of `eval` is
    /// lane by lane. Only for a curve that selects its segments (not [`WideCurve::LOOKS_UP`],
    /// which would look both curves up in one table; refused at compile time).
    ///
    /// # Safety
    /// The CPU must have `V`'s instructions (see [`Vector`]).
    #[cfg(target_arch = "x86_64")]
    #[inline(always)]
    pub(crate) unsafe fn wide_alternating<V: Vector>(
        &self,
        other: &ExactCurve<N>,
    ) -> WideCurve<V, N> {
        const { assert!(!WideCurve::<V, N>::LOOKS_UP) };
        let mut w = WideCurve::zeros(false, V::zero(), V::zero());
        for j in 0..N {
            w.xs[j] = alternate(self.xs[j], other.xs[j]);
            w.ys[j] = alternate(self.ys[j], other.ys[j]);
            w.slopes[j] = alternate(self.slopes[j], other.slopes[j]);
        }
        w
    }
}

/// `[a, b, a, b, ...]` in the lanes of `V` (a function, not a closure, so that it has the
/// caller's target features).
///
/// # Safety
/// The CPU must have `V`'s instructions (see [`Vector`]).
#[cfg(target_arch = "x86_64")]
#[inline(always)]
unsafe fn alternate<V: Vector>(a: f64, b: f64) -> V {
    let ab = [a, b, a, b, a, b, a, b];
    // SAFETY: the caller's promise; `V::N <= 8` numbers of `ab`.
    unsafe { V::load(ab.as_ptr()) }
}

/// An [`ExactCurve`] for several abscissas at a time (eight with AVX-512, four with AVX2):
/// [`ExactCurve::eval`] lane by lane, the same operations on the same operands, each `if` a
/// select.
#[cfg(target_arch = "x86_64")]
#[derive(Clone, Copy)]
pub(crate) struct WideCurve<V: Vector, const N: usize> {
    xs: [V; N],
    ys: [V; N],
    slopes: [V; N],
    /// The first `2 V::N` abscissas, values and slopes, two vectors each (`0.0` past `N`)
    table: [[V; 2]; 3],
    /// Where the curve [`WideCurve::guess`]es: the buckets' segments and next abscissas
    /// ([`ExactCurve::segs`]), two vectors each
    grid: [[V; 2]; 2],
    /// Whether [`WideCurve::eval`] guesses each lane's segment: the curve has a grid and is
    /// looked up ([`WideCurve::LOOKS_UP`])
    guess: bool,
    /// The grid's buckets a unit and `N - 1`, in every lane
    scale: V,
    top: V,
    /// [`ExactCurve::cut`]: [`WideCurve::eval_cut`] makes the selects `1..cut`
    cut: usize,
}

#[cfg(target_arch = "x86_64")]
impl<V: Vector, const N: usize> WideCurve<V, N> {
    /// A curve of zeros but for `guess`, `scale` and `top`, whose numbers its maker then sets.
    ///
    /// # Safety
    /// The CPU must have `V`'s instructions (see [`Vector`]).
    #[inline(always)]
    unsafe fn zeros(guess: bool, scale: V, top: V) -> Self {
        WideCurve {
            xs: [V::zero(); N],
            ys: [V::zero(); N],
            slopes: [V::zero(); N],
            table: [[V::zero(); 2]; 3],
            grid: [[V::zero(); 2]; 2],
            guess,
            scale,
            top,
            cut: N.saturating_sub(1),
        }
    }

    /// The number at index `i` (each lane's) of a table of `N` numbers in one vector or two
    /// (a function, not a closure, so that it has the caller's target features).
    ///
    /// # Safety
    /// The CPU must have `V`'s instructions (see [`Vector`]).
    #[inline(always)]
    unsafe fn pick([lo, hi]: [V; 2], i: V::Index) -> V {
        if N <= V::N {
            lo.pick(i)
        } else {
            lo.pick2(hi, i)
        }
    }

    /// Whether [`WideCurve::eval`] looks segments up rather than selects them: for curves of
    /// more than 4 points (3 selects and a compare a point, against 4 operations a halving and
    /// 3 look-ups in all), a power of two up to [`Vector::LOOKUP`].
    const LOOKS_UP: bool = N > 4 && N.is_power_of_two() && N <= V::LOOKUP;

    /// The value at each lane of `x`: [`ExactCurve::eval`]'s bits in each lane, for a curve
    /// that [`ExactCurve::widens`]. [`Vector::le`] is Rust's `<=` (false when either side is
    /// NaN), `a.select(k, b)` is `if k { b } else { a }`, and `along` is the same `y + (x - x0) *
    /// slope`, rounded after each operation (no fused multiply-add). The end: where `x < x[N-1]`
    /// (`within`) the value is `along`, elsewhere `y[N-1]`; the raised `x` is never NaN, so
    /// `within` is `!(x[N-1] <= x)`, `ExactCurve::eval`'s `!after`. (Written as `y[N-1]`
    /// replaced by `along` where `within`, AVX-512 computes the last `+` only in those lanes, a
    /// masked add in place of an add and a select.)
    ///
    /// Before the first point (or at a NaN) `ExactCurve::eval` gives `y[0]`; here `x` is first
    /// raised to `x[0]` (`x.max(x0)` gives its second operand `x0` for a NaN `x`, and for
    /// two zeros), and segment 0 at `x[0]` is `y[0] + 0 * slope[0]`: `y[0]` plus a zero, `y[0]`
    /// again since it is not `-0.0` and the slope is finite. The point after `x[0]` is further
    /// (`x[0] < x[1]`), so segment 0 is the one chosen, and `within` is true (`x[0] < x[N-1]`).
    /// At or above `x[0]` the raised `x` is `x`, but when `x` and `x[0]` are zeros of opposite
    /// signs, where it is `x[0]`: segment 0 either way, and `x - x0` a zero either way, so the
    /// value is `y[0]` plus a zero, `y[0]`, either way.
    ///
    /// A curve of more points looks its segment up ([`WideCurve::LOOKS_UP`]): the abscissas are
    /// sorted and `x[0] <= x` (`x` raised), so the `j` with `x[j] <= x` are `0..=s` for some `s <
    /// N`, which a binary search finds: `s` is in `i..i + 2h`, first `0..N` (`i = 0`, `h = N /
    /// 2`); then if `x[i + h] <= x`, `s` is in `i + h..i + 2h`, else in `i..i + h`, which is
    /// `i..i + 2h` again for the next `h`, half this one, down to `h = 1` (no index read is past
    /// `N - 1`). Where `s < N - 1` it is the segment the selects keep (the last `j < N - 1`
    /// with `x[j] <= x`); where `s = N - 1` the selects keep `N - 2`, but `x[N-1] <= x`, so
    /// `within` is false and both give `y[N-1]`. [`Vector::pick`] (or [`Vector::pick2`]) reads
    /// the `x[s]`, `y[s]` and slope from the table, the numbers the selects would.
    ///
    /// Where the curve has an exact grid ([`WideCurve::guess`]), `s` is guessed instead, as
    /// [`WideLong::eval`] does ([`Grid`]: the segment of the lane's bucket, plus one where the
    /// abscissa after it is `<= x`; both looked up by bucket): the search's `s` wherever `x <
    /// x[N-1]`, and an index below `N` elsewhere, where the value is `y[N-1]` whatever `s`. The
    /// bucket is `min((x - x[0]) scale, N - 1)` truncated, `Grid::bucket`'s operations, from the
    /// raised `x` (never NaN; `+inf` gives `N - 1`): an index below `N`.
    ///
    /// # Safety
    /// The CPU must have `V`'s instructions (see [`Vector`]).
    #[inline(always)]
    pub(crate) unsafe fn eval(&self, x: V) -> V {
        self.eval_as::<false>(x)
    }

    /// [`WideCurve::eval`], but for a curve of 8 points or more that selects its segments, the
    /// selects from `N / 2` on stop at [`ExactCurve::cut`], read at run time (those from it on
    /// may be skipped: [`ExactCurve::trimmed`], the same bits; a curve the engine keeps at 8 or
    /// 16 points, [`ExactCurve::kept`], has more than `N / 2`, so the first `N / 2 - 1` are
    /// written out and the rest is a loop). For the grid step's strings, whose pair of curves
    /// is compiled at its padded counts: a 7-point curve at 8 makes 5 selects, not 6, a
    /// 13-point one at 16 11, not 14 (on Zen 3, the strings of the bench's `lnl-drawn` and
    /// `lnl-fine` 1.16x faster, a 16-point one with nothing to skip 0.97x; fully a loop, the
    /// curves of 3 and 4 points ran 0.88x; docs/BENCHMARKS-LOG.md, sixty-third session).
    ///
    /// # Safety
    /// The CPU must have `V`'s instructions (see [`Vector`]).
    #[inline(always)]
    pub(crate) unsafe fn eval_cut(&self, x: V) -> V {
        self.eval_as::<true>(x)
    }

    #[inline(always)]
    unsafe fn eval_as<const CUT: bool>(&self, x: V) -> V {
        if N < 2 {
            return V::zero(); // (`N` is 0: `ExactCurve::new` refuses 1)
        }
        let x = x.max(self.xs[0]);
        let (x0, y, slope) = if Self::LOOKS_UP && self.guess {
            let pick = Self::pick;
            let b = x.sub(self.xs[0]).mul(self.scale).min(self.top).truncated();
            let s = pick(self.grid[0], b).index_bits();
            let i = V::moved(s, pick(self.grid[1], b).le(x), V::plus(s, 1));
            let [xs, ys, slopes] = self.table;
            (pick(xs, i), pick(ys, i), pick(slopes, i))
        } else if Self::LOOKS_UP {
            let pick = Self::pick;
            // (the first halving: `i + h` is `h` in every lane, `x[h]` broadcast)
            let mut h = N / 2;
            let mut i = V::first();
            i = V::moved(i, self.xs[h].le(x), V::plus(i, h));
            while h > 1 {
                h /= 2;
                let next = V::plus(i, h);
                i = V::moved(i, pick(self.table[0], next).le(x), next);
            }
            let [xs, ys, slopes] = self.table;
            (pick(xs, i), pick(ys, i), pick(slopes, i))
        } else {
            let (mut x0, mut y, mut slope) = (self.xs[0], self.ys[0], self.slopes[0]);
            let (lo, hi) = if CUT && N >= 8 {
                (N / 2, self.cut.clamp(N / 2, N - 1))
            } else {
                (N - 1, N - 1)
            };
            macro_rules! selects {
                ($js:expr) => {
                    for j in $js {
                        let past = self.xs[j].le(x);
                        x0 = x0.select(past, self.xs[j]);
                        y = y.select(past, self.ys[j]);
                        slope = slope.select(past, self.slopes[j]);
                    }
                };
            }
            selects!(1..lo);
            selects!(lo..hi);
            (x0, y, slope)
        };
        let along = y.add(x.sub(x0).mul(slope));
        let within = x.lt(self.xs[N - 1]);
        self.ys[N - 1].select(within, along)
    }
}

/// A curve of any number of points prepared for the vector paths (the engine gives them curves
/// of more points than an [`ExactCurve`] holds): [`LongCurve::wide`] evaluates it several
/// abscissas at a time, [`Curve::eval`]'s bits, finding each lane's segment by a binary search of
/// indexed loads, or by a guess from a uniform grid ([`Grid`]) corrected by one compare. The
/// abscissas, values and slopes are each padded to `P`, the smallest power of two at least `n -
/// 1` (and at least 1), with the last point repeated (slope `0.0`).
#[derive(Clone, Debug)]
pub(crate) struct LongCurve {
    /// Points (`n`).
    n: usize,
    /// `P`.
    segs: usize,
    /// `x[0..P]`, `y[0..P]`, `slope[0..P]`, then the guess's: each bucket's segment
    /// `seg[0..P]` ([`Grid`], an index's bits as an `f64`) and the next abscissas `next[0..P]`,
    /// `x[i + 1]` for `i + 1 < min(n, P)`, NaN past them (a zero curve: `[0.0; 5]`).
    table: Box<[f64]>,
    /// The grid's buckets a unit of `x` where the guess gives the search's segment ([`Grid`]).
    scale: Option<f64>,
    /// Where the curve has a grid, the guess's numbers by bucket ([`Row`]); else empty.
    rows: Box<[Row]>,
    /// The last point, `(x[n-1], y[n-1])` (`P` may be `n - 1`, the table without it).
    last: (f64, f64),
    /// [`LongCurve::widens`], decided from the curve's own points (a 2-point curve's table has
    /// its first point alone).
    widens: bool,
}

impl LongCurve {
    /// The curve `c`, padded.
    pub(crate) fn new(c: &Curve) -> LongCurve {
        let (xs, ys, slopes) = (c.xs(), c.ys(), c.slopes());
        let n = xs.len();
        let segs = n.saturating_sub(1).max(1).next_power_of_two();
        let mut table = vec![0.0; 5 * segs];
        let mut scale = None;
        let mut rows = Vec::new();
        if n > 0 {
            for i in 0..segs {
                let j = i.min(n - 1);
                table[i] = xs[j];
                table[segs + i] = ys[j];
                table[2 * segs + i] = if i + 1 < n { slopes[i] } else { 0.0 };
                table[4 * segs + i] = if i + 1 < n.min(segs) {
                    xs[i + 1]
                } else {
                    f64::NAN
                };
            }
            if n >= 2 {
                (table[0], table[2 * segs]) = first_segment(xs, ys, slopes);
            }
            if let Some(grid) = Grid::new(&table[..segs], xs[n - 1]) {
                for (b, &edge) in grid.edges.iter().enumerate() {
                    table[3 * segs + b] = f64::from_bits(grid.segment(edge) as u64);
                }
                scale = Some(grid.scale);
                rows = (grid.edges.iter())
                    .map(|&edge| Row::new(&table, segs, grid.segment(edge)))
                    .collect();
            }
        }
        let widens = n < 2
            || (table[0] < xs[1]
                && table[2 * segs].is_finite()
                && ys[0].to_bits() != (-0.0f64).to_bits());
        LongCurve {
            n,
            segs,
            table: table.into(),
            scale,
            rows: rows.into(),
            last: n.checked_sub(1).map_or((0.0, 0.0), |l| (xs[l], ys[l])),
            widens,
        }
    }

    /// Whether [`WideLong::eval`] gives [`Curve::eval`]'s bits: as [`ExactCurve::widens`] (a
    /// zero or one-point curve, or a first segment of a width, a finite slope, and a first value
    /// other than `-0.0`).
    pub(crate) fn widens(&self) -> bool {
        self.widens
    }

    /// Whether [`Curve::eval`] (and [`WideLong::eval`]) never gives `-0.0`, as
    /// [`ExactCurve::never_minus_zero`]: no value is `-0.0` (the table's, and the last point's,
    /// which the table may not hold).
    pub(crate) fn never_minus_zero(&self) -> bool {
        let s = self.segs;
        let not_minus_zero = |y: &f64| y.to_bits() != (-0.0f64).to_bits();
        self.n == 0
            || (self.table[s..2 * s].iter().all(not_minus_zero) && not_minus_zero(&self.last.1))
    }

    /// Whether [`WideLong::eval`] guesses each lane's segment ([`Grid`]): where the grid is
    /// exact and the table is of `2 V::N` numbers or more (smaller ones are searched in
    /// registers), and of fewer than `2^25` segments (each bucket a number [`Vector::rows`]
    /// takes).
    #[cfg(target_arch = "x86_64")]
    fn guesses<V: Vector>(&self) -> bool {
        self.scale.is_some() && self.segs >= 2 * V::N && self.segs < 1 << 25
    }

    /// The curve without its grid: [`WideLong::eval`] searches whatever the curve (for the
    /// tests, which check both).
    #[cfg(test)]
    fn searched(&self) -> LongCurve {
        LongCurve {
            scale: None,
            rows: Box::new([]),
            ..self.clone()
        }
    }

    /// Whether `other` has the same points, bit for bit.
    pub(crate) fn same_bits(&self, other: &LongCurve) -> bool {
        let bits = |(x, y): (f64, f64)| (x.to_bits(), y.to_bits());
        self.n == other.n
            && self.segs == other.segs
            && self.scale.map(f64::to_bits) == other.scale.map(f64::to_bits)
            && bits(self.last) == bits(other.last)
            && (self.table.iter().zip(other.table.iter())).all(|(a, b)| a.to_bits() == b.to_bits())
    }

    /// The curve's table and the numbers [`WideLong::eval`] broadcasts.
    ///
    /// # Safety
    /// The CPU must have `V`'s instructions (see [`Vector`]).
    #[cfg(target_arch = "x86_64")]
    #[inline(always)]
    pub(crate) unsafe fn wide<V: Vector>(&self) -> WideLong<'_, V> {
        let (s, t) = (self.segs, &self.table);
        let c = 2 * V::N;
        // (up to `2 V::N` numbers as two vectors, `0.0` past them)
        let two = |a: &[f64]| {
            let (lo, hi) = a.split_at(a.len().min(V::N));
            [V::load_part(lo), V::load_part(hi)]
        };
        let mut lookup = [[V::zero(); 2]; 3];
        if s <= c {
            for (k, l) in lookup.iter_mut().enumerate() {
                *l = two(&t[k * s..k * s + s]);
            }
        } else {
            let mut coarse = [0.0; 16];
            for (j, x) in coarse.iter_mut().enumerate().take(c) {
                *x = t[j * (s / c)];
            }
            lookup[0] = two(&coarse[..c]);
        }
        WideLong {
            n: self.n,
            segs: s,
            table: t,
            rows: &self.rows,
            lookup,
            x0: V::splat(t[0]),
            mid: V::splat(t[s / 2]),
            x_last: V::splat(self.last.0),
            y_last: V::splat(self.last.1),
            guess: self.guesses::<V>(),
            scale: V::splat(self.scale.unwrap_or(0.0)),
            top: V::splat((s - 1) as f64),
        }
    }
}

/// A bucket's numbers for [`WideLong::eval`]'s guess ([`Grid`]), read in one place (a cache
/// line): the segment `s` of the bucket's edge, its abscissa, value and slope, the next abscissa
/// (`next[s]`, NaN past the table), and the value and slope of segment `s + 1` (`0.0` past the
/// table, where `next[s]` is NaN), then two zeros.
#[derive(Clone, Copy, Debug)]
#[repr(C, align(64))]
struct Row([f64; 8]);

impl Row {
    /// Segment `s`'s row, from a [`LongCurve`]'s table of `P = segs` segments.
    fn new(table: &[f64], segs: usize, s: usize) -> Row {
        let after = |k: usize| {
            if s + 1 < segs {
                table[k * segs + s + 1]
            } else {
                0.0
            }
        };
        let at = |k: usize| table[k * segs + s];
        Row([at(0), at(1), at(2), at(4), after(1), after(2), 0.0, 0.0])
    }
}

/// The uniform grid from which [`WideLong::eval`] (and [`WideCurve::eval`], `P = N`) guesses a
/// lane's segment: `P` buckets over `[x[0], x[n-1]]`, `scale = P / (x[n-1] - x[0])` buckets a
/// unit, the bucket of `x >= x[0]` being `b(x) = min((x - x[0]) scale, P - 1)` truncated (each
/// operation rounded, as the vector code does them), and each bucket's *edge*, its least `x`.
/// The bucket never decreases as `x` grows (a subtraction, a product by a positive number, a
/// `min` and a truncation each keep the order), so the edge is found by bisection over the
/// doubles in order, and every `x` of bucket `b` lies in `edge[b] <= x < edge[b + 1]`.
///
/// The guess takes the segment of the bucket's edge, `s = seg(edge[b])` (`seg(x)`: the last of
/// `0..P` whose abscissa is `<= x`), then `s + 1` where `x[s + 1] <= x`. The grid is *exact*
/// when in every bucket the segments of its `x` below `x[n-1]` are `s` or `s + 1`: then the
/// guess is `seg(x)` wherever `x < x[n-1]` (`seg(x) >= s`, the segments never decreasing; if it
/// is `s`, `x[s + 1] > x`, the last abscissa `<= x` being `x[s]`, and the table's `next[s]` is
/// that abscissa or NaN, never `<= x`; if it is `s + 1`, `s + 1 < n - 1` and `next[s] = x[s +
/// 1] <= x`). Past the last point the value is `y[n-1]` whatever the segment, and the guess is
/// still an index below `P` (`next[P-1]` is NaN). A curve whose abscissas crowd (several in one
/// bucket, a jump of two points or more inside one) has no exact grid and keeps the search.
struct Grid {
    scale: f64,
    /// `x[0..P]`, padded
    xs: Vec<f64>,
    edges: Vec<f64>,
}

impl Grid {
    /// The grid of the padded abscissas `xs` (`P` of them) whose last point is at `last`, if it
    /// is exact; `None` for a curve of one point (no width) or one whose scale is not a finite
    /// positive number.
    fn new(xs: &[f64], last: f64) -> Option<Grid> {
        let p = xs.len();
        let scale = p as f64 / (last - xs[0]);
        if !(scale.is_finite() && scale > 0.0) {
            return None;
        }
        let mut grid = Grid {
            scale,
            xs: xs.to_vec(),
            edges: Vec::with_capacity(p),
        };
        // (the doubles in order as integers: a negative double's bits count down)
        let key = |x: f64| {
            let b = x.to_bits() as i64;
            if b < 0 {
                i64::MIN - b
            } else {
                b
            }
        };
        let unkey = |k: i64| {
            f64::from_bits(if k < 0 {
                (i64::MIN - k) as u64
            } else {
                k as u64
            })
        };
        let (bottom, top) = (key(xs[0]), key(f64::MAX));
        for b in 0..p {
            // (bisection between 64 doubles either side of `x[0] + b / scale` where the edge is
            // between them, as it is unless rounding moved it far: a curve is loaded in
            // microseconds; else over all the doubles from `x[0]`)
            let near = key(xs[0] + b as f64 / scale);
            let (lo, hi) = ((near - 64).max(bottom), (near + 64).min(top));
            let brackets = grid.bucket(unkey(lo)) < b && grid.bucket(unkey(hi)) >= b;
            let (mut lo, mut hi) = if brackets { (lo, hi) } else { (bottom, top) };
            while lo < hi {
                let mid = ((i128::from(lo) + i128::from(hi)) >> 1) as i64;
                if grid.bucket(unkey(mid)) >= b {
                    hi = mid;
                } else {
                    lo = mid + 1;
                }
            }
            grid.edges.push(unkey(hi));
        }
        // the segments below the last point: before the first abscissa at `last`
        let most = xs.partition_point(|&a| a < last) - 1;
        let exact = (0..p).all(|b| {
            let end = grid
                .edges
                .get(b + 1)
                .map_or(f64::INFINITY, |e| e.next_down());
            grid.segment(end).min(most) <= grid.segment(grid.edges[b]) + 1
        });
        exact.then_some(grid)
    }

    /// The bucket of `x`: [`WideLong::eval`]'s operations, one at a time.
    fn bucket(&self, x: f64) -> usize {
        let (first, top) = (self.xs[0], (self.xs.len() - 1) as f64);
        ((x.max(first) - first) * self.scale).min(top) as usize
    }

    /// The last of `0..P` whose abscissa is `<= x` (0 below the first).
    fn segment(&self, x: f64) -> usize {
        self.xs.partition_point(|&a| a <= x).max(1) - 1
    }
}

/// A [`LongCurve`] for several abscissas at a time ([`LongCurve::wide`]).
#[cfg(target_arch = "x86_64")]
#[derive(Clone, Copy)]
pub(crate) struct WideLong<'a, V: Vector> {
    n: usize,
    segs: usize,
    table: &'a [f64],
    /// [`LongCurve::rows`].
    rows: &'a [Row],
    /// With `P <= 2 V::N` the table's abscissas, values and slopes, two vectors each; else the
    /// `2 V::N` abscissas `x[j P / (2 V::N)]` (the *coarse* ones).
    lookup: [[V; 2]; 3],
    /// `x[0]`, `x[P/2]`, `x[n-1]`, `y[n-1]` in every lane.
    x0: V,
    mid: V,
    x_last: V,
    y_last: V,
    /// [`LongCurve::guesses`], and the grid's buckets a unit and `P - 1` in every lane.
    guess: bool,
    scale: V,
    top: V,
}

#[cfg(target_arch = "x86_64")]
impl<V: Vector> WideLong<'_, V> {
    /// The value at each lane of `x`: [`Curve::eval`]'s bits in each lane, for a curve that
    /// [`LongCurve::widens`], by [`WideCurve::eval`]'s arithmetic. `x` is first raised to `x[0]`
    /// (a NaN too: `max` gives its second operand), which changes no value (see
    /// `WideCurve::eval`; a one-point curve is `y[0]` everywhere, and the raised `x` is never
    /// below `x[0]`); then the segment `i` is the last of `0..P` with `x[i] <= x`, found by
    /// halving (`i = 0`; for `h = P/2, P/4, .., 1`, `i + h` where `x[i + h] <= x`: a binary
    /// search over sorted abscissas). The first halving compares `x[P/2]` broadcast; with `P <=
    /// 2 V::N` the others and the segment's numbers are looked up in two vectors
    /// ([`Vector::pick2`]); else the halvings down to `P / (2 V::N)` look the coarse abscissas
    /// up (`j` counts coarse abscissas, `i = j P / (2 V::N)`: the same comparisons), and the
    /// rest and the segment's numbers are fetched from the table ([`WideLong::fetch`]). Where
    /// `x < x[n-1]` (`within`) that is the segment [`Curve::eval`] takes, its last point `<= x`
    /// (the points from `n - 1` on, and any padding, `x[n-1]`, are not `<= x`); the value is
    /// then `y + (x - x[i]) slope`, and elsewhere `y[n-1]`, as `Curve::eval` at or past the last
    /// point (the raised `x` is never NaN). Every index is below `P` (a sum of distinct
    /// halvings), within the table.
    ///
    /// Where the curve [`LongCurve::guesses`], the segment is guessed instead ([`Grid`]: the
    /// segment of the bucket's edge, plus one where the next abscissa is `<= x`), which is the
    /// search's wherever `x < x[n-1]`, and an index below `P` elsewhere: the same bits. The
    /// bucket is computed from the raised `x` (never NaN; at `+inf` the product is `+inf` and
    /// the `min` gives `P - 1`) by the operations of `Grid::bucket`: a number from `+0.0` or
    /// `-0.0` (`x = x[0]`) to `P - 1`, truncated. Where [`Vector::ROWS`] (AVX2), the bucket's
    /// [`Row`] gives the numbers of both segments the guess may take, `s` and `s + 1`, and the
    /// next abscissa, read at once, and the compare selects one: the numbers the fetches
    /// give, without the wait for the segment before the fetches.
    ///
    /// # Safety
    /// The CPU must have `V`'s instructions (see [`Vector`]).
    #[inline(always)]
    pub(crate) unsafe fn eval(&self, x: V) -> V {
        if self.n == 0 {
            return V::zero();
        }
        let s = self.segs;
        let x = x.max(self.x0);
        let c = 2 * V::N;
        let [_, ys, slopes] = self.lookup;
        let xs = self.lookup[0];
        let (x0, y, slope) = if self.guess {
            let b = x.sub(self.x0).mul(self.scale).min(self.top);
            if V::ROWS {
                assert!(self.rows.len() == s);
                // SAFETY: each bucket is a number from `-0.0` to `P - 1`, the index of one of
                // the `P` rows (asserted), and `P < 2^25` (`LongCurve::guesses`), as `rows`
                // asks.
                let [x0, y, slope, next, y1, slope1] = b.rows(self.rows.as_ptr().cast());
                let up = next.le(x);
                (
                    x0.select(up, next),
                    y.select(up, y1),
                    slope.select(up, slope1),
                )
            } else {
                let first = self.fetch(3, b.truncated()).index_bits();
                let i = V::moved(first, self.fetch(4, first).le(x), V::plus(first, 1));
                (self.fetch(0, i), self.fetch(1, i), self.fetch(2, i))
            }
        } else if s <= c {
            let i = self.search(x, s / 2);
            (
                xs[0].pick2(xs[1], i),
                ys[0].pick2(ys[1], i),
                slopes[0].pick2(slopes[1], i),
            )
        } else {
            let stride = s / c;
            let mut i = V::times(self.search(x, c / 2), stride.trailing_zeros());
            let mut h = stride;
            while h > 1 {
                h /= 2;
                let next = V::plus(i, h);
                i = V::moved(i, self.fetch(0, next).le(x), next);
            }
            (self.fetch(0, i), self.fetch(1, i), self.fetch(2, i))
        };
        let along = y.add(x.sub(x0).mul(slope));
        let within = x.lt(self.x_last);
        self.y_last.select(within, along)
    }

    /// Item `i` (each lane's) of the table's part `k` (`0` the abscissas, `1` the values, `2`
    /// the slopes, `3` the buckets' segments, `4` the next abscissas), of `P >= 2 V::N` numbers:
    /// looked up in its vectors ([`WideLong::look`]) up to [`Vector::LOOK_MAX`] numbers, else
    /// gathered.
    ///
    /// # Safety
    /// The CPU must have `V`'s instructions (see [`Vector`]); `k < 5`, each index below `P`.
    #[inline(always)]
    unsafe fn fetch(&self, k: usize, i: V::Index) -> V {
        let s = self.segs;
        assert!(k < 5 && self.table.len() == 5 * s && s.is_multiple_of(2 * V::N));
        // SAFETY: `P` numbers from `k P` are within the table (asserted); the caller's promise
        // for the indices.
        let t = self.table.as_ptr().add(k * s);
        if s <= V::LOOK_MAX {
            Self::look(t, s, i)
        } else {
            V::gather(t, i)
        }
    }

    /// `t[i]` in each lane, from the table of `len` numbers at `t` (a multiple of `2 V::N`): the
    /// number at `i mod 2 V::N` of each `2 V::N` of them ([`Vector::pick2`]), that of the last
    /// `2 V::N` that starts at or before `i` kept (a select each).
    ///
    /// # Safety
    /// The CPU must have `V`'s instructions (see [`Vector`]); `t` is valid for `len` reads, and
    /// each index below `len`.
    #[inline(always)]
    unsafe fn look(t: *const f64, len: usize, i: V::Index) -> V {
        let n = V::N;
        let low = V::low(i);
        let mut r = V::load(t).pick2(V::load(t.add(n)), low);
        let mut p = 2 * n;
        while p < len {
            let later = V::load(t.add(p)).pick2(V::load(t.add(p + n)), low);
            r = r.select(V::at_least(i, p), later);
            p += 2 * n;
        }
        r
    }

    /// The halvings of `eval` from `h` (`P / 2`, or `V::N`) down, over the first table of
    /// `lookup` (the first from `x[P/2]` broadcast): an index below `2 h` in each lane (a
    /// function, not a closure, so that it has the caller's target features).
    ///
    /// # Safety
    /// The CPU must have `V`'s instructions (see [`Vector`]).
    #[inline(always)]
    unsafe fn search(&self, x: V, mut h: usize) -> V::Index {
        let xs = self.lookup[0];
        let mut i = V::first();
        if h > 0 {
            i = V::moved(i, self.mid.le(x), V::plus(i, h));
            while h > 1 {
                h /= 2;
                let next = V::plus(i, h);
                i = V::moved(i, xs[0].pick2(xs[1], next).le(x), next);
            }
        }
        i
    }
}

/// Why a list of points is not a curve.
#[derive(Clone, Debug, PartialEq)]
pub enum CurveError {
    /// A coordinate is NaN or infinite; `index` is the point's position in the list.
    NonFinite {
        /// Position of the offending point.
        index: usize,
    },
    /// The abscissa of point `index` is smaller than the one before it.
    Decreasing {
        /// Position of the offending point.
        index: usize,
    },
}

impl std::fmt::Display for CurveError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            CurveError::NonFinite { index } => write!(f, "point {} is not finite", index + 1),
            CurveError::Decreasing { index } => write!(
                f,
                "point {} has a smaller abscissa than the point before it (abscissas must not decrease)",
                index + 1
            ),
        }
    }
}

impl std::error::Error for CurveError {}

impl Curve {
    /// The zero curve.
    pub fn zero() -> Curve {
        Curve::default()
    }

    /// A curve through `points`, checked: finite coordinates, non-decreasing abscissas.
    pub fn new(points: &[(f64, f64)]) -> Result<Curve, CurveError> {
        for (index, &(x, y)) in points.iter().enumerate() {
            if !x.is_finite() || !y.is_finite() {
                return Err(CurveError::NonFinite { index });
            }
            if index > 0 && x < points[index - 1].0 {
                return Err(CurveError::Decreasing { index });
            }
        }
        let slopes: Vec<f64> = points
            .windows(2)
            .map(|w| {
                if w[1].0 > w[0].0 {
                    (w[1].1 - w[0].1) / (w[1].0 - w[0].0)
                } else {
                    0.0
                }
            })
            .collect();
        let mut cumulative = Vec::with_capacity(points.len());
        let mut acc = 0.0;
        for (i, p) in points.iter().enumerate() {
            if i > 0 {
                let q = points[i - 1];
                acc += 0.5 * (q.1 + p.1) * (p.0 - q.0);
            }
            cumulative.push(acc);
        }
        let mut table = Vec::with_capacity(4 * points.len());
        table.extend(points.iter().map(|p| p.0));
        table.extend(points.iter().map(|p| p.1));
        table.extend(slopes);
        table.extend(cumulative);
        Ok(Curve {
            table: table.into_boxed_slice(),
        })
    }

    /// Number of points, from the table's length `4 n - 1` (0 for the zero curve).
    #[inline(always)]
    fn n(&self) -> usize {
        self.table.len().div_ceil(4)
    }

    /// The abscissas.
    #[inline(always)]
    fn xs(&self) -> &[f64] {
        &self.table[..self.n()]
    }

    /// The values.
    #[inline(always)]
    fn ys(&self) -> &[f64] {
        let n = self.n();
        &self.table[n..2 * n]
    }

    /// The slopes of the `n - 1` segments.
    #[inline(always)]
    fn slopes(&self) -> &[f64] {
        let n = self.n();
        &self.table[2 * n..(3 * n).saturating_sub(1)]
    }

    /// `∫ from x[0] to x[i]`.
    #[inline(always)]
    fn cumulative(&self) -> &[f64] {
        let n = self.n();
        &self.table[(3 * n).saturating_sub(1)..]
    }

    /// The points, in order.
    pub fn points(&self) -> impl Iterator<Item = (f64, f64)> + '_ {
        self.xs().iter().copied().zip(self.ys().iter().copied())
    }

    /// Number of points.
    pub fn len(&self) -> usize {
        self.xs().len()
    }

    /// True for the zero curve (no points).
    pub fn is_empty(&self) -> bool {
        self.xs().is_empty()
    }

    /// The curve's value at `x` (see the type's documentation for the exact arithmetic).
    #[inline]
    pub fn eval(&self, x: f64) -> f64 {
        let n = self.xs().len();
        if n == 0 {
            return 0.0;
        }
        // Number of points whose abscissa is <= x; the last of them is `i = count - 1`. Abscissas
        // are sorted, so a branch-free count over a short curve (the usual LNL) finds the same
        // `count` as the binary search, faster.
        let count = if n <= 8 {
            self.xs().iter().map(|&a| usize::from(a <= x)).sum()
        } else {
            self.xs().partition_point(|&a| a <= x)
        };
        if count == 0 {
            return self.ys()[0];
        }
        let i = count - 1;
        if i == n - 1 {
            return self.ys()[i];
        }
        // x[i] <= x < x[i+1]: a proper segment, never a jump.
        self.ys()[i] + (x - self.xs()[i]) * self.slopes()[i]
    }

    /// The slope of the segment that contains `x` (0 outside the points and at a jump's abscissa
    /// only when the segment after it is flat). Used by analysis to linearise an LNL.
    pub fn slope(&self, x: f64) -> f64 {
        let n = self.xs().len();
        let count = self.xs().partition_point(|&a| a <= x);
        if count == 0 || count >= n {
            return 0.0;
        }
        let i = count - 1;
        (self.ys()[i + 1] - self.ys()[i]) / (self.xs()[i + 1] - self.xs()[i])
    }

    /// The largest absolute slope over all finite segments (a worst-case stiffness).
    pub fn max_abs_slope(&self) -> f64 {
        let mut best = 0.0f64;
        for i in 1..self.xs().len() {
            let dx = self.xs()[i] - self.xs()[i - 1];
            if dx > 0.0 {
                best = best.max(((self.ys()[i] - self.ys()[i - 1]) / dx).abs());
            }
        }
        best
    }

    /// An antiderivative: `∫ from x[0] to x` of the curve (constant extensions included).
    pub fn antiderivative(&self, x: f64) -> f64 {
        let n = self.xs().len();
        if n == 0 {
            return 0.0;
        }
        let count = self.xs().partition_point(|&a| a <= x);
        if count == 0 {
            return self.ys()[0] * (x - self.xs()[0]);
        }
        let i = count - 1;
        let t = x - self.xs()[i];
        if i == n - 1 {
            return self.cumulative()[i] + self.ys()[i] * t;
        }
        self.cumulative()[i] + t * (self.ys()[i] + 0.5 * self.slopes()[i] * t)
    }

    /// `∫ from 0 to x` of the curve: the potential energy of an LNL elastic curve at elongation `x`.
    pub fn integral_from_zero(&self, x: f64) -> f64 {
        self.antiderivative(x) - self.antiderivative(0.0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `n` numbers spread evenly over `-half..half` (a linear congruential generator).
    fn uniform(mut seed: u64, n: usize, half: f64) -> Vec<f64> {
        (0..n)
            .map(|_| {
                seed = seed
                    .wrapping_mul(6364136223846793005)
                    .wrapping_add(1442695040888963407);
                ((seed >> 11) as f64 / (1u64 << 53) as f64) * 2.0 * half - half
            })
            .collect()
    }

    #[test]
    fn exact_curves_evaluate_to_the_same_bits() {
        let curves = [
            vec![],
            vec![(0.5, -2.0)],
            vec![(-1.0, 0.5), (2.0, 1.0)],
            vec![(0.0, -1.0), (0.0, 1.0)],
            vec![(-1.0, -0.1), (0.0, 0.0), (1.0, 0.1)],
            vec![(0.0, 0.0), (1.0, 1.0), (1.0, -0.0)],
            vec![(-2.0, -0.0), (-2.0, 3.0), (5.0, -1.0)],
            vec![(-0.5, 0.0), (-0.5, -0.05), (0.5, 0.05), (0.5, 0.0)],
            vec![
                (-3.0, 1.0),
                (-1.0, -0.0),
                (0.0, 0.0),
                (0.0, 2.0),
                (1.0, 3.0),
                (4.0, -1.0),
            ],
            vec![
                (-2.0, -1.0),
                (-1.0, -0.5),
                (-1.0, -0.25),
                (0.0, 0.0),
                (0.5, 0.75),
            ],
            (0..7).map(|i| (i as f64 / 3.0, (i as f64).sin())).collect(),
            (0..8).map(|i| (i as f64, (i * i) as f64)).collect(),
            (0..9).map(|i| (i as f64 - 4.5, (i as f64).cos())).collect(),
            (0..13)
                .map(|i| (((i / 2) * 2) as f64 * 0.25, (i % 5) as f64 - 2.0))
                .collect(),
            (0..16)
                .map(|i| ((i as f64).sqrt(), i as f64 * -0.5))
                .collect(),
        ];
        let mut xs = vec![f64::NAN, f64::INFINITY, f64::NEG_INFINITY, 0.0, -0.0, 1e300];
        xs.extend(uniform(12345, 2000, 6.0));
        for pts in &curves {
            let c = Curve::new(pts).unwrap();
            xs.extend(pts.iter().map(|p| p.0));
            // (each size the curve is exact at, or pads to: 2, 3, 4, 8, 16)
            let (e0, e2, e3, e4) = (
                ExactCurve::<0>::new(&c),
                ExactCurve::<2>::new(&c),
                ExactCurve::<3>::new(&c),
                ExactCurve::<4>::new(&c),
            );
            assert_eq!(
                [e0.is_some(), e2.is_some(), e3.is_some(), e4.is_some()],
                [
                    pts.is_empty(),
                    pts.len() == 2,
                    pts.len() == 3,
                    pts.len() == 4
                ]
            );
            assert!(ExactCurve::<1>::new(&c).is_none());
            let (f2, f3, f4, f8, f16) = (
                ExactCurve::<2>::fitted(&c),
                ExactCurve::<3>::fitted(&c),
                ExactCurve::<4>::fitted(&c),
                ExactCurve::<8>::fitted(&c),
                ExactCurve::<16>::fitted(&c),
            );
            let fits = |m: usize| !pts.is_empty() && pts.len() <= m;
            assert_eq!(
                [
                    f2.is_some(),
                    f3.is_some(),
                    f4.is_some(),
                    f8.is_some(),
                    f16.is_some()
                ],
                [fits(2), fits(3), fits(4), fits(8), fits(16)]
            );
            assert_eq!(ExactCurve::<0>::fitted(&c).is_some(), pts.is_empty());
            for &x in &xs {
                let want = c.eval(x).to_bits();
                let exact = [
                    e0.map(|e| e.eval(x)),
                    e2.map(|e| e.eval(x)),
                    e3.map(|e| e.eval(x)),
                    e4.map(|e| e.eval(x)),
                    f2.map(|e| e.eval(x)),
                    f3.map(|e| e.eval(x)),
                    f4.map(|e| e.eval(x)),
                    f8.map(|e| e.eval(x)),
                    f16.map(|e| e.eval(x)),
                ];
                for v in exact.into_iter().flatten() {
                    assert_eq!(v.to_bits(), want, "{pts:?} at {x} (exact)");
                }
            }
        }
        let seventeen: Vec<(f64, f64)> = (0..17).map(|i| (i as f64, 0.0)).collect();
        assert!(ExactCurve::<16>::fitted(&Curve::new(&seventeen).unwrap()).is_none());
    }

    /// `WideCurve::eval` gives `Curve::eval`'s bits in every lane for the curves that widen,
    /// at the points, next to them, at zeros, infinities and NaNs of both signs; the curves that
    /// do not widen (a `-0.0` first value, an infinite first slope) are refused because it would
    /// not; a jump at the first point widens ([`first_segment`]). Curves of 9 to 16 points whose
    /// grid is exact are evaluated both ways, their segments guessed and searched (also at the
    /// grid's bucket edges and next to them).
    #[test]
    fn wide_curves_evaluate_to_the_same_bits() {
        let curves = curves_to_widen();
        let probed = probes(777, 500, curves.iter().map(|c| &c.0[..]));
        let (mut refused_differ, mut refused_runs) = (0, 0);
        // (the runs of each curve: one a width, and with AVX-512 one more where it has a grid)
        let mut widths = usize::MAX;
        let mut gridded = 0;
        for (pts, widens) in &curves {
            let c = Curve::new(pts).unwrap();
            let mut xs = probed.clone();
            let n = pts.len();
            if (9..=16).contains(&n) {
                // (the abscissas as `ExactCurve::fitted` pads them, to 16)
                let padded: Vec<f64> = (0..16).map(|i| c.xs()[i.min(n - 1)]).collect();
                if let Some(grid) = Grid::new(&padded, padded[15]) {
                    probe_edges(&mut xs, &grid);
                    gridded += 1;
                }
            }
            // (each curve as the `ExactCurve` of its size, evaluated wide and one at a time)
            let (got, want): (Vec<Vec<u64>>, Vec<u64>) = match pts.len() {
                0 => wide_bits(&ExactCurve::<0>::new(&c).unwrap(), &xs, *widens),
                2 => wide_bits(&ExactCurve::<2>::new(&c).unwrap(), &xs, *widens),
                3 => wide_bits(&ExactCurve::<3>::new(&c).unwrap(), &xs, *widens),
                4 => wide_bits(&ExactCurve::<4>::new(&c).unwrap(), &xs, *widens),
                5..=8 => wide_bits(&ExactCurve::<8>::fitted(&c).unwrap(), &xs, *widens),
                _ => wide_bits(&ExactCurve::<16>::fitted(&c).unwrap(), &xs, *widens),
            };
            let scalar: Vec<u64> = xs.iter().map(|&x| c.eval(x).to_bits()).collect();
            assert_eq!(want, scalar, "{pts:?}: ExactCurve::eval");
            widths = widths.min(got.len());
            for got in got {
                if *widens {
                    for (i, (g, w)) in got.iter().zip(&want).enumerate() {
                        assert_eq!(g, w, "{pts:?} at {}", xs[i]);
                    }
                } else {
                    refused_runs += 1;
                    refused_differ += usize::from(got != want);
                }
            }
        }
        // (each refused curve would give other bits somewhere, in every width and both ways:
        // `+0.0` for a `-0.0` first value, `0 * inf`, a NaN, before an infinite slope)
        assert_eq!(refused_differ, refused_runs);
        assert!(refused_runs >= widths * curves.iter().filter(|c| !c.1).count());
        // the evenly spread curves of 9 to 16 points and the mildly uneven one have an exact
        // grid; jumps inside, and abscissas that crowd toward one end, do not
        let grids = |pts: &[(f64, f64)]| {
            let c = Curve::new(pts).unwrap();
            ExactCurve::<16>::fitted(&c).unwrap().scale > 0.0
        };
        let even = |n: usize| -> Vec<(f64, f64)> {
            (0..n)
                .map(|i| (i as f64 * 0.5 - 1.0, (i as f64).cos()))
                .collect()
        };
        for n in [9, 13, 16] {
            assert!(grids(&even(n)), "{n}");
        }
        // (the engine bench's `fine` spring of 13 points, at 0, ±1/4, ±1/2, ±3/4, ±1, ±3/2 and
        // ±2 times 1000: its points fall on the edges of buckets a quarter wide)
        let ts = [
            -2.0, -1.5, -1.0, -0.75, -0.5, -0.25, 0.0, 0.25, 0.5, 0.75, 1.0, 1.5, 2.0,
        ];
        let fine: Vec<(f64, f64)> = (ts.iter())
            .map(|&t: &f64| {
                let y = if t.abs() <= 1.0 {
                    t
                } else {
                    t.signum() * (2.0 * t.abs() - 1.0)
                };
                (t * 1e3, 0.1 * y * 1e3)
            })
            .collect();
        assert!(grids(&fine));
        // (the 12 points with jumps inside, the 16 at square roots, the 16 in jumps of two)
        let crowded: Vec<_> = (curves.iter().map(|c| &c.0))
            .filter(|p| p.len() == 12 || (p.len() == 16 && p[1].0 - p[0].0 == 1.0))
            .collect();
        assert!(crowded.len() == 3 && crowded.iter().all(|p| !grids(p)));
        // (and in `curves_to_widen`: the 9 evenly spread, the 13 and 16 evenly spread, the 13
        // mildly uneven, and the refused 13 of a `-0.0` first value, which are spread evenly)
        assert_eq!(gridded, 5);
    }

    /// Curves of 0 to 16 points, and whether they widen ([`ExactCurve::widens`]).
    fn curves_to_widen() -> Vec<(Vec<(f64, f64)>, bool)> {
        vec![
            (vec![], true),
            (vec![(-1.0, 0.5), (2.0, 1.0)], true),
            (vec![(-1.0, -0.1), (0.0, 0.0), (1.0, 0.1)], true),
            (vec![(0.0, 0.0), (1.0, 1.0), (1.0, -0.0)], true),
            (vec![(-0.01, -1e-3), (0.0, 0.0), (0.01, 2e-3)], true),
            (
                vec![(-0.5, 0.0), (-0.25, -0.05), (0.5, 0.05), (0.5, 0.0)],
                true,
            ),
            (
                vec![(-0.0, 0.0), (0.5, -1.0), (0.5, 2.0), (3.0, -0.0)],
                true,
            ),
            (vec![(-1.0, -0.0), (1.0, 1.0)], false),
            // (a jump at the first point, as `first_segment` prepares it: at 0, of either
            // sign, the first value a zero or not, points stacked; the sticking spring)
            (vec![(0.0, -1.0), (0.0, 1.0)], true),
            (vec![(0.0, 1.0), (0.0, 2.0)], true),
            (vec![(0.0, 0.0), (0.0, 1.0), (1.0, 2.0)], true),
            (vec![(-0.0, 1.0), (0.0, 2.0), (0.0, -1.0), (1.0, 0.0)], true),
            (
                vec![(-0.5, 0.0), (-0.5, -0.05), (0.5, 0.05), (0.5, 0.0)],
                true,
            ),
            (vec![(-2.0, -0.0), (-2.0, 3.0), (5.0, -1.0)], false),
            (vec![(-1e-300, -1e300), (1e-300, 1e300), (1.0, 0.0)], false),
            (
                (0..5)
                    .map(|i| (i as f64 - 2.0, (i as f64 - 2.0).powi(3)))
                    .collect(),
                true,
            ),
            (
                vec![
                    (-3.0, 1.0),
                    (-1.0, -0.5),
                    (0.0, 0.0),
                    (0.0, 2.0),
                    (1.0, 3.0),
                    (2.0, 3.0),
                    (4.0, -1.0),
                    (4.0, -0.0),
                ],
                true,
            ),
            (
                vec![(-1.0, 1.0), (-1.0, 2.0), (0.0, 0.0), (1.0, 1.0), (2.0, 0.0)],
                true,
            ),
            // (9 to 16 points, padded to 16: jumps inside and at the end, a -0.0 value; then
            // evenly spread and mildly uneven, with a grid)
            (
                (0..9)
                    .map(|i| (i as f64 * 0.75 - 3.0, (i as f64 * 0.9).sin()))
                    .collect(),
                true,
            ),
            (
                (0..12)
                    .map(|i| {
                        let x = [
                            -3.5, -3.0, -2.0, -1.0, -1.0, 0.0, 0.5, 1.0, 1.0, 2.5, 3.0, 3.0,
                        ];
                        (x[i], [0.5, -0.0, 1.0, 2.0][i % 4] - i as f64 * 0.125)
                    })
                    .collect(),
                true,
            ),
            (
                (0..16)
                    .map(|i| ((i as f64).sqrt() - 2.0, (i as f64 - 7.0).powi(3)))
                    .collect(),
                true,
            ),
            (
                (0..16)
                    .map(|i| (((i + 1) / 2) as f64 - 4.0, if i == 0 { -0.0 } else { 1.0 }))
                    .collect(),
                false,
            ),
            (
                (0..13)
                    .map(|i| (i as f64 / 6.0 - 1.0, (i as f64 * 0.8).sin() - 0.25))
                    .collect(),
                true,
            ),
            (
                (0..16)
                    .map(|i| (i as f64 * 0.125 - 0.9375, ((i * i) % 7) as f64))
                    .collect(),
                true,
            ),
            (
                (0..13)
                    .map(|i| {
                        let u = i as f64 / 6.0 - 1.0;
                        (u * (1.0 + 0.1 * u * u), u * u * u)
                    })
                    .collect(),
                true,
            ),
            (
                (0..7)
                    .map(|i| (i as f64 * 0.3 - 0.9, (i as f64 * 0.9).cos()))
                    .collect(),
                true,
            ),
            (
                (0..13)
                    .map(|i| (i as f64 / 6.0 - 1.0, if i == 0 { -0.0 } else { 0.5 }))
                    .collect(),
                false,
            ),
        ]
    }

    /// A curve of more than 16 points ([`LongCurve`]) gives [`Curve::eval`]'s bits wide, in
    /// each width the CPU has, wherever it widens ([`LongCurve::widens`], the rule of
    /// `ExactCurve::widens`): curves of 17 to 100 points with jumps inside and at the end and
    /// `-0.0` values, and the curves of 0 to 16 points of the wide test; a curve refused gives
    /// other bits somewhere in each width.
    #[test]
    fn long_curves_evaluate_to_the_same_bits() {
        let mut curves = curves_to_widen();
        let wavy = |n: usize, i: usize| (i as f64 * 4.0 / n as f64 - 2.0, (i as f64 * 0.7).sin());
        curves.push(((0..17).map(|i| wavy(17, i)).collect(), true));
        // (a last value of `-0.0`, which the table of 16 segments does not hold)
        let mut ends_minus_zero: Vec<(f64, f64)> = (0..17).map(|i| wavy(17, i)).collect();
        ends_minus_zero[16].1 = -0.0;
        curves.push((ends_minus_zero, true));
        curves.push(((0..33).map(|i| wavy(33, i)).collect(), true));
        curves.push(((0..64).map(|i| wavy(64, i)).collect(), true));
        // (jumps inside and at the end, `-0.0` values)
        let jumpy: Vec<(f64, f64)> = (0..40usize)
            .map(|i| {
                let x = i.div_ceil(3) as f64 * 0.25 - 1.5;
                let y = [0.5, -0.0, 1.0, 1.0, -2.0][i % 5] + (i / 5) as f64;
                (x, y)
            })
            .collect();
        curves.push((jumpy.clone(), true));
        curves.push(((0..100).map(|i| wavy(100, i)).collect(), true));
        // (a jump at the first point, as `first_segment` prepares it; refused: a `-0.0` first
        // value)
        let mut first_jump = jumpy.clone();
        first_jump[1].0 = first_jump[0].0;
        curves.push((first_jump.clone(), true));
        let mut minus_zero = (0..20).map(|i| wavy(20, i)).collect::<Vec<_>>();
        minus_zero[0].1 = -0.0;
        curves.push((minus_zero, false));
        // (abscissas spread unevenly, as a sampled force law's: mildly, one to a bucket at
        // most; and more, two in some buckets)
        let uneven = |n: usize, bend: f64| -> Vec<(f64, f64)> {
            (0..n)
                .map(|i| {
                    let u = i as f64 * 2.0 / (n - 1) as f64 - 1.0;
                    (u * (1.0 + bend * u * u), u.sin())
                })
                .collect()
        };
        curves.push((uneven(30, 0.05), true));
        curves.push((uneven(33, 0.3), true));
        let xs = probes(779, 500, curves.iter().map(|c| &c.0[..]));
        let mut refused_differ = 0;
        let mut widths = 0;
        let mut guessed = 0;
        for (pts, widens) in &curves {
            let c = Curve::new(pts).unwrap();
            let long = LongCurve::new(&c);
            assert_eq!(long.widens(), *widens, "{pts:?}");
            let minus_zero = pts.iter().any(|p| p.1.to_bits() == (-0.0f64).to_bits());
            assert_eq!(long.never_minus_zero(), !minus_zero, "{pts:?}");
            // the grid's bucket edges and their neighbours too, where it has one
            let mut xs = xs.clone();
            let grid =
                (pts.len() > 1).then(|| Grid::new(&long.table[..long.segs], c.xs()[pts.len() - 1]));
            if let Some(Some(grid)) = &grid {
                guessed += 1;
                assert!(long.scale.is_some());
                probe_edges(&mut xs, grid);
            } else {
                assert!(long.scale.is_none());
            }
            let want: Vec<u64> = xs.iter().map(|&x| c.eval(x).to_bits()).collect();
            let got = long_bits(&long, &xs);
            let searched = long_bits(&long.searched(), &xs);
            widths = got.len();
            for got in got.into_iter().chain(searched) {
                if *widens {
                    for (i, (g, w)) in got.iter().zip(&want).enumerate() {
                        assert_eq!(g, w, "{} points at {}", pts.len(), xs[i]);
                    }
                } else if got != want {
                    refused_differ += 1;
                }
            }
        }
        assert_eq!(
            refused_differ,
            2 * widths * curves.iter().filter(|c| !c.1).count()
        );
        // the evenly spread curves of 17 to 100 points and the mildly uneven one have an exact
        // grid; the jumps of three points (`jumpy`, `first_jump`) and the crowded abscissas
        // do not
        let grids = |pts: &[(f64, f64)]| LongCurve::new(&Curve::new(pts).unwrap()).scale.is_some();
        for n in [17, 33, 64, 100] {
            assert!(
                grids(&(0..n).map(|i| wavy(n, i)).collect::<Vec<_>>()),
                "{n}"
            );
        }
        assert!(grids(&uneven(30, 0.05)));
        assert!(!grids(&uneven(33, 0.3)) && !grids(&jumpy) && !grids(&first_jump));
        assert!(guessed >= 6, "{guessed}");
        #[cfg(target_arch = "x86_64")]
        assert!(widths > 0 || !std::is_x86_feature_detected!("avx2"));
    }

    /// `WideLong::eval` of `c` at `xs` in each width the CPU has (AVX-512, AVX2; none
    /// elsewhere).
    fn long_bits(c: &LongCurve, xs: &[f64]) -> Vec<Vec<u64>> {
        #[allow(unused_mut)]
        let mut got = Vec::new();
        #[cfg(target_arch = "x86_64")]
        {
            use crate::wide::{V4, V8};
            /// `WideLong::eval` of `c` at `xs`, `V::N` at a time (the last lanes `0.0`).
            #[inline(always)]
            unsafe fn eval_as<V: Vector>(c: &LongCurve, xs: &[f64]) -> Vec<u64> {
                let w = c.wide::<V>();
                let mut got = Vec::new();
                for chunk in xs.chunks(V::N) {
                    let mut lanes = [0.0; 8];
                    w.eval(V::load_part(chunk)).store(lanes.as_mut_ptr());
                    got.extend(lanes[..chunk.len()].iter().map(|v| v.to_bits()));
                }
                got
            }
            #[target_feature(enable = "avx512f")]
            unsafe fn eval8(c: &LongCurve, xs: &[f64]) -> Vec<u64> {
                eval_as::<V8>(c, xs)
            }
            #[target_feature(enable = "avx2")]
            unsafe fn eval4(c: &LongCurve, xs: &[f64]) -> Vec<u64> {
                eval_as::<V4>(c, xs)
            }
            if std::is_x86_feature_detected!("avx512f") {
                // SAFETY: the CPU has AVX-512F.
                got.push(unsafe { eval8(c, xs) });
            }
            if std::is_x86_feature_detected!("avx2") {
                // SAFETY: the CPU has AVX2.
                got.push(unsafe { eval4(c, xs) });
            }
        }
        got
    }

    /// A curve without the points its padding added, or the first of a jump at its end
    /// ([`ExactCurve::trimmed`]), gives the bits of the curve, one at a time and wide, at the
    /// points, next to them, at zeros, infinities and NaNs; it is trimmed only to its own count
    /// (`cut + 1`), which for the bench's springs and the sticking spring is their own points'
    /// but for a jump at the end.
    #[test]
    fn trimmed_curves_evaluate_to_the_same_bits() {
        /// `e` trimmed: its count, and its bits and the curve's at `xs`; and the curve kept
        /// ([`ExactCurve::kept`]) as `e` trimmed, at its count and at 16.
        fn trimmed<const N: usize>(e: &ExactCurve<N>, c: &Curve, xs: &[f64]) -> usize {
            let m = e.cut() + 1;
            assert!(e.trimmed::<2>().is_some() == (m == 2) && e.trimmed::<N>().is_some());
            assert_eq!(kept_len(c), m, "{c:?}");
            let sixteen = ExactCurve::<16>::kept(c).unwrap();
            assert!(
                sixteen.same_bits(&e.trimmed::<16>().unwrap()),
                "{c:?} kept as 16"
            );
            macro_rules! kept {
                ($($m:literal)*) => {
                    match m {
                        $($m => {
                            let kept = ExactCurve::<$m>::kept(c).unwrap();
                            assert!(kept.same_bits(&e.trimmed::<$m>().unwrap()), "{c:?} kept");
                            assert!(ExactCurve::<{ $m - 1 }>::kept(c).is_none(), "{c:?}");
                        })*
                        _ => unreachable!("{m} points"),
                    }
                };
            }
            kept!(2 3 4 5 6 7 8 9 10 11 12 13 14 15 16);
            let scalar: Vec<u64> = xs.iter().map(|&x| c.eval(x).to_bits()).collect();
            let (got, want) = wide_bits(&e.trimmed::<16>().unwrap(), xs, true);
            assert!(
                want == scalar && got.iter().all(|g| *g == scalar),
                "{c:?} as 16"
            );
            macro_rules! at {
                ($($m:literal)*) => {
                    match m {
                        $($m => wide_bits(&e.trimmed::<$m>().unwrap(), xs, true),)*
                        _ => unreachable!("{m} points"),
                    }
                };
            }
            let (got, want) = at!(2 3 4 5 6 7 8 9 10 11 12 13 14 15 16);
            assert_eq!(want, scalar, "{c:?} trimmed to {m}");
            for got in got {
                assert_eq!(got, scalar, "{c:?} trimmed to {m}, wide");
            }
            m
        }
        let curves = curves_to_widen();
        let xs = probes(779, 300, curves.iter().map(|c| &c.0[..]));
        let mut shed = 0;
        for (pts, _) in curves.iter().filter(|(p, widens)| *widens && p.len() >= 2) {
            let c = Curve::new(pts).unwrap();
            let n = pts.len();
            // (each curve at its own count where the engine has it, and padded to 8 and 16)
            let mut counts = vec![];
            if n <= 4 {
                counts.push(match n {
                    2 => trimmed(&ExactCurve::<2>::fitted(&c).unwrap(), &c, &xs),
                    3 => trimmed(&ExactCurve::<3>::fitted(&c).unwrap(), &c, &xs),
                    _ => trimmed(&ExactCurve::<4>::fitted(&c).unwrap(), &c, &xs),
                });
            }
            if n <= 8 {
                counts.push(trimmed(&ExactCurve::<8>::fitted(&c).unwrap(), &c, &xs));
            }
            counts.push(trimmed(&ExactCurve::<16>::fitted(&c).unwrap(), &c, &xs));
            // (the same count whatever the padding: the points before the last abscissa, and it)
            let last = pts[n - 1].0;
            let own = 1 + pts.iter().position(|p| p.0 == last).unwrap().max(1);
            assert!(
                counts.iter().all(|&m| m == own),
                "{pts:?}: {counts:?}, not {own}"
            );
            shed += usize::from(own < n);
        }
        // (five of the curves that widen end in a jump: of 3, 4 (two, one the sticking
        // spring), 8 and 12 points)
        assert_eq!(shed, 5);
        let line = |n: usize| -> Vec<(f64, f64)> { (0..n).map(|i| (i as f64, 0.5)).collect() };
        for n in [3, 7, 13] {
            let c = Curve::new(&line(n)).unwrap();
            assert_eq!(trimmed(&ExactCurve::<16>::fitted(&c).unwrap(), &c, &xs), n);
        }
    }

    /// A curve padded to more points ([`ExactCurve::padded`]) gives the bits of the curve, one
    /// at a time and wide, at the points, next to them, at zeros, infinities and NaNs; it
    /// survives being written and read back; the zero curve pads only to itself.
    #[test]
    fn padded_curves_evaluate_to_the_same_bits() {
        let curves: [Vec<(f64, f64)>; 3] = [
            vec![(-1.0, 0.5), (2.0, 1.0)],
            vec![(-1.0, -0.1), (0.0, 0.0), (1.0, 0.1)],
            vec![(0.0, 0.0), (1.0, 1.0), (1.0, -0.0)],
        ];
        let xs = probes(778, 300, curves.iter().map(|c| &c[..]));
        /// `e` and its padding to `M` points: the same bits at `xs`, wide and one at a time.
        fn same<const N: usize, const M: usize>(e: &ExactCurve<N>, xs: &[f64]) {
            let p = e.padded::<M>().expect("pads to more points");
            let mut t = Vec::new();
            p.write(&mut t);
            assert_eq!(t.len(), 3 * M);
            assert!(ExactCurve::<M>::read(&t).same_bits(&p));
            let (got, want) = wide_bits(e, xs, true);
            let (got_p, want_p) = wide_bits(&p, xs, true);
            assert_eq!(want, want_p, "{e:?} as {p:?}");
            assert_eq!(got, got_p, "{e:?} as {p:?}, wide");
        }
        for pts in &curves {
            let c = Curve::new(pts).unwrap();
            if pts.len() == 2 {
                let e = ExactCurve::<2>::new(&c).unwrap();
                same::<2, 2>(&e, &xs);
                same::<2, 3>(&e, &xs);
                same::<2, 4>(&e, &xs);
                assert!(e.padded::<0>().is_none() && e.padded::<1>().is_none());
            } else {
                let e = ExactCurve::<3>::new(&c).unwrap();
                same::<3, 4>(&e, &xs);
                assert!(e.padded::<2>().is_none());
            }
        }
        let zero = ExactCurve::<0>::new(&Curve::zero()).unwrap();
        assert!(zero.padded::<0>().is_some());
        assert!(zero.padded::<2>().is_none() && zero.padded::<4>().is_none());
    }

    /// Abscissas to probe curves at: NaNs and infinities of both signs, the two zeros, `n` drawn
    /// at random in `[-4, 4]`, and each point of `curves`, its opposite, the next `f64` of both,
    /// and just before and after it.
    fn probes<'c>(seed: u64, n: usize, curves: impl Iterator<Item = &'c [(f64, f64)]>) -> Vec<f64> {
        let neg_nan = f64::from_bits(f64::NAN.to_bits() | 1 << 63);
        let mut xs = vec![
            f64::NAN,
            neg_nan,
            f64::INFINITY,
            f64::NEG_INFINITY,
            0.0,
            -0.0,
        ];
        xs.extend(uniform(seed, n, 4.0));
        for pts in curves {
            for &(x, _) in pts {
                let up = f64::from_bits(x.to_bits() + 1);
                xs.extend([x, -x, up, -up, x * 0.999, x * 1.001]);
            }
        }
        xs
    }

    /// Adds to `xs` the grid's bucket edges and the doubles either side of each, checking that
    /// each edge is the least `x` of its bucket.
    fn probe_edges(xs: &mut Vec<f64>, grid: &Grid) {
        for (b, &e) in grid.edges.iter().enumerate() {
            xs.extend([e, e.next_down(), e.next_up()]);
            assert!(grid.bucket(e) >= b && (b == 0 || grid.bucket(e.next_down()) < b));
        }
    }

    /// The bits of `e` at `xs`: `WideCurve::eval`'s and `eval_cut`'s in each width the CPU has
    /// (AVX-512, AVX2;
    /// none elsewhere; with AVX-512, of `e` searched too where it has a grid) and `eval`'s;
    /// checks that `e.widens()` is `widens`.
    fn wide_bits<const N: usize>(
        e: &ExactCurve<N>,
        xs: &[f64],
        widens: bool,
    ) -> (Vec<Vec<u64>>, Vec<u64>) {
        assert_eq!(e.widens(), widens);
        let want = xs.iter().map(|&x| e.eval(x).to_bits()).collect();
        #[allow(unused_mut)]
        let mut got = Vec::new();
        #[cfg(target_arch = "x86_64")]
        {
            use crate::wide::{V4, V8};
            /// `WideCurve::eval` (or, `CUT`, `WideCurve::eval_cut`) of `e` at `xs`, `V::N` at a
            /// time (the last lanes `0.0`).
            #[inline(always)]
            unsafe fn eval_as<V: Vector, const N: usize, const CUT: bool>(
                e: &ExactCurve<N>,
                xs: &[f64],
            ) -> Vec<u64> {
                let w = e.wide::<V>();
                let mut got = Vec::new();
                for chunk in xs.chunks(V::N) {
                    let mut lanes = [0.0; 8];
                    let x = V::load_part(chunk);
                    let y = if CUT { w.eval_cut(x) } else { w.eval(x) };
                    y.store(lanes.as_mut_ptr());
                    got.extend(lanes[..chunk.len()].iter().map(|v| v.to_bits()));
                }
                got
            }
            #[target_feature(enable = "avx512f")]
            unsafe fn eval8<const N: usize>(e: &ExactCurve<N>, xs: &[f64]) -> [Vec<u64>; 2] {
                [
                    eval_as::<V8, N, false>(e, xs),
                    eval_as::<V8, N, true>(e, xs),
                ]
            }
            #[target_feature(enable = "avx2")]
            unsafe fn eval4<const N: usize>(e: &ExactCurve<N>, xs: &[f64]) -> [Vec<u64>; 2] {
                [
                    eval_as::<V4, N, false>(e, xs),
                    eval_as::<V4, N, true>(e, xs),
                ]
            }
            if std::is_x86_feature_detected!("avx512f") {
                // SAFETY: the CPU has AVX-512F.
                got.extend(unsafe { eval8(e, xs) });
                if e.scale > 0.0 {
                    // SAFETY: as above.
                    got.extend(unsafe { eval8(&e.searched(), xs) });
                }
            }
            if std::is_x86_feature_detected!("avx2") {
                // SAFETY: the CPU has AVX2.
                got.extend(unsafe { eval4(e, xs) });
            }
        }
        (got, want)
    }

    #[test]
    fn jumps_take_the_later_value_and_ends_hold() {
        let s = 0.5;
        let k = 0.1;
        let c = Curve::new(&[(-s, 0.0), (-s, -k * s), (s, k * s), (s, 0.0)]).unwrap();
        assert_eq!(c.eval(-1.0), 0.0);
        assert_eq!(c.eval(-s), -k * s); // at the jump the later point holds
        assert_eq!(c.eval(0.0), 0.0);
        assert!((c.eval(0.25) - k * 0.25).abs() < 1e-17);
        assert_eq!(c.eval(s), 0.0);
        assert_eq!(c.eval(10.0), 0.0);
    }

    #[test]
    fn rejects_decreasing_and_non_finite() {
        assert_eq!(
            Curve::new(&[(0.0, 0.0), (-1.0, 1.0)]),
            Err(CurveError::Decreasing { index: 1 })
        );
        assert_eq!(
            Curve::new(&[(f64::NAN, 0.0)]),
            Err(CurveError::NonFinite { index: 0 })
        );
        assert_eq!(Curve::zero().eval(3.0), 0.0);
    }

    #[test]
    fn integral_of_a_linear_spring_is_its_potential() {
        let c = Curve::new(&[(-1.0, -2.0), (1.0, 2.0)]).unwrap(); // 2 d
        for &d in &[-0.7, 0.0, 0.3, 0.9] {
            assert!((c.integral_from_zero(d) - d * d).abs() < 1e-15);
        }
        // beyond the points the force stays at 2: U(1.5) = 1 + 2 * 0.5
        assert!((c.integral_from_zero(1.5) - 2.0).abs() < 1e-15);
    }

    #[test]
    fn integral_of_the_sticking_curve() {
        let (k, s) = (0.1, 0.5);
        let c = Curve::new(&[(-s, 0.0), (-s, -k * s), (s, k * s), (s, 0.0)]).unwrap();
        for &d in &[-0.4, -0.1, 0.0, 0.2, 0.49] {
            assert!(
                (c.integral_from_zero(d) - 0.5 * k * d * d).abs() < 1e-15,
                "{d}"
            );
        }
        // outside the threshold the force is 0: the integral stays at 1/2 k s^2
        for &d in &[-3.0, 0.7, 9.0] {
            assert!(
                (c.integral_from_zero(d) - 0.5 * k * s * s).abs() < 1e-15,
                "{d}"
            );
        }
    }

    #[test]
    fn antiderivative_matches_a_fine_riemann_sum() {
        let c = Curve::new(&[
            (-1.0, 0.5),
            (-0.5, -0.5),
            (-0.5, 0.2),
            (0.3, 0.9),
            (2.0, -1.0),
        ])
        .unwrap();
        let (a, b) = (-2.0, 3.0);
        let n = 200_000;
        let h = (b - a) / n as f64;
        let sum: f64 = (0..n).map(|i| c.eval(a + (i as f64 + 0.5) * h) * h).sum();
        let exact = c.antiderivative(b) - c.antiderivative(a);
        assert!((sum - exact).abs() < 1e-6, "{sum} vs {exact}");
    }
}
