//! The multigrid's per-node passes in SIMD lanes (issue 20, session 38): the red-black
//! smoother, the residual and the truncated correction of [`super::multigrid`], several
//! nodes per instruction, the same bits as the scalar passes there.
//!
//! How, as [`crate::bearing::rule::slices_lanes`]: one generic body per pass, compiled in
//! `#[target_feature]` copies (AVX-512F: 8 lanes, AVX2: 4) chosen at run time; the build's
//! baseline runs the scalar passes of [`super::multigrid`] unchanged. The body works on a
//! vector type ([`simd::Vf`], the intrinsics of `std::arch`), not on `[f64; W]` arrays
//! left to the compiler: written that way (session 38, first try) the compiler saw that
//! the other colour's lanes store their own value, dropped them and evaluated this
//! colour's nodes one by one (scalar code, 13 % slower in wall). Every node's operations
//! are the scalar pass's, in the same order (no fused multiply-add; `+ − ×` are the same
//! IEEE operations in a lane; `max(x, 0)` is `maxpd(x, 0)` as the scalar `maxsd(x, 0)`:
//! `x` where `x > 0`, else `+0`, NaN included):
//! - red-black is stride 2 within a row: a chunk evaluates `W` consecutive nodes and keeps
//!   the result in this colour's lanes only (the other colour's lanes store back their own
//!   value). A colour's update reads only the other colour, so the wasted lanes change
//!   nothing and the chunk's order does not matter. The row's periodic ends (nodes 0 and
//!   `nt − 1`, whose neighbours wrap, and which are neighbours of each other when `nt` is
//!   odd) stay scalar, in the scalar pass's order: node 0 first, `nt − 1` last;
//! - held and frozen nodes (`inv == 0`) take the scalar branch's value by a select;
//! - the correction's zone test reads the west neighbour as already corrected (a chain
//!   along the row): a chunk is evaluated with the uncorrected west values and kept only
//!   when no lane changed the sign of its value (the only thing the next node's test
//!   reads); otherwise the chunk is done again node by node.
//!
//! The coarsest grid's sweep, which tracks the largest change (`Level::sweep`), stays
//! scalar.

// Off x86-64 every pass is the scalar one (the dispatch answers false): the row helpers
// are then unused.
#![cfg_attr(not(target_arch = "x86_64"), allow(dead_code))]

use std::sync::OnceLock;

use crate::bearing::LaneIsa;

/// The instruction set the passes run on: where the CPU has both AVX-512F and AVX2, the
/// faster of the two on this CPU, measured once per process ([`super::calibrate`]: cold
/// 128 × 32 solves, 5-20 ms: on two hosts of the same VM type either one won, by 3 % and
/// 13 %; BENCHMARKS.md "Issue 20, session 41: the multigrid's lanes chosen by measurement"), else the
/// widest it has; a narrower one named by the
/// environment variable `BEARING_SWEEP_LANES` (`baseline`, `avx2`, `avx512`; a benchmark
/// knob, read once) is taken as asked. The same bits on every one, so the choice changes
/// only the time.
pub(super) fn isa() -> LaneIsa {
    if let Some(forced) = FORCED.with(|f| f.get()) {
        return forced;
    }
    static ISA: OnceLock<LaneIsa> = OnceLock::new();
    *ISA.get_or_init(|| {
        let best = LaneIsa::detect();
        let rank = |i: LaneIsa| match i {
            LaneIsa::Baseline => 0,
            LaneIsa::Avx2 => 1,
            LaneIsa::Avx512 => 2,
        };
        let asked = match std::env::var("BEARING_SWEEP_LANES").as_deref() {
            Ok("baseline") => LaneIsa::Baseline,
            Ok("avx2") => LaneIsa::Avx2,
            Ok("avx512") => return best,
            _ if best == LaneIsa::Avx512 => return super::calibrate::faster(),
            _ => LaneIsa::Avx512,
        };
        if rank(asked) < rank(best) {
            asked
        } else {
            best
        }
    })
}

thread_local! {
    /// The instruction set [`on_isa`] holds on this thread while it runs its closure.
    static FORCED: std::cell::Cell<Option<LaneIsa>> = const { std::cell::Cell::new(None) };
}

/// `f()` with every pass on this thread on instruction set `isa` (one the CPU has): the
/// calibration's timed solves, which must not ask [`isa`] while it is being chosen.
pub(super) fn on_isa<R>(isa: LaneIsa, f: impl FnOnce() -> R) -> R {
    let before = FORCED.with(|c| c.replace(Some(isa)));
    let out = f();
    FORCED.with(|c| c.set(before));
    out
}

/// A pass of plain Rust loops that [`widened`] compiles for AVX-512F or AVX2: `run` must be
/// `#[inline(always)]` (and what it calls), so that its body is compiled inside each copy.
pub(super) trait Widen {
    /// What the pass returns.
    type Out;
    /// The pass.
    fn run(self) -> Self::Out;
}

/// `job.run()` compiled for AVX-512F or AVX2 where [`isa`] picks one (else as built): the
/// compiler widens plain Rust loops by itself, as it does `Level::setup`'s. The same bits on
/// every instruction set: the compiler keeps each operation and its order (Rust does not
/// fuse or reassociate floating-point arithmetic), only the registers are wider.
#[inline(always)]
pub(super) fn widened<J: Widen>(job: J) -> J::Out {
    widened_on(isa(), job)
}

/// [`widened`] on the instruction set `isa` (the unit tests compare them).
#[inline(always)]
pub(super) fn widened_on<J: Widen>(isa: LaneIsa, job: J) -> J::Out {
    #[cfg(target_arch = "x86_64")]
    {
        #[target_feature(enable = "avx512f")]
        fn wide<J: Widen>(job: J) -> J::Out {
            job.run()
        }
        #[target_feature(enable = "avx2")]
        fn narrow<J: Widen>(job: J) -> J::Out {
            job.run()
        }
        match isa {
            LaneIsa::Avx512 if std::arch::is_x86_feature_detected!("avx512f") => {
                // SAFETY: the CPU has AVX-512F (checked just above).
                return unsafe { wide(job) };
            }
            LaneIsa::Avx2 if std::arch::is_x86_feature_detected!("avx2") => {
                // SAFETY: the CPU has AVX2 (checked just above).
                return unsafe { narrow(job) };
            }
            _ => {}
        }
    }
    let _ = isa;
    job.run()
}

/// One grid's operator and right-hand side as row-major slices (`nt` nodes per row,
/// `nz + 1` rows, the end rows not unknowns), as the passes read them.
pub(super) struct Grid<'a> {
    /// Nodes per row (θ).
    pub nt: usize,
    /// Intervals in ζ (rows `0..=nz`).
    pub nz: usize,
    /// East-face coefficient of each node.
    pub ae: &'a [f64],
    /// North-face coefficient of each node.
    pub an: &'a [f64],
    /// Diagonal of the operator.
    pub d: &'a [f64],
    /// Right-hand side.
    pub f: &'a [f64],
    /// Inverse diagonal in force (0: held or frozen).
    pub inv: &'a [f64],
    /// Held values.
    pub hold: &'a [f64],
    /// Whether the grid is the one being solved (held nodes set to `hold`) or a
    /// correction grid (frozen nodes kept).
    pub top: bool,
    /// Whether `hold` is `+0` everywhere (`Level::hold_zero`: a film without held bands):
    /// the passes then take `+0` for it and never read it (session 40: a load per chunk,
    /// and the array's pages are not touched).
    pub hold_zero: bool,
}

/// The rows around row `j` of a grid: the row's coefficients and the field south and north
/// of it, each `nt` long.
struct Rows<'a> {
    south: &'a [f64],
    north: &'a [f64],
    ae: &'a [f64],
    an: &'a [f64],
    an_south: &'a [f64],
    d: &'a [f64],
    f: &'a [f64],
    inv: &'a [f64],
}

impl<'a> Rows<'a> {
    #[inline(always)]
    fn of(g: &Grid<'a>, south: &'a [f64], north: &'a [f64], j: usize) -> Self {
        let (nt, row) = (g.nt, j * g.nt);
        assert!(south.len() == nt && north.len() == nt);
        Rows {
            south,
            north,
            ae: &g.ae[row..row + nt],
            an: &g.an[row..row + nt],
            an_south: &g.an[row - nt..row],
            d: &g.d[row..row + nt],
            f: &g.f[row..row + nt],
            inv: &g.inv[row..row + nt],
        }
    }
}

