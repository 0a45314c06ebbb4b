//! The grid step: a membrane, row by row, with every force in registers.
//!
//! A membrane is a grid of `rows x cols` MAS in consecutive storage slots (row `r`, column `c` at
//! slot `r cols + c`), each tied to its four neighbours by REF links of one `K` and `Z`, and a
//! border MAS to a SOL in place of each missing neighbour: as the C baseline kit declares it, or
//! the language's `membrane` generator with a fixed border. The gather step computes every link
//! force into a buffer and the MAS loop reads four of them back per MAS: on a 100x100 membrane the
//! buffer's traffic, not the arithmetic, bounds it (docs/BENCHMARKS.md). The grid step keeps no
//! force buffer. Going down the rows, eight MAS at a time:
//!
//! - each MAS's velocity `v = x(n) - x(n-1)` is computed once, when its row is the one below, and
//!   kept in a row buffer;
//! - the horizontal links of eight MAS are computed from their `x`, `v` and the next eight's,
//!   shifted by one lane; the link on the left of the first is the last lane of the block before;
//! - the vertical links down to the row below are computed, and kept in a row buffer: they are
//!   the links up of the next row;
//! - `F(n) = (((0 + f_left) - f_right) + f_up) - f_down` and `x(n+1)` are computed and stored.
//!
//! **Why the bits are the reference's.** `Grid::new` takes a network only if each MAS's first
//! four terms are its links (then come its ENF inputs, if any): to each neighbour, a REF link of
//! the one `K` and `Z`, the MAS end 2 of the link on its left and above, end 1 of the others; in
//! place of each missing neighbour, a link to a SOL, the MAS at either end. Every link force is
//! `K (x1 - x2) + Z ((x1 - x1') - (x2 - x2'))` with the same operands ([`super::LinkLaw`]). A
//! ground's term is `K (x_g - x) + Z (v_g - v)` whichever end the MAS is: `F -= K (x - x_g) + Z
//! (v - v_g)` adds the same value, since rounding is symmetric (`a - b = -(b - a)`, `K (-y) =
//! -(K y)`, `(-p) + (-q) = -(p + q)`), but for the sign of a zero, which changes no sum: `F`
//! starts at `+0.0` and is never `-0.0` (a sum is `-0.0` only if both operands are), and adding
//! a zero of either sign to it gives it back. So each term is one of the step's `f_left`,
//! `-f_right`, `f_up`, `-f_down` (the grounds, in their terms' order, standing for the missing
//! neighbours taken left, right, up, down), and a MAS adds them, from `+0.0`, in its [`Order`]:
//! the inner MAS of a row all in one, left-right-up-down or left-right-down-up (the top row of
//! the language's `membrane`, whose rim links come last), which the vector loop sums; the row's
//! first and last MAS in any (the first recomputed after the loop, the last in the scalar tail).
//! The update is `mas_with`'s. A MAS with ENF inputs is recomputed after its rows, term by term
//! (as `update_mas` does its exceptions). The loads and shuffles are AVX-512 (an [`Avx512`] token
//! is the CPU's proof); `tests/engine.rs` compares every step with the reference, and
//! `engine.rs`'s tests with the gather step.

#[cfg(target_arch = "x86_64")]
use std::arch::x86_64::*;
use std::ops::Range;

use crate::lanes::{Avx512, LANES};
use crate::parallel::{Poisoned, SharedBuf, SpinBarrier, Task};

use super::{by_div, by_inv, Kernel, Law, LinkLaw, MasLaw, RefLaw, Roles, Run, State, NEG};

/// Fewest columns (so that a row has at least one whole block and its tail) and rows.
const COLS_MIN: usize = 2 * LANES;
const ROWS_MIN: usize = 2;

/// The sides of a MAS's link terms: the link to the MAS on its left, on its right, above, below.
const LEFT: usize = 0;
const RIGHT: usize = 1;
const UP: usize = 2;
const DOWN: usize = 3;

/// The order in which a MAS sums its four link terms: the side of each term, two bits each, the
/// first term in the lowest bits.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct Order(u8);

