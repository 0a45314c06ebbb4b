//! The grid step: membranes and strings, row by row, with every force in registers.
//!
//! A membrane is a grid of `rows x cols` MAS in consecutive storage slots (row `r`, column `c` at
//! slot `base + r cols + c`), each tied to its four neighbours by REF links of one `K` and `Z`,
//! and a border MAS to a SOL in place of some or all of its missing neighbours: as the C baseline
//! kit declares it, or the language's `membrane` generator with a fixed or free border. A network
//! whose MAS may hold one ([`may_hold`]) is stored with its MAS in declaration order, whatever
//! their degree, so that the membrane's border MAS and the MAS tied to something else stay in
//! their rows ([`super::Mobiles`]). The gather step computes every link
//! force into a buffer and the MAS loop reads four of them back per MAS: on a 100x100 membrane the
//! buffer's traffic, not the arithmetic, bounds it (docs/BENCHMARKS.md). The grid step keeps no
//! force buffer. A network may hold several membranes, each a [`Sheet`] with its own size and
//! law, found one after the other in storage ([`Grid::new`]); a sheet's MAS have one inertia, or
//! each its own (`Sheet::per_mas`: the row loop then loads eight of them where it would
//! broadcast one). Going down each sheet's rows, eight MAS at a time:
//!
//! - each MAS's velocity `v = x(n) - x(n-1)` is computed where it is needed: in its row, and
//!   when its row is the one below (a subtraction costs less than keeping it in a row buffer, a
//!   store and a load, docs/BENCHMARKS-LOG.md, twenty-fourth session);
//! - the horizontal links of eight MAS are computed from their `x`, `v` and the next eight's,
//!   shifted by one lane; the link on the left of the first is the last lane of the block before;
//! - the vertical links down to the row below are computed, and kept in a row buffer: they are
//!   the links up of the next row;
//! - `F(n) = (((0 + f_left) - f_right) + f_up) - f_down` and `x(n+1)` are computed and stored.
//!
//! **Why the bits are the reference's.** `Grid::new` takes a network only if each MAS's first
//! terms are its grid's links: to each neighbour, a REF link of the one `K` and `Z`, the MAS end
//! 2 of the link on its left and above, end 1 of the others; in place of some or all of its
//! missing neighbours, a link to a SOL, the MAS at either end. Every link force is
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
//! first and last MAS in any (recomputed after the loop when theirs is not the row's). The
//! row's last block, of 1 to 8 MAS, is one masked block, its last lane's right neighbour the
//! row's ground. The update is `mas_with`'s.
//!
//! **Free sides.** A missing neighbour without a SOL (a free border) gets the MAS itself as its
//! SOL: the link of a MAS to itself is `K (x - x) + Z (v - v)`, a zero, for a finite `x` and `v`,
//! and a zero added to `F`, which is never `-0.0`, gives `F` back. (A non-finite `x` or `v` makes
//! the MAS's links to its neighbours non-finite in the reference as well: a blow-up either way,
//! which the gather step replays.) Its side comes after the MAS's terms in its [`Order`]: the top
//! row of a free membrane sums left-right-down, the bottom row left-right-up.
//!
//! **Around the membranes.** The sheet's terms of a MAS come first; a MAS with more (a link to a
//! hammer, a string, another MAS of the sheet or of another sheet; ENF inputs) is a *fix*,
//! recomputed after its rows term by term, each link by its own law (as `update_mas` does its
//! exceptions), from `x(n)` and `x(n-1)` alone. The moving materials outside the sheets (before,
//! between or after them in storage: a hammer, a CEL, an ENX, a membrane too narrow for a sheet)
//! are stepped each step as the gather step does, their links' forces computed into `sf` first
//! ([`Grid::outside_links`], [`Grid::outside_mats`]); a model where they, their links and the
//! fixes' terms are more than half the sheets' MAS keeps the gather step ([`OUTSIDE_SHARE`]).
//! The rows are written once over `wide.rs`'s [`Vector`] and compiled for two widths: eight MAS
//! per block with AVX-512, four with AVX2 (where a shift by a lane costs two shuffles, the right
//! neighbours are loaded from one slot further instead); a CPU with neither keeps the gather
//! step. `tests/engine.rs` compares every step with the reference, and `engine/tests.rs` with
//! the gather step in both widths.
//!
//! **Strings.** A string is a sheet too ([`Sheet::string_at`]): at least [`COLS_MIN`] MAS in
//! consecutive storage slots, each tied to the next by a link of one law and parameters (end 1
//! the MAS before): REF of one `K`, `Z`; BUT of one `K`, `Z`, `S`; or LNL of one pair of curves
//! of at most 16 points that [`ExactCurve::widens`] ([`Strand`]). Each MAS sums its links to
//! the MAS before and after it (in either order: two terms from `+0.0` commute, see
//! [`Sheet::piece`]), its first and last MAS tied to a SOL or free, any other terms a fix. Its
//! "rows" are pieces of about [`PIECE`] MAS one after the other (`Sheet::starts`), which the
//! threads share as they share a membrane's rows: a piece reads the MAS before and after it, as
//! a membrane's row reads the rows above and below. Eight MAS at a time, each velocity computed
//! once, each link once (from the block and its neighbours on the right), `F(n) = (0 + f_left) -
//! f_right` (for LNL links, whose force the grid step makes sure is never `-0.0`, `f_left -
//! f_right`, the same bits), the update: no force buffer, so a string of 10,000 MAS runs from the
//! L2 cache at the speed one of 1,000 had from the L1 cache (docs/BENCHMARKS-LOG.md, eighteenth
//! session). Each law
//! is a [`StringLaw`] computing eight links with the gather step's operands and operations; an
//! LNL string's curves are evaluated eight at a time by `curve.rs`'s `WideCurve` (whose doc
//! shows they give `ExactCurve::eval`'s bits), in a piece compiled for its pair of point counts
//! ([`ExactPair::visit`]; with AVX2 the selects of the points its padding added skipped at run
//! time, `WideCurve::eval_cut`), or, for curves of more than 16 points, by `WideLong` ([`LongLinks`],
//! one piece for every point count, `Curve::eval`'s bits). Short strings one after the other in
//! storage, of REF links all or BUT links all, step in banks ([`Grid::units`]): one call loops
//! over their pieces, so that a string of 30 MAS costs its 30 MAS and not a call chain as well
//! (docs/BENCHMARKS-LOG.md, twenty-second session).

use std::ops::Range;

use crate::curve::ExactCurve;
#[cfg(target_arch = "x86_64")]
use crate::curve::{WideCurve, WideLong};
use crate::lanes::LANES;
use crate::lines::LINE;
use crate::parallel::{Poisoned, SharedBuf, SpinBarrier, Task};
#[cfg(target_arch = "x86_64")]
use crate::wide::{Vector, V4, V8};

use super::{by_div, by_inv, AnyPair, ButLaw, ExactPair, Forces, Kernel, Law, LinkLaw, Lnl};
use super::{Claim, Simd, State, NEG};
use super::{MasLaw, PairFn};
use super::{Positions, Recorded, RefLaw, Roles, Run};
use crate::{Interaction, Material, Network};

/// Fewest columns (so that a row has at least one whole block and its tail) and rows.
const COLS_MIN: usize = 2 * LANES;
const ROWS_MIN: usize = 2;

/// MAS per chunk of rows on threads (see [`Grid::partition`]). A chunk recomputes the links up
/// into its first row, about half a row's work, so chunks of fewer MAS cost more; more chunks
/// let a thread take over more of the other's rows when the other's core runs slower (on a
/// shared host one vCPU may run 30-45 % slower than the other for a whole block).
const CHUNK_MAS: usize = 8192;
/// Fewest chunks per thread, where there are rows enough: so that the threads of a small
/// membrane can help each other too (and the tests' membranes claim chunks).
const CHUNKS_MIN: usize = 4;

/// MAS per row of a string (see [`Sheet::string_at`]): a string is cut into rows of about as many
/// MAS, which the threads share as they share a membrane's rows.
const PIECE: usize = 1024;

/// No SOL: the free end of a string ([`Sheet::left`], [`Sheet::right`]).
const FREE: u32 = u32::MAX;

/// The law of a sheet's links, with its `K` and `Z` (`Sheet::k`, `Sheet::z`): a membrane's are
/// REF; a string's REF, BUT (threshold `s`) or LNL (curves of at most 16 points, boxed: a pair
/// of 16 and 16 points is 776 bytes; or of more points).
#[derive(Clone, Debug)]
enum Strand {
    Ref,
    But {
        s: f64,
    },
    Lnl(Box<ExactPair>),
    /// LNL links of curves of more than 16 points ([`LongLinks`])
    Long(Box<AnyPair>),
}

/// A string's link law, as [`Sheet::piece`] computes it: one link at a time (the piece's ends)
/// and a vector of them (`force_n`), each with the gather step's operands and operations.
trait StringLaw: Copy {
    /// The law's numbers broadcast to the lanes of `V`, made once per piece.
    #[cfg(target_arch = "x86_64")]
    type Wide<V: Vector>: Copy;

    /// Whether [`Sheet::piece`] loads each block's neighbours on the right (from one slot
    /// further) rather than shifting them by a lane from the block and the next: a REF string
    /// runs 9-12 % slower so and a BUT string 3 % (the loads cross cache lines), an LNL string
    /// 7 % faster (its curves keep both vector ports busy;
    /// docs/BENCHMARKS-LOG.md, nineteenth session).
    const LOADS: bool;

    /// Whether `force` and `force_n` never give `-0.0`, so that [`Sheet::piece`]'s `F(n) = (0 +
    /// f_left) - f_right` is `f_left - f_right` (`0 + a` is `a` but for `a = -0.0`; a NaN's bits
    /// pass through): one operation fewer per block. REF and BUT links can give `-0.0` (`K (-0.0)
    /// + Z (-0.0)`); the grid step takes LNL strings whose force never is
    /// ([`ExactPair::never_minus_zero`]).
    const NEVER_MINUS_ZERO: bool;

    /// The force of a link from its ends' positions and velocities (`x - x'`).
    fn force(&self, xa: f64, va: f64, xb: f64, vb: f64) -> f64;

    /// # Safety
    /// The CPU must have `V`'s instructions (see [`Vector`]).
    #[cfg(target_arch = "x86_64")]
    unsafe fn wide<V: Vector>(&self) -> Self::Wide<V>;