/// Row `j` of a grid for the smoother, as pointers to the row's first node: the field's
/// row and the rows south and north of it, the row's coefficients (session 40: slices,
/// each with its bounds checks per row, were a fifth of the smoother's instructions
/// outside its chunks, which are a quarter of the whole at 128 × 32 with AVX2).
#[derive(Clone, Copy)]
struct RowPtr {
    cur: *mut f64,
    south: *const f64,
    north: *const f64,
    ae: *const f64,
    an: *const f64,
    an_south: *const f64,
    f: *const f64,
    inv: *const f64,
    hold: *const f64,
    /// The grid solved with every hold `+0` ([`Grid::hold_zero`]): `hold` is not read.
    hold0: bool,
}

/// The scalar smoother's node update (`RowRef::update` at ω = 1, not tracked).
///
/// # Safety
/// `i`, `ip`, `im` are nodes of the row (`< nt`); every pointer of `r` has `nt` values
/// (`hold` read only when `top` and not `r.hold0`).
#[inline(always)]
unsafe fn relax_node(r: &RowPtr, i: usize, ip: usize, im: usize, top: bool) {
    let ik = *r.inv.add(i);
    let c = r.cur;
    let old = *c.add(i);
    if ik == 0.0 {
        if top {
            *c.add(i) = if r.hold0 { 0.0 } else { *r.hold.add(i) };
        }
        return;
    }
    let s = *r.ae.add(i) * *c.add(ip)
        + *r.ae.add(im) * *c.add(im)
        + *r.an.add(i) * *r.north.add(i)
        + *r.an_south.add(i) * *r.south.add(i);
    *c.add(i) = (old + ((s + *r.f.add(i)) * ik - old)).max(0.0);
}

/// The scalar residual at node `i` (`ResidualRow::at`).
#[inline(always)]
fn residual_node(r: &Rows, cur: &[f64], i: usize, ip: usize, im: usize) -> f64 {
    if r.inv[i] == 0.0 {
        return 0.0;
    }
    let pk = cur[i];
    let v = r.f[i] - r.d[i] * pk
        + r.ae[i] * cur[ip]
        + r.ae[im] * cur[im]
        + r.an[i] * r.north[i]
        + r.an_south[i] * r.south[i];
    if pk <= 0.0 && v < 0.0 {
        0.0
    } else {
        v
    }
}

/// One fine row of the truncated correction: its neighbours' rows and the interpolated
/// correction `v` at every node of the row, each `nt` long.
struct CorrRow<'a> {
    south: &'a [f64],
    north: &'a [f64],
    inv: &'a [f64],
    hold: &'a [f64],
    /// As [`RowPtr::hold0`].
    hold0: bool,
    v: &'a [f64],
    /// Rows next to the end faces: the face's p = 0 does not count against the zone.
    first: bool,
    last: bool,
}

/// The scalar correction of node `i` (`prolong_correction_on`'s loop body).
#[inline(always)]
fn correct_node(r: &CorrRow, cur: &mut [f64], i: usize, ip: usize, im: usize, top: bool) {
    if r.inv[i] == 0.0 {
        if top {
            cur[i] = if r.hold0 { 0.0 } else { r.hold[i] };
        }
        return;
    }
    let pk = cur[i];
    let inside = pk > 0.0
        && cur[ip] > 0.0
        && cur[im] > 0.0
        && (r.last || r.north[i] > 0.0)
        && (r.first || r.south[i] > 0.0);
    if inside {
        cur[i] = (pk + r.v[i]).max(0.0);
    }
}

/// The interpolated correction of fine row `j` (the coarse corrections `e0` at the coarse
/// row `j / SZ`, `e1` the row above, `jo = j mod SZ`), at every node of the row: the scalar
/// pass's `match` on the offsets, the same sums in the same order.
#[inline(always)]
fn interpolate_row<const ST: usize>(e0: &[f64], e1: &[f64], jo: usize, v: &mut [f64]) {
    let cnt = e0.len();
    if ST == 2 {
        for ic in 0..cnt {
            let ic1 = if ic + 1 == cnt { 0 } else { ic + 1 };
            let (a, b) = (e0[ic], e0[ic1]);
            let (x, y) = if jo == 0 {
                (a, 0.5 * (a + b))
            } else {
                let (c, d) = (e1[ic], e1[ic1]);
                (0.5 * (a + c), 0.25 * (a + b + c + d))
            };
            v[2 * ic] = x;
            v[2 * ic + 1] = y;
        }
    } else if jo == 0 {
        v[..cnt].copy_from_slice(e0);
    } else {
        for ((v, a), c) in v.iter_mut().zip(e0).zip(e1) {
            *v = 0.5 * (a + c);
        }
    }
}

/// The vector types of the lanes and the few operations the passes use.
#[cfg(target_arch = "x86_64")]
mod simd {
    use std::arch::x86_64::*;

    /// `W` f64 lanes. Every function is `unsafe`: the CPU must have the instruction set
    /// (the callers are `#[target_feature]` functions), and the loads and stores read and
    /// write `W` values from the pointer.
    pub(super) trait Vf: Copy {
        /// Lanes.
        const W: usize;
        /// A lane mask.
        type M: Copy;
        unsafe fn load(p: *const f64) -> Self;
        unsafe fn store(self, p: *mut f64);
        unsafe fn zero() -> Self;
        unsafe fn splat(x: f64) -> Self;
        /// `[prev[W − 1], cur[0], …, cur[W − 2]]`: the west neighbours of `cur`'s nodes
        /// when `prev` holds the `W` nodes before them.
        unsafe fn shift_in(prev: Self, cur: Self) -> Self;
        unsafe fn add(self, o: Self) -> Self;
        unsafe fn sub(self, o: Self) -> Self;
        unsafe fn mul(self, o: Self) -> Self;
        /// `max(self, 0)` as `maxpd(self, 0)`: `self` where `self > 0`, else `+0`.
        unsafe fn max0(self) -> Self;
        /// `self == 0`, `self > 0`, `self <= 0`, `self < 0` (ordered: false for NaN).
        unsafe fn eq0(self) -> Self::M;
        unsafe fn gt0(self) -> Self::M;
        unsafe fn le0(self) -> Self::M;
        unsafe fn lt0(self) -> Self::M;
        unsafe fn and(a: Self::M, b: Self::M) -> Self::M;
        unsafe fn xor(a: Self::M, b: Self::M) -> Self::M;
        /// `m ? a : b` lane by lane.
        unsafe fn select(m: Self::M, a: Self, b: Self) -> Self;
        /// `a` in the even lanes, `b` in the odd ones.
        unsafe fn even(a: Self, b: Self) -> Self;
        /// The even lanes of `a` then those of `b` (`x[0], x[2], …` of `x = a : b`).
        unsafe fn evens(a: Self, b: Self) -> Self;
        /// The odd lanes of `a` then those of `b`.
        unsafe fn odds(a: Self, b: Self) -> Self;
        /// The first half of `a` and `b` interleaved: `a0, b0, a1, b1, …` (the inverse of
        /// [`Vf::evens`] and [`Vf::odds`] with [`Vf::zip_hi`]).
        unsafe fn zip_lo(a: Self, b: Self) -> Self;
        /// The second half of `a` and `b` interleaved.
        unsafe fn zip_hi(a: Self, b: Self) -> Self;
        /// Whether any lane is set.
        unsafe fn any(m: Self::M) -> bool;
        /// `self` with its last lane `x`.
        unsafe fn with_last(self, x: f64) -> Self;
    }

    /// AVX2: four lanes, masks as all-ones lanes.
    #[derive(Clone, Copy)]
    pub(super) struct Avx2(__m256d);