impl Order {
    /// Left, right, up, down: every inner MAS of a membrane whose links are declared row by row
    /// (each row's grounds, horizontal links, then grounds), or horizontal links then vertical.
    const CANONICAL: Order = Order::of([LEFT, RIGHT, UP, DOWN]);
    /// Left, right, down, up: the top row of the language's `membrane`, whose rim links come last.
    const UP_LAST: Order = Order::of([LEFT, RIGHT, DOWN, UP]);

    const fn of(sides: [usize; 4]) -> Order {
        Order((sides[0] | sides[1] << 2 | sides[2] << 4 | sides[3] << 6) as u8)
    }

    /// `F(n)`, from `+0.0`, of the signed terms `t` of each side (`t[LEFT]`, `-f_right`,
    /// `t[UP]`, `-f_down`: `F -= f` is `F += -f`, bit for bit) in this order.
    #[inline(always)]
    fn sum(self, t: [f64; 4]) -> f64 {
        let mut f = 0.0;
        for i in 0..4 {
            f += t[(self.0 >> (2 * i)) as usize & 3];
        }
        f
    }
}

/// A membrane the grid step can take (see the module's documentation).
#[derive(Clone, Debug)]
pub(super) struct Grid {
    cpu: Avx512,
    rows: usize,
    cols: usize,
    k: f64,
    z: f64,
    /// `1 / M` to multiply by, or (`div`) `M` to divide by: every MAS's
    m: f64,
    div: bool,
    /// The SOL (storage slot) on the left and on the right of each row, above and below each column
    left: Vec<u32>,
    right: Vec<u32>,
    top: Vec<u32>,
    bottom: Vec<u32>,
    /// The order of each row's MAS but the first and last (`CANONICAL` or `UP_LAST`), and of
    /// its first and last MAS (any)
    mid: Vec<Order>,
    first: Vec<Order>,
    last: Vec<Order>,
    /// The MAS with ENF inputs (ascending storage slots): recomputed after their rows.
    fixes: Vec<u32>,
    /// The links the outputs read (see [`Kernel::recorded_links`]).
    recorded: Vec<Run>,
}

/// The `x(n+1)` of one row: the whole state, the row below's `x(n)` and `x(n-1)`, and the
/// row buffers (see [`Grid::row`]).
struct RowArgs<'a> {
    x: &'a [f64],
    xp: &'a [f64],
    below: (&'a [f64], &'a [f64]),
    next: &'a mut [f64],
    vc: &'a [f64],
    vn: &'a mut [f64],
    up: &'a mut [f64],
}