    /// The forces of `V::N` links, lane by lane as `force`.
    ///
    /// # Safety
    /// The CPU must have `V`'s instructions.
    #[cfg(target_arch = "x86_64")]
    unsafe fn force_n<V: Vector>(w: &Self::Wide<V>, xa: V, va: V, xb: V, vb: V) -> V;
}

/// REF links of `K`, `Z`.
#[derive(Clone, Copy)]
struct RefLinks(f64, f64);

impl StringLaw for RefLinks {
    const LOADS: bool = false;
    const NEVER_MINUS_ZERO: bool = false;

    #[cfg(target_arch = "x86_64")]
    type Wide<V: Vector> = (V, V);

    #[inline(always)]
    fn force(&self, xa: f64, va: f64, xb: f64, vb: f64) -> f64 {
        RefLaw::force(self.0, self.1, 0.0, xa, va, xb, vb)
    }

    #[cfg(target_arch = "x86_64")]
    #[inline(always)]
    unsafe fn wide<V: Vector>(&self) -> (V, V) {
        (V::splat(self.0), V::splat(self.1))
    }

    /// `K (x1 - x2) + Z (v1 - v2)`, as `RefLaw::force`.
    #[cfg(target_arch = "x86_64")]
    #[inline(always)]
    unsafe fn force_n<V: Vector>(&(k, z): &(V, V), xa: V, va: V, xb: V, vb: V) -> V {
        k.mul(xa.sub(xb)).add(z.mul(va.sub(vb)))
    }
}

/// BUT links of `K`, `Z`, `S`.
#[derive(Clone, Copy)]
struct ButLinks(f64, f64, f64);

impl StringLaw for ButLinks {
    const LOADS: bool = false;
    const NEVER_MINUS_ZERO: bool = false;

    #[cfg(target_arch = "x86_64")]
    type Wide<V: Vector> = (V, V, V);

    #[inline(always)]
    fn force(&self, xa: f64, va: f64, xb: f64, vb: f64) -> f64 {
        ButLaw::force(self.0, self.1, self.2, xa, va, xb, vb)
    }

    #[cfg(target_arch = "x86_64")]
    #[inline(always)]
    unsafe fn wide<V: Vector>(&self) -> (V, V, V) {
        (V::splat(self.0), V::splat(self.1), V::splat(self.2))
    }

    /// `K ((x1 - x2) + S) + Z (v1 - v2)` where `x2 - x1 < S`, else `+0.0`, as `ButLaw::force`.
    #[cfg(target_arch = "x86_64")]
    #[inline(always)]
    unsafe fn force_n<V: Vector>(&(k, z, s): &(V, V, V), xa: V, va: V, xb: V, vb: V) -> V {
        let f = k.mul(xa.sub(xb).add(s)).add(z.mul(va.sub(vb)));
        f.keep(xb.sub(xa).lt(s))
    }
}

/// LNL links of an elastic curve of `A` points and a viscous one of `B`.
#[derive(Clone, Copy)]
struct LnlLinks<const A: usize, const B: usize>(ExactCurve<A>, ExactCurve<B>);

impl<const A: usize, const B: usize> StringLaw for LnlLinks<A, B> {
    const LOADS: bool = true;
    const NEVER_MINUS_ZERO: bool = true;

    #[cfg(target_arch = "x86_64")]
    type Wide<V: Vector> = (WideCurve<V, A>, WideCurve<V, B>);

    /// `elastic(x1 - x2) + viscous(v1 - v2)`, as the gather step's `exact_run`.
    #[inline(always)]
    fn force(&self, xa: f64, va: f64, xb: f64, vb: f64) -> f64 {
        self.0.eval(xa - xb) + self.1.eval(va - vb)
    }

    #[cfg(target_arch = "x86_64")]
    #[inline(always)]
    unsafe fn wide<V: Vector>(&self) -> Self::Wide<V> {
        (self.0.wide(), self.1.wide())
    }

    /// `eval_cut`: a piece is compiled for the pair's padded counts, and the selects of the
    /// padding are skipped at run time (with AVX-512, or curves of fewer than 8 points, `eval`).
    #[cfg(target_arch = "x86_64")]
    #[inline(always)]
    unsafe fn force_n<V: Vector>((ck, cz): &Self::Wide<V>, xa: V, va: V, xb: V, vb: V) -> V {
        ck.eval_cut(xa.sub(xb)).add(cz.eval_cut(va.sub(vb)))
    }
}

/// LNL links of curves of any number of points (`curve.rs`'s `LongCurve`, evaluated by
/// `WideLong`).
#[derive(Clone, Copy)]
struct LongLinks<'a>(&'a AnyPair);

impl<'a> StringLaw for LongLinks<'a> {
    const LOADS: bool = true;
    const NEVER_MINUS_ZERO: bool = true;

    #[cfg(target_arch = "x86_64")]
    type Wide<V: Vector> = (WideLong<'a, V>, WideLong<'a, V>);

    /// `elastic(x1 - x2) + viscous(v1 - v2)`, as the gather step.
    #[inline(always)]
    fn force(&self, xa: f64, va: f64, xb: f64, vb: f64) -> f64 {
        self.0.force(xa - xb, va - vb)
    }

    #[cfg(target_arch = "x86_64")]
    #[inline(always)]
    unsafe fn wide<V: Vector>(&self) -> Self::Wide<V> {
        (self.0.long.0.wide(), self.0.long.1.wide())
    }

    #[cfg(target_arch = "x86_64")]
    #[inline(always)]
    unsafe fn force_n<V: Vector>((ck, cz): &Self::Wide<V>, xa: V, va: V, xb: V, vb: V) -> V {
        ck.eval(xa.sub(xb)).add(cz.eval(va.sub(vb)))
    }
}

/// [`Sheet::strings`] of an LNL string, compiled for its curves' point counts.
struct LnlStrings<'a> {
    bank: &'a [Sheet],
    rows: Range<usize>,
    x: &'a [f64],
    xp: &'a [f64],
    ms: &'a [f64],
    next: &'a mut [f64],
}

impl PairFn for LnlStrings<'_> {
    type Out = ();

    fn call<const A: usize, const B: usize>(self, k: &ExactCurve<A>, z: &ExactCurve<B>) {
        let LnlStrings {
            bank,
            rows,
            x,
            xp,
            ms,
            next,
        } = self;
        let (k, z) = (*k, *z);
        let law = move |_: &Sheet| LnlLinks(k, z);
        Sheet::strings_as(bank, rows, law, x, xp, ms, next);
    }
}

/// How the vector loops apply the inertia ([`Sheet::mass`]): multiply by `1 / M`, divide by
/// `M`, or (every MAS's `1 / M` or `M` exactly `1`) neither.
const INV: u8 = 0;
const DIVIDE: u8 = 1;
const UNIT: u8 = 2;

/// `x(n+1) = 2 x - x' + F / M` (or `F (1 / M)`) of `V::N` MAS, as `by_div` (`by_inv`): `m`
/// every MAS's `M` (`MASS` [`DIVIDE`]) or `1 / M` ([`INV`]), or (`PER_MAS`) theirs, `mr[c0..c0 +
/// V::N]`. With [`UNIT`] (`m` is `1`) `F` is added as it is: `F 1 = F / 1 = F`, bit for bit, for
/// every `F` but a signalling NaN, which no arithmetic yields (a NaN `F` is quiet, and IEEE
/// multiplication and division by `1` return a quiet NaN operand as it is on x86-64).
///
/// # Safety
/// The CPU must have `V`'s instructions; with `PER_MAS`, `c0 + V::N <= mr.len()`.
#[cfg(target_arch = "x86_64")]
#[inline(always)]
unsafe fn update<V: Vector, const MASS: u8, const PER_MAS: bool>(
    x: V,
    xp: V,
    f: V,
    m: V,
    mr: &[f64],
    c0: usize,
) -> V {
    let m = if PER_MAS {
        V::load(mr.as_ptr().add(c0))
    } else {
        m
    };
    let by = match MASS {
        DIVIDE => f.div(m),
        UNIT => f,
        _ => f.mul(m),
    };
    x.add(x).sub(xp).add(by)
}

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

/// The membranes of a network the grid step takes (see the module's documentation), in storage
/// order, and what is around them.
#[derive(Clone, Debug)]
pub(super) struct Grid {
    sheets: Vec<Sheet>,
    /// The first row of each sheet in the grid's row count (its rows one after the other), and
    /// the total: sheet `i` has rows `row0[i]..row0[i + 1]`
    row0: Vec<usize>,
    /// The sheets stepped by one call each, in order (see [`Part`]): a *bank* of strings of
    /// one row each, one after the other in storage and of one law kind (REF or BUT), vector
    /// width and inertia law ([`Sheet::banks_with`]), or any other sheet alone
    units: Vec<Range<usize>>,
    /// The storage slots of the moving materials outside every sheet (before, between, after),
    /// ascending, none empty
    outside: Vec<Range<usize>>,
    /// The links of the moving materials outside the sheets, stepped as the gather step does,
    /// after the links of `outside_runs` and the ENF inputs of `outside_inputs` are computed into
    /// `sf`.
    outside_runs: Vec<Run>,
    /// The ENF inputs on the materials outside the sheets, as ranges of input indices (the
    /// fixes compute those on the sheets' MAS themselves).
    outside_inputs: Vec<Range<usize>>,
    /// The links the outputs read (see [`Kernel::recorded_links`]).
    recorded: Vec<Recorded>,
}

/// One membrane of a [`Grid`].
#[derive(Clone, Debug)]
struct Sheet {
    /// The vector width the rows are stepped with: `Avx512` or `Avx2`, never `None`
    simd: Simd,
    /// The storage slot of the MAS of row 0, column 0: row `r`, column `c` is at `base + r cols +
    /// c`
    base: usize,
    rows: usize,
    cols: usize,
    k: f64,
    z: f64,
    /// `1 / M` to multiply by, or (`div`) `M` to divide by: every MAS's; unless `per_mas`, when
    /// each MAS's is its own, in the kernel's [`MasLaw`] (`Inv` or `Div`)
    m: f64,
    div: bool,
    per_mas: bool,
    /// For a string ([`Sheet::string_at`]): where each row, a piece of the string, starts (its
    /// offset from `base`), and the string's length; empty for a membrane, whose rows are `cols`
    /// long (a string has no use for `top`, `bottom`, `mid`, `first`, `last`)
    starts: Vec<usize>,
    /// The law of the links (a membrane's: REF)
    strand: Strand,
    /// The SOL (storage slot) on the left and on the right of each row, above and below each
    /// column (a string's: on the left of its row 0, on the right of its last row, or [`FREE`])
    left: Vec<u32>,
    right: Vec<u32>,
    top: Vec<u32>,
    bottom: Vec<u32>,
    /// The order of each row's MAS but the first and last (`CANONICAL` or `UP_LAST`), and of
    /// its first and last MAS (any)
    mid: Vec<Order>,
    first: Vec<Order>,
    last: Vec<Order>,
    /// The MAS with terms after their grid links (links of any kind, ENF inputs), ascending:
    /// recomputed after their rows from `terms`.
    fixes: Vec<Fix>,
    terms: Vec<FixTerm>,
}