    impl Vf for Avx2 {
        const W: usize = 4;
        type M = __m256d;
        #[inline(always)]
        unsafe fn load(p: *const f64) -> Self {
            Avx2(_mm256_loadu_pd(p))
        }
        #[inline(always)]
        unsafe fn store(self, p: *mut f64) {
            _mm256_storeu_pd(p, self.0)
        }
        #[inline(always)]
        unsafe fn zero() -> Self {
            Avx2(_mm256_setzero_pd())
        }
        #[inline(always)]
        unsafe fn splat(x: f64) -> Self {
            Avx2(_mm256_set1_pd(x))
        }
        #[inline(always)]
        unsafe fn shift_in(prev: Self, cur: Self) -> Self {
            // [prev2, prev3, cur0, cur1], then [prev3, cur0, cur1, cur2].
            let t = _mm256_permute2f128_pd::<0x21>(prev.0, cur.0);
            Avx2(_mm256_shuffle_pd::<0b0101>(t, cur.0))
        }
        #[inline(always)]
        unsafe fn add(self, o: Self) -> Self {
            Avx2(_mm256_add_pd(self.0, o.0))
        }
        #[inline(always)]
        unsafe fn sub(self, o: Self) -> Self {
            Avx2(_mm256_sub_pd(self.0, o.0))
        }
        #[inline(always)]
        unsafe fn mul(self, o: Self) -> Self {
            Avx2(_mm256_mul_pd(self.0, o.0))
        }
        #[inline(always)]
        unsafe fn max0(self) -> Self {
            Avx2(_mm256_max_pd(self.0, _mm256_setzero_pd()))
        }
        #[inline(always)]
        unsafe fn eq0(self) -> __m256d {
            _mm256_cmp_pd::<_CMP_EQ_OQ>(self.0, _mm256_setzero_pd())
        }
        #[inline(always)]
        unsafe fn gt0(self) -> __m256d {
            _mm256_cmp_pd::<_CMP_GT_OQ>(self.0, _mm256_setzero_pd())
        }
        #[inline(always)]
        unsafe fn le0(self) -> __m256d {
            _mm256_cmp_pd::<_CMP_LE_OQ>(self.0, _mm256_setzero_pd())
        }
        #[inline(always)]
        unsafe fn lt0(self) -> __m256d {
            _mm256_cmp_pd::<_CMP_LT_OQ>(self.0, _mm256_setzero_pd())
        }
        #[inline(always)]
        unsafe fn and(a: __m256d, b: __m256d) -> __m256d {
            _mm256_and_pd(a, b)
        }
        #[inline(always)]
        unsafe fn xor(a: __m256d, b: __m256d) -> __m256d {
            _mm256_xor_pd(a, b)
        }
        #[inline(always)]
        unsafe fn select(m: __m256d, a: Self, b: Self) -> Self {
            Avx2(_mm256_blendv_pd(b.0, a.0, m))
        }
        #[inline(always)]
        unsafe fn even(a: Self, b: Self) -> Self {
            // Immediate bit k set: lane k from the second operand.
            Avx2(_mm256_blend_pd::<0b1010>(a.0, b.0))
        }
        #[inline(always)]
        unsafe fn evens(a: Self, b: Self) -> Self {
            // [a0, b0, a2, b2], then lanes 0, 2, 1, 3.
            let t = _mm256_unpacklo_pd(a.0, b.0);
            Avx2(_mm256_permute4x64_pd::<0b11_01_10_00>(t))
        }
        #[inline(always)]
        unsafe fn odds(a: Self, b: Self) -> Self {
            let t = _mm256_unpackhi_pd(a.0, b.0);
            Avx2(_mm256_permute4x64_pd::<0b11_01_10_00>(t))
        }
        #[inline(always)]
        unsafe fn zip_lo(a: Self, b: Self) -> Self {
            // [a0, b0, a2, b2] and [a1, b1, a3, b3]: their low halves.
            let (lo, hi) = (_mm256_unpacklo_pd(a.0, b.0), _mm256_unpackhi_pd(a.0, b.0));
            Avx2(_mm256_permute2f128_pd::<0x20>(lo, hi))
        }
        #[inline(always)]
        unsafe fn zip_hi(a: Self, b: Self) -> Self {
            let (lo, hi) = (_mm256_unpacklo_pd(a.0, b.0), _mm256_unpackhi_pd(a.0, b.0));
            Avx2(_mm256_permute2f128_pd::<0x31>(lo, hi))
        }
        #[inline(always)]
        unsafe fn any(m: __m256d) -> bool {
            _mm256_movemask_pd(m) != 0
        }
        #[inline(always)]
        unsafe fn with_last(self, x: f64) -> Self {
            Avx2(_mm256_blend_pd::<0b1000>(self.0, _mm256_set1_pd(x)))
        }
    }

    /// AVX-512F: eight lanes, masks as bits.
    #[derive(Clone, Copy)]
    pub(super) struct Avx512(__m512d);

    impl Vf for Avx512 {
        const W: usize = 8;
        type M = __mmask8;
        #[inline(always)]
        unsafe fn load(p: *const f64) -> Self {
            Avx512(_mm512_loadu_pd(p))
        }
        #[inline(always)]
        unsafe fn store(self, p: *mut f64) {
            _mm512_storeu_pd(p, self.0)
        }
        #[inline(always)]
        unsafe fn zero() -> Self {
            Avx512(_mm512_setzero_pd())
        }
        #[inline(always)]
        unsafe fn splat(x: f64) -> Self {
            Avx512(_mm512_set1_pd(x))
        }
        #[inline(always)]
        unsafe fn shift_in(prev: Self, cur: Self) -> Self {
            // `valignq`: the 16 lanes `prev : cur` shifted down by 7.
            Avx512(_mm512_castsi512_pd(_mm512_alignr_epi64::<7>(
                _mm512_castpd_si512(cur.0),
                _mm512_castpd_si512(prev.0),
            )))
        }
        #[inline(always)]
        unsafe fn add(self, o: Self) -> Self {
            Avx512(_mm512_add_pd(self.0, o.0))
        }
        #[inline(always)]
        unsafe fn sub(self, o: Self) -> Self {
            Avx512(_mm512_sub_pd(self.0, o.0))
        }
        #[inline(always)]
        unsafe fn mul(self, o: Self) -> Self {
            Avx512(_mm512_mul_pd(self.0, o.0))
        }
        #[inline(always)]
        unsafe fn max0(self) -> Self {
            Avx512(_mm512_max_pd(self.0, _mm512_setzero_pd()))
        }
        #[inline(always)]
        unsafe fn eq0(self) -> __mmask8 {
            _mm512_cmp_pd_mask::<_CMP_EQ_OQ>(self.0, _mm512_setzero_pd())
        }
        #[inline(always)]
        unsafe fn gt0(self) -> __mmask8 {
            _mm512_cmp_pd_mask::<_CMP_GT_OQ>(self.0, _mm512_setzero_pd())
        }
        #[inline(always)]
        unsafe fn le0(self) -> __mmask8 {
            _mm512_cmp_pd_mask::<_CMP_LE_OQ>(self.0, _mm512_setzero_pd())
        }
        #[inline(always)]
        unsafe fn lt0(self) -> __mmask8 {
            _mm512_cmp_pd_mask::<_CMP_LT_OQ>(self.0, _mm512_setzero_pd())
        }
        #[inline(always)]
        unsafe fn and(a: __mmask8, b: __mmask8) -> __mmask8 {
            a & b
        }
        #[inline(always)]
        unsafe fn xor(a: __mmask8, b: __mmask8) -> __mmask8 {
            a ^ b
        }
        #[inline(always)]
        unsafe fn select(m: __mmask8, a: Self, b: Self) -> Self {
            // `_mm512_mask_blend_pd(k, x, y)`: `y` where `k` is set.
            Avx512(_mm512_mask_blend_pd(m, b.0, a.0))
        }
        #[inline(always)]
        unsafe fn even(a: Self, b: Self) -> Self {
            Avx512(_mm512_mask_blend_pd(0b1010_1010, a.0, b.0))
        }
        #[inline(always)]
        unsafe fn evens(a: Self, b: Self) -> Self {
            // Index k < 8: lane k of `a`, else lane k − 8 of `b`.
            let idx = _mm512_set_epi64(14, 12, 10, 8, 6, 4, 2, 0);
            Avx512(_mm512_permutex2var_pd(a.0, idx, b.0))
        }
        #[inline(always)]
        unsafe fn odds(a: Self, b: Self) -> Self {
            let idx = _mm512_set_epi64(15, 13, 11, 9, 7, 5, 3, 1);
            Avx512(_mm512_permutex2var_pd(a.0, idx, b.0))
        }
        #[inline(always)]
        unsafe fn zip_lo(a: Self, b: Self) -> Self {
            let idx = _mm512_set_epi64(11, 3, 10, 2, 9, 1, 8, 0);
            Avx512(_mm512_permutex2var_pd(a.0, idx, b.0))
        }
        #[inline(always)]
        unsafe fn zip_hi(a: Self, b: Self) -> Self {
            let idx = _mm512_set_epi64(15, 7, 14, 6, 13, 5, 12, 4);
            Avx512(_mm512_permutex2var_pd(a.0, idx, b.0))
        }
        #[inline(always)]
        unsafe fn any(m: __mmask8) -> bool {
            m != 0
        }
        #[inline(always)]
        unsafe fn with_last(self, x: f64) -> Self {
            Avx512(_mm512_mask_blend_pd(0b1000_0000, self.0, _mm512_set1_pd(x)))
        }
    }
}