impl Grid {
    /// The grid step of `k`, if its network is a membrane as the module's documentation says and
    /// the CPU has AVX-512.
    pub(super) fn new(k: &Kernel) -> Option<Grid> {
        let cpu = k.tails()?;
        let n = k.n_mas;
        if n != k.n_mce || n < COLS_MIN * ROWS_MIN {
            return None;
        }
        let (m, div) = match k.mas {
            MasLaw::UniformInv(inv) => (inv, false),
            MasLaw::UniformDiv(m) => (m, true),
            _ => return None,
        };
        let edges = |s: usize| &k.eidx[k.eoff[s] as usize..k.eoff[s + 1] as usize];
        let link = |e: u32| (e & !NEG) as usize;
        // the other end of each term of MAS 0 (its neighbours are MAS 1 and MAS `cols`)
        let other = |e: u32| {
            let l = link(e);
            let end = if e & NEG != 0 { &k.lb } else { &k.la };
            end.get(l).map(|&o| o as usize)
        };
        let cols = edges(0)
            .iter()
            .filter_map(|&e| other(e))
            .filter(|&o| o < n)
            .max()?;
        if cols < COLS_MIN || !n.is_multiple_of(cols) || n / cols < ROWS_MIN {
            return None;
        }
        let rows = n / cols;
        let mut law = vec![Law::Ref; k.nl];
        for run in &k.whole.runs {
            law[run.start..run.end].fill(run.law);
        }
        let first = link(*edges(0).first()?);
        let (kk, zz) = (*k.lk.get(first)?, *k.lz.get(first)?);
        let same = |l: usize| {
            l < k.nl
                && law[l] == Law::Ref
                && k.lk[l].to_bits() == kk.to_bits()
                && k.lz[l].to_bits() == zz.to_bits()
        };
        let mut g = Grid {
            cpu,
            rows,
            cols,
            k: kk,
            z: zz,
            m,
            div,
            left: vec![0; rows],
            right: vec![0; rows],
            top: vec![0; cols],
            bottom: vec![0; cols],
            mid: vec![Order::CANONICAL; rows],
            first: vec![Order::CANONICAL; rows],
            last: vec![Order::CANONICAL; rows],
            fixes: Vec::new(),
            recorded: k.recorded_links()?,
        };
        for s in 0..n {
            let (r, c) = (s / cols, s % cols);
            let e = edges(s);
            let (Some(terms), inputs) = (e.first_chunk::<4>(), e.get(4..)?) else {
                return None;
            };
            if inputs.iter().any(|&i| i & NEG != 0 || (i as usize) < k.nl) {
                return None;
            }
            if !inputs.is_empty() {
                g.fixes.push(s as u32);
            }
            // each side's neighbour, if it has one, and the sign its term must have (the MAS is
            // end 2 of the link on its left and above, end 1 of the others)
            let neighbour = [
                (c > 0).then(|| s - 1),
                (c + 1 < cols).then_some(s + 1),
                (r > 0).then(|| s - cols),
                (r + 1 < rows).then_some(s + cols),
            ];
            let mut taken = [false; 4];
            let mut sides = [0; 4];
            let mut grounds = Vec::new();
            for (i, &t) in terms.iter().enumerate() {
                let (l, o) = (link(t), other(t)?);
                let mine = if t & NEG != 0 { k.la[l] } else { k.lb[l] };
                if !same(l) || mine as usize != s {
                    return None;
                }
                if o >= k.n_mce {
                    // a link to a SOL: its term is `K (x_g - x) + Z (v_g - v)` whichever end
                    // the MAS is (up to the sign of a zero), as a missing neighbour's below
                    grounds.push((i, o as u32));
                    continue;
                }
                let side = neighbour.iter().position(|&b| b == Some(o))?;
                let end1 = side == RIGHT || side == DOWN;
                if taken[side] || (t & NEG != 0) != end1 {
                    return None;
                }
                (taken[side], sides[i]) = (true, side);
            }
            // the grounds, in their terms' order, stand for the missing neighbours in side order
            let missing = (0..4).filter(|&d| neighbour[d].is_none());
            if grounds.len() != missing.clone().count()
                || (0..4).any(|d| neighbour[d].is_some() && !taken[d])
            {
                return None;
            }
            for ((i, ground), side) in grounds.into_iter().zip(missing) {
                sides[i] = side;
                match side {
                    LEFT => g.left[r] = ground,
                    RIGHT => g.right[r] = ground,
                    UP => g.top[c] = ground,
                    _ => g.bottom[c] = ground,
                }
            }
            let order = Order::of(sides);
            if c == 0 {
                g.first[r] = order;
            } else if c + 1 == cols {
                g.last[r] = order;
            } else if c == 1 {
                if order != Order::CANONICAL && order != Order::UP_LAST {
                    return None;
                }
                g.mid[r] = order;
            } else if order != g.mid[r] {
                return None;
            }
        }
        Some(g)
    }

    /// The scratch one thread needs: five row buffers (velocities of two rows, the links up,
    /// the grounds' `x(n)` and `x(n-1)` of the top or bottom row).
    pub(super) fn scratch_len(&self) -> usize {
        5 * self.stride()
    }

    fn stride(&self) -> usize {
        self.cols + 2 * LANES
    }

    /// The rows of each of `threads` threads (consecutive, about equal).
    pub(super) fn partition(&self, threads: usize) -> Vec<Range<usize>> {
        super::split(self.rows, threads.max(1), |_| 1)
    }