/// What one call steps ([`Grid::parts`]): rows `rows` of sheet `sheets.start` alone, or (a
/// bank's) the one row of each string of `sheets`, `rows` then `0..1`.
#[derive(Clone, Debug)]
struct Part {
    sheets: Range<usize>,
    rows: Range<usize>,
}

/// A MAS of a sheet recomputed term by term: its storage slot and its terms, `Sheet::terms[terms]`.
#[derive(Clone, Debug)]
struct Fix {
    slot: u32,
    terms: Range<u32>,
}

/// A term of a [`Fix`], in the MAS's order.
#[derive(Clone, Copy, Debug)]
enum FixTerm {
    /// The force of `link` (computed alone), negated where the MAS is its end 1
    Link { link: Recorded, neg: bool },
    /// The sample of ENF input `i`
    Input(u32),
}

/// The moving materials outside the sheets, their links and the fixes' terms may be at most `1 /
/// OUTSIDE_SHARE` of the sheets' MAS: they are stepped one by one (or as the gather step does),
/// and a model that is mostly something else keeps the gather step.
const OUTSIDE_SHARE: usize = 2;

/// How many places that look like a sheet's first MAS but are none (a membrane of other laws
/// than one REF, a coupling that ties a row further than the next) are tried before the search
/// for sheets stops: each costs up to a pass over a sheet.
const REFUSED_MAX: usize = 16;

/// The terms of material `s` (a storage slot below `n_mc`): `Kernel::eidx`.
fn terms(k: &Kernel, s: usize) -> &[u32] {
    &k.eidx[k.eoff[s] as usize..k.eoff[s + 1] as usize]
}

/// The other end of the link of a material's term `e`, if it is a link's (not an input's).
fn other_end(k: &Kernel, e: u32) -> Option<usize> {
    let end = if e & NEG != 0 { &k.lb } else { &k.la };
    end.get((e & !NEG) as usize).map(|&o| o as usize)
}

/// Whether link `l` is a REF of stiffness and viscosity `(K, Z)` (`law`: each link's).
fn is_ref(k: &Kernel, law: &[Law], (kk, zz): (f64, f64), l: usize) -> bool {
    l < k.nl
        && law[l] == Law::Ref
        && k.lk[l].to_bits() == kk.to_bits()
        && k.lz[l].to_bits() == zz.to_bits()
}

/// Whether the MAS of `net`, in declaration order, may hold a membrane or a string the grid step
/// takes: one MAS tied to the next and to one at least [`COLS_MIN`] further, itself tied to the
/// next, or [`COLS_MIN`] MAS each tied to the next by a REF, BUT or LNL link (`Grid::new`
/// decides; a cheap test, so that only such networks are built with their MAS in declaration
/// order, see [`super::Mobiles`]).
pub(super) fn may_hold(net: &Network) -> bool {
    let mut rank = vec![u32::MAX; net.materials.len()];
    let mut n = 0;
    for (r, m) in rank.iter_mut().zip(&net.materials) {
        if matches!(m, Material::Mas { .. }) {
            (*r, n) = (n, n + 1);
        }
    }
    let n = n as usize;
    if n < COLS_MIN {
        return false;
    }
    // each link between two MAS, as (first, second) in declaration order
    let pairs = net.links.iter().filter_map(|link| {
        let (a, b) = (*rank.get(link.a.index())?, *rank.get(link.b.index())?);
        (a != u32::MAX && b != u32::MAX)
            .then(|| (&link.law, (a.min(b) as usize, a.max(b) as usize)))
    });
    // whether a link ties each MAS to the next, and a REF, BUT or LNL link does
    let (mut next, mut next_ref) = (vec![false; n], vec![false; n]);
    for (law, (lo, hi)) in pairs.clone() {
        next[lo] |= hi == lo + 1;
        next_ref[lo] |= hi == lo + 1
            && matches!(
                law,
                Interaction::Ref { .. } | Interaction::But { .. } | Interaction::Lnl { .. }
            );
    }
    // a membrane, or a string: `COLS_MIN` MAS each tied to the next by a REF, BUT or LNL link
    let string = next_ref
        .split(|&tied| !tied)
        .any(|run| run.len() + 1 >= COLS_MIN);
    string
        || pairs
            .clone()
            .any(|(_, (lo, hi))| hi - lo >= COLS_MIN && next[lo] && next[hi])
}

/// What a membrane's rows are stepped with: the whole state, what lies below (`x(n)` and
/// `x(n-1)`: for [`Sheet::row`] the row below or the bottom grounds, for [`Sheet::rows_as`] the
/// bottom grounds, the last row's below), `x(n+1)` of the row (of all the rows for `rows_as`),
/// the inertias and the row buffer of the links up.
struct RowArgs<'a> {
    x: &'a [f64],
    xp: &'a [f64],
    below: (&'a [f64], &'a [f64]),
    next: &'a mut [f64],
    /// Every material's `1 / M` or `M` (by storage slot), or nothing when all the sheet's MAS
    /// have one ([`Sheet::per_mas`])
    ms: &'a [f64],
    up: &'a mut [f64],
}

impl Grid {
    /// The grid step of `k`, if its network holds membranes as the module's documentation says
    /// and the kernel is compiled for AVX-512 or AVX2.
    pub(super) fn new(k: &Kernel) -> Option<Grid> {
        let simd = k.simd;
        if simd == Simd::None {
            return None;
        }
        // the MAS after MAS `s` that its terms tie it to
        let after = |s: usize| {
            let ends = terms(k, s).iter().filter_map(|&e| other_end(k, e));
            ends.filter(move |&o| o > s && o < k.n_mas)
        };
        let tied_next = |s: usize| after(s).any(|o| o == s + 1);
        // each sheet's first MAS: the first after the sheet before tied to the next and to one a
        // row further, itself tied to the next; each such row length in turn (a link across the
        // membrane, or to a MAS after it, can tie its first MAS further than a row)
        let membrane = |s: usize| after(s).any(|o| o - s >= COLS_MIN && tied_next(o));
        // or the first of `COLS_MIN` MAS each tied to the next, a string's, from `strings_from`
        // on (a run tried as a string is not tried again from its other MAS)
        let string = |s: usize| s + COLS_MIN <= k.n_mas && (s..s + COLS_MIN - 1).all(tied_next);
        let law = k.laws();
        let (mut sheets, mut from, mut refused, mut strings_from) = (Vec::<Sheet>::new(), 0, 0, 0);
        while let Some(base) = (from..k.n_mas)
            .find(|&s| tied_next(s) && (membrane(s) || (s >= strings_from && string(s))))
        {
            let mut widths: Vec<usize> = after(base)
                .map(|o| o - base)
                .filter(|&d| d >= COLS_MIN)
                .collect();
            widths.sort_unstable();
            widths.dedup();
            let found = (widths.into_iter()).find_map(|cols| Sheet::at(k, simd, &law, base, cols));
            let found = found.or_else(|| {
                if base < strings_from || !string(base) {
                    return None;
                }
                let mut end = base + 1;
                while end < k.n_mas && tied_next(end - 1) {
                    end += 1;
                }
                strings_from = end;
                Sheet::string_at(k, simd, &law, base..end)
            });
            match found {
                Some(sheet) => {
                    from = sheet.slots(&(0..sheet.rows)).end;
                    sheets.push(sheet);
                }
                None if !membrane(base) => from = base + 1,
                None if refused < REFUSED_MAX => (from, refused) = (base + 1, refused + 1),
                None => break,
            }
        }
        if sheets.is_empty() {
            return None;
        }
        let mut row0 = vec![0];
        for sheet in &sheets {
            row0.push(row0[row0.len() - 1] + sheet.rows);
        }
        // the moving materials outside the sheets, and their links
        let mut outside = Vec::new();
        let mut start = 0;
        for sheet in &sheets {
            let mine = sheet.slots(&(0..sheet.rows));
            outside.push(start..mine.start);
            start = mine.end;
        }
        outside.push(start..k.n_mce);
        outside.retain(|o| !o.is_empty());
        // their links' and inputs' terms (an ENX has no terms: its position is its signal)
        let mut wanted = vec![false; k.nl + k.enf.len()];
        for s in outside
            .iter()
            .flat_map(|o| o.start.min(k.n_mc)..o.end.min(k.n_mc))
        {
            for &e in terms(k, s) {
                wanted[(e & !NEG) as usize] = true;
            }
        }
        let mut outside_inputs: Vec<Range<usize>> = Vec::new();
        for i in (0..k.enf.len()).filter(|&i| wanted[k.nl + i]) {
            match outside_inputs.last_mut() {
                Some(r) if r.end == i => r.end += 1,
                _ => outside_inputs.push(i..i + 1),
            }
        }
        let mut units: Vec<Range<usize>> = Vec::new();
        for (i, sheet) in sheets.iter().enumerate() {
            match units.last_mut() {
                Some(u) if sheets[u.end - 1].banks_with(sheet) => u.end = i + 1,
                _ => units.push(i..i + 1),
            }
        }
        let g = Grid {
            outside_runs: k.runs_of(&wanted[..k.nl])?,
            outside_inputs,
            recorded: k.recorded_links()?,
            row0,
            units,
            outside,
            sheets,
        };
        let n: usize = g.sheets.iter().map(|s| s.slots(&(0..s.rows)).len()).sum();
        let around = g.outside.iter().map(|o| o.len()).sum::<usize>()
            + g.outside_runs
                .iter()
                .map(|r| r.end - r.start)
                .sum::<usize>()
            + g.sheets.iter().map(|s| s.terms.len()).sum::<usize>();
        (around <= n / OUTSIDE_SHARE).then_some(g)
    }

    /// How many membranes and strings the grid steps.
    #[cfg(test)]
    pub(super) fn sheets(&self) -> usize {
        self.sheets.len()
    }