#[cfg(target_arch = "x86_64")]
use simd::Vf;

/// The smoother on `W` consecutive nodes `i..i + W` of a row: this colour's lanes (the
/// even ones where `EVEN`, else the odd ones) updated, the others stored unchanged; returns
/// the nodes' values before. `prev`: the `W` nodes before, as loaded (only its last lane is
/// read, node `i − 1`'s value). The west neighbours from registers: loaded from memory
/// they straddle the last chunk's store, which a load cannot be forwarded from and waits
/// for (measured 2.9× slower than scalar with AVX2); taken from that chunk's result they
/// chain every chunk to the last one's latency (1.5× slower). A node's west neighbour is
/// of the other colour, unchanged by the sweep, so the values as loaded are the ones.
///
/// `TOP` (the grid solved: held nodes take `hold`, else frozen nodes keep their value),
/// `EVEN` and `HOLD0` are constants of the row's loop (session 40: tested per chunk, they
/// were 4 of its 32 AVX2 instructions). `HOLD0` (`TOP` with `hold` all `+0`): no select
/// at all, for the update itself is `+0` where `inv = 0`: `(s + f)·0` is `±0` (or NaN
/// where `s + f` is not finite), `old + (±0 − old)` is `old − old = +0` in
/// round-to-nearest for a finite `old` (NaN for an infinite one), and `maxpd(·, 0)` gives
/// `+0` for a zero and a NaN alike: the scalar pass's `hold[i] = +0`, the same bits.
///
/// `wrap`: the chunk holding node 0 (`first`: its west face and neighbour wrap, the
/// neighbour from `prev`) or node `nt − 1` (`last`: its east neighbour wraps), see
/// [`relax_row_whole`].
///
/// # Safety
/// The CPU has `V`'s instruction set; `1 ≤ i`, `i + W < nt` (no wrap; every row of `r`
/// is `nt` long), or `i = 0` with `wrap.first`, or `i + W = nt` with `wrap.last` (then
/// the field's next row is there: its first node is read, not used).
#[cfg(target_arch = "x86_64")]
#[inline(always)]
unsafe fn relax_chunk<V: Vf, const TOP: bool, const EVEN: bool, const HOLD0: bool>(
    r: &RowPtr,
    i: usize,
    prev: V,
    wrap: Wrap,
) -> V {
    let c = r.cur.add(i);
    let (old, mut e) = (V::load(c), V::load(c.add(1)));
    if wrap.last {
        // Node `nt − 1`'s east neighbour is node 0 (the load's last lane: the next row's).
        e = e.with_last(*r.cur);
    }
    let w = V::shift_in(prev, old);
    let ae = V::load(r.ae.add(i));
    let aw = if wrap.first {
        // Node 0's west face is node `nt − 1`'s east face.
        V::shift_in(V::splat(*r.ae.add(wrap.nt - 1)), ae)
    } else {
        V::load(r.ae.add(i - 1))
    };
    let (an, no) = (V::load(r.an.add(i)), V::load(r.north.add(i)));
    let (ans, so) = (V::load(r.an_south.add(i)), V::load(r.south.add(i)));
    let (f, ik) = (V::load(r.f.add(i)), V::load(r.inv.add(i)));
    let s = ae.mul(e).add(aw.mul(w)).add(an.mul(no)).add(ans.mul(so));
    let new = old.add(s.add(f).mul(ik).sub(old)).max0();
    let v = if TOP && HOLD0 {
        new
    } else {
        let keep = if TOP { V::load(r.hold.add(i)) } else { old };
        V::select(ik.eq0(), keep, new)
    };
    let out = if EVEN {
        V::even(v, old)
    } else {
        V::even(old, v)
    };
    out.store(c);
    old
}

/// The chunks of a row from node 1 ([`relax_chunk`] while `i + W < nt`); returns the first
/// node after them.
///
/// # Safety
/// As [`relax_chunk`]: the CPU has `V`'s instruction set, every row is `nt` long.
#[cfg(target_arch = "x86_64")]
#[inline(always)]
unsafe fn relax_chunks<V: Vf, const TOP: bool, const EVEN: bool, const HOLD0: bool>(
    r: &RowPtr,
    nt: usize,
) -> usize {
    let mut i = 1;
    if i + V::W < nt {
        let mut prev = V::splat(*r.cur);
        while i + V::W < nt {
            prev = relax_chunk::<V, TOP, EVEN, HOLD0>(r, i, prev, Wrap::NONE);
            i += V::W;
        }
    }
    i
}

/// Which row ends a chunk holds (see [`relax_chunk`]).
#[derive(Clone, Copy)]
struct Wrap {
    first: bool,
    last: bool,
    /// Nodes per row.
    nt: usize,
}

impl Wrap {
    const NONE: Wrap = Wrap {
        first: false,
        last: false,
        nt: 0,
    };
}

/// A whole row in chunks from node 0 when `nt` is a multiple of `W` (session 40): the
/// first chunk takes node 0's west neighbour and face from the row's end, the last one
/// node `nt − 1`'s east neighbour from node 0; no node by node, no scalar row ends (they
/// were ~75 of the ~140 AVX2 instructions per row and colour outside the chunks). The
/// same updates: `nt` even, so nodes 0 and `nt − 1` are of different colours (the scalar
/// pass's order between them, node 0 first, does not matter), and each node's sums are the
/// scalar pass's in its order. The chunks' offsets are the same in every row and colour,
/// so a row's loads of its neighbour rows still match their stores (see
/// [`smooth_generic`]).
///
/// # Safety
/// The CPU has `V`'s instruction set; `nt` is a positive multiple of `W`, and the field's
/// row after this one is there (rows `1..nz` of `nz + 1`).
#[cfg(target_arch = "x86_64")]
#[inline(always)]
unsafe fn relax_row_whole<V: Vf, const TOP: bool, const EVEN: bool, const HOLD0: bool>(
    r: &RowPtr,
    nt: usize,
) {
    let prev = V::splat(*r.cur.add(nt - 1));
    let last = nt - V::W;
    let ends = |first, last| Wrap { first, last, nt };
    if last == 0 {
        relax_chunk::<V, TOP, EVEN, HOLD0>(r, 0, prev, ends(true, true));
        return;
    }
    let mut prev = relax_chunk::<V, TOP, EVEN, HOLD0>(r, 0, prev, ends(true, false));
    let mut i = V::W;
    while i < last {
        prev = relax_chunk::<V, TOP, EVEN, HOLD0>(r, i, prev, Wrap::NONE);
        i += V::W;
    }
    relax_chunk::<V, TOP, EVEN, HOLD0>(r, last, prev, ends(false, true));
}