    /// The storage slots of the MAS of `rows`.
    pub(super) fn slots(&self, rows: &Range<usize>) -> Range<usize> {
        rows.start * self.cols..rows.end * self.cols
    }

    /// Steps `frames` times from `st` on the calling thread, writing the outputs into `out` (see
    /// [`super::Engine::process`]).
    pub(super) fn block(&self, k: &Kernel, st: &mut State, frames: usize, out: &mut [f64]) {
        let ch = k.channels.len();
        let all = 0..self.rows;
        for frame in 0..frames {
            let roles = Roles::at(st.c);
            let (cur, prev, next) = roles.split(&mut st.pos);
            let frame_out = &mut out[frame * ch..(frame + 1) * ch];
            k.record_with(&self.recorded, cur, prev, &mut st.sf, frame_out);
            let next = &mut next[self.slots(&all)];
            self.step(k, st.n, all.clone(), cur, prev, next, &mut st.grid);
            st.n += 1;
            st.c = roles.next;
        }
    }

    /// Step `n` of `rows`: `x(n+1)` of their MAS into `next` (exactly their slots), from `x(n)`,
    /// `x(n-1)` of every material, with `scratch` ([`Grid::scratch_len`] values).
    #[allow(clippy::too_many_arguments)] // the step's buffers
    pub(super) fn step(
        &self,
        k: &Kernel,
        n: u64,
        rows: Range<usize>,
        cur: &[f64],
        prev: &[f64],
        next: &mut [f64],
        scratch: &mut [f64],
    ) {
        let cols = self.cols;
        assert!(cur.len() == k.nm && prev.len() == k.nm && rows.end <= self.rows);
        assert!(next.len() == rows.len() * cols && scratch.len() >= self.scratch_len());
        if rows.is_empty() {
            return;
        }
        let (mut vc, rest) = scratch.split_at_mut(self.stride());
        let (mut vn, rest) = rest.split_at_mut(self.stride());
        let (up, rest) = rest.split_at_mut(self.stride());
        let (gx, gp) = rest.split_at_mut(self.stride());
        let link =
            |xa: f64, va: f64, xb: f64, vb: f64| RefLaw::force(self.k, self.z, 0.0, xa, va, xb, vb);
        // the first row's velocities, and the links into it from above
        let r0 = rows.start * cols;
        for (c, v) in vc[..cols].iter_mut().enumerate() {
            *v = cur[r0 + c] - prev[r0 + c];
        }
        for c in 0..cols {
            let a = if rows.start == 0 {
                self.top[c] as usize
            } else {
                r0 - cols + c
            };
            up[c] = link(cur[a], cur[a] - prev[a], cur[r0 + c], vc[c]);
        }
        if rows.end == self.rows {
            for (c, &g) in self.bottom.iter().enumerate() {
                (gx[c], gp[c]) = (cur[g as usize], prev[g as usize]);
            }
        }
        for r in rows.clone() {
            let below = if r + 1 < self.rows {
                let b = (r + 1) * cols..(r + 2) * cols;
                (&cur[b.clone()], &prev[b])
            } else {
                (&gx[..cols], &gp[..cols])
            };
            let i = (r - rows.start) * cols;
            let args = RowArgs {
                x: cur,
                xp: prev,
                below,
                next: &mut next[i..i + cols],
                vc: &vc[..],
                vn: &mut vn[..],
                up: &mut up[..],
            };
            self.row_for_cpu(r, args);
            std::mem::swap(&mut vc, &mut vn);
        }
        // the MAS with inputs, term by term (their links, then their inputs)
        let slots = self.slots(&rows);
        let lo = self.fixes.partition_point(|&s| (s as usize) < slots.start);
        for &s in &self.fixes[lo..] {
            let s = s as usize;
            if s >= slots.end {
                break;
            }
            let mut f = 0.0;
            for &j in &k.eidx[k.eoff[s] as usize..k.eoff[s + 1] as usize] {
                let l = (j & !NEG) as usize;
                if l >= k.nl {
                    f += k.enf[l - k.nl].at(n);
                    continue;
                }
                let (a, b) = (k.la[l] as usize, k.lb[l] as usize);
                let t = link(cur[a], cur[a] - prev[a], cur[b], cur[b] - prev[b]);
                if j & NEG != 0 {
                    f -= t;
                } else {
                    f += t;
                }
            }
            let (x, xp) = (cur[s], prev[s]);
            next[s - slots.start] = self.update(x, xp, f);
        }
    }