    /// How many calls step the sheets: banks of strings and sheets alone ([`Grid::units`]).
    #[cfg(test)]
    pub(super) fn units(&self) -> usize {
        self.units.len()
    }

    /// The scratch one thread needs: three row buffers of the widest membrane (the links up, the
    /// grounds' `x(n)` and `x(n-1)` of the bottom row).
    pub(super) fn scratch_len(&self) -> usize {
        (self.sheets.iter())
            .filter(|s| s.starts.is_empty())
            .map(|s| 3 * s.stride())
            .max()
            .unwrap_or(0)
    }

    /// The rows of each of `threads` threads, in the grid's row count (the sheets' rows one
    /// after the other): consecutive, about as many MAS each, and each thread's cut into chunks
    /// of consecutive rows, the units the threads claim ([`GridJob`]): about [`CHUNK_MAS`] MAS
    /// each, and at least [`CHUNKS_MIN`] where the rows allow.
    pub(super) fn partition(&self, threads: usize) -> Vec<Vec<Range<usize>>> {
        let rows = self.row0[self.sheets.len()];
        let cols = |r: usize| {
            let i = self.row0.partition_point(|&r0| r0 <= r) - 1;
            self.sheets[i].row_len(r - self.row0[i])
        };
        let cost = |r: usize| cols(r) as u64;
        (super::split(rows, threads.max(1), cost).into_iter())
            .map(|share| {
                let mas: usize = share.clone().map(cols).sum();
                let chunks = (mas / CHUNK_MAS).max(CHUNKS_MIN).min(share.len()).max(1);
                let chunk = |c: usize| share.start + c;
                (super::split(share.len(), chunks, |i| cost(chunk(i))).into_iter())
                    .map(|r| chunk(r.start)..chunk(r.end))
                    .collect()
            })
            .collect()
    }

    /// The parts of `rows` (in the grid's row count), in order: each unit's ([`Grid::units`]),
    /// of a bank the strings of `rows`, of a sheet alone its rows of `rows`.
    fn parts(&self, rows: Range<usize>) -> impl Iterator<Item = Part> + '_ {
        self.units.iter().filter_map(move |u| {
            let (r0, r1) = (self.row0[u.start], self.row0[u.end]);
            let (lo, hi) = (rows.start.max(r0), rows.end.min(r1));
            (lo < hi).then(|| match u.len() {
                1 => Part {
                    sheets: u.clone(),
                    rows: lo - r0..hi - r0,
                },
                // (a bank's strings have one row each: string `i` is row `r0 + i - u.start`)
                _ => Part {
                    sheets: u.start + (lo - r0)..u.start + (hi - r0),
                    rows: 0..1,
                },
            })
        })
    }

    /// The storage slots of the MAS of `part`: its sheets' rows, one after the other.
    fn part_slots(&self, part: &Part) -> Range<usize> {
        let sheets = &self.sheets[part.sheets.clone()];
        sheets[0].slots(&part.rows).start..sheets[sheets.len() - 1].slots(&part.rows).end
    }

    /// Step `n` of `part`: `x(n+1)` of its MAS into `next` (exactly [`Grid::part_slots`]), as
    /// [`Sheet::step`] steps each of its sheets.
    #[inline]
    fn step_part(
        &self,
        k: &Kernel,
        n: u64,
        part: Part,
        (cur, prev): (&[f64], &[f64]),
        next: &mut [f64],
        scratch: &mut [f64],
    ) {
        let bank = &self.sheets[part.sheets];
        if let [sheet] = bank {
            return sheet.step(k, n, part.rows, (cur, prev), next, scratch);
        }
        let ms = bank[0].inertias(k);
        assert!(cur.len() == k.nm && prev.len() == k.nm);
        Sheet::strings_for_cpu(bank, 0..1, cur, prev, ms, next);
        let lo = bank[0].base;
        for sheet in bank.iter().filter(|s| !s.fixes.is_empty()) {
            let mine = sheet.slots(&(0..1));
            let next = &mut next[mine.start - lo..mine.end - lo];
            sheet.fixes(k, n, 0..1, (cur, prev), next, ms);
        }
    }

    /// Steps `frames` times from `st` on the calling thread, writing the outputs into `out` (see
    /// [`super::Engine::process`]).
    pub(super) fn block(&self, k: &Kernel, st: &mut State, frames: usize, out: &mut [f64]) {
        let ch = k.channels.len();
        for frame in 0..frames {
            let roles = Roles::at(st.c);
            let (cur, prev, next) = roles.split(&mut st.pos);
            let frame_out = &mut out[frame * ch..(frame + 1) * ch];
            k.record_with(&self.recorded, cur, prev, &mut st.sf, frame_out);
            self.outside_links(k, st.n, (cur, prev), &mut st.sf);
            for mats in &self.outside {
                let next = &mut next[mats.clone()];
                Grid::outside_mats(k, st.n, mats.clone(), (cur, prev), next, &st.sf);
            }
            // (a sheet alone is stepped directly: through `step_part` and `part_slots`, a string
            // of 1,000 MAS cost 0.5 % more instructions)
            for u in &self.units {
                let bank = &self.sheets[u.clone()];
                if let [sheet] = bank {
                    let all = 0..sheet.rows;
                    let next = &mut next[sheet.slots(&all)];
                    sheet.step(k, st.n, all, (cur, prev), next, &mut st.grid);
                } else {
                    let part = Part {
                        sheets: u.clone(),
                        rows: 0..1,
                    };
                    let next = &mut next[self.part_slots(&part)];
                    self.step_part(k, st.n, part, (cur, prev), next, &mut st.grid);
                }
            }
            st.n += 1;
            st.c = roles.next;
        }
    }

    /// Step `n`'s ENF inputs of `outside_inputs` and forces of the links of `outside_runs` into
    /// `sf`, for the materials outside the sheets (nothing when there are none).
    #[inline]
    pub(super) fn outside_links(
        &self,
        k: &Kernel,
        n: u64,
        (cur, prev): (&[f64], &[f64]),
        sf: &mut [f64],
    ) {
        if self.outside.is_empty() {
            return;
        }
        for inputs in &self.outside_inputs {
            k.inputs(inputs.clone(), n, &mut sf[k.nl + inputs.start..]);
        }
        let state = Positions::new(k, cur, prev);
        for run in &self.outside_runs {
            k.run_links(run, &state, &mut sf[run.start..run.end]);
        }
    }

    /// Step `n` of the materials `mats` (one of [`Grid::outside`]): `x(n+1)` into `next`
    /// (exactly their slots), from `sf` as [`Grid::outside_links`] leaves it, as the gather step
    /// computes it.
    fn outside_mats(
        k: &Kernel,
        n: u64,
        mats: Range<usize>,
        (cur, prev): (&[f64], &[f64]),
        next: &mut [f64],
        sf: &[f64],
    ) {
        let seg = k.first_segment(mats.start);
        k.materials_phase(mats, seg, n, (cur, prev), next, Forces(sf));
    }
}

impl Sheet {
    /// A sheet of the MAS `mine` (`rows x cols` of them, `cols` 0 for a string), of the law of
    /// the first term of its first MAS and of their inertia, with no border, fix or order yet.
    fn blank(
        k: &Kernel,
        simd: Simd,
        mine: Range<usize>,
        rows: usize,
        cols: usize,
    ) -> Option<Sheet> {
        let uniform = |v: &[f64]| {
            v.iter()
                .all(|m| m.to_bits() == v[0].to_bits())
                .then(|| v[0])
        };
        // (`m` is unused with `per_mas`)
        let (m, div, per_mas) = match &k.mas {
            MasLaw::UniformInv(inv) => (*inv, false, false),
            MasLaw::UniformDiv(m) => (*m, true, false),
            MasLaw::Inv(inv) => {
                uniform(&inv[mine.clone()]).map_or((0.0, false, true), |m| (m, false, false))
            }
            MasLaw::Div(ms) => {
                uniform(&ms[mine.clone()]).map_or((0.0, true, true), |m| (m, true, false))
            }
        };
        let first = (*terms(k, mine.start).first()? & !NEG) as usize;
        Some(Sheet {
            simd,
            base: mine.start,
            rows,
            cols,
            k: *k.lk.get(first)?,
            z: *k.lz.get(first)?,
            m,
            div,
            per_mas,
            starts: Vec::new(),
            strand: Strand::Ref,
            left: vec![0; rows],
            right: vec![0; rows],
            top: vec![0; cols],
            bottom: vec![0; cols],
            mid: vec![Order::CANONICAL; rows],
            first: vec![Order::CANONICAL; rows],
            last: vec![Order::CANONICAL; rows],
            fixes: Vec::new(),
            terms: Vec::new(),
        })
    }