/// One red-black projected Gauss–Seidel sweep at ω = 1 (`Level::smooth`) in `V`'s lanes.
/// The chunks of every row start at the same node (0 where `nt` is a multiple of `W`,
/// [`relax_row_whole`]; else 1), whatever the colour (this colour's lanes odd
/// or even): a row's loads of the row south, just relaxed, then match that row's stores
/// exactly (a store forwards to a load of the same place and size; starting at this
/// colour's first node instead, each load straddled two stores and waited for them:
/// measured 1.5× slower than scalar with AVX2). Any order of rows gives the same bits: a
/// colour's update reads only the other colour.
///
/// # Safety
/// The CPU has `V`'s instruction set.
#[cfg(target_arch = "x86_64")]
#[inline(always)]
unsafe fn smooth_generic<V: Vf>(g: &Grid, p: &mut [f64]) {
    let (nt, nz, top) = (g.nt, g.nz, g.top);
    let hold0 = top && g.hold_zero;
    let n = nt * (nz + 1);
    // Every row `0..=nz` of every array is there (the pointers below stay inside).
    assert!(nz >= 1 && p.len() >= n && g.ae.len() >= n && g.an.len() >= n);
    assert!(g.f.len() >= n && g.inv.len() >= n && (hold0 || g.hold.len() >= n));
    // The field through one pointer only: every row's reads and writes derive from it
    // (no slices of `p` alive while it is written).
    let pp = p.as_mut_ptr();
    // Whole rows in chunks from node 0 (every grid of the 128 × 32 hierarchy), else the
    // chunks from node 1 and the row's ends node by node.
    let whole = nt % V::W == 0;
    for colour in 0..2 {
        for j in 1..nz {
            let row = j * nt;
            let r = RowPtr {
                cur: pp.add(row),
                south: pp.add(row - nt),
                north: pp.add(row + nt),
                ae: g.ae.as_ptr().add(row),
                an: g.an.as_ptr().add(row),
                an_south: g.an.as_ptr().add(row - nt),
                f: g.f.as_ptr().add(row),
                inv: g.inv.as_ptr().add(row),
                hold: g.hold.as_ptr().wrapping_add(row),
                hold0,
            };
            // This colour's nodes: i ≡ par (mod 2).
            let par = (colour + j) % 2;
            if whole {
                // Lane 0 is node 0: this colour's lanes are the even ones where par = 0.
                match (top, par == 0, hold0) {
                    (true, true, true) => relax_row_whole::<V, true, true, true>(&r, nt),
                    (true, false, true) => relax_row_whole::<V, true, false, true>(&r, nt),
                    (true, true, false) => relax_row_whole::<V, true, true, false>(&r, nt),
                    (true, false, false) => relax_row_whole::<V, true, false, false>(&r, nt),
                    (false, true, _) => relax_row_whole::<V, false, true, false>(&r, nt),
                    (false, false, _) => relax_row_whole::<V, false, false, false>(&r, nt),
                }
                continue;
            }
            if par == 0 {
                relax_node(&r, 0, 1 % nt, nt - 1, top);
            }
            let i = match (top, par == 1, hold0) {
                (true, true, true) => relax_chunks::<V, true, true, true>(&r, nt),
                (true, false, true) => relax_chunks::<V, true, false, true>(&r, nt),
                (true, true, false) => relax_chunks::<V, true, true, false>(&r, nt),
                (true, false, false) => relax_chunks::<V, true, false, false>(&r, nt),
                (false, true, _) => relax_chunks::<V, false, true, false>(&r, nt),
                (false, false, _) => relax_chunks::<V, false, false, false>(&r, nt),
            };
            // The rest of the row node by node, the row's last node last.
            let mut i = if i % 2 == par { i } else { i + 1 };
            while i + 1 < nt {
                relax_node(&r, i, i + 1, i - 1, top);
                i += 2;
            }
            if i + 1 == nt {
                relax_node(&r, i, 0, i - 1, top);
            }
        }
    }
}

/// The residual's value at nodes `pk` with neighbours `[east, west, north, south]`, face
/// coefficients `a` in the same order, diagonal `d`, right-hand side `f` and inverse
/// diagonal `ik`: the scalar `residual_node`'s sums in its order, 0 where the node is held
/// (`ik` = 0) or where the projection holds it (`pk ≤ 0` and the residual negative).
///
/// # Safety
/// The CPU has `V`'s instruction set.
#[cfg(target_arch = "x86_64")]
#[inline(always)]
unsafe fn residual_value<V: Vf>(pk: V, nb: [V; 4], a: [V; 4], d: V, f: V, ik: V) -> V {
    let v = f
        .sub(d.mul(pk))
        .add(a[0].mul(nb[0]))
        .add(a[1].mul(nb[1]))
        .add(a[2].mul(nb[2]))
        .add(a[3].mul(nb[3]));
    let zero = V::zero();
    let v = V::select(V::and(pk.le0(), v.lt0()), zero, v);
    V::select(ik.eq0(), zero, v)
}

/// The residual on `W` consecutive nodes `i..i + W`, node `i` of the first colour: its
/// value in the even lanes, 0 in the odd ones.
///
/// # Safety
/// As [`relax_chunk`]; `out` is `nt` long.
#[cfg(target_arch = "x86_64")]
#[inline(always)]
unsafe fn residual_chunk<V: Vf>(r: &Rows, cur: &[f64], out: &mut [f64], i: usize) {
    let c = cur.as_ptr().add(i);
    let (pk, e, w) = (V::load(c), V::load(c.add(1)), V::load(c.sub(1)));
    let (ae, aw) = (
        V::load(r.ae.as_ptr().add(i)),
        V::load(r.ae.as_ptr().add(i - 1)),
    );
    let (an, no) = (
        V::load(r.an.as_ptr().add(i)),
        V::load(r.north.as_ptr().add(i)),
    );
    let (ans, so) = (
        V::load(r.an_south.as_ptr().add(i)),
        V::load(r.south.as_ptr().add(i)),
    );
    let (d, f) = (V::load(r.d.as_ptr().add(i)), V::load(r.f.as_ptr().add(i)));
    let ik = V::load(r.inv.as_ptr().add(i));
    let v = residual_value(pk, [e, w, no, so], [ae, aw, an, ans], d, f, ik);
    let zero = V::zero();
    V::even(v, zero).store(out.as_mut_ptr().add(i));
}

/// The residual on the `W` nodes `i..i + W` of row `j` (`c`: the field at the row's node
/// 0, `o` the output's), the first colour's lanes (odd ones where `ODD`) kept, 0 in the
/// others; `FIRST`: `i = 0` (node 0's west face and neighbour from the row's end), `LAST`:
/// `i + W = nt` (node `nt − 1`'s east neighbour is node 0; the load's last lane, the next
/// row's first node, is replaced). The scalar `residual_node`'s sums in its order.
///
/// # Safety
/// The CPU has `V`'s instruction set; the grid's arrays hold rows `j − 1 ..= j + 1`.
#[cfg(target_arch = "x86_64")]
#[inline(always)]
unsafe fn residual_chunk_whole<V: Vf, const ODD: bool, const FIRST: bool, const LAST: bool>(
    g: &Grid,
    c: *const f64,
    o: *mut f64,
    row: usize,
    i: usize,
) {
    let nt = g.nt;
    let q = c.add(i);
    let pk = V::load(q);
    let mut e = V::load(q.add(1));
    if LAST {
        e = e.with_last(*c);
    }
    let ae = V::load(g.ae.as_ptr().add(row + i));
    let (w, aw) = if FIRST {
        (
            V::shift_in(V::splat(*c.add(nt - 1)), pk),
            V::shift_in(V::splat(*g.ae.as_ptr().add(row + nt - 1)), ae),
        )
    } else {
        (V::load(q.sub(1)), V::load(g.ae.as_ptr().add(row + i - 1)))
    };
    let (an, no) = (V::load(g.an.as_ptr().add(row + i)), V::load(q.add(nt)));
    let (ans, so) = (V::load(g.an.as_ptr().add(row - nt + i)), V::load(q.sub(nt)));
    let (d, f) = (
        V::load(g.d.as_ptr().add(row + i)),
        V::load(g.f.as_ptr().add(row + i)),
    );
    let ik = V::load(g.inv.as_ptr().add(row + i));
    let v = residual_value(pk, [e, w, no, so], [ae, aw, an, ans], d, f, ik);
    let zero = V::zero();
    let out = if ODD {
        V::even(zero, v)
    } else {
        V::even(v, zero)
    };
    out.store(o.add(i));
}

/// Row `j` of [`residual_generic`] in whole chunks from node 0 when `nt` is a multiple of
/// `W` (session 40, as the smoother's `relax_row_whole`): no scalar row ends. The first
/// colour's nodes are those with `i ≡ j (mod 2)`: the odd lanes on odd rows.
///
/// # Safety
/// The CPU has `V`'s instruction set; `nt` is a positive multiple of `W`; `1 ≤ j < nz`;
/// the grid's arrays, `p` and `out` hold all `nz + 1` rows.
#[cfg(target_arch = "x86_64")]
#[inline(always)]
unsafe fn residual_row_whole<V: Vf, const ODD: bool>(g: &Grid, p: &[f64], out: *mut f64, j: usize) {
    let nt = g.nt;
    let row = j * nt;
    let (c, o) = (p.as_ptr().add(row), out.add(row));
    let last = nt - V::W;
    if last == 0 {
        residual_chunk_whole::<V, ODD, true, true>(g, c, o, row, 0);
        return;
    }
    residual_chunk_whole::<V, ODD, true, false>(g, c, o, row, 0);
    let mut i = V::W;
    while i < last {
        residual_chunk_whole::<V, ODD, false, false>(g, c, o, row, i);
        i += V::W;
    }
    residual_chunk_whole::<V, ODD, false, true>(g, c, o, row, last);
}