    #[inline(always)]
    fn update(&self, x: f64, xp: f64, f: f64) -> f64 {
        if self.div {
            Self::update_as::<true>(x, xp, f, self.m)
        } else {
            Self::update_as::<false>(x, xp, f, self.m)
        }
    }

    /// `x(n+1)` of a MAS: divided by `m` (`DIV`) or multiplied by it, as `Grid::m` says.
    #[inline(always)]
    fn update_as<const DIV: bool>(x: f64, xp: f64, f: f64, m: f64) -> f64 {
        if DIV {
            by_div(x, xp, f, m)
        } else {
            by_inv(x, xp, f, m)
        }
    }

    fn row_for_cpu(&self, r: usize, args: RowArgs<'_>) {
        debug_assert_eq!(Some(self.cpu), Avx512::detect());
        #[cfg(target_arch = "x86_64")]
        // SAFETY: `self.cpu` exists, so the CPU has AVX-512F (see `Avx512::detect`).
        unsafe {
            match (self.div, self.mid[r] == Order::UP_LAST) {
                (true, true) => self.row::<true, true>(r, args),
                (true, false) => self.row::<true, false>(r, args),
                (false, true) => self.row::<false, true>(r, args),
                (false, false) => self.row::<false, false>(r, args),
            }
        }
        #[cfg(not(target_arch = "x86_64"))]
        {
            let _ = (r, args);
            unreachable!("a grid step needs an Avx512 token, which exists only on x86-64");
        }
    }