    /// The membrane of `cols` columns from MAS `base` on, if `k` has one there.
    fn at(k: &Kernel, simd: Simd, law: &[Law], base: usize, cols: usize) -> Option<Sheet> {
        let link = |e: u32| (e & !NEG) as usize;
        // down the rows whose first MAS is tied to the next row's
        let first_of = |r: usize| base + r * cols;
        let mut rows = 1;
        while first_of(rows + 1) <= k.n_mas
            && terms(k, first_of(rows - 1))
                .iter()
                .any(|&e| other_end(k, e) == Some(first_of(rows)))
        {
            rows += 1;
        }
        if rows < ROWS_MIN {
            return None;
        }
        let mine = base..base + rows * cols;
        let mut g = Sheet::blank(k, simd, mine.clone(), rows, cols)?;
        let kz = (g.k, g.z);
        let same = |l: usize| is_ref(k, law, kz, l);
        for s in mine.clone() {
            let (r, c) = ((s - base) / cols, (s - base) % cols);
            let e = terms(k, s);
            // each side's neighbour, if it has one, and the sign its term must have (the MAS is
            // end 2 of the link on its left and above, end 1 of the others)
            let neighbour = [
                (c > 0).then(|| s - 1),
                (c + 1 < cols).then_some(s + 1),
                (r > 0).then(|| s - cols),
                (r + 1 < rows).then_some(s + cols),
            ];
            let missing = (0..4).filter(|&d| neighbour[d].is_none());
            // the grid's terms come first: a link to each neighbour, and a link to a SOL for
            // some of the missing ones; the terms after them are the MAS's own (a fix)
            let mut taken = [false; 4];
            let mut sides = [0; 4];
            let mut grounds = Vec::new();
            let mut t = 0;
            for &term in e {
                let (l, Some(o)) = (link(term), other_end(k, term)) else {
                    break; // an input
                };
                let end = if term & NEG != 0 { k.la[l] } else { k.lb[l] };
                if !same(l) || end as usize != s {
                    break;
                }
                if o >= k.n_mce {
                    // a link to a SOL: its term is `K (x_g - x) + Z (v_g - v)` whichever end
                    // the MAS is (up to the sign of a zero), as a missing neighbour's below
                    if grounds.len() == missing.clone().count() {
                        break;
                    }
                    grounds.push((t, o as u32));
                } else {
                    let Some(side) = neighbour.iter().position(|&b| b == Some(o)) else {
                        break;
                    };
                    let end1 = side == RIGHT || side == DOWN;
                    if taken[side] || (term & NEG != 0) != end1 {
                        break;
                    }
                    (taken[side], sides[t]) = (true, side);
                }
                t += 1;
            }
            if (0..4).any(|d| neighbour[d].is_some() && !taken[d]) {
                return None;
            }
            // the grounds, in their terms' order, stand for the missing neighbours in side
            // order; a missing neighbour without one (a free border) is the MAS itself, whose
            // link to itself is a zero, added after the MAS's terms (see the module's doc)
            let mut free = t;
            for (i, side) in missing.enumerate() {
                let (at, slot) = grounds.get(i).copied().unwrap_or_else(|| {
                    free += 1;
                    (free - 1, s as u32)
                });
                sides[at] = side;
                match side {
                    LEFT => g.left[r] = slot,
                    RIGHT => g.right[r] = slot,
                    UP => g.top[c] = slot,
                    _ => g.bottom[c] = slot,
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
            if t < e.len() {
                g.fix(k, s, e)?;
            }
        }
        Some(g)
    }

    /// The string of the MAS `run` (at least [`COLS_MIN`], each tied to the next), if the grid
    /// step takes it: each MAS's first two terms are links of one law and parameters (REF, BUT,
    /// or LNL of curves the same bit for bit and of the kernel's `Lnl::Exact` form, that widen
    /// and whose force is never `-0.0` (`StringLaw::NEVER_MINUS_ZERO`; both curves with a
    /// `-0.0` value, which a person rarely writes, are left to the gather step):
    /// [`Strand`]) to the MAS before it (end 2) and after it (end 1), in either order, and the
    /// first and last MAS each have, in place of its missing neighbour, a link of that law to a
    /// SOL or nothing (a free end); a MAS with more terms is a fix, and at most a quarter of them
    /// are (a string with a damper on each MAS is left to the other steps). A REF link to a SOL
    /// may have the MAS at either end (its force is odd in its ends, see the module's doc); a BUT
    /// or LNL link must have it where a neighbour would (end 2 on the left, end 1 on the right),
    /// since its force is not. Its rows are pieces of about [`PIECE`] MAS, `starts`.
    fn string_at(k: &Kernel, simd: Simd, law: &[Law], run: Range<usize>) -> Option<Sheet> {
        let n = run.len();
        let rows = n.div_ceil(PIECE);
        let mut g = Sheet::blank(k, simd, run.clone(), rows, 0)?;
        g.starts = (0..=rows).map(|r| r * n / rows).collect();
        (g.left, g.right) = (vec![FREE], vec![FREE]);
        let first = (*terms(k, run.start).first()? & !NEG) as usize;
        g.strand = match *law.get(first)? {
            Law::Ref => Strand::Ref,
            Law::But => Strand::But { s: k.ls[first] },
            Law::Lnl => match &k.lnl[k.lnl_of[first] as usize] {
                Lnl::Exact(pair) if pair.widens() && pair.never_minus_zero() => {
                    Strand::Lnl(Box::new(*pair))
                }
                Lnl::Any(pair) if pair.widens() && pair.never_minus_zero() => {
                    Strand::Long(pair.clone())
                }
                _ => return None,
            },
            _ => return None,
        };
        let strand = g.strand.clone();
        let same = |l: usize| {
            l < k.nl
                && law[l] == law[first]
                && k.lk[l].to_bits() == k.lk[first].to_bits()
                && k.lz[l].to_bits() == k.lz[first].to_bits()
                && match &strand {
                    Strand::Ref => true,
                    Strand::But { s } => k.ls[l].to_bits() == s.to_bits(),
                    Strand::Lnl(pair) => match &k.lnl[k.lnl_of[l] as usize] {
                        Lnl::Exact(other) => other.same_bits(pair),
                        _ => false,
                    },
                    Strand::Long(pair) => match &k.lnl[k.lnl_of[l] as usize] {
                        Lnl::Any(other) => other.same_bits(pair),
                        _ => false,
                    },
                }
        };
        let odd = matches!(strand, Strand::Ref);
        for s in run.clone() {
            let c = s - run.start;
            let e = terms(k, s);
            let neighbour = [(c > 0).then(|| s - 1), (c + 1 < n).then_some(s + 1)];
            // the string's terms: a link to each neighbour and one to a SOL for a missing one
            let (mut sides, mut t, mut ground) = ([LEFT; 2], 0, None);
            for &term in e {
                let (l, Some(o)) = ((term & !NEG) as usize, other_end(k, term)) else {
                    break; // an input
                };
                let end = if term & NEG != 0 { k.la[l] } else { k.lb[l] };
                if t == 2 || !same(l) || end as usize != s {
                    break;
                }
                let side = if o >= k.n_mce {
                    match neighbour.iter().position(Option::is_none) {
                        Some(side)
                            if ground.is_none()
                                && (odd || (term & NEG != 0) == (side == RIGHT)) =>
                        {
                            ground = Some(o as u32);
                            side
                        }
                        _ => break,
                    }
                } else {
                    match neighbour.iter().position(|&b| b == Some(o)) {
                        Some(side) if (term & NEG != 0) == (side == RIGHT) => side,
                        _ => break,
                    }
                };
                if t == 1 && sides[0] == side {
                    break;
                }
                (sides[t], t) = (side, t + 1);
            }
            if (0..2).any(|d| neighbour[d].is_some() && !sides[..t].contains(&d)) {
                return None;
            }
            if c == 0 {
                g.left[0] = ground.unwrap_or(FREE);
            } else if c + 1 == n {
                g.right[0] = ground.unwrap_or(FREE);
            }
            if t < e.len() {
                g.fix(k, s, e)?;
            }
        }
        (g.fixes.len() * 4 <= n).then_some(g)
    }

    /// Makes MAS `s`, whose terms are `edges`, a fix.
    fn fix(&mut self, k: &Kernel, s: usize, edges: &[u32]) -> Option<()> {
        let from = self.terms.len() as u32;
        for &e in edges {
            let l = (e & !NEG) as usize;
            self.terms.push(if l < k.nl {
                FixTerm::Link {
                    link: k.alone(l)?,
                    neg: e & NEG != 0,
                }
            } else {
                FixTerm::Input((l - k.nl) as u32)
            });
        }
        let terms = from..self.terms.len() as u32;
        self.fixes.push(Fix {
            slot: s as u32,
            terms,
        });
        Some(())
    }

    /// A row buffer's length: a row and two blocks, rounded up to whole cache lines (so that
    /// the row buffers, one after the other from a line, each start on one).
    fn stride(&self) -> usize {
        (self.cols + 2 * LANES).next_multiple_of(LINE)
    }

    /// Where row `r` starts: its offset from `base` (`r` may be `rows`: the end of the last).
    fn start(&self, r: usize) -> usize {
        if self.starts.is_empty() {
            r * self.cols
        } else {
            self.starts[r]
        }
    }

    /// How many MAS row `r` has.
    fn row_len(&self, r: usize) -> usize {
        self.start(r + 1) - self.start(r)
    }

    /// The storage slots of the MAS of `rows`.
    fn slots(&self, rows: &Range<usize>) -> Range<usize> {
        self.base + self.start(rows.start)..self.base + self.start(rows.end)
    }

    /// Step `n` of `rows`: `x(n+1)` of their MAS into `next` (exactly their slots), from `x(n)`,
    /// `x(n-1)` of every material, with `scratch` (for a membrane at least three row buffers,
    /// [`Grid::scratch_len`]).
    fn step(
        &self,
        k: &Kernel,
        n: u64,
        rows: Range<usize>,
        (cur, prev): (&[f64], &[f64]),
        next: &mut [f64],
        scratch: &mut [f64],
    ) {
        let ms = self.inertias(k);
        if self.starts.is_empty() {
            self.membrane_rows(k, rows.clone(), cur, prev, next, scratch);
        } else {
            assert!(cur.len() == k.nm && prev.len() == k.nm && rows.end <= self.rows);
            Self::strings_for_cpu(
                std::slice::from_ref(self),
                rows.clone(),
                cur,
                prev,
                ms,
                next,
            );
        }
        if !self.fixes.is_empty() {
            self.fixes(k, n, rows, (cur, prev), next, ms);
        }
    }

    /// [`Sheet::step`]'s rows of a membrane.
    fn membrane_rows(
        &self,
        k: &Kernel,
        rows: Range<usize>,
        cur: &[f64],
        prev: &[f64],
        next: &mut [f64],
        scratch: &mut [f64],
    ) {
        let cols = self.cols;
        assert!(cur.len() == k.nm && prev.len() == k.nm && rows.end <= self.rows);
        assert!(next.len() == rows.len() * cols && scratch.len() >= 3 * self.stride());
        if rows.is_empty() {
            return;
        }
        let (up, rest) = scratch.split_at_mut(self.stride());
        let (gx, gp) = rest.split_at_mut(self.stride());
        let link =
            |xa: f64, va: f64, xb: f64, vb: f64| RefLaw::force(self.k, self.z, 0.0, xa, va, xb, vb);
        let ms = self.inertias(k);
        // the links into the first row from above
        let r0 = self.base + rows.start * cols;
        for (c, u) in up[..cols].iter_mut().enumerate() {
            let a = if rows.start == 0 {
                self.top[c] as usize
            } else {
                r0 - cols + c
            };
            let b = r0 + c;
            *u = link(cur[a], cur[a] - prev[a], cur[b], cur[b] - prev[b]);
        }
        if rows.end == self.rows {
            for (c, &g) in self.bottom.iter().enumerate() {
                (gx[c], gp[c]) = (cur[g as usize], prev[g as usize]);
            }
        }
        let bufs = RowArgs {
            x: cur,
            xp: prev,
            below: (&gx[..cols], &gp[..cols]),
            next,
            ms,
            up,
        };
        self.rows_for_cpu(rows, bufs);
    }

    /// The rows `rows` of a membrane, one after the other (the last with the bottom grounds
    /// below it), each as [`Sheet::row`] computes it in its order: called once per step, so
    /// that the loops over the rows and in them are compiled together, for the sheet's vector
    /// width and inertia law.
    ///
    /// # Safety
    /// The CPU must have `V`'s instructions, and the caller be compiled with them.
    #[cfg(target_arch = "x86_64")]
    #[inline(always)]
    unsafe fn rows_as<V: Vector, const MASS: u8, const PER_MAS: bool>(
        &self,
        rows: Range<usize>,
        b: RowArgs<'_>,
    ) {
        let cols = self.cols;
        let RowArgs {
            x,
            xp,
            below: ground,
            next,
            ms,
            up,
        } = b;
        for r in rows.clone() {
            let below = if r + 1 < self.rows {
                let b = self.slots(&(r + 1..r + 2));
                (&x[b.clone()], &xp[b])
            } else {
                ground
            };
            let i = (r - rows.start) * cols;
            let args = RowArgs {
                x,
                xp,
                below,
                next: &mut next[i..i + cols],
                ms,
                up: &mut up[..],
            };
            if self.mid[r] == Order::UP_LAST {
                self.row::<V, MASS, true, PER_MAS>(r, args)
            } else {
                self.row::<V, MASS, false, PER_MAS>(r, args)
            }
        }
    }

    /// [`Sheet::step`]'s fixes: the MAS of `rows` with terms of their own, term by term.
    fn fixes(
        &self,
        k: &Kernel,
        n: u64,
        rows: Range<usize>,
        (cur, prev): (&[f64], &[f64]),
        next: &mut [f64],
        ms: &[f64],
    ) {
        let slots = self.slots(&rows);
        let lo = self
            .fixes
            .partition_point(|f| (f.slot as usize) < slots.start);
        for fix in &self.fixes[lo..] {
            let s = fix.slot as usize;
            if s >= slots.end {
                break;
            }
            let mut f = 0.0;
            for t in &self.terms[fix.terms.start as usize..fix.terms.end as usize] {
                match *t {
                    FixTerm::Input(i) => f += k.enf[i as usize].at(n),
                    FixTerm::Link { link, neg } => {
                        let lf = k.link_alone(&link, cur, prev);
                        if neg {
                            f -= lf;
                        } else {
                            f += lf;
                        }
                    }
                }
            }
            let (x, xp) = (cur[s], prev[s]);
            let m = ms.get(s).copied().unwrap_or(self.m);
            next[s - slots.start] = if self.div {
                Self::update_as::<DIVIDE>(x, xp, f, m)
            } else {
                Self::update_as::<INV>(x, xp, f, m)
            };
        }
    }

    /// Every material's `1 / M` or `M` (by storage slot) if the sheet's MAS each have their own
    /// ([`Sheet::per_mas`]), else nothing.
    fn inertias<'k>(&self, k: &'k Kernel) -> &'k [f64] {
        match &k.mas {
            MasLaw::Inv(ms) | MasLaw::Div(ms) if self.per_mas => ms,
            _ => &[],
        }
    }