/// `Level::residual` (the point smoother's: first colour only) in `V`'s lanes.
///
/// # Safety
/// The CPU has `V`'s instruction set.
#[cfg(target_arch = "x86_64")]
#[inline(always)]
unsafe fn residual_generic<V: Vf>(g: &Grid, p: &[f64], res: &mut [f64]) {
    let (nt, nz) = (g.nt, g.nz);
    if nt % V::W == 0 && nz >= 1 {
        // Whole rows from node 0 (session 40; see `residual_row_whole`).
        let n = nt * (nz + 1);
        assert!(p.len() >= n && res.len() >= n && g.ae.len() >= n && g.an.len() >= n);
        assert!(g.d.len() >= n && g.f.len() >= n && g.inv.len() >= n);
        let out = res.as_mut_ptr();
        for j in 1..nz {
            if j % 2 == 1 {
                residual_row_whole::<V, true>(g, p, out, j);
            } else {
                residual_row_whole::<V, false>(g, p, out, j);
            }
        }
        return;
    }
    for j in 1..nz {
        let row = j * nt;
        let cur = &p[row..row + nt];
        let r = Rows::of(g, &p[row - nt..row], &p[row + nt..row + 2 * nt], j);
        let out = &mut res[row..row + nt];
        let mut i = j % 2;
        if i == 1 {
            out[0] = 0.0;
        } else {
            out[0] = residual_node(&r, cur, 0, 1, nt - 1);
            out[1] = 0.0;
            i = 2;
        }
        while i + V::W < nt {
            residual_chunk::<V>(&r, cur, out, i);
            i += V::W;
        }
        while i + 1 < nt {
            out[i] = residual_node(&r, cur, i, i + 1, i - 1);
            out[i + 1] = 0.0;
            i += 2;
        }
        if i + 1 == nt {
            out[i] = residual_node(&r, cur, i, 0, i - 1);
        }
    }
}

/// The correction on `W` consecutive nodes `i..i + W`; returns the nodes' values before it
/// (`prev`: those before them, as [`relax_chunk`]), or after it where it was done node by
/// node. The zone test of node `k` reads node `k − 1` corrected; the lanes read it
/// uncorrected (no chain from chunk to chunk), which is the same test unless node `k − 1`'s
/// value changed sign (`> 0` or not): then the chunk is corrected node by node instead,
/// and the next chunk reads this one's last node corrected.
///
/// # Safety
/// As [`relax_chunk`].
#[cfg(target_arch = "x86_64")]
#[inline(always)]
unsafe fn correct_chunk<V: Vf, const TOP: bool, const HOLD0: bool>(
    r: &CorrRow,
    cur: &mut [f64],
    i: usize,
    prev: V,
) -> V {
    let top = TOP;
    let c = cur.as_mut_ptr().add(i);
    let (pk, e) = (V::load(c), V::load(c.add(1)));
    let w = V::shift_in(prev, pk);
    let ik = V::load(r.inv.as_ptr().add(i));
    let mut inside = V::and(pk.gt0(), V::and(e.gt0(), w.gt0()));
    if !r.last {
        inside = V::and(inside, V::load(r.north.as_ptr().add(i)).gt0());
    }
    if !r.first {
        inside = V::and(inside, V::load(r.south.as_ptr().add(i)).gt0());
    }
    let corrected = pk.add(V::load(r.v.as_ptr().add(i))).max0();
    let keep = if TOP && HOLD0 {
        V::zero()
    } else if TOP {
        V::load(r.hold.as_ptr().add(i))
    } else {
        pk
    };
    let val = V::select(ik.eq0(), keep, V::select(inside, corrected, pk));
    if V::any(V::xor(val.gt0(), pk.gt0())) {
        for k in i..i + V::W {
            correct_node(r, cur, k, k + 1, k - 1, top);
        }
        // Only the last lane is read (scalar stores, a scalar load: forwarded).
        V::splat(cur[i + V::W - 1])
    } else {
        val.store(c);
        pk
    }
}

/// [`interpolate_row`] for `ST = 2` in `V`'s lanes: the coarse columns `ic … ic + W − 1`
/// (not the last, whose east neighbour wraps) `W` at a time, the even and odd fine
/// columns interleaved by permutes; the rest by [`interpolate_row`]'s arithmetic.
///
/// # Safety
/// The CPU has `V`'s instruction set; `v` is `2 e0.len()` long and `e1` as long as `e0`.
#[cfg(target_arch = "x86_64")]
#[inline(always)]
unsafe fn interpolate_row_lanes<V: Vf>(e0: &[f64], e1: &[f64], jo: usize, v: &mut [f64]) {
    let cnt = e0.len();
    assert!(e1.len() == cnt && v.len() == 2 * cnt);
    let mut ic = 0;
    let half = V::splat(0.5);
    while ic + V::W < cnt {
        let (a, b) = (
            V::load(e0.as_ptr().add(ic)),
            V::load(e0.as_ptr().add(ic + 1)),
        );
        let (x, y) = if jo == 0 {
            (a, half.mul(a.add(b)))
        } else {
            let (c, d) = (
                V::load(e1.as_ptr().add(ic)),
                V::load(e1.as_ptr().add(ic + 1)),
            );
            (
                half.mul(a.add(c)),
                V::splat(0.25).mul(a.add(b).add(c).add(d)),
            )
        };
        let q = v.as_mut_ptr().add(2 * ic);
        V::zip_lo(x, y).store(q);
        V::zip_hi(x, y).store(q.add(V::W));
        ic += V::W;
    }
    for ic in ic..cnt {
        let ic1 = if ic + 1 == cnt { 0 } else { ic + 1 };
        let (a, b) = (e0[ic], e0[ic1]);
        let (x, y) = if jo == 0 {
            (a, 0.5 * (a + b))
        } else {
            let (c, d) = (e1[ic], e1[ic1]);
            (0.5 * (a + c), 0.25 * (a + b + c + d))
        };
        v[2 * ic] = x;
        v[2 * ic + 1] = y;
    }
}

/// Rows of the interpolated correction kept at a time by [`correct_generic`] (a ring).
const CORR_RING: usize = 4;
/// How many rows ahead of the row being corrected [`correct_generic`] interpolates: the
/// chunks' loads of a row just written (at other offsets) would wait for its stores; two
/// rows of correction later they are long written. Below [`CORR_RING`], so the row being
/// written is never one still to be read.
const CORR_AHEAD: usize = 2;

/// `prolong_correction_on` in `V`'s lanes: `e` the coarse correction `u_H − u₀` (`cnt`
/// per coarse row), `scratch` the interpolated correction of [`CORR_RING`] rows (a ring,
/// row `j` in slot `j mod CORR_RING`, written [`CORR_AHEAD`] rows ahead of the row
/// corrected). Session 40: it held every row of the fine grid, interpolated before the
/// first row was corrected: an array of the fine grid's size whose pages the first state
/// of a run faulted in (~2 µs each on the 2-core VM), for the same values.
///
/// # Safety
/// The CPU has `V`'s instruction set.
#[cfg(target_arch = "x86_64")]
#[inline(always)]
unsafe fn correct_generic<V: Vf, const ST: usize, const SZ: usize>(
    g: &Grid,
    p: &mut [f64],
    e: &[f64],
    cnt: usize,
    scratch: &mut Vec<f64>,
) {
    let (nt, top) = (g.nt, g.top);
    if scratch.len() < CORR_RING * nt {
        scratch.resize(CORR_RING * nt, 0.0);
    }
    let ring = &mut scratch[..CORR_RING * nt];
    // The grid's role and its holds as constants of the chunks' loop (session 40).
    match (top, top && g.hold_zero) {
        (true, true) => correct_rows::<V, ST, SZ, true, true>(g, p, e, cnt, ring),
        (true, false) => correct_rows::<V, ST, SZ, true, false>(g, p, e, cnt, ring),
        (false, _) => correct_rows::<V, ST, SZ, false, false>(g, p, e, cnt, ring),
    }
}