    /// Row `r`: `x(n+1)` into `next`, from the state `x`, `xp`, the row below (`x(n)`, `x(n-1)`,
    /// `cols` each: the next row, or the bottom grounds), the row's velocities `vc`; writes the
    /// row below's velocities into `vn` and its links down into `up` (where they were the links up).
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx512f")]
    fn row<const DIV: bool, const UP_LAST: bool>(&self, r: usize, a: RowArgs<'_>) {
        let (cols, stride) = (self.cols, self.stride());
        let RowArgs {
            x,
            xp,
            below: (xd, pd),
            next,
            vc,
            vn,
            up,
        } = a;
        let row = r * cols;
        // every access below is within these (checked once here)
        let (xr, pr) = (&x[row..row + cols], &xp[row..row + cols]);
        assert!(xd.len() == cols && pd.len() == cols && next.len() == cols);
        assert!(vc.len() == stride && vn.len() == stride && up.len() == stride);
        assert!(cols >= COLS_MIN);
        let (kk, zz) = (self.k, self.z);
        let link = |xa: f64, va: f64, xb: f64, vb: f64| RefLaw::force(kk, zz, 0.0, xa, va, xb, vb);
        // the link on the left of column 0, from this row's left ground
        let gl = self.left[r] as usize;
        let h0 = link(x[gl], x[gl] - xp[gl], xr[0], vc[0]);
        // whole blocks: columns `0..full`, the last of which has a right neighbour in the row
        let full = (cols - 1) / LANES * LANES;
        let (k8, z8, m8) = (
            _mm512_set1_pd(kk),
            _mm512_set1_pd(zz),
            _mm512_set1_pd(self.m),
        );
        let zero = _mm512_setzero_pd();
        let shift_next = _mm512_setr_epi64(1, 2, 3, 4, 5, 6, 7, 8);
        let shift_prev = _mm512_setr_epi64(7, 8, 9, 10, 11, 12, 13, 14);
        let mut hl = h0;
        let u0 = up[0];
        // SAFETY: every load and store is of 8 items from `c0 < full` or `c0 + 8 <= full` on,
        // `full + 8 <= cols + 7 < stride`, within `xr`, `pr`, `xd`, `pd`, `next` (`cols` each:
        // `c0 + 8 <= full < cols`) or the row buffers (`stride` each), asserted above; the next
        // block's `x` is loaded whole only when it is within the row (`c0 + 8 < full`).
        unsafe {
            let mut xa = _mm512_loadu_pd(xr.as_ptr());
            let mut va = _mm512_loadu_pd(vc.as_ptr());
            let mut hprev = _mm512_set1_pd(h0);
            let mut c0 = 0;
            while c0 < full {
                let xn = if c0 + LANES < full {
                    _mm512_loadu_pd(xr.as_ptr().add(c0 + LANES))
                } else {
                    _mm512_set1_pd(xr[c0 + LANES])
                };
                let vnx = _mm512_loadu_pd(vc.as_ptr().add(c0 + LANES));
                let xb = _mm512_permutex2var_pd(xa, shift_next, xn);
                let vb = _mm512_permutex2var_pd(va, shift_next, vnx);
                // `K (x1 - x2) + Z (v1 - v2)`, as `RefLaw::force`
                let h = _mm512_add_pd(
                    _mm512_mul_pd(k8, _mm512_sub_pd(xa, xb)),
                    _mm512_mul_pd(z8, _mm512_sub_pd(va, vb)),
                );
                let left = _mm512_permutex2var_pd(hprev, shift_prev, h);
                let xdn = _mm512_loadu_pd(xd.as_ptr().add(c0));
                let vd = _mm512_sub_pd(xdn, _mm512_loadu_pd(pd.as_ptr().add(c0)));
                _mm512_storeu_pd(vn.as_mut_ptr().add(c0), vd);
                let d = _mm512_add_pd(
                    _mm512_mul_pd(k8, _mm512_sub_pd(xa, xdn)),
                    _mm512_mul_pd(z8, _mm512_sub_pd(va, vd)),
                );
                let u = _mm512_loadu_pd(up.as_ptr().add(c0));
                _mm512_storeu_pd(up.as_mut_ptr().add(c0), d);
                // `F(n)` from `+0.0`, term by term
                let f = _mm512_sub_pd(_mm512_add_pd(zero, left), h);
                let f = if UP_LAST {
                    _mm512_add_pd(_mm512_sub_pd(f, d), u)
                } else {
                    _mm512_sub_pd(_mm512_add_pd(f, u), d)
                };
                // `2 x - x' + F / M` (or `F (1 / M)`), as `by_div` (`by_inv`)
                let p = _mm512_loadu_pd(pr.as_ptr().add(c0));
                let by = if DIV {
                    _mm512_div_pd(f, m8)
                } else {
                    _mm512_mul_pd(f, m8)
                };
                let out = _mm512_add_pd(_mm512_sub_pd(_mm512_add_pd(xa, xa), p), by);
                _mm512_storeu_pd(next.as_mut_ptr().add(c0), out);
                hprev = h;
                (xa, va) = (xn, vnx);
                c0 += LANES;
            }
            if full > 0 {
                let mut lanes = [0.0; LANES];
                _mm512_storeu_pd(lanes.as_mut_ptr(), hprev);
                hl = lanes[LANES - 1];
            }
        }
        // the last columns, one at a time, the last with this row's right ground
        let mid = if UP_LAST {
            Order::UP_LAST
        } else {
            Order::CANONICAL
        };
        let gr = self.right[r] as usize;
        // column `c` with its right neighbour's `x` and `v`, summed in `order`; gives its link on
        // the right (a macro, so that the last column's order stays out of the loop)
        macro_rules! column {
            ($c:expr, $xr:expr, $vr:expr, $order:expr) => {{
                let c = $c;
                let (x0, v0) = (xr[c], vc[c]);
                let h = link(x0, v0, $xr, $vr);
                let v = xd[c] - pd[c];
                vn[c] = v;
                let d = link(x0, v0, xd[c], v);
                let f = $order.sum([hl, -h, up[c], -d]);
                up[c] = d;
                next[c] = Self::update_as::<DIV>(x0, pr[c], f, self.m);
                h
            }};
        }
        for c in full..cols - 1 {
            hl = column!(c, xr[c + 1], vc[c + 1], mid);
        }
        let order = self.last[r];
        if order == mid {
            column!(cols - 1, x[gr], x[gr] - xp[gr], mid);
        } else {
            column!(cols - 1, x[gr], x[gr] - xp[gr], order);
        }
        // the first MAS again if its terms come in another order than the row's
        if self.first[r] != mid {
            let (x0, v0) = (xr[0], vc[0]);
            let h = link(x0, v0, xr[1], vc[1]);
            let f = self.first[r].sum([h0, -h, u0, -up[0]]);
            next[0] = Self::update_as::<DIV>(x0, pr[0], f, self.m);
        }
    }
}