    /// `x(n+1)` of a MAS: divided by `m` (`MASS` [`DIVIDE`]) or multiplied by it (with [`UNIT`],
    /// `m` is `1`), as `Grid::m` says.
    #[inline(always)]
    fn update_as<const MASS: u8>(x: f64, xp: f64, f: f64, m: f64) -> f64 {
        if MASS == DIVIDE {
            by_div(x, xp, f, m)
        } else {
            by_inv(x, xp, f, m)
        }
    }

    /// (in debug builds) That this CPU has the sheet's vector width (an engine made for AVX2
    /// may run on a CPU with AVX-512, which has AVX2's instructions too).
    #[cfg(target_arch = "x86_64")]
    #[inline(always)]
    fn debug_check_simd(&self) {
        debug_assert!(match self.simd {
            Simd::Avx512(_) => Simd::detect() == self.simd,
            Simd::Avx2 => Simd::detect() != Simd::None,
            Simd::None => false,
        });
    }

    /// [`Sheet::rows_as`] compiled for the sheet's vector width, inertia law and per-MAS
    /// inertias (each row's order chosen in the loop).
    fn rows_for_cpu(&self, rows: Range<usize>, b: RowArgs<'_>) {
        #[cfg(target_arch = "x86_64")]
        {
            self.debug_check_simd();
            macro_rules! rows {
                ($mass:ident, $per:literal) => {
                    match self.simd {
                        // SAFETY: as in `strings_as`.
                        Simd::Avx512(_) => unsafe { self.rows_avx512::<$mass, $per>(rows, b) },
                        // SAFETY: as in `strings_as`.
                        Simd::Avx2 => unsafe { self.rows_avx2::<$mass, $per>(rows, b) },
                        Simd::None => {
                            unreachable!("a sheet is made only with vectors (`Grid::new`)")
                        }
                    }
                };
            }
            match (self.mass(), self.per_mas) {
                (UNIT, _) => rows!(UNIT, false),
                (DIVIDE, false) => rows!(DIVIDE, false),
                (_, false) => rows!(INV, false),
                (DIVIDE, true) => rows!(DIVIDE, true),
                (_, true) => rows!(INV, true),
            }
        }
        #[cfg(not(target_arch = "x86_64"))]
        {
            let _ = (rows, b);
            unreachable!("a grid step needs AVX-512 or AVX2, which exist only on x86-64");
        }
    }

    /// [`Sheet::rows_as`] eight MAS at a time.
    ///
    /// # Safety
    /// The CPU must have AVX-512F.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx512f")]
    unsafe fn rows_avx512<const MASS: u8, const PER_MAS: bool>(
        &self,
        rows: Range<usize>,
        b: RowArgs<'_>,
    ) {
        self.rows_as::<V8, MASS, PER_MAS>(rows, b)
    }