/// The interpolated correction of fine row `j` into its slot of the ring.
///
/// # Safety
/// The CPU has `V`'s instruction set.
#[cfg(target_arch = "x86_64")]
#[inline(always)]
unsafe fn interpolate_into<V: Vf, const ST: usize, const SZ: usize>(
    e: &[f64],
    cnt: usize,
    j: usize,
    ring: &mut [f64],
) {
    let nt = ring.len() / CORR_RING;
    let (jc, jo) = if SZ == 2 { (j / 2, j % 2) } else { (j, 0) };
    let crow = jc * cnt;
    let (e0, e1) = (&e[crow..crow + cnt], &e[crow + cnt..crow + 2 * cnt]);
    let slot = j % CORR_RING;
    let vrow = &mut ring[slot * nt..(slot + 1) * nt];
    if ST == 2 {
        interpolate_row_lanes::<V>(e0, e1, jo, vrow);
    } else {
        interpolate_row::<ST>(e0, e1, jo, vrow);
    }
}

/// The rows of [`correct_generic`]: `TOP` and `HOLD0` as [`relax_chunk`]'s.
///
/// # Safety
/// The CPU has `V`'s instruction set.
#[cfg(target_arch = "x86_64")]
#[inline(always)]
unsafe fn correct_rows<
    V: Vf,
    const ST: usize,
    const SZ: usize,
    const TOP: bool,
    const HOLD0: bool,
>(
    g: &Grid,
    p: &mut [f64],
    e: &[f64],
    cnt: usize,
    ring: &mut [f64],
) {
    let (nt, nz, top) = (g.nt, g.nz, TOP);
    for j in 1..(1 + CORR_AHEAD).min(nz) {
        interpolate_into::<V, ST, SZ>(e, cnt, j, ring);
    }
    for j in 1..nz {
        if j + CORR_AHEAD < nz {
            interpolate_into::<V, ST, SZ>(e, cnt, j + CORR_AHEAD, ring);
        }
        let slot = j % CORR_RING;
        let vrow = &ring[slot * nt..(slot + 1) * nt];
        let row = j * nt;
        let (below, rest) = p.split_at_mut(row);
        let (cur, above) = rest.split_at_mut(nt);
        let r = CorrRow {
            south: &below[row - nt..row],
            north: &above[..nt],
            inv: &g.inv[row..row + nt],
            hold: &g.hold[row..row + nt],
            hold0: HOLD0,
            v: vrow,
            first: j == 1,
            last: j + 1 == nz,
        };
        correct_node(&r, cur, 0, 1, nt - 1, top);
        let mut i = 1;
        let mut prev = V::splat(cur[0]);
        while i + V::W < nt {
            prev = correct_chunk::<V, TOP, HOLD0>(&r, cur, i, prev);
            i += V::W;
        }
        while i + 1 < nt {
            correct_node(&r, cur, i, i + 1, i - 1, top);
            i += 1;
        }
        if nt > 1 {
            correct_node(&r, cur, nt - 1, 0, nt - 2, top);
        }
    }
}

/// The coarse grid of a restriction: its operator (a [`Grid`] of `cnt × cnz`) and the
/// arrays it writes.
pub(super) struct Coarse<'a> {
    /// The coarse operator (its `f` and `hold` unused).
    pub g: Grid<'a>,
    /// Injected fine iterate `u₀`.
    pub base: &'a mut [f64],
    /// Coarse iterate (set to `u₀`).
    pub p: &'a mut [f64],
    /// FAS right-hand side written.
    pub f: &'a mut [f64],
}

/// The scalar FAS right-hand side at coarse node `ic` of a row (`restrict_fas_on`'s loop
/// body): `rs, rc, rn` the fine residual rows south, at and north of it, `u*` the coarse
/// `u₀` rows, `r` the coarse operator's row.
#[inline(always)]
#[allow(clippy::too_many_arguments)]
fn restrict_node<const ST: usize, const SZ: usize>(
    rs: &[f64],
    rc: &[f64],
    rn: &[f64],
    r: &Rows,
    uc: &[f64],
    ic: usize,
    ip: usize,
    iw: usize,
) -> f64 {
    if r.inv[ic] == 0.0 {
        return 0.0;
    }
    let fnt = rc.len();
    let i0 = ic * ST;
    let im = if i0 == 0 { fnt - 1 } else { i0 - 1 };
    let along = |x: &[f64]| {
        if ST == 2 {
            0.25 * x[im] + 0.5 * x[i0] + 0.25 * x[i0 + 1]
        } else {
            x[i0]
        }
    };
    let rr = if SZ == 2 {
        0.25 * along(rs) + 0.5 * along(rc) + 0.25 * along(rn)
    } else {
        along(rc)
    };
    let s = r.ae[ic] * uc[ip]
        + r.ae[iw] * uc[iw]
        + r.an[ic] * r.north[ic]
        + r.an_south[ic] * r.south[ic];
    rr + (r.d[ic] * uc[ic] - s)
}

/// The fine residual's weighted θ-stencil at the fine columns `2 (i + l)` (`ST = 2`) or
/// `i + l` of row `x`, lanes `l`.
///
/// # Safety
/// The CPU has `V`'s instruction set; the columns read (`ST · i − 1 … ST · (i + W)`) are in
/// the row.
#[cfg(target_arch = "x86_64")]
#[inline(always)]
unsafe fn along_lanes<V: Vf, const ST: usize>(x: &[f64], i: usize) -> V {
    let q = x.as_ptr();
    if ST == 2 {
        let (a, b) = (V::load(q.add(2 * i)), V::load(q.add(2 * i + V::W)));
        let (am, bm) = (V::load(q.add(2 * i - 1)), V::load(q.add(2 * i - 1 + V::W)));
        let (c, e, w) = (V::evens(a, b), V::odds(a, b), V::evens(am, bm));
        let h = V::splat(0.25);
        h.mul(w).add(V::splat(0.5).mul(c)).add(h.mul(e))
    } else {
        V::load(q.add(i))
    }
}

/// `restrict_fas_on` in `V`'s lanes: the injection `u₀` of the fine iterate `p` and the
/// FAS right-hand side from the fine residual `res` (`fnt` per fine row).
///
/// # Safety
/// The CPU has `V`'s instruction set.
#[cfg(target_arch = "x86_64")]
#[inline(always)]
#[allow(clippy::needless_range_loop)] // one index across several row slices
unsafe fn restrict_generic<V: Vf, const ST: usize, const SZ: usize>(
    p: &[f64],
    res: &[f64],
    fnt: usize,
    c: &mut Coarse,
) {
    let (cnt, cnz) = (c.g.nt, c.g.nz);
    for jc in 0..=cnz {
        let (frow, crow) = (jc * SZ * fnt, jc * cnt);
        let src = &p[frow..frow + fnt];
        let (base, cp) = (&mut c.base[crow..crow + cnt], &mut c.p[crow..crow + cnt]);
        if ST == 2 {
            let mut ic = 0;
            while ic + V::W <= cnt {
                let q = src.as_ptr().add(2 * ic);
                let v = V::evens(V::load(q), V::load(q.add(V::W)));
                v.store(base.as_mut_ptr().add(ic));
                v.store(cp.as_mut_ptr().add(ic));
                ic += V::W;
            }
            for ic in ic..cnt {
                let v = src[2 * ic];
                base[ic] = v;
                cp[ic] = v;
            }
        } else {
            base.copy_from_slice(&src[..cnt]);
            cp.copy_from_slice(&src[..cnt]);
        }
    }
    let u: &[f64] = c.base;
    let out = &mut *c.f;
    out[..cnt].fill(0.0);
    out[cnz * cnt..(cnz + 1) * cnt].fill(0.0);
    for jc in 1..cnz {
        let jf = jc * SZ;
        let crow = jc * cnt;
        let rc = &res[jf * fnt..(jf + 1) * fnt];
        let (rs, rn) = if SZ == 2 {
            (
                &res[(jf - 1) * fnt..jf * fnt],
                &res[(jf + 1) * fnt..(jf + 2) * fnt],
            )
        } else {
            (rc, rc)
        };
        let uc = &u[crow..crow + cnt];
        let r = Rows::of(
            &c.g,
            &u[crow - cnt..crow],
            &u[crow + cnt..crow + 2 * cnt],
            jc,
        );
        let outr = &mut out[crow..crow + cnt];
        outr[0] = restrict_node::<ST, SZ>(rs, rc, rn, &r, uc, 0, 1 % cnt, cnt - 1);
        let mut ic = 1;
        while ic + V::W < cnt {
            let rr = if SZ == 2 {
                let q = V::splat(0.25);
                q.mul(along_lanes::<V, ST>(rs, ic))
                    .add(V::splat(0.5).mul(along_lanes::<V, ST>(rc, ic)))
                    .add(q.mul(along_lanes::<V, ST>(rn, ic)))
            } else {
                along_lanes::<V, ST>(rc, ic)
            };
            let k = uc.as_ptr().add(ic);
            let (u0, ue, uw) = (V::load(k), V::load(k.add(1)), V::load(k.sub(1)));
            let (ae, aw) = (
                V::load(r.ae.as_ptr().add(ic)),
                V::load(r.ae.as_ptr().add(ic - 1)),
            );
            let (an, un) = (
                V::load(r.an.as_ptr().add(ic)),
                V::load(r.north.as_ptr().add(ic)),
            );
            let (ans, us) = (
                V::load(r.an_south.as_ptr().add(ic)),
                V::load(r.south.as_ptr().add(ic)),
            );
            let (d, ik) = (
                V::load(r.d.as_ptr().add(ic)),
                V::load(r.inv.as_ptr().add(ic)),
            );
            let s = ae.mul(ue).add(aw.mul(uw)).add(an.mul(un)).add(ans.mul(us));
            let v = rr.add(d.mul(u0).sub(s));
            V::select(ik.eq0(), V::zero(), v).store(outr.as_mut_ptr().add(ic));
            ic += V::W;
        }
        for ic in ic.max(1)..cnt {
            let ip = if ic + 1 == cnt { 0 } else { ic + 1 };
            outr[ic] = restrict_node::<ST, SZ>(rs, rc, rn, &r, uc, ic, ip, ic - 1);
        }
    }
}