/// The grid step of a block on the pool's threads, thread `t` stepping the rows `shares[t]`:
///
/// | in a step, thread `t` reads | and writes |
/// | --- | --- |
/// | `pos[cur]`, `pos[prev]` | the slots of its rows in `pos[next]`, its part of `scratch` |
///
/// Thread 0 also records the outputs: it reads `pos[cur]` and `pos[prev]`, and writes `sf` (the
/// recorded links' forces) and its frame of the output, which no other thread touches. Nothing a
/// step reads is written in it; the shares' rows are disjoint, and so are their parts of
/// `scratch` (`scratch_len` each); the one barrier after each step orders its writes of
/// `pos[next]` before the next step's reads (where it is `cur`). Which thread steps a row changes
/// no bit: every value is computed from the same operands whoever computes it (a share's first
/// row recomputes the links up from the row above).
pub(super) struct GridJob<'a> {
    pub(super) k: &'a Kernel,
    pub(super) grid: &'a Grid,
    pub(super) shares: &'a [Range<usize>],
    pub(super) pos: [SharedBuf; 3],
    pub(super) sf: SharedBuf,
    pub(super) scratch: SharedBuf,
    pub(super) n0: u64,
    /// `n0 % 3`
    pub(super) c0: usize,
    pub(super) frames: usize,
}

impl Task for GridJob<'_> {
    fn run(&self, t: usize, barrier: &SpinBarrier) -> Result<(), Poisoned> {
        self.run_share(t, None, barrier)
    }
}

impl GridJob<'_> {
    /// Thread `t`'s steps; thread 0 passes the output buffer.
    pub(super) fn run_share(
        &self,
        t: usize,
        mut out: Option<&mut [f64]>,
        barrier: &SpinBarrier,
    ) -> Result<(), Poisoned> {
        let k = self.k;
        let rows = self.shares[t].clone();
        let slots = self.grid.slots(&rows);
        let len = self.grid.scratch_len();
        let ch = k.channels.len();
        let mut c = self.c0;
        for s in 0..self.frames {
            let r = Roles::at(c);
            // SAFETY: each access follows the table in the type's documentation: shared reads of
            // buffers nobody writes in this step, exclusive writes to this share's slots and
            // scratch (or, on thread 0, to `sf`), every slice dropped before the barrier that
            // ends the step.
            unsafe {
                let (cur, prev) = (self.pos[r.cur].read(), self.pos[r.prev].read());
                if let Some(out) = out.as_deref_mut() {
                    let sf = self.sf.write(0..k.sf_len);
                    let frame = &mut out[s * ch..(s + 1) * ch];
                    k.record_with(&self.grid.recorded, cur, prev, sf, frame);
                }
                let next = self.pos[r.next].write(slots.clone());
                let scratch = self.scratch.write(t * len..(t + 1) * len);
                let n = self.n0 + s as u64;
                self.grid.step(k, n, rows.clone(), cur, prev, next, scratch);
            }
            barrier.wait()?;
            c = r.next;
        }
        Ok(())
    }
}