    /// [`Sheet::rows_as`] four MAS at a time.
    ///
    /// # Safety
    /// The CPU must have AVX2.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    unsafe fn rows_avx2<const MASS: u8, const PER_MAS: bool>(
        &self,
        rows: Range<usize>,
        b: RowArgs<'_>,
    ) {
        self.rows_as::<V4, MASS, PER_MAS>(rows, b)
    }

    /// Whether `next`, the sheet after this one, steps in one call with it ([`Grid::units`]):
    /// both strings of one row (`PIECE` MAS at most), `next` right after this one in storage,
    /// of REF links both or BUT links both (each its own `K`, `Z`, `S`; not LNL, whose pieces
    /// are compiled for their curves' point counts), with the same vector width and inertia
    /// law ([`Sheet::mass`], `Sheet::per_mas`).
    fn banks_with(&self, next: &Sheet) -> bool {
        let string = |s: &Sheet| !s.starts.is_empty() && s.rows == 1;
        string(self)
            && string(next)
            && next.base == self.slots(&(0..1)).end
            && matches!(
                (&self.strand, &next.strand),
                (Strand::Ref, Strand::Ref) | (Strand::But { .. }, Strand::But { .. })
            )
            && (self.simd, self.mass(), self.per_mas) == (next.simd, next.mass(), next.per_mas)
    }

    /// How the vector loops apply the inertia: [`UNIT`] where every MAS's `1 / M` or `M` is
    /// exactly `1` (unit masses, the usual case: no multiplication, see [`update`]), else
    /// [`DIVIDE`] or [`INV`] as `Sheet::div` says.
    fn mass(&self) -> u8 {
        match (self.per_mas, self.div) {
            (false, _) if self.m == 1.0 => UNIT,
            (_, true) => DIVIDE,
            (_, false) => INV,
        }
    }

    /// [`Sheet::strings`] of `bank`, strings one after the other in storage and of one law kind
    /// (a sheet alone, or [`Sheet::banks_with`] each the next), rows `rows` of each, compiled
    /// for their law, the CPU's vector width and the inertia law; `next` holds exactly their
    /// slots.
    #[inline]
    fn strings_for_cpu(
        bank: &[Sheet],
        rows: Range<usize>,
        x: &[f64],
        xp: &[f64],
        ms: &[f64],
        next: &mut [f64],
    ) {
        match &bank[0].strand {
            Strand::Ref => {
                let law = |s: &Sheet| RefLinks(s.k, s.z);
                Self::strings_as(bank, rows, law, x, xp, ms, next)
            }
            Strand::But { .. } => {
                let law = |s: &Sheet| match s.strand {
                    Strand::But { s: th } => ButLinks(s.k, s.z, th),
                    _ => unreachable!("a bank's strings are of one law kind (`banks_with`)"),
                };
                Self::strings_as(bank, rows, law, x, xp, ms, next)
            }
            Strand::Lnl(pair) => {
                assert!(
                    bank.len() == 1,
                    "an LNL string is stepped alone (`banks_with`)"
                );
                (**pair).visit(LnlStrings {
                    bank,
                    rows,
                    x,
                    xp,
                    ms,
                    next,
                })
            }
            Strand::Long(pair) => {
                assert!(
                    bank.len() == 1,
                    "an LNL string is stepped alone (`banks_with`)"
                );
                let law = |_: &Sheet| LongLinks(pair);
                Self::strings_as(bank, rows, law, x, xp, ms, next)
            }
        }
    }

    /// [`Sheet::strings`] of links of the law `law` gives each string, compiled for the CPU's
    /// vector width and each inertia law.
    fn strings_as<L: StringLaw, F: Fn(&Sheet) -> L>(
        bank: &[Sheet],
        rows: Range<usize>,
        law: F,
        x: &[f64],
        xp: &[f64],
        ms: &[f64],
        next: &mut [f64],
    ) {
        #[cfg(target_arch = "x86_64")]
        {
            let s0 = &bank[0];
            s0.debug_check_simd();
            macro_rules! strings {
                ($mass:ident, $per:literal) => {
                    match s0.simd {
                        // SAFETY: `Simd::Avx512` holds the proof that the CPU has AVX-512F
                        // (`Avx512::detect`), and a bank's sheets have one width.
                        Simd::Avx512(_) => unsafe {
                            Self::strings_avx512::<$mass, $per, L, F>(
                                bank, rows, law, x, xp, ms, next,
                            )
                        },
                        // SAFETY: `Simd::detect` returns `Avx2` only when the CPU has AVX2 (and
                        // an engine does not move to another machine).
                        Simd::Avx2 => unsafe {
                            Self::strings_avx2::<$mass, $per, L, F>(
                                bank, rows, law, x, xp, ms, next,
                            )
                        },
                        Simd::None => {
                            unreachable!("a sheet is made only with vectors (`Grid::new`)")
                        }
                    }
                };
            }
            match (s0.mass(), s0.per_mas) {
                (UNIT, _) => strings!(UNIT, false),
                (DIVIDE, false) => strings!(DIVIDE, false),
                (_, false) => strings!(INV, false),
                (DIVIDE, true) => strings!(DIVIDE, true),
                (_, true) => strings!(INV, true),
            }
        }
        #[cfg(not(target_arch = "x86_64"))]
        {
            let _ = (bank, rows, law, x, xp, ms, next);
            unreachable!("a grid step needs AVX-512 or AVX2, which exist only on x86-64");
        }
    }

    /// [`Sheet::strings`] eight MAS at a time.
    ///
    /// # Safety
    /// The CPU must have AVX-512F.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx512f")]
    unsafe fn strings_avx512<const MASS: u8, const PER_MAS: bool, L, F>(
        bank: &[Sheet],
        rows: Range<usize>,
        law: F,
        x: &[f64],
        xp: &[f64],
        ms: &[f64],
        next: &mut [f64],
    ) where
        L: StringLaw,
        F: Fn(&Sheet) -> L,
    {
        Self::strings::<V8, MASS, PER_MAS, L, F>(bank, rows, law, x, xp, ms, next)
    }

    /// [`Sheet::strings`] four MAS at a time.
    ///
    /// # Safety
    /// The CPU must have AVX2.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    unsafe fn strings_avx2<const MASS: u8, const PER_MAS: bool, L, F>(
        bank: &[Sheet],
        rows: Range<usize>,
        law: F,
        x: &[f64],
        xp: &[f64],
        ms: &[f64],
        next: &mut [f64],
    ) where
        L: StringLaw,
        F: Fn(&Sheet) -> L,
    {
        Self::strings::<V4, MASS, PER_MAS, L, F>(bank, rows, law, x, xp, ms, next)
    }

    /// Rows `rows` of each string of `bank` (one after the other in storage), string by string
    /// and row by row ([`Sheet::piece`]), each with its links of law `law(string)`: `x(n+1)`
    /// into `next`, which holds exactly their slots, from the state `x`, `xp`. One call steps a
    /// whole bank of short strings, so that each string costs its piece and no call.
    ///
    /// # Safety
    /// The CPU must have `V`'s instructions, and the caller be compiled with them.
    #[cfg(target_arch = "x86_64")]
    #[inline(always)]
    unsafe fn strings<V: Vector, const MASS: u8, const PER_MAS: bool, L, F>(
        bank: &[Sheet],
        rows: Range<usize>,
        law: F,
        x: &[f64],
        xp: &[f64],
        ms: &[f64],
        next: &mut [f64],
    ) where
        L: StringLaw,
        F: Fn(&Sheet) -> L,
    {
        let lo = bank[0].slots(&rows).start;
        for sheet in bank {
            let law = law(sheet);
            for r in rows.clone() {
                let mine = sheet.slots(&(r..r + 1));
                let next = &mut next[mine.start - lo..mine.end - lo];
                sheet.piece::<V, MASS, PER_MAS, L>(law, r, x, xp, ms, next);
            }
        }
    }

    /// Row `r` of a string (a piece of it): `x(n+1)` into `next`, from the state `x`, `xp`. Each
    /// MAS's `1 / M` or `M` is `Sheet::m`, or (`PER_MAS`) its own in `ms`. `V::N` MAS at a time
    /// (a *block*), two blocks per loop turn: the velocities of a block and of their neighbours
    /// on the right (shifted by a lane from the next block's, or with `L::LOADS` loaded from one
    /// slot further), their links on the right (`L::force_n`), the links on the left the same
    /// shifted the other way (the first from the block before), `F(n) = (0 + f_left) - f_right`
    /// from `+0.0`, whichever order the MAS's two terms
    /// come in: `(0 + a) + b = (0 + b) + a` bit for bit (addition commutes, and `0 + a` is `a`
    /// but for `a = -0.0`, where both sides are `b`, or `+0.0` if `b` is `-0.0` too; only the
    /// payload of a NaN, a blow-up either way, could tell). A free end has no term: its link is
    /// a `+0.0` here, which changes no bit (`(0 + 0) - f = 0 - f`, `y - 0 = y`). Where the law's
    /// force is never `-0.0` (`L::NEVER_MINUS_ZERO`), `0 + f_left` is `f_left`, and is left out.
    ///
    /// # Safety
    /// The CPU must have `V`'s instructions, and the caller be compiled with them.
    #[cfg(target_arch = "x86_64")]
    #[inline(always)]
    unsafe fn piece<V: Vector, const MASS: u8, const PER_MAS: bool, L: StringLaw>(
        &self,
        law: L,
        r: usize,
        x: &[f64],
        xp: &[f64],
        ms: &[f64],
        next: &mut [f64],
    ) {
        let n = V::N;
        let loads = L::LOADS || !V::SHIFT_IS_ONE;
        let slots = self.slots(&(r..r + 1));
        let (lo, hi, len) = (slots.start, slots.end, slots.len());
        // every access below is within these (checked once here)
        let (xr, pr) = (&x[slots.clone()], &xp[slots.clone()]);
        let mr = if PER_MAS { &ms[slots] } else { &[] };
        assert!(next.len() == len && len >= COLS_MIN && COLS_MIN >= 2 * n);
        let link = |xa: f64, va: f64, xb: f64, vb: f64| law.force(xa, va, xb, vb);
        // the neighbour (a storage slot) before the piece's first MAS and after its last, if any
        let before = match (r, self.left[0]) {
            (0, FREE) => None,
            (0, g) => Some(g as usize),
            _ => Some(lo - 1),
        };
        let after = match (r + 1 == self.rows, self.right[0]) {
            (true, FREE) => None,
            (true, g) => Some(g as usize),
            _ => Some(hi),
        };
        let h0 = before.map_or(0.0, |b| link(x[b], x[b] - xp[b], xr[0], xr[0] - pr[0]));
        // whole blocks: MAS `0..full`, the last of which has a right neighbour in the piece; the
        // last block, MAS `full..len` (1 to `n`), the last of which has the neighbour after the
        // piece
        let full = (len - 1) / n * n;
        let last = V::lane(len - full - 1);
        // SAFETY: every load and store is of `n` items from `c0` or `c0 + 1` where `c0 < full`,
        // a multiple of `n` (so `c0 + 1 + n <= full + 1 <= len`), or, the next block's, from `c0
        // + n` when `c0 + 2 n <= len`, within `xr`, `pr`, `next` and with `PER_MAS` `mr` (`len`
        // each, asserted above; `mr` sliced to `len`); else the next block's first item alone,
        // at `c0 + n <= full < len`. The last block's are `V::load_part` and `store_part` of
        // `xr`, `pr`, `mr`, `next` from `full`, which touch those slices' items alone.
        let (wide, m) = (law.wide::<V>(), V::splat(self.m));
        let zero = V::zero();
        let mut hprev = V::splat(h0);
        let mut c0 = 0;
        // (without `L::LOADS`) the block's `x`, `x'`, `v`, loaded with the block before
        let mut xa = V::load(xr.as_ptr());
        let mut pa = V::load(pr.as_ptr());
        let mut va = xa.sub(pa);
        // one block of `n` MAS from `c0` (a macro, so that the loop below holds it twice)
        macro_rules! block {
            () => {
                // the block's `x`, `x'`, `v` and their neighbours' on the right
                let (xa, pa, va, xb, vb) = if loads {
                    // loaded from `c0` and `c0 + 1`
                    let (at, pat) = (xr.as_ptr().add(c0), pr.as_ptr().add(c0));
                    let (xa, pa) = (V::load(at), V::load(pat));
                    let (xb, pb) = (V::load(at.add(1)), V::load(pat.add(1)));
                    (xa, pa, xa.sub(pa), xb, xb.sub(pb))
                } else {
                    // shifted by a lane from this block's and the next block's
                    let (xn, pn) = if c0 + 2 * n <= len {
                        let at = c0 + n;
                        (V::load(xr.as_ptr().add(at)), V::load(pr.as_ptr().add(at)))
                    } else {
                        (V::splat(xr[c0 + n]), V::splat(pr[c0 + n]))
                    };
                    let vn = xn.sub(pn);
                    let xb = xa.next1(xn);
                    let vb = va.next1(vn);
                    let here = (xa, pa, va);
                    (xa, pa, va) = (xn, pn, vn);
                    (here.0, here.1, here.2, xb, vb)
                };
                let h = L::force_n(&wide, xa, va, xb, vb);
                let left = hprev.prev1(h);
                let f = if L::NEVER_MINUS_ZERO {
                    left.sub(h)
                } else {
                    zero.add(left).sub(h)
                };
                update::<V, MASS, PER_MAS>(xa, pa, f, m, mr, c0).store(next.as_mut_ptr().add(c0));
                hprev = h;
                c0 += n;
            };
        }
        while c0 + n < full {
            block!();
            block!();
        }
        #[allow(unused_assignments)] // (the last block's `c0` and next block are not read)
        if c0 < full {
            block!();
        }
        // the last block: its right neighbours within it, then the one after the piece in the
        // last lane, or (a free end) a `+0.0` link there
        let (xa, pa) = (V::load_part(&xr[full..]), V::load_part(&pr[full..]));
        let va = xa.sub(pa);
        let (mut xb, mut vb) = (xa.next1(zero), va.next1(zero));
        if let Some(a) = after {
            xb = xb.select(last, V::splat(x[a]));
            vb = vb.select(last, V::splat(x[a] - xp[a]));
        }
        let mut h = L::force_n(&wide, xa, va, xb, vb);
        if after.is_none() {
            h = h.select(last, zero);
        }
        let left = hprev.prev1(h);
        let f = if L::NEVER_MINUS_ZERO {
            left.sub(h)
        } else {
            zero.add(left).sub(h)
        };
        let m = if PER_MAS {
            V::load_part(&mr[full..])
        } else {
            m
        };
        update::<V, MASS, false>(xa, pa, f, m, mr, full).store_part(&mut next[full..]);
    }

    /// Row `r`: `x(n+1)` into `next`, from the state `x`, `xp`, the row below (`x(n)`, `x(n-1)`,
    /// `cols` each: the next row, or the bottom grounds) and the links up `up`; writes the row's
    /// links down into `up` (the links up of the row below). Each MAS's velocity is computed
    /// from the row's `x(n)` and `x(n-1)`, which the update loads anyway. Each MAS's `1 / M` or
    /// `M` is `Sheet::m`, or (`PER_MAS`) its own in `ms`. `V::N` MAS at a time.
    ///
    /// # Safety
    /// The CPU must have `V`'s instructions, and the caller be compiled with them.
    #[cfg(target_arch = "x86_64")]
    #[inline(always)]
    unsafe fn row<V: Vector, const MASS: u8, const UP_LAST: bool, const PER_MAS: bool>(
        &self,
        r: usize,
        a: RowArgs<'_>,
    ) {
        let n = V::N;
        let (cols, stride) = (self.cols, self.stride());
        let RowArgs {
            x,
            xp,
            below: (xd, pd),
            next,
            ms,
            up,
        } = a;
        let row = self.base + r * cols;
        // every access below is within these (checked once here)
        let (xr, pr) = (&x[row..row + cols], &xp[row..row + cols]);
        let mr = if PER_MAS { &ms[row..row + cols] } else { &[] };
        let m_at = |c: usize| if PER_MAS { mr[c] } else { self.m };
        assert!(xd.len() == cols && pd.len() == cols && next.len() == cols);
        assert!(up.len() == stride);
        assert!(cols >= COLS_MIN && n <= LANES);
        let law = RefLinks(self.k, self.z);
        let link = |xa: f64, va: f64, xb: f64, vb: f64| law.force(xa, va, xb, vb);
        // the link on the left of column 0, from this row's left ground
        let gl = self.left[r] as usize;
        let h0 = link(x[gl], x[gl] - xp[gl], xr[0], xr[0] - pr[0]);
        // whole blocks: columns `0..full`, the last of which has a right neighbour in the row;
        // the last block, columns `full..cols` (its first 1 to `n` lanes), the last of which has
        // this row's right ground
        let full = (cols - 1) / n * n;
        let gr = self.right[r] as usize;
        let (xg, vg) = (x[gr], x[gr] - xp[gr]);
        let (u0, u_last) = (up[0], up[cols - 1]);
        // SAFETY: every load and store is of `n` items from `c0 <= full` on, `full + n <= cols +
        // n - 1 < stride`, within the row buffer `up` (`stride`), or within `xr`, `pr`, `xd`,
        // `pd`, `next`, and with `PER_MAS` `mr` (`cols` each, asserted above; `mr` sliced to
        // `cols`): whole from `c0 < full` (so `c0 + n <= full < cols`), or `V::load_part` and
        // `store_part` of their items from `full`, which touch those slices' items alone.
        let w = law.wide::<V>();
        let m = V::splat(self.m);
        let zero = V::zero();
        let mut xa = V::load(xr.as_ptr());
        let mut pa = V::load(pr.as_ptr());
        let mut va = xa.sub(pa);
        let mut hprev = V::splat(h0);
        let mut c0 = 0;
        // `n` items of a row from `c0`, or (`$tail`) those of the last block
        macro_rules! load {
            ($at:expr, $tail:expr) => {
                if $tail {
                    V::load_part(&$at[c0..])
                } else {
                    V::load($at.as_ptr().add(c0))
                }
            };
        }
        // the block from `c0` with its right neighbours `xb`, `vb`, whole or (`$tail`) the
        // lanes of `tail`; gives its links on the right
        macro_rules! block {
            ($xb:expr, $vb:expr, $tail:expr) => {{
                let (xb, vb) = ($xb, $vb);
                let h = RefLinks::force_n(&w, xa, va, xb, vb);
                let left = hprev.prev1(h);
                let xdn = load!(xd, $tail);
                let vd = xdn.sub(load!(pd, $tail));
                let d = RefLinks::force_n(&w, xa, va, xdn, vd);
                let u = V::load(up.as_ptr().add(c0));
                d.store(up.as_mut_ptr().add(c0));
                // `F(n)` from `+0.0`, term by term
                let f = zero.add(left).sub(h);
                let f = if UP_LAST {
                    f.sub(d).add(u)
                } else {
                    f.add(u).sub(d)
                };
                if $tail {
                    let m = if PER_MAS { V::load_part(&mr[c0..]) } else { m };
                    update::<V, MASS, false>(xa, pa, f, m, mr, c0).store_part(&mut next[c0..]);
                } else {
                    let out = update::<V, MASS, PER_MAS>(xa, pa, f, m, mr, c0);
                    out.store(next.as_mut_ptr().add(c0));
                }
                h
            }};
        }
        // a whole block from `c0 < full` (a macro, so that the loop below holds it twice)
        macro_rules! whole {
            () => {
                // the next block (the last one's lanes past the row read as `0.0`)
                let (xn, pn) = if c0 + n < full {
                    let at = c0 + n;
                    (V::load(xr.as_ptr().add(at)), V::load(pr.as_ptr().add(at)))
                } else {
                    (V::load_part(&xr[c0 + n..]), V::load_part(&pr[c0 + n..]))
                };
                let vnx = xn.sub(pn);
                // the right neighbours: shifted by a lane, or (where that takes two
                // instructions) loaded from one column further
                let (xb, vb) = if V::SHIFT_IS_ONE {
                    (xa.next1(xn), va.next1(vnx))
                } else {
                    let xb = V::load(xr.as_ptr().add(c0 + 1));
                    (xb, xb.sub(V::load(pr.as_ptr().add(c0 + 1))))
                };
                hprev = block!(xb, vb, false);
                (xa, va, pa) = (xn, vnx, pn);
                c0 += n;
            };
        }
        // two blocks per loop turn, as `Sheet::piece`
        while c0 + n < full {
            whole!();
            whole!();
        }
        if c0 < full {
            whole!();
        }
        // the last block: its right neighbours within it, then the ground's in the last lane
        let last = V::lane(cols - full - 1);
        let xb = xa.next1(zero).select(last, V::splat(xg));
        let vb = va.next1(zero).select(last, V::splat(vg));
        let _ = block!(xb, vb, true);
        // the first and last MAS again if their terms come in another order than the row's
        let mid = if UP_LAST {
            Order::UP_LAST
        } else {
            Order::CANONICAL
        };
        if self.first[r] != mid {
            let (x0, v0) = (xr[0], xr[0] - pr[0]);
            let h = link(x0, v0, xr[1], xr[1] - pr[1]);
            let f = self.first[r].sum([h0, -h, u0, -up[0]]);
            next[0] = Self::update_as::<MASS>(x0, pr[0], f, m_at(0));
        }
        if self.last[r] != mid {
            let c = cols - 1;
            let (x0, v0) = (xr[c], xr[c] - pr[c]);
            let hl = link(xr[c - 1], xr[c - 1] - pr[c - 1], x0, v0);
            let f = self.last[r].sum([hl, -link(x0, v0, xg, vg), u_last, -up[c]]);
            next[c] = Self::update_as::<MASS>(x0, pr[c], f, m_at(c));
        }
    }
}