/// The coarse solution interpolated to a fine grid (`prolong_solution_on`: bilinear, the
/// accuracy ladder's start) in `V`'s lanes: `out` the fine iterate, rows `1..nz` written,
/// held nodes (`inv == 0`) at `hold` (`+0` without reading it where `hold_zero`), the rest
/// projected; `cp` the coarse iterate (`cnt` per row).
///
/// # Safety
/// The CPU has `V`'s instruction set.
#[cfg(target_arch = "x86_64")]
#[inline(always)]
#[allow(clippy::too_many_arguments)]
unsafe fn prolong_generic<V: Vf, const ST: usize, const SZ: usize>(
    out: &mut [f64],
    inv: &[f64],
    hold: &[f64],
    hold_zero: bool,
    nt: usize,
    nz: usize,
    cp: &[f64],
    cnt: usize,
) {
    for j in 1..nz {
        let (jc, jo) = if SZ == 2 { (j / 2, j % 2) } else { (j, 0) };
        let c0 = &cp[jc * cnt..(jc + 1) * cnt];
        let c1 = if jo == 1 {
            &cp[(jc + 1) * cnt..(jc + 2) * cnt]
        } else {
            c0
        };
        let row = j * nt;
        let (o, ir, hr) = (
            &mut out[row..row + nt],
            &inv[row..row + nt],
            &hold[row..row + nt],
        );
        assert!(ST * cnt <= nt);
        let put_lanes = |o: &mut [f64], k: usize, v: V| {
            let ik = V::load(ir.as_ptr().add(k));
            let held = if hold_zero {
                V::zero()
            } else {
                V::load(hr.as_ptr().add(k))
            };
            V::select(ik.eq0(), held, v.max0()).store(o.as_mut_ptr().add(k));
        };
        let half = V::splat(0.5);
        let mut ic = 0;
        while ic + V::W < cnt {
            let a = V::load(c0.as_ptr().add(ic));
            if ST == 2 {
                let b = V::load(c0.as_ptr().add(ic + 1));
                let (x, y) = if jo == 0 {
                    (a, half.mul(a.add(b)))
                } else {
                    let (c, d) = (
                        V::load(c1.as_ptr().add(ic)),
                        V::load(c1.as_ptr().add(ic + 1)),
                    );
                    (
                        half.mul(a.add(c)),
                        V::splat(0.25).mul(a.add(b).add(c).add(d)),
                    )
                };
                put_lanes(o, 2 * ic, V::zip_lo(x, y));
                put_lanes(o, 2 * ic + V::W, V::zip_hi(x, y));
            } else {
                let x = if jo == 0 {
                    a
                } else {
                    half.mul(a.add(V::load(c1.as_ptr().add(ic))))
                };
                put_lanes(o, ic, x);
            }
            ic += V::W;
        }
        // The rest as the scalar pass.
        let put = |o: &mut [f64], i: usize, v: f64| {
            o[i] = if ir[i] != 0.0 {
                v.max(0.0)
            } else if hold_zero {
                0.0
            } else {
                hr[i]
            };
        };
        for ic in ic..cnt {
            let ic1 = if ic + 1 == cnt { 0 } else { ic + 1 };
            let (a, b) = (c0[ic], c0[ic1]);
            if jo == 0 {
                put(o, ST * ic, a);
                if ST == 2 {
                    put(o, 2 * ic + 1, 0.5 * (a + b));
                }
            } else {
                let (c, d) = (c1[ic], c1[ic1]);
                put(o, ST * ic, 0.5 * (a + c));
                if ST == 2 {
                    put(o, 2 * ic + 1, 0.25 * (a + b + c + d));
                }
            }
        }
    }
}

/// A pass `$name(isa, args…) -> bool` running `$generic` in AVX-512F or AVX2 lanes where
/// `isa` names one the CPU has (true), else nothing (false: the caller runs the scalar
/// pass).
macro_rules! dispatch {
    ($(#[$m:meta])* $name:ident, $generic:ident, [$($cg:ident),*], ($($a:ident: $t:ty),*)) => {
        $(#[$m])*
        // The pass's own arguments plus the instruction set: as many as the scalar pass takes.
        #[allow(clippy::too_many_arguments)]
        pub(super) fn $name<$(const $cg: usize),*>(isa: LaneIsa, $($a: $t),*) -> bool {
            #[cfg(target_arch = "x86_64")]
            {
                #[target_feature(enable = "avx512f")]
                unsafe fn wide<$(const $cg: usize),*>($($a: $t),*) {
                    $generic::<simd::Avx512, $($cg),*>($($a),*)
                }
                #[target_feature(enable = "avx2")]
                unsafe fn narrow<$(const $cg: usize),*>($($a: $t),*) {
                    $generic::<simd::Avx2, $($cg),*>($($a),*)
                }
                match isa {
                    LaneIsa::Avx512 if std::arch::is_x86_feature_detected!("avx512f") => {
                        // SAFETY: the CPU has AVX-512F (checked just above).
                        unsafe { wide::<$($cg),*>($($a),*) };
                        return true;
                    }
                    LaneIsa::Avx2 if std::arch::is_x86_feature_detected!("avx2") => {
                        // SAFETY: the CPU has AVX2 (checked just above).
                        unsafe { narrow::<$($cg),*>($($a),*) };
                        return true;
                    }
                    _ => {}
                }
            }
            let _ = ($($a),*);
            false
        }
    };
}

dispatch!(
    /// [`smooth_generic`] on `isa`; false (nothing done) on the baseline: the caller runs
    /// the scalar sweep.
    smooth, smooth_generic, [], (g: &Grid, p: &mut [f64])
);
dispatch!(
    /// [`residual_generic`] on `isa`; false (nothing done) on the baseline.
    residual, residual_generic, [], (g: &Grid, p: &[f64], res: &mut [f64])
);
dispatch!(
    /// [`correct_generic`] on `isa` for the strides `ST`, `SZ`; false (nothing done) on the
    /// baseline.
    correct, correct_generic, [ST, SZ],
    (g: &Grid, p: &mut [f64], e: &[f64], cnt: usize, scratch: &mut Vec<f64>)
);
dispatch!(
    /// [`restrict_generic`] on `isa` for the strides `ST`, `SZ`; false (nothing done) on the
    /// baseline.
    restrict, restrict_generic, [ST, SZ],
    (p: &[f64], res: &[f64], fnt: usize, c: &mut Coarse)
);
dispatch!(
    /// [`prolong_generic`] on `isa` for the strides `ST`, `SZ`; false (nothing done) on the
    /// baseline.
    prolong, prolong_generic, [ST, SZ],
    (out: &mut [f64], inv: &[f64], hold: &[f64], hold_zero: bool, nt: usize, nz: usize, cp: &[f64], cnt: usize)
);