/// The grid step of a block on the pool's threads. The rows (in the grid's row count: the
/// sheets' rows one after the other, [`Grid::parts`]) are cut into `shares[t]`, the chunks of
/// thread `t` ([`Grid::partition`]). In each step thread `t` claims the chunks of its own share
/// first, then whatever is left of the others', each to exactly one thread, `claims[q]` counting
/// share `q`'s ([`Claim::claimed`]):
///
/// | in a step, thread `t` reads | and writes |
/// | --- | --- |
/// | `pos[cur]`, `pos[prev]` | the slots of the rows of the chunks it claimed in `pos[next]`, its part of `scratch` |
///
/// Thread 0 also records the outputs and steps the materials outside the sheets: it reads
/// `pos[cur]` and `pos[prev]`, and writes `sf` (the recorded links' forces, the ENF inputs, the
/// outside links' forces), the outside slots of `pos[next]` (no share's rows) and its frame of
/// the output, which no other thread touches (the fixes compute their own link forces, and
/// read no `sf`). Nothing a step reads is written in it; the chunks' rows are disjoint (and the
/// sheets' slots are, and none is outside), and so are the threads' parts of `scratch`
/// (`scratch_len` each, used for one chunk at a time); the one barrier after each step orders
/// its writes of `pos[next]` before the next step's reads (where it is `cur`). Which thread steps
/// a row changes no bit: every value is computed from the same operands whoever computes it (a
/// chunk's first row recomputes the links up from the row above).
pub(super) struct GridJob<'a> {
    pub(super) k: &'a Kernel,
    pub(super) grid: &'a Grid,
    pub(super) shares: &'a [Vec<Range<usize>>],
    /// one counter per share, at 0 when the block starts
    pub(super) claims: &'a [Claim],
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
        let (k, grid) = (self.k, self.grid);
        let threads = self.shares.len();
        assert!(t < threads && self.claims.len() >= threads);
        let len = grid.scratch_len();
        let ch = k.channels.len();
        let mut c = self.c0;
        for s in 0..self.frames {
            let r = Roles::at(c);
            // SAFETY: each access follows the table in the type's documentation: shared reads of
            // buffers nobody writes in this step, exclusive writes to the slots of the chunks this
            // thread claimed and to its scratch (or, on thread 0, to `sf` and the outside slots
            // of `pos[next]`), every slice dropped before the barrier that ends the step.
            unsafe {
                let state = (self.pos[r.cur].read(), self.pos[r.prev].read());
                let n = self.n0 + s as u64;
                if let Some(out) = out.as_deref_mut() {
                    let sf = self.sf.write(0..k.sf_len);
                    let frame = &mut out[s * ch..(s + 1) * ch];
                    k.record_with(&grid.recorded, state.0, state.1, sf, frame);
                    grid.outside_links(k, n, state, sf);
                    for mats in &grid.outside {
                        let next = self.pos[r.next].write(mats.clone());
                        Grid::outside_mats(k, n, mats.clone(), state, next, sf);
                    }
                }
                let scratch = self.scratch.write(t * len..(t + 1) * len);
                let chunks = |q: usize| self.shares[q].len();
                for (q, j) in Claim::claimed(&self.claims[..threads], t, s, chunks) {
                    for part in grid.parts(self.shares[q][j].clone()) {
                        let next = self.pos[r.next].write(grid.part_slots(&part));
                        grid.step_part(k, n, part, state, next, scratch);
                    }
                }
            }
            barrier.wait()?;
            c = r.next;
        }
        Ok(())
    }
}
