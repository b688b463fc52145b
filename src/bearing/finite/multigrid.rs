//! Projected full-approximation multigrid for the Swift–Stieber complementarity problem
//! (issue 20; docs/finite-film.md "Solver").
//!
//! The discrete problem on each grid is the LCP `p ≥ 0, A p − f ≥ 0, pᵀ(A p − f) = 0` with
//! `A` the five-point finite-volume operator of [`super::solver`] (an M-matrix: diagonal
//! `d`, off-diagonals `−a`), `f = −rhs`. One V-cycle on level `l`:
//!
//! 1. `NU_PRE` red-black projected Gauss–Seidel sweeps (the smoother);
//! 2. the residual `r = f − A p`, set to zero where the constraint is active
//!    (`p = 0`, `r < 0`: those nodes are solved, their residual is the contact force),
//!    computed on the sweep's first colour (the second's is zero after the sweep);
//! 3. FAS coarse problem (Brandt–Cryer): `u₀ = inject(p)`, `f_H = A_H u₀ + R r` (full
//!    weighting), constraint `u_H ≥ 0`, solved by a V-cycle on level `l − 1`;
//! 4. correction `p ← max(0, p + P(u_H − u₀))` (bilinear `P`) at the nodes inside the
//!    pressure zone only (node and four neighbours positive: a truncated correction;
//!    the free boundary is left to the smoother), held nodes kept at 0; coarse nodes
//!    where the fine grid holds its pressure are frozen at `u₀` (see `freeze`: one
//!    node per row for the inlet line, the stencil's reach for grooves and arcs);
//! 5. `NU_POST` smoothing sweeps.
//!
//! Optionally ([`MgCycle`], explicit grids; issue 20 session 37, not the default) the
//! smoother is zebra line relaxation along ζ on the grids where ζ is the strong direction,
//! each line's complementarity problem solved exactly ([`line_lcp`]), and the sweeps per
//! cycle are set (e.g. V(2,0)).
//!
//! Coarsening halves both directions where the grid's couplings `cθ = λ/Δθ²` and
//! `cz = 1/Δζ²` are within a factor [`ANISOTROPY`] of each other, else only the strongly
//! coupled one (semi-coarsening keeps point smoothing effective for short and long
//! bearings). The coarsest grid is solved by projected SOR (inside a V-cycle to
//! [`COARSEST_CORRECTION`] of the coarse-grid correction, see [`CoarsestSolve`]).
//!
//! Full multigrid: each grid starts from the interpolation of the next coarser
//! solution (cubic on explicit grids, [`prolong_solution_cubic`]; bilinear on the accuracy
//! ladder, [`prolong_solution`]), so a solve from cold costs a few V-cycles of the finest grid, linear in the
//! node count, and passes through every coarser grid's solution (the nested solutions the
//! accuracy control of [`super::solver`] extrapolates from).

use std::f64::consts::PI;

use super::lanes;
use super::pages;
use super::solver::{FiniteGrid, FiniteJob};
use crate::bearing::FilmLayout;
use crate::bearing::LaneIsa;

/// Smoothing sweeps before the coarse-grid correction.
const NU_PRE: u32 = 2;
/// Smoothing sweeps after the coarse-grid correction.
const NU_POST: u32 = 1;
/// Couplings within this factor of each other: coarsen both directions.
const ANISOTROPY: f64 = 4.0;
/// Largest number of interior nodes solved by projected SOR as the coarsest grid without
/// further coarsening being attempted.
const COARSEST_NODES: usize = 64;
/// Sweep limit of the coarsest-grid projected SOR.
const COARSEST_SWEEPS: u32 = 4000;
/// The coarsest grid's solve inside a V-cycle ends when its estimated remaining change is
/// below this fraction of the coarse-grid correction's largest value `max |u_H − u₀|`
/// (issue 20, session 38; was 1e-12 of the field's largest value). The cycle contracts
/// the error by ~0.1-0.25, so a correction good to 10 % costs it nothing measurable
/// (`zeta_probe prof`, `mg_equal_error table` with `corr:0.03`, `corr:0.01`: the same
/// cycles); the solve takes ~3 sweeps instead of 10-18. Dimensionless.
pub(crate) const COARSEST_CORRECTION: f64 = 0.1;

/// How a grid was coarsened into the next coarser one.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Coarsen {
    /// Both directions halved.
    Both,
    /// Only θ halved.
    Theta,
    /// Only ζ halved.
    Zeta,
}

/// One row of a level for the relaxation: the row's coefficients and the field's rows
/// south and north of it (see [`Level::relax`]).
struct RowRef<'a> {
    south: &'a [f64],
    north: &'a [f64],
    ae: &'a [f64],
    an: &'a [f64],
    an_south: &'a [f64],
    f: &'a [f64],
    inv: &'a [f64],
    hold: &'a [f64],
}

impl RowRef<'_> {
    /// The projected Gauss–Seidel update of node `i` of the row (`ip`, `im`: its east and
    /// west neighbours in `cur`, the row's field) at factor `omega`: `Some((old, new))`
    /// where the node is relaxed or held (`top`), `None` where it is frozen.
    #[inline(always)]
    fn update(
        &self,
        cur: &mut [f64],
        i: usize,
        ip: usize,
        im: usize,
        omega: f64,
        top: bool,
    ) -> Option<(f64, f64)> {
        let ik = self.inv[i];
        let old = cur[i];
        if ik == 0.0 {
            // Held (solved grid): its value (0 at the inlet); frozen on a correction grid
            // (next to a held fine node): unchanged.
            if top {
                cur[i] = self.hold[i];
                return Some((old, self.hold[i]));
            }
            return None;
        }
        let s = self.ae[i] * cur[ip]
            + self.ae[im] * cur[im]
            + self.an[i] * self.north[i]
            + self.an_south[i] * self.south[i];
        let new = (old + omega * ((s + self.f[i]) * ik - old)).max(0.0);
        cur[i] = new;
        Some((old, new))
    }
}

/// One row of a level for the residual (see [`Level::residual`]).
struct ResidualRow<'a> {
    south: &'a [f64],
    cur: &'a [f64],
    north: &'a [f64],
    ae: &'a [f64],
    an: &'a [f64],
    an_south: &'a [f64],
    d: &'a [f64],
    f: &'a [f64],
    inv: &'a [f64],
}

impl ResidualRow<'_> {
    /// `f − A p` at node `i` of the row (`ip`, `im`: east and west), 0 where held or frozen
    /// and where the constraint is active.
    #[inline(always)]
    fn at(&self, i: usize, ip: usize, im: usize) -> f64 {
        if self.inv[i] == 0.0 {
            return 0.0;
        }
        let pk = self.cur[i];
        let v = self.f[i] - self.d[i] * pk
            + self.ae[i] * self.cur[ip]
            + self.ae[im] * self.cur[im]
            + self.an[i] * self.north[i]
            + self.an_south[i] * self.south[i];
        if pk <= 0.0 && v < 0.0 {
            0.0
        } else {
            v
        }
    }
}

/// One grid of the hierarchy with its operator, right-hand sides and iterate.
#[derive(Default)]
pub(crate) struct Level {
    pub nt: usize,
    pub nz: usize,
    /// East-face coefficient of node k (between θ_i and θ_{i+1}).
    ae: Vec<f64>,
    /// North-face coefficient of node k (between ζ_j and ζ_{j+1}).
    an: Vec<f64>,
    /// Diagonal of `A` (sum of the four face coefficients).
    d: Vec<f64>,
    /// Inverse diagonal; 0 at held nodes (the inlet, grooves, gaps between arcs), which
    /// the smoother keeps at their `hold` value.
    inv_d: Vec<f64>,
    /// Held value of each held node (0 elsewhere and at the inlet).
    hold: Vec<f64>,
    /// Whether `hold` is known to be 0 everywhere (set up for a film without held bands):
    /// [`Level::setup`] then leaves it as it is (issue 20, session 39: a store per node
    /// and state, the same zeros).
    hold_zero: bool,
    /// Inverse diagonal as a correction grid: its own inlet column is not held (it
    /// differs from the fine grid's; held, it would feed a correction `0 − u₀` back even
    /// at the fine solution); nodes next to a held fine node are frozen at `u₀` (0 here,
    /// skipped by the smoother). Sized and written inside by [`freeze`] (at each
    /// [`Hierarchy::iterate`]) before any cycle reads it (no pass reads its end rows):
    /// the finest grid, never a correction grid, has none (issue 20, session 39).
    inv_d_free: Vec<f64>,
    /// Whether this grid is the one being solved (holds apply) or a correction grid.
    top: bool,
    /// This grid's own right-hand side `f = −rhs` (when it is the finest grid solved).
    f_own: Vec<f64>,
    /// The FAS right-hand side as a coarse grid (written by a finer grid's restriction).
    f: Vec<f64>,
    /// Whether the right-hand side in use is `f_own` (set up, or made the grid solved by
    /// [`Hierarchy::iterate`]) or `f` (cleared when a finer grid's restriction writes
    /// `f`): every reader picks by it. Before issue 20 session 39 `f` was always the one in use,
    /// written as a copy of `f_own` by `setup` (a store per node and state) and copied
    /// back by `iterate`: the same values.
    f_is_own: bool,
    /// Iterate.
    pub p: Vec<f64>,
    /// Injected fine iterate `u₀` (as a coarse grid) / scratch.
    base: Vec<f64>,
    /// Residual scratch.
    r: Vec<f64>,
    /// Relationship to the next coarser level (None: coarsest).
    pub coarsen: Option<Coarsen>,
    /// Per row: the column held on the maximum-film line when this grid is solved
    /// (`usize::MAX`: none).
    inlet_col: Vec<usize>,
    /// Per row: as a correction grid, the column frozen for the finer grid's inlet line
    /// (see [`freeze`]; `usize::MAX`: none).
    inlet_corr: Vec<usize>,
    /// Per row: `(εx, εy, angle)` of the maximum-film line as [`Level::setup`] last found
    /// it (NaN angle: none), and the `theta0` it was found for: a finer grid's row with
    /// the same `(εx, εy)` bits and `theta0` takes the angle instead of an `atan2` (issue
    /// 20, session 39: the same bits, half the `atan2` calls of a hierarchy).
    inlet_angles: Vec<(f64, f64, f64)>,
    inlet_theta0: u64,
    /// `(cos, sin)` of the half-node angles (see [`Level::set_trig`]).
    trig: Vec<(f64, f64)>,
    /// `(cos, sin)` of the column angles (the even entries of `trig`).
    cols: Vec<(f64, f64)>,
    /// `(n_theta, bits of the angle of node 0)` of `trig` (`n_theta` 0: none yet).
    trig_of: (usize, u64),
    /// Scratch of [`freeze`]: per column of the finer grid, a held node in reach.
    held_cols: Vec<bool>,
    /// Whether ζ is the strongly coupled direction on this grid (`1/Δζ² > λ/Δθ²`): the
    /// line smoother ([`Level::smooth_lines`]) relaxes lines along ζ only then.
    z_strong: bool,
    /// Scratch of one ζ-line (see [`LineScratch`]): the lines solved again.
    line: LineScratch,
    /// Scratch of [`Level::smooth_lines`] per node: forward-elimination factors, the
    /// line's right-hand side, the start's active set.
    cp: Vec<f64>,
    dp: Vec<f64>,
    bl: Vec<f64>,
    act: Vec<bool>,
    /// Scratch of [`Level::smooth_lines`] per column: solved again by [`line_lcp`].
    dirty: Vec<bool>,
    /// Scratch of the lanes' correction ([`lanes::correct`]): the interpolated
    /// correction of a few rows at a time (a ring; every node's before session 40).
    lane_row: Vec<f64>,
}

impl Level {
    fn len(&self) -> usize {
        self.nt * (self.nz + 1)
    }

    fn interior(&self) -> usize {
        self.nt * (self.nz.max(1) - 1)
    }

    /// Discretises the job's Reynolds equation on an `nt × nz` grid (the same
    /// discretisation as the PSOR solver's, see [`super::solver`]).
    /// `theta0`: angle of node 0, rad (0 on explicit grids; the accuracy ladder puts a
    /// node on the maximum film so the inlet line is on the grid at every level).
    /// `layout`: the grooves and arcs, held at their pressures (Shortley–Weller faces at
    /// their edges, see [`FilmLayout::held_nodes`]).
    /// `coarser`: the level below in the same hierarchy, whose angle table this grid's
    /// shares (see [`Level::set_trig`]); `zero_iterate`: the iterate set to 0 inside too
    /// (else only on the end rows: see [`Hierarchy::push_finer`]).
    // The grid, its film and its place in the hierarchy: one call per grid and state.
    #[allow(clippy::too_many_arguments)]
    pub fn setup(
        &mut self,
        job: &FiniteJob,
        nt: usize,
        nz: usize,
        max_film_inlet: bool,
        layout: &FilmLayout,
        theta0: f64,
        coarser: Option<&Level>,
        zero_iterate: bool,
    ) {
        // The same body compiled for AVX-512F or AVX2 where the CPU has them (issue 20,
        // session 38): the compiler evaluates its per-node loops (film, faces, diagonal,
        // `1/d`) in wider registers; no fused multiply-add, so the same bits.
        #[cfg(target_arch = "x86_64")]
        {
            #[target_feature(enable = "avx512f")]
            #[allow(clippy::too_many_arguments)]
            fn wide(
                l: &mut Level,
                job: &FiniteJob,
                nt: usize,
                nz: usize,
                max_film_inlet: bool,
                layout: &FilmLayout,
                theta0: f64,
                coarser: Option<&Level>,
                zero_iterate: bool,
            ) {
                l.setup_body(
                    job,
                    nt,
                    nz,
                    max_film_inlet,
                    layout,
                    theta0,
                    coarser,
                    zero_iterate,
                )
            }
            #[target_feature(enable = "avx2")]
            #[allow(clippy::too_many_arguments)]
            fn narrow(
                l: &mut Level,
                job: &FiniteJob,
                nt: usize,
                nz: usize,
                max_film_inlet: bool,
                layout: &FilmLayout,
                theta0: f64,
                coarser: Option<&Level>,
                zero_iterate: bool,
            ) {
                l.setup_body(
                    job,
                    nt,
                    nz,
                    max_film_inlet,
                    layout,
                    theta0,
                    coarser,
                    zero_iterate,
                )
            }
            match lanes::isa() {
                LaneIsa::Avx512 if std::arch::is_x86_feature_detected!("avx512f") => {
                    // SAFETY: the CPU has AVX-512F (checked just above).
                    return unsafe {
                        wide(
                            self,
                            job,
                            nt,
                            nz,
                            max_film_inlet,
                            layout,
                            theta0,
                            coarser,
                            zero_iterate,
                        )
                    };
                }
                LaneIsa::Avx2 if std::arch::is_x86_feature_detected!("avx2") => {
                    // SAFETY: the CPU has AVX2 (checked just above).
                    return unsafe {
                        narrow(
                            self,
                            job,
                            nt,
                            nz,
                            max_film_inlet,
                            layout,
                            theta0,
                            coarser,
                            zero_iterate,
                        )
                    };
                }
                _ => {}
            }
        }
        self.setup_body(
            job,
            nt,
            nz,
            max_film_inlet,
            layout,
            theta0,
            coarser,
            zero_iterate,
        )
    }

    /// [`Level::setup`]'s body, for each instruction set.
    #[inline(always)]
    #[allow(clippy::too_many_arguments)]
    fn setup_body(
        &mut self,
        job: &FiniteJob,
        nt: usize,
        nz: usize,
        max_film_inlet: bool,
        layout: &FilmLayout,
        theta0: f64,
        coarser: Option<&Level>,
        zero_iterate: bool,
    ) {
        self.nt = nt;
        self.nz = nz;
        let n = self.len();
        let dt = 2.0 * PI / nt as f64;
        let dz = 1.0 / nz as f64;
        let ct = job.aspect * job.aspect / (dt * dt);
        let cz = 1.0 / (dz * dz);
        self.z_strong = cz > ct;
        let e = &job.state.ecc;
        let r = &job.state.rate;
        // Resized, not zeroed (issue 20, session 36: zeroing was 10 % of a default-accuracy
        // solve's instructions): the operator's arrays are written in full below, and the
        // scratch `base` and `r` are written before they are read (restriction, residual,
        // correction, cubic start).
        // The holds, when they must grow: a zeroed allocation (`calloc`), whose fresh
        // pages the system maps as they are first read, without writing them as
        // `resize` does; a film without held bands only reads them (issue 20, session
        // 39: a run's first state faulted them in by the writes).
        // Known to be `+0` then (session 40: the first state's setup wrote them, as
        // `hold_zero` was not yet set, and so faulted their pages in after all).
        let mut hold_zero = self.hold_zero;
        if self.hold.capacity() < n {
            self.hold = vec![0.0; n];
            hold_zero = true;
        }
        // The arrays that must grow (a process's or a thread's first state on this grid),
        // grown first and their fresh pages mapped in one call before the writes below
        // (issue 20, session 42: otherwise a page fault per 4 KiB as `resize` writes its
        // zeros, ~2 µs each on the 2-core VM, ~0.2 ms of a 128 × 32 hierarchy's first
        // state; see `pages`). Grown exactly as `resize` grows them, in the same order:
        // the same allocations at the same places (the arrays' relative offsets set how
        // they share cache sets: a different order measured 4 % slower in steady state).
        let mut fresh = [(0, 0); 8];
        let mut grown = 0;
        for v in [
            &mut self.ae,
            &mut self.an,
            &mut self.d,
            &mut self.inv_d,
            &mut self.f_own,
            &mut self.base,
            &mut self.r,
            &mut self.p,
        ] {
            if v.capacity() < n {
                v.reserve(n - v.len());
                fresh[grown] = pages::range_of(v);
                grown += 1;
            }
        }
        if grown > 0 {
            pages::populate(&mut fresh[..grown]);
        }
        for v in [
            &mut self.ae,
            &mut self.an,
            &mut self.d,
            &mut self.inv_d,
            &mut self.hold,
            &mut self.f_own,
            &mut self.base,
            &mut self.r,
            &mut self.p,
        ] {
            v.resize(n, 0.0);
        }
        // Sized where first written, not here (issue 20, session 39: each array is a
        // store per node when first allocated, and the first state of a run pays its
        // pages): the FAS right-hand side `f` by the restriction onto this grid, the line
        // smoother's scratch by `Level::smooth_lines`.
        self.f_is_own = true;
        // The iterate: 0 on the end rows always (every cycle reads them), inside only
        // when `zero_iterate` (see [`Hierarchy::push_finer`]).
        if zero_iterate {
            self.p.fill(0.0);
        } else {
            self.p[..nt].fill(0.0);
            self.p[nz * nt..].fill(0.0);
        }
        self.set_trig(theta0, coarser);
        // The held bands' face factors and pressures; none for the plain 360° film (factor
        // 1, exact, and no three arrays of the grid's size to allocate and fill).
        let held = (!layout.is_empty()).then(|| layout.held_nodes(nt, nz, theta0));
        // The holds are all 0 without held bands: written only when not already so.
        let write_hold = held.is_some() || !hold_zero;
        self.inlet_col.clear();
        self.inlet_col.resize(nz + 1, usize::MAX);
        self.inlet_corr.clear();
        self.inlet_corr.resize(nz + 1, usize::MAX);
        // The coarser grid's inlet angles, by its row at this row's ζ where there is one.
        let below = coarser
            .filter(|c| max_film_inlet && c.inlet_theta0 == theta0.to_bits() && c.nz > 0)
            .filter(|c| c.inlet_angles.len() == c.nz + 1 && nz.is_multiple_of(c.nz));
        self.inlet_angles.clear();
        self.inlet_angles.resize(nz + 1, (0.0, 0.0, f64::NAN));
        self.inlet_theta0 = theta0.to_bits();
        let trig = &self.trig;
        // Row by row on slices (no index checks per node; issue 20, session 36: ~130
        // instructions per node before); the held bands' face factors and holds applied
        // afterwards to the stored values, the same products in the same order.
        for j in 0..=nz {
            let zeta = j as f64 * dz;
            let zh = (j as f64 + 0.5) * dz;
            let a = r[0] + (r[2] - r[0]) * zeta;
            let b = r[1] + (r[3] - r[1]) * zeta;
            // The end eccentricities interpolated once per row, on the row (east faces)
            // and half a row north (north faces): `solver::film`'s arithmetic, the same bits.
            let ex = e[0] + (e[2] - e[0]) * zeta;
            let ey = e[1] + (e[3] - e[1]) * zeta;
            let exh = e[0] + (e[2] - e[0]) * zh;
            let eyh = e[1] + (e[3] - e[1]) * zh;
            let row = j * nt;
            let rows = row..row + nt;
            {
                let ae = &mut self.ae[rows.clone()];
                let an = &mut self.an[rows.clone()];
                let f_own = &mut self.f_own[rows.clone()];
                // Node angle at 2i, east face at 2i + 1.
                for (((ae, an), fo), t) in ae
                    .iter_mut()
                    .zip(an.iter_mut())
                    .zip(f_own.iter_mut())
                    .zip(trig.chunks_exact(2))
                {
                    let ((cn, sn), (cf, sf)) = (t[0], t[1]);
                    let hf = 1.0 - ex * cf - ey * sf;
                    *ae = ct * hf * hf * hf;
                    let hn = 1.0 - exh * cn - eyh * sn;
                    *an = cz * hn * hn * hn;
                    *fo = -6.0 * (a * sn - b * cn);
                }
                // No face north of the last row.
                if j == nz {
                    for v in an.iter_mut() {
                        *v = 0.0;
                    }
                }
                if let Some(h) = &held {
                    for (v, w) in ae.iter_mut().zip(&h.east[rows.clone()]) {
                        *v *= w;
                    }
                    if j < nz {
                        for (v, w) in an.iter_mut().zip(&h.north[rows.clone()]) {
                            *v *= w;
                        }
                    }
                }
            }
            // The diagonal of this row (the row south of it is complete): 0 on the end
            // rows, whose nodes are not unknowns.
            if j == 0 || j == nz {
                // One loop of stores, not several `memset`s (see above).
                for (d, i) in self.d[rows.clone()]
                    .iter_mut()
                    .zip(&mut self.inv_d[rows.clone()])
                {
                    (*d, *i) = (0.0, 0.0);
                }
                if write_hold {
                    self.hold[rows.clone()].fill(0.0);
                }
                continue;
            }
            {
                let ae = &self.ae[rows.clone()];
                let an = &self.an[rows.clone()];
                let an_s = &self.an[row - nt..row];
                let d = &mut self.d[rows.clone()];
                // West face of column 0: column nt − 1's east face (periodic).
                d[0] = ae[0] + ae[nt - 1] + an[0] + an_s[0];
                for ((((d, e), w), n), s) in d[1..]
                    .iter_mut()
                    .zip(&ae[1..])
                    .zip(&ae[..nt - 1])
                    .zip(&an[1..])
                    .zip(&an_s[1..])
                {
                    *d = e + w + n + s;
                }
                let inv_d = &mut self.inv_d[rows.clone()];
                let hold = &mut self.hold[rows.clone()];
                // `inv_d_free` inside: written by `freeze` before the grid serves as a
                // correction grid (issue 20, session 39: it was `1/d` here, a store per
                // node and state that `freeze` overwrote or no one read).
                for (d, i) in d.iter().zip(inv_d.iter_mut()) {
                    *i = 1.0 / d;
                }
                if write_hold {
                    hold.fill(0.0);
                }
                if let Some(hn) = &held {
                    for ((pa, i), h) in hn.held_pa[rows.clone()]
                        .iter()
                        .zip(inv_d.iter_mut())
                        .zip(hold.iter_mut())
                    {
                        if *pa >= 0.0 {
                            *i = 0.0;
                            *h = pa * job.supply;
                        }
                    }
                }
            }
            if max_film_inlet && (ex != 0.0 || ey != 0.0) {
                // The column nearest the maximum film, angle arg(−ε(ζ)), held at zero. The
                // angle of the coarser grid's row where its `(εx, εy)` are these bits.
                let same = |&(x, y, t): &(f64, f64, f64)| {
                    (x.to_bits() == ex.to_bits() && y.to_bits() == ey.to_bits() && !t.is_nan())
                        .then_some(t)
                };
                let th = below
                    .and_then(|c| {
                        let s = nz / c.nz;
                        (j % s == 0).then(|| c.inlet_angles[j / s])
                    })
                    .as_ref()
                    .and_then(same)
                    .unwrap_or_else(|| ((-ey).atan2(-ex) - theta0).rem_euclid(2.0 * PI));
                self.inlet_angles[j] = (ex, ey, th);
                let i = (th / dt).round() as usize % nt;
                self.inv_d[row + i] = 0.0;
                self.inlet_col[j] = i;
            }
        }
        self.hold_zero = held.is_none();
    }

    /// `(cos, sin)` of the half-node angles `theta0 + kΔθ/2`, `k < 2 nt` (faces at odd
    /// `k`), and of the columns `theta0 + iΔθ` (the load sums). Kept when the grid and
    /// `theta0` are those of the table (explicit grids: every state); from a `coarser`
    /// level of the same hierarchy, its table holds this grid's columns (`nt` halved:
    /// `Δθ_H/2 = Δθ` bitwise, so `(Δθ_H/2)·i = (Δθ/2)·2i` bitwise) or all of it (`nt`
    /// kept): only the new half of the angles is evaluated (issue 20, session 36; the
    /// sines and cosines were 3.5 % of a default-accuracy solve).
    fn set_trig(&mut self, theta0: f64, coarser: Option<&Level>) {
        let nt = self.nt;
        if self.trig_of == (nt, theta0.to_bits()) && self.trig.len() == 2 * nt {
            return;
        }
        let dt = 2.0 * PI / nt as f64;
        let at = |k: usize| {
            let th = theta0 + 0.5 * dt * k as f64;
            (th.cos(), th.sin())
        };
        self.trig.clear();
        match coarser.filter(|c| c.trig_of == (c.nt, theta0.to_bits())) {
            Some(c) if c.nt == nt => self.trig.extend_from_slice(&c.trig),
            Some(c) if 2 * c.nt == nt => {
                for (k, &v) in c.trig.iter().enumerate() {
                    self.trig.push(v);
                    self.trig.push(at(2 * k + 1));
                }
            }
            _ => self.trig.extend((0..2 * nt).map(at)),
        }
        self.cols.clear();
        self.cols.extend(self.trig.iter().step_by(2));
        self.trig_of = (nt, theta0.to_bits());
    }

    /// The inverse diagonal in force: with the inlet holds when this grid is solved,
    /// without them as a correction grid.
    #[inline]
    fn inv(&self) -> &[f64] {
        if self.top {
            &self.inv_d
        } else {
            &self.inv_d_free
        }
    }

    /// One red-black projected SOR sweep with factor `omega` (1: Gauss–Seidel); returns
    /// the largest change and the largest value (the coarsest grid's stop test).
    pub fn sweep(&mut self, omega: f64) -> (f64, f64) {
        self.relax::<true>(omega)
    }

    /// The smoother of a V-cycle: [`Level::sweep`] at ω = 1 without the largest change
    /// and value, which no cycle reads (same iterates, bit for bit).
    fn smooth(&mut self) {
        self.smooth_on(lanes::isa());
    }

    /// [`Level::smooth`] on the instruction set `isa`: in SIMD lanes ([`lanes::smooth`])
    /// where the CPU has AVX2 or AVX-512F, else the scalar sweep; the same bits.
    fn smooth_on(&mut self, isa: LaneIsa) {
        let n = self.len();
        let g = lanes::Grid {
            nt: self.nt,
            nz: self.nz,
            ae: &self.ae[..n],
            an: &self.an[..n],
            d: &self.d[..n],
            f: if self.f_is_own {
                &self.f_own[..n]
            } else {
                &self.f[..n]
            },
            inv: if self.top {
                &self.inv_d[..n]
            } else {
                &self.inv_d_free[..n]
            },
            hold: &self.hold[..n],
            top: self.top,
            hold_zero: self.hold_zero,
        };
        if !lanes::smooth(isa, &g, &mut self.p[..n]) {
            self.relax::<false>(1.0);
        }
    }

    /// The red-black sweep, row by row on row slices (this row, the rows south and north,
    /// the row's coefficients), the periodic ends of a row outside the inner loop: the
    /// inner loop then has no wrap test and no bounds check (callgrind, issue 20 pass 5:
    /// 60 → 30 instructions per node update). `TRACK`: whether the largest change and value
    /// are wanted. The arithmetic and its order are those of the node update before.
    /// Two full colour passes on purpose: a fused pass (first colour on row `j`, second on
    /// row `j − 1` or `j − 2`, the residual fused in too) gives the same bits and cuts the
    /// first-level data misses by 18-37 %, but measured 1.5-5 % slower in wall (issue 20,
    /// session 37, BENCHMARKS "the smoother's cache traffic"): the misses hit the
    /// second-level cache behind the prefetcher; each colour pass's nodes are independent.
    fn relax<const TRACK: bool>(&mut self, omega: f64) -> (f64, f64) {
        let (nt, nz) = (self.nt, self.nz);
        let n = self.len();
        let top = self.top;
        let inv = if top {
            &self.inv_d[..n]
        } else {
            &self.inv_d_free[..n]
        };
        let f = if self.f_is_own {
            &self.f_own[..n]
        } else {
            &self.f[..n]
        };
        let (ae, an, hold) = (&self.ae[..n], &self.an[..n], &self.hold[..n]);
        let p = &mut self.p[..n];
        let mut max_dp = 0.0_f64;
        let mut max_p = 0.0_f64;
        for colour in 0..2 {
            for j in 1..nz {
                let row = j * nt;
                let (below, rest) = p.split_at_mut(row);
                let (cur, above) = rest.split_at_mut(nt);
                let r = RowRef {
                    south: &below[row - nt..row],
                    north: &above[..nt],
                    ae: &ae[row..row + nt],
                    an: &an[row..row + nt],
                    an_south: &an[row - nt..row],
                    f: &f[row..row + nt],
                    inv: &inv[row..row + nt],
                    hold: &hold[row..row + nt],
                };
                // Inlined by hand (`RowRef::update` is `inline(always)`; a closure here was
                // left as a call per node).
                macro_rules! node {
                    ($i:expr, $ip:expr, $im:expr) => {
                        if let Some((old, new)) = r.update(cur, $i, $ip, $im, omega, top) {
                            if TRACK {
                                max_dp = max_dp.max((new - old).abs());
                                max_p = max_p.max(new);
                            }
                        }
                    };
                }
                // This colour's nodes of the row: (i + j + colour) even. The ends of the
                // row (periodic neighbours) outside the inner loop.
                let mut i = (colour + j) % 2;
                if i == 0 {
                    node!(0, 1, nt - 1);
                    i = 2;
                }
                while i + 1 < nt {
                    node!(i, i + 1, i - 1);
                    i += 2;
                }
                if i + 1 == nt {
                    node!(i, 0, i - 1);
                }
            }
        }
        (max_dp, max_p)
    }

    /// The line smoother: one zebra sweep of projected line relaxation along ζ, first the
    /// even columns (lines of constant θ), then the odd ones, each line's discrete
    /// complementarity problem solved exactly ([`line_lcp`]) with its θ-neighbours'
    /// current values. Held nodes (solved grid) are set to their value, frozen nodes
    /// (correction grid) kept, both entering their line's neighbours as fixed values.
    ///
    /// Why the fixed point is the same: a field is a fixed point of this sweep iff every
    /// line solves its LCP given its neighbours, i.e. node by node `p ≥ 0`, `A p − f ≥ 0`,
    /// `pᵀ(A p − f) = 0` (the line's rows are the grid's rows with the θ-couplings moved
    /// to the right-hand side): exactly the grid's LCP, the fixed point of the point
    /// smoother too.
    fn smooth_lines(&mut self) {
        let (nt, nz) = (self.nt, self.nz);
        let n = self.len();
        let top = self.top;
        let inv = if top {
            &self.inv_d[..n]
        } else {
            &self.inv_d_free[..n]
        };
        let (ae, an, d, f, hold) = (
            &self.ae[..n],
            &self.an[..n],
            &self.d[..n],
            if self.f_is_own {
                &self.f_own[..n]
            } else {
                &self.f[..n]
            },
            &self.hold[..n],
        );
        // Its scratch (written before read), sized here: the point smoother's runs never
        // allocate it.
        for v in [&mut self.cp, &mut self.dp, &mut self.bl] {
            v.resize(n, 0.0);
        }
        self.act.resize(n, false);
        let p = &mut self.p[..n];
        let (cp, dp, bl, act) = (
            &mut self.cp[..n],
            &mut self.dp[..n],
            &mut self.bl[..n],
            &mut self.act[..n],
        );
        let dirty = &mut self.dirty;
        dirty.clear();
        dirty.resize(nt, false);
        // Row 0 (end face, p = 0): no elimination factors.
        cp[..nt].fill(0.0);
        dp[..nt].fill(0.0);
        for colour in 0..2 {
            // All lines of this colour at once, row by row on row slices (independent
            // lines: no serial chain along a row), the first pass of `line_lcp`'s
            // active-set iteration from its start: forward elimination, `p_j = dp_j +
            // cp_j p_{j+1}` ...
            for j in 1..nz {
                let row = j * nt;
                let (ps, pc, pn) = (
                    &p[row - nt..row],
                    &p[row..row + nt],
                    &p[row + nt..row + 2 * nt],
                );
                let (cps, cpc) = cp.split_at_mut(row);
                let (cps, cpc) = (&cps[row - nt..], &mut cpc[..nt]);
                let (dps, dpc) = dp.split_at_mut(row);
                let (dps, dpc) = (&dps[row - nt..], &mut dpc[..nt]);
                let (aer, anr, ans) = (&ae[row..row + nt], &an[row..row + nt], &an[row - nt..row]);
                let (dr, fr, ir, hr) = (
                    &d[row..row + nt],
                    &f[row..row + nt],
                    &inv[row..row + nt],
                    &hold[row..row + nt],
                );
                let (blr, actr) = (&mut bl[row..row + nt], &mut act[row..row + nt]);
                // A macro, not a closure (left as a call per node, see `Level::relax`).
                macro_rules! node {
                    ($i:expr, $ie:expr, $iw:expr) => {{
                        let (i, ie, iw) = ($i, $ie, $iw);
                        if ir[i] == 0.0 {
                            // Held (solved grid: its value) or frozen (correction grid: kept).
                            cpc[i] = 0.0;
                            dpc[i] = if top { hr[i] } else { pc[i] };
                            actr[i] = false;
                        } else {
                            let b = fr[i] + aer[i] * pc[ie] + aer[iw] * pc[iw];
                            blr[i] = b;
                            let sn = ans[i];
                            let a = pc[i] <= 0.0 && -anr[i] * pn[i] - sn * ps[i] - b >= 0.0;
                            actr[i] = a;
                            let m = 1.0 / (dr[i] - sn * cps[i]);
                            (cpc[i], dpc[i]) = if a {
                                (0.0, 0.0)
                            } else {
                                (anr[i] * m, (b + sn * dps[i]) * m)
                            };
                        }
                    }};
                }
                let mut i = colour;
                if i == 0 {
                    node!(0, 1, nt - 1);
                    i = 2;
                }
                while i + 1 < nt {
                    node!(i, i + 1, i - 1);
                    i += 2;
                }
                if i + 1 == nt {
                    node!(i, 0, i - 1);
                }
            }
            // ... back substitution (row n_z is 0), and the test of the row north of it,
            // now final: a line whose active set would change (an inactive node below 0,
            // an active one with `A p − f < 0`) is solved again from here by `line_lcp`
            // (rare: ~1 % of the lines).
            for j in (1..nz).rev() {
                let row = j * nt;
                let (below, rest) = p.split_at_mut(row);
                let (pc, above) = rest.split_at_mut(nt);
                let (cpc, dpc) = (&cp[row..row + nt], &dp[row..row + nt]);
                let pn = &above[..nt];
                let mut i = colour;
                while i < nt {
                    pc[i] = dpc[i] + cpc[i] * pn[i];
                    i += 2;
                }
                // The row north (j + 1 < n_z), between this row and the one above it.
                let mut check = |jj: usize, south: &[f64], cur: &[f64], north: &[f64]| {
                    let r = jj * nt;
                    let (ir, actr, blr) = (&inv[r..r + nt], &act[r..r + nt], &bl[r..r + nt]);
                    let (anr, ans) = (&an[r..r + nt], &an[r - nt..r]);
                    let mut i = colour;
                    while i < nt {
                        if ir[i] != 0.0 {
                            let bad = if actr[i] {
                                -anr[i] * north[i] - ans[i] * south[i] - blr[i] < 0.0
                            } else {
                                cur[i] < 0.0
                            };
                            dirty[i] |= bad;
                        }
                        i += 2;
                    }
                };
                if j + 1 < nz {
                    check(j + 1, pc, &above[..nt], &above[nt..2 * nt]);
                }
                if j == 1 {
                    check(1, &below[..nt], pc, &above[..nt]);
                }
            }
            let l = &mut self.line;
            l.resize(nz + 1);
            let mut i = colour;
            while i < nt {
                if dirty[i] {
                    l.fixed[0] = true;
                    l.fixed[nz] = true;
                    l.val[0] = 0.0;
                    l.val[nz] = 0.0;
                    l.up[0] = 0.0;
                    for j in 1..nz {
                        let k = j * nt + i;
                        l.up[j] = an[k];
                        l.fixed[j] = inv[k] == 0.0;
                        l.diag[j] = d[k];
                        l.b[j] = bl[k];
                        l.val[j] = p[k];
                    }
                    line_lcp(l, nz);
                    for j in 1..nz {
                        p[j * nt + i] = l.val[j];
                    }
                }
                i += 2;
            }
        }
    }

    /// `r = f − A p` after a smoothing sweep, zero at held nodes and where the constraint is
    /// active. Row slices as in [`Level::relax`]. Computed at the sweep's first colour only
    /// (see below; issue 20 pass 5: the same cycle counts, iterates equal to rounding).
    /// Out of line (one call per grid and cycle) so that profiles attribute it.
    #[inline(never)]
    fn residual(&mut self) {
        self.residual_lanes(lanes::isa());
    }

    /// [`Level::residual`] on the instruction set `isa`: in SIMD lanes
    /// ([`lanes::residual`]) where the CPU has AVX2 or AVX-512F, else the scalar pass; the
    /// same bits.
    fn residual_lanes(&mut self, isa: LaneIsa) {
        let n = self.len();
        let g = lanes::Grid {
            nt: self.nt,
            nz: self.nz,
            ae: &self.ae[..n],
            an: &self.an[..n],
            d: &self.d[..n],
            f: if self.f_is_own {
                &self.f_own[..n]
            } else {
                &self.f[..n]
            },
            inv: if self.top {
                &self.inv_d[..n]
            } else {
                &self.inv_d_free[..n]
            },
            hold: &self.hold[..n],
            top: self.top,
            hold_zero: self.hold_zero,
        };
        if !lanes::residual(isa, &g, &self.p[..n], &mut self.r[..n]) {
            self.residual_on::<false>();
        }
    }

    /// [`Level::residual`] after a smoothing sweep of the smoother `LINES` (true:
    /// [`Level::smooth_lines`], whose odd columns are solved last: the residual at the
    /// even columns, zero at the odd ones; false: the red-black point sweep's first colour).
    #[inline(never)]
    fn residual_on<const LINES: bool>(&mut self) {
        let (nt, nz) = (self.nt, self.nz);
        let n = self.len();
        let inv = if self.top {
            &self.inv_d[..n]
        } else {
            &self.inv_d_free[..n]
        };
        let (ae, an, d, f, p) = (
            &self.ae[..n],
            &self.an[..n],
            &self.d[..n],
            if self.f_is_own {
                &self.f_own[..n]
            } else {
                &self.f[..n]
            },
            &self.p[..n],
        );
        for j in 1..nz {
            let row = j * nt;
            let (south, cur, north) = (
                &p[row - nt..row],
                &p[row..row + nt],
                &p[row + nt..row + 2 * nt],
            );
            let (aer, anr, ans) = (&ae[row..row + nt], &an[row..row + nt], &an[row - nt..row]);
            let (dr, fr, ir) = (&d[row..row + nt], &f[row..row + nt], &inv[row..row + nt]);
            let out = &mut self.r[row..row + nt];
            let row_ref = ResidualRow {
                south,
                cur,
                north,
                ae: aer,
                an: anr,
                an_south: ans,
                d: dr,
                f: fr,
                inv: ir,
            };
            // The first colour's nodes ((i + j) even); the second colour's residual is
            // zero to rounding after the sweep (each node solved, or projected to 0 with
            // a negative residual, which the rule zeroes): written as 0, half the work.
            // The second colour's zeros stored beside the first colour's values (not a
            // `memset` of the row first, half of it overwritten).
            let mut i = if LINES { 0 } else { j % 2 };
            if i == 1 {
                out[0] = 0.0;
            } else {
                out[0] = row_ref.at(0, 1, nt - 1);
                out[1] = 0.0;
                i = 2;
            }
            while i + 1 < nt {
                out[i] = row_ref.at(i, i + 1, i - 1);
                out[i + 1] = 0.0;
                i += 2;
            }
            if i + 1 == nt {
                out[i] = row_ref.at(i, 0, i - 1);
            }
        }
    }

    /// Projected SOR on this grid until the estimated remaining change is below `tol` of
    /// the largest value, or, with `rel` > 0 (a correction grid), below `rel` of the
    /// correction's largest value `max |p − u₀|` if that is larger; or exactly `sweeps`
    /// sweeps when given.
    fn solve_coarsest(&mut self, aspect: f64, tol: f64, rel: f64, sweeps: Option<u32>) -> u64 {
        let g = FiniteGrid {
            n_theta: self.nt,
            n_z: self.nz,
            tolerance: tol,
            max_film_inlet: false,
            accuracy: None,
            layout: FilmLayout::default(),
            cavitation: super::Cavitation::Reynolds,
            polish: false,
        };
        let omega = g.relaxation(aspect);
        let mut updates = 0;
        let mut hist = [f64::INFINITY; 6];
        // The stop test below is monotone in the contraction ρ ≥ ω − 1: with this
        // smallest tail factor failing, the (costly) measured ρ is not needed.
        let floor = (omega - 1.0).min(0.9999);
        let min_tail = floor / (1.0 - floor);
        if let Some(n) = sweeps {
            for _ in 0..n {
                self.sweep(omega);
            }
            return n as u64 * self.interior() as u64;
        }
        let n = self.len();
        for s in 0..COARSEST_SWEEPS {
            let (dp, mp) = self.sweep(omega);
            updates += self.interior() as u64;
            hist.rotate_left(1);
            hist[5] = dp;
            let tol_abs = if rel > 0.0 {
                let c = self.p[..n]
                    .iter()
                    .zip(&self.base[..n])
                    .fold(0.0_f64, |m, (a, b)| m.max((a - b).abs()));
                (tol * mp).max(rel * c)
            } else {
                tol * mp
            };
            if rel > 0.0 && s >= 1 && dp != 0.0 {
                // The correction's test from the second sweep on: the contraction as
                // measured over the last sweep, at least ω − 1.
                let rho = (dp / hist[4]).max(omega - 1.0).min(0.9999);
                if dp * rho / (1.0 - rho) <= tol_abs {
                    break;
                }
            }
            if dp != 0.0 && dp * min_tail > tol_abs {
                continue;
            }
            let measured = if hist[0].is_finite() && hist[0] > 0.0 {
                (hist[5] / hist[0]).powf(0.2)
            } else {
                0.0
            };
            let rho = measured.max(omega - 1.0).min(0.9999);
            if dp == 0.0 || (s >= 5 && dp * rho / (1.0 - rho) <= tol_abs) {
                break;
            }
        }
        updates
    }
}

/// Scratch of one line of [`Level::smooth_lines`], rows `0 ..= nz` (rows 0 and `nz`, the
/// end faces, fixed at 0): the line's tridiagonal LCP
/// `diag_j p_j − up_j p_{j+1} − up_{j−1} p_{j−1} − b_j = w_j`, `p ≥ 0`, `w ≥ 0`, `p w = 0`
/// at the free rows, `p_j = val_j` at the fixed ones.
#[derive(Default)]
pub(crate) struct LineScratch {
    /// Diagonal (free rows).
    pub diag: Vec<f64>,
    /// Coupling of row j to row j + 1 (the north face coefficient, ≥ 0).
    pub up: Vec<f64>,
    /// Right-hand side (free rows; the θ-neighbours' terms included).
    pub b: Vec<f64>,
    /// In: the start (free rows) and the fixed values; out: the solution.
    pub val: Vec<f64>,
    /// Fixed rows (end faces, held or frozen nodes).
    pub fixed: Vec<bool>,
    /// Active set of the primal-dual iteration (free rows held at 0).
    act: Vec<bool>,
    /// Forward-elimination factors.
    cp: Vec<f64>,
    dp: Vec<f64>,
}

impl LineScratch {
    /// Sized for rows `0 ..= nz` (contents unspecified).
    pub fn resize(&mut self, len: usize) {
        for v in [
            &mut self.diag,
            &mut self.up,
            &mut self.b,
            &mut self.val,
            &mut self.cp,
            &mut self.dp,
        ] {
            v.resize(len, 0.0);
        }
        self.fixed.resize(len, false);
        self.act.resize(len, false);
    }
}

/// Solves the line LCP of `l` (rows `0 ..= nz`, see [`LineScratch`]) exactly by the
/// primal-dual active-set iteration: with the active rows held at 0 and the fixed rows at
/// their values, the other rows' equations are solved by the Thomas algorithm; then a free
/// row whose value came out negative becomes active, an active row whose `w` came out
/// negative becomes free; until the set does not change, when `p ≥ 0` at every free row,
/// `w = 0` at the inactive ones and `w ≥ 0` at the active ones: the LCP's solution. For an
/// M-matrix (here: `diag_j ≥ up_j + up_{j−1}`, the θ-faces making it strict) the iteration
/// terminates (Hintermüller, Ito & Kunisch 2003: monotone after the first step); a line
/// that is all pressure or all cavitated takes one pass. The start: active where the
/// current value is 0 and its `w` at the current neighbours is ≥ 0. Returns the passes.
pub(crate) fn line_lcp(l: &mut LineScratch, nz: usize) -> u32 {
    // Initial active set from the current values.
    for j in 1..nz {
        l.act[j] = !l.fixed[j]
            && l.val[j] <= 0.0
            && -l.up[j] * l.val[j + 1] - l.up[j - 1] * l.val[j - 1] - l.b[j] >= 0.0;
    }
    // Safety cap: each pass moves at least one row, at most every row twice in practice.
    let max_passes = 2 * nz as u32 + 2;
    let mut passes = 0;
    loop {
        passes += 1;
        // Forward elimination: p_j = dp_j + cp_j p_{j+1}.
        l.cp[0] = 0.0;
        l.dp[0] = l.val[0];
        for j in 1..nz {
            if l.fixed[j] || l.act[j] {
                l.cp[j] = 0.0;
                l.dp[j] = if l.fixed[j] { l.val[j] } else { 0.0 };
            } else {
                let s = l.up[j - 1];
                let inv = 1.0 / (l.diag[j] - s * l.cp[j - 1]);
                l.cp[j] = l.up[j] * inv;
                l.dp[j] = (l.b[j] + s * l.dp[j - 1]) * inv;
            }
        }
        for j in (1..nz).rev() {
            l.val[j] = l.dp[j] + l.cp[j] * l.val[j + 1];
        }
        let mut changed = false;
        for j in 1..nz {
            if l.fixed[j] {
                continue;
            }
            if l.act[j] {
                let w = -l.up[j] * l.val[j + 1] - l.up[j - 1] * l.val[j - 1] - l.b[j];
                if w < 0.0 {
                    l.act[j] = false;
                    changed = true;
                }
            } else if l.val[j] < 0.0 {
                l.act[j] = true;
                changed = true;
            }
        }
        if !changed || passes >= max_passes {
            break;
        }
    }
    // Rounding (or the cap): never a negative pressure.
    for j in 1..nz {
        if !l.fixed[j] && l.val[j] < 0.0 {
            l.val[j] = 0.0;
        }
    }
    passes
}

/// The next coarser grid of `nt × nz` at aspect `B/r0`, and how it is coarsened; `None`
/// when the grid is the coarsest.
pub(crate) fn coarser(nt: usize, nz: usize, aspect: f64) -> Option<(usize, usize, Coarsen)> {
    if nt * (nz.max(1) - 1) <= COARSEST_NODES {
        return None;
    }
    let dt = 2.0 * PI / nt as f64;
    let ct = aspect * aspect / (dt * dt);
    let cz = (nz * nz) as f64;
    // θ stays even and at least 4 intervals; ζ keeps at least 2 intervals.
    let can_t = nt.is_multiple_of(4) && nt >= 8;
    let can_z = nz.is_multiple_of(2) && nz >= 4;
    let pick = if ct > ANISOTROPY * cz {
        can_t.then_some(Coarsen::Theta)
    } else if cz > ANISOTROPY * ct {
        can_z.then_some(Coarsen::Zeta)
    } else if can_t && can_z {
        Some(Coarsen::Both)
    } else if can_t {
        Some(Coarsen::Theta)
    } else if can_z {
        Some(Coarsen::Zeta)
    } else {
        None
    };
    pick.map(|c| match c {
        Coarsen::Both => (nt / 2, nz / 2, c),
        Coarsen::Theta => (nt / 2, nz, c),
        Coarsen::Zeta => (nt, nz / 2, c),
    })
}

/// Stride of a coarsening in (θ, ζ).
fn strides(c: Coarsen) -> (usize, usize) {
    match c {
        Coarsen::Both => (2, 2),
        Coarsen::Theta => (2, 1),
        Coarsen::Zeta => (1, 2),
    }
}

/// The FAS coarse problem of `fine` on `coarse` (coarsened by `c`): `u₀` = injection of
/// the fine iterate (also the coarse start), `f_H = A_H u₀ + R r` with `R` the full
/// weighting, zero at frozen coarse nodes. One pass over the coarse grid on row slices, the
/// strides as constants (was: the restriction through a closure testing the stride per
/// point, then `A_H u₀` through a per-node call: ~145 instructions per coarse node,
/// callgrind, issue 20 pass 5); the same arithmetic in the same order.
#[inline(never)]
fn restrict_fas(fine: &Level, coarse: &mut Level, c: Coarsen) {
    restrict_fas_with(lanes::isa(), fine, coarse, c);
}

/// [`restrict_fas`] on the instruction set `isa`: in SIMD lanes ([`lanes::restrict`])
/// where the CPU has AVX2 or AVX-512F, else the scalar pass; the same bits.
fn restrict_fas_with(isa: LaneIsa, fine: &Level, coarse: &mut Level, c: Coarsen) {
    let n = coarse.len();
    coarse.f_is_own = false;
    // Written in full below (sized here, not by `Level::setup`).
    coarse.f.resize(n, 0.0);
    let mut cg = lanes::Coarse {
        g: lanes::Grid {
            nt: coarse.nt,
            nz: coarse.nz,
            ae: &coarse.ae[..n],
            an: &coarse.an[..n],
            d: &coarse.d[..n],
            f: &coarse.f_own[..n],
            inv: if coarse.top {
                &coarse.inv_d[..n]
            } else {
                &coarse.inv_d_free[..n]
            },
            hold: &coarse.hold[..n],
            top: coarse.top,
            hold_zero: coarse.hold_zero,
        },
        base: &mut coarse.base[..n],
        p: &mut coarse.p[..n],
        f: &mut coarse.f[..n],
    };
    let (p, r, fnt) = (&fine.p[..fine.len()], &fine.r[..fine.len()], fine.nt);
    let done = match c {
        Coarsen::Both => lanes::restrict::<2, 2>(isa, p, r, fnt, &mut cg),
        Coarsen::Theta => lanes::restrict::<2, 1>(isa, p, r, fnt, &mut cg),
        Coarsen::Zeta => lanes::restrict::<1, 2>(isa, p, r, fnt, &mut cg),
    };
    if done {
        return;
    }
    match c {
        Coarsen::Both => restrict_fas_on::<2, 2>(fine, coarse),
        Coarsen::Theta => restrict_fas_on::<2, 1>(fine, coarse),
        Coarsen::Zeta => restrict_fas_on::<1, 2>(fine, coarse),
    }
}

/// [`restrict_fas`] for the strides `ST` in θ and `SZ` in ζ.
// One index across several row slices of the same length.
#[allow(clippy::needless_range_loop)]
#[inline(always)]
fn restrict_fas_on<const ST: usize, const SZ: usize>(fine: &Level, coarse: &mut Level) {
    let (fnt, cnt, cnz) = (fine.nt, coarse.nt, coarse.nz);
    for jc in 0..=cnz {
        let (frow, crow) = (jc * SZ * fnt, jc * cnt);
        let src = &fine.p[frow..frow + fnt];
        let (base, p) = (
            &mut coarse.base[crow..crow + cnt],
            &mut coarse.p[crow..crow + cnt],
        );
        for ic in 0..cnt {
            let v = src[ic * ST];
            base[ic] = v;
            p[ic] = v;
        }
    }
    // Weighted θ-stencil of a fine row at fine column `i0` (west neighbour `im`; the east
    // one, i0 + 1, never wraps: i0 is even and the row's length even).
    let along = |r: &[f64], i0: usize, im: usize| {
        if ST == 2 {
            0.25 * r[im] + 0.5 * r[i0] + 0.25 * r[i0 + 1]
        } else {
            r[i0]
        }
    };
    let inv = if coarse.top {
        &coarse.inv_d
    } else {
        &coarse.inv_d_free
    };
    let (u, d, ae, an) = (&coarse.base, &coarse.d, &coarse.ae, &coarse.an);
    coarse.f_is_own = false;
    let out = &mut coarse.f;
    out[..cnt].fill(0.0);
    out[cnz * cnt..].fill(0.0);
    let r = &fine.r;
    for jc in 1..cnz {
        let jf = jc * SZ;
        let crow = jc * cnt;
        let rc = &r[jf * fnt..(jf + 1) * fnt];
        let (rs, rn) = if SZ == 2 {
            (
                &r[(jf - 1) * fnt..jf * fnt],
                &r[(jf + 1) * fnt..(jf + 2) * fnt],
            )
        } else {
            (rc, rc)
        };
        let (us, uc, un) = (
            &u[crow - cnt..crow],
            &u[crow..crow + cnt],
            &u[crow + cnt..crow + 2 * cnt],
        );
        let (aer, anr, ans) = (
            &ae[crow..crow + cnt],
            &an[crow..crow + cnt],
            &an[crow - cnt..crow],
        );
        let (dr, ir) = (&d[crow..crow + cnt], &inv[crow..crow + cnt]);
        let outr = &mut out[crow..crow + cnt];
        for ic in 0..cnt {
            outr[ic] = if ir[ic] == 0.0 {
                0.0
            } else {
                let i0 = ic * ST;
                let im = if i0 == 0 { fnt - 1 } else { i0 - 1 };
                let rr = if SZ == 2 {
                    0.25 * along(rs, i0, im) + 0.5 * along(rc, i0, im) + 0.25 * along(rn, i0, im)
                } else {
                    along(rc, i0, im)
                };
                let ip = if ic + 1 == cnt { 0 } else { ic + 1 };
                let iw = if ic == 0 { cnt - 1 } else { ic - 1 };
                let s = aer[ic] * uc[ip] + aer[iw] * uc[iw] + anr[ic] * un[ic] + ans[ic] * us[ic];
                rr + (dr[ic] * uc[ic] - s)
            };
        }
    }
}

/// `fine.p[k] += P(coarse.p − coarse.base)` by bilinear interpolation at the nodes inside
/// the pressure zone, then projected; held nodes set to 0. The correction `u_H − u₀` is
/// formed once per coarse node in `coarse.r` (scratch: the coarse grid's residual is not
/// read again before its next descent), not up to four times per fine node.
#[inline(never)]
fn prolong_correction(fine: &mut Level, coarse: &mut Level, c: Coarsen, truncate_coarse: bool) {
    prolong_correction_with(lanes::isa(), fine, coarse, c, truncate_coarse);
}

/// The coarse side of the truncated correction ([`Hierarchy::coarse_truncation`]): the
/// correction `u_H − u₀` (in `coarse.r`) set to 0 at the coarse nodes outside the
/// coarse pressure zone, where `u₀` (the injected fine iterate) is 0 at the node or at one
/// of its four neighbours (the end rows count as positive, as on the fine side). There
/// the coarse problem's own free boundary, a coarse cell off the fine one, moved the
/// coarse solution; interpolated, that move reached fine nodes inside the fine zone and
/// the active set flipped back and forth from cycle to cycle (issue 20 session 41:
/// 20-100 nodes per cycle, a period-4 limit cycle on 2048 × 256 and 4096 × 512 at ε 0.9).
fn truncate_outside_zone(coarse: &mut Level) {
    let (nt, nz) = (coarse.nt, coarse.nz);
    let (b, e) = (&coarse.base, &mut coarse.r);
    for j in 1..nz {
        let row = j * nt;
        for i in 0..nt {
            let k = row + i;
            let ip = row + if i + 1 == nt { 0 } else { i + 1 };
            let im = row + if i == 0 { nt - 1 } else { i - 1 };
            let inside = b[k] > 0.0
                && b[ip] > 0.0
                && b[im] > 0.0
                && (j + 1 == nz || b[k + nt] > 0.0)
                && (j == 1 || b[k - nt] > 0.0);
            if !inside {
                e[k] = 0.0;
            }
        }
    }
}

/// [`prolong_correction`] on the instruction set `isa`: in SIMD lanes
/// ([`lanes::correct`]) where the CPU has AVX2 or AVX-512F, else the scalar pass; the same
/// bits.
fn prolong_correction_with(
    isa: LaneIsa,
    fine: &mut Level,
    coarse: &mut Level,
    c: Coarsen,
    truncate_coarse: bool,
) {
    let cn = coarse.len();
    for ((e, p), b) in coarse.r[..cn].iter_mut().zip(&coarse.p).zip(&coarse.base) {
        *e = p - b;
    }
    if truncate_coarse {
        truncate_outside_zone(coarse);
    }
    let n = fine.len();
    let g = lanes::Grid {
        nt: fine.nt,
        nz: fine.nz,
        ae: &fine.ae[..n],
        an: &fine.an[..n],
        d: &fine.d[..n],
        f: if fine.f_is_own {
            &fine.f_own[..n]
        } else {
            &fine.f[..n]
        },
        inv: if fine.top {
            &fine.inv_d[..n]
        } else {
            &fine.inv_d_free[..n]
        },
        hold: &fine.hold[..n],
        top: fine.top,
        hold_zero: fine.hold_zero,
    };
    let (p, e, cnt, row) = (
        &mut fine.p[..n],
        &coarse.r[..cn],
        coarse.nt,
        &mut fine.lane_row,
    );
    let done = match c {
        Coarsen::Both => lanes::correct::<2, 2>(isa, &g, p, e, cnt, row),
        Coarsen::Theta => lanes::correct::<2, 1>(isa, &g, p, e, cnt, row),
        Coarsen::Zeta => lanes::correct::<1, 2>(isa, &g, p, e, cnt, row),
    };
    if done {
        return;
    }
    match c {
        Coarsen::Both => prolong_correction_on::<2, 2>(fine, coarse),
        Coarsen::Theta => prolong_correction_on::<2, 1>(fine, coarse),
        Coarsen::Zeta => prolong_correction_on::<1, 2>(fine, coarse),
    }
}

/// [`prolong_correction`] for the strides `ST` in θ and `SZ` in ζ, on row slices: the row
/// south of the fine row is already corrected, the row north not yet, as in the walk by
/// node index before (the same tests see the same values; the same arithmetic).
// One index across several row slices of the same length.
#[allow(clippy::needless_range_loop)]
#[inline(always)]
fn prolong_correction_on<const ST: usize, const SZ: usize>(fine: &mut Level, coarse: &mut Level) {
    let cnt = coarse.nt;
    let cn = coarse.len();
    // The correction `u_H − u₀` (formed by the caller, `prolong_correction_with`).
    let e = &coarse.r[..cn];
    let (nt, nz, top) = (fine.nt, fine.nz, fine.top);
    let inv = if top { &fine.inv_d } else { &fine.inv_d_free };
    let hold = &fine.hold;
    let p = &mut fine.p;
    for j in 1..nz {
        let (jc, jo) = if SZ == 2 { (j / 2, j % 2) } else { (j, 0) };
        let (row, crow) = (j * nt, jc * cnt);
        // The coarse rows at and above this fine row (jc + 1 ≤ the coarse grid's n_z).
        let (e0, e1) = (&e[crow..crow + cnt], &e[crow + cnt..crow + 2 * cnt]);
        let (below, rest) = p.split_at_mut(row);
        let (cur, above) = rest.split_at_mut(nt);
        let (south, north) = (&below[row - nt..row], &above[..nt]);
        let (ir, hr) = (&inv[row..row + nt], &hold[row..row + nt]);
        // Rows next to the end faces: the face's p = 0 does not count against the zone.
        let (first, last) = (j == 1, j + 1 == nz);
        for i in 0..nt {
            if ir[i] == 0.0 {
                // Held (solved grid): its value; frozen (correction grid): unchanged.
                if top {
                    cur[i] = hr[i];
                }
                continue;
            }
            // Truncation: only nodes inside the pressure zone (the node and its four
            // neighbours positive) take the correction; the free boundary's nodes are
            // left to the smoother. Corrected there, the coarse grid's view of the
            // active set fights the fine one and the cycle settles into a limit cycle
            // (measured: a constant change per cycle from 256 × 32 on).
            let ip = if i + 1 == nt { 0 } else { i + 1 };
            let im = if i == 0 { nt - 1 } else { i - 1 };
            let pk = cur[i];
            let inside = pk > 0.0
                && cur[ip] > 0.0
                && cur[im] > 0.0
                && (last || north[i] > 0.0)
                && (first || south[i] > 0.0);
            if !inside {
                continue;
            }
            let (ic, io) = if ST == 2 { (i / 2, i % 2) } else { (i, 0) };
            let ic1 = if ic + 1 == cnt { 0 } else { ic + 1 };
            let v = match (jo, io) {
                (0, 0) => e0[ic],
                (0, _) => 0.5 * (e0[ic] + e0[ic1]),
                (_, 0) => 0.5 * (e0[ic] + e1[ic]),
                _ => 0.25 * (e0[ic] + e0[ic1] + e1[ic] + e1[ic1]),
            };
            cur[i] = (pk + v).max(0.0);
        }
    }
}

/// Freezes nodes of `coarse` (as a correction grid of `fine`, coarsened by `how`) at
/// `u₀`, a zero correction where the fine grid holds its pressure. At the fine solution
/// `u₀` is the coarse solution whatever nodes are frozen, so the fixed point is kept;
/// the pattern only sets how fast the cycle converges. It depends only on the holds, so it
/// is set once per [`Hierarchy::iterate`], not per cycle.
///
/// - Grooves and arcs (held bands): every coarse node whose restriction stencil touches a
///   held or frozen fine node.
/// - The maximum-film inlet line (one node per row), on explicit grids (`line`; the
///   accuracy ladder keeps the stencil rule, see [`Hierarchy::line_freeze`]): one coarse
///   node per row, the one on
///   the line, or, when the line falls between two coarse nodes, the one on the side of
///   the smaller right-hand side (upstream: the cavitated side, where the correction is
///   zero anyway). Frozen by the stencil rule above instead, the line took two coarse
///   columns per row on every coarser grid, a band a quarter to an eighth of the
///   circumference wide on the coarsest ones, right where the pressure rises: the
///   correction missed it and the cycle contracted by ~0.5 instead of ~0.25 (issue 20
///   pass 3: 128 × 32, max-film inlet, 83 → 42 sweeps on average; examples/mg_probe.rs).
fn freeze(fine: &Level, coarse: &mut Level, how: Coarsen, line: bool) {
    // Widened by the compiler (issue 20, session 38: inlined into `Hierarchy::iterate`,
    // it was most of that function's own instructions at 128 × 32).
    lanes::widened(Freeze {
        fine,
        coarse,
        how,
        line,
    })
}

/// [`freeze`]'s arguments, for [`lanes::widened`].
struct Freeze<'a> {
    fine: &'a Level,
    coarse: &'a mut Level,
    how: Coarsen,
    line: bool,
}

impl lanes::Widen for Freeze<'_> {
    type Out = ();
    #[inline(always)]
    fn run(self) {
        freeze_body(self.fine, self.coarse, self.how, self.line)
    }
}

/// [`freeze`]'s body, for each instruction set.
#[inline(always)]
fn freeze_body(fine: &Level, coarse: &mut Level, how: Coarsen, line: bool) {
    let (st, sz) = strides(how);
    // Sized here (not by `Level::setup`): every row read below the end rows is written.
    let n = coarse.len();
    coarse.inv_d_free.resize(n, 0.0);
    let fine_inv = fine.inv();
    let fnt = fine.nt;
    // Without `line` (see `Hierarchy::line_freeze`): no inlet line, the stencil rule for
    // the inlet's held nodes too.
    let fine_inlet: &[usize] = if !line {
        &[]
    } else if fine.top {
        &fine.inlet_col
    } else {
        &fine.inlet_corr
    };
    // The fine inlet line on the coarse grid: the coincident node, or (between two coarse
    // nodes) the one on the side of the smaller right-hand side, upstream of the pressure
    // zone (freezing the downstream one pins the correction where the pressure rises).
    for jc in 1..coarse.nz {
        let jf = jc * sz;
        let fi = fine_inlet.get(jf).copied().unwrap_or(usize::MAX);
        coarse.inlet_corr[jc] = if fi == usize::MAX {
            usize::MAX
        } else if st == 1 || fi % 2 == 0 {
            fi / st
        } else {
            let left = fi - 1;
            let right = if fi + 1 == fnt { 0 } else { fi + 1 };
            if fine.f_own[jf * fnt + left] <= fine.f_own[jf * fnt + right] {
                left / 2
            } else {
                right / 2
            }
        };
    }
    for jc in 1..coarse.nz {
        let jf = jc * sz;
        let (jlo, jhi) = if sz == 2 { (jf - 1, jf + 1) } else { (jf, jf) };
        // Per fine column: a held fine node off the inlet line in the rows this coarse
        // row's stencils reach (once per fine node and row, instead of once per coarse
        // node and stencil point; issue 20, session 36: the same pattern).
        // Built only once a row holds a node off the line (`any`): the plain film holds
        // the inlet line alone, and its rows are only counted (a reduction the compiler
        // widens; issue 20, session 38: the mask and the loop below were most of
        // `Hierarchy::iterate`'s own instructions at 128 × 32).
        let mask = &mut coarse.held_cols;
        let mut any = false;
        for j in jlo.max(1)..=jhi.min(fine.nz - 1) {
            let line = fine_inlet.get(j).copied().filter(|&i| i < fnt);
            let row = &fine_inv[j * fnt..(j + 1) * fnt];
            let zeros = row.iter().filter(|v| **v == 0.0).count();
            if zeros == line.map_or(0, |i| usize::from(row[i] == 0.0)) {
                continue;
            }
            if !any {
                mask.clear();
                mask.resize(fnt, false);
                any = true;
            }
            // Every held node, then the inlet line's node put back as it was before this
            // row: the same mask as `|= held && i != line`, without the index test.
            let before = line.map(|i| mask[i]);
            for (m, v) in mask.iter_mut().zip(row) {
                *m |= *v == 0.0;
            }
            if let (Some(i), Some(b)) = (line, before) {
                mask[i] = b;
            }
        }
        let cnt = coarse.nt;
        let row = jc * cnt..(jc + 1) * cnt;
        let (inv_c, d_c) = (&coarse.inv_d[row.clone()], &coarse.d[row.clone()]);
        let out = &mut coarse.inv_d_free[row];
        let line_c = coarse.inlet_corr[jc];
        // `1/d`: the coarse grid's own `inv_d` holds it wherever it is not 0
        // (`Level::setup` writes `1/d` or 0 there), the same bits without the division.
        let free = |k: usize| {
            if inv_c[k] != 0.0 {
                inv_c[k]
            } else {
                1.0 / d_c[k]
            }
        };
        if !any {
            // Only the inlet line's node is held on this row.
            for (ic, o) in out.iter_mut().enumerate() {
                *o = if line_c == ic { 0.0 } else { free(ic) };
            }
            continue;
        }
        let mask = &mask[..fnt];
        for (ic, o) in out.iter_mut().enumerate() {
            let i0 = ic * st;
            // The fine inlet line's node on this grid; and any node whose stencil
            // touches a held fine node off that line (grooves, arcs).
            let held = line_c == ic
                || if st == 2 {
                    let im = if i0 == 0 { fnt - 1 } else { i0 - 1 };
                    let ip = if i0 + 1 == fnt { 0 } else { i0 + 1 };
                    mask[im] || mask[i0] || mask[ip]
                } else {
                    mask[i0]
                };
            *o = if held { 0.0 } else { free(ic) };
        }
    }
}

/// `fine.p = P coarse.p` (bilinear interpolation of a solution; the FMG start).
pub(crate) fn prolong_solution(fine: &mut Level, coarse: &Level, c: Coarsen) {
    prolong_solution_with(lanes::isa(), fine, coarse, c);
}

/// [`prolong_solution`] on the instruction set `isa`: in SIMD lanes ([`lanes::prolong`])
/// where the CPU has AVX2 or AVX-512F, else the scalar pass; the same bits.
fn prolong_solution_with(isa: LaneIsa, fine: &mut Level, coarse: &Level, c: Coarsen) {
    let n = fine.len();
    let (nt, nz, cnt) = (fine.nt, fine.nz, coarse.nt);
    let (out, inv, hold) = (&mut fine.p[..n], &fine.inv_d[..n], &fine.hold[..n]);
    let h0 = fine.hold_zero;
    let cp = &coarse.p[..coarse.len()];
    let done = match c {
        Coarsen::Both => lanes::prolong::<2, 2>(isa, out, inv, hold, h0, nt, nz, cp, cnt),
        Coarsen::Theta => lanes::prolong::<2, 1>(isa, out, inv, hold, h0, nt, nz, cp, cnt),
        Coarsen::Zeta => lanes::prolong::<1, 2>(isa, out, inv, hold, h0, nt, nz, cp, cnt),
    };
    if done {
        return;
    }
    match c {
        Coarsen::Both => prolong_solution_on::<2, 2>(fine, coarse),
        Coarsen::Theta => prolong_solution_on::<2, 1>(fine, coarse),
        Coarsen::Zeta => prolong_solution_on::<1, 2>(fine, coarse),
    }
}

/// [`prolong_solution`] for the strides `ST` in θ and `SZ` in ζ, on row slices, a coarse
/// column at a time (was: a per-node `match` on both offsets through a closure, 4.4 % of a
/// default-accuracy solve; issue 20, session 36): the same sums in the same order.
#[inline(always)]
fn prolong_solution_on<const ST: usize, const SZ: usize>(fine: &mut Level, coarse: &Level) {
    let (cnt, nt) = (coarse.nt, fine.nt);
    for j in 1..fine.nz {
        let (jc, jo) = if SZ == 2 { (j / 2, j % 2) } else { (j, 0) };
        let c0 = &coarse.p[jc * cnt..(jc + 1) * cnt];
        // The coarse row above (between two coarse rows), else unused.
        let c1 = if jo == 1 {
            &coarse.p[(jc + 1) * cnt..(jc + 2) * cnt]
        } else {
            c0
        };
        let row = j * nt;
        let out = &mut fine.p[row..row + nt];
        let inv = &fine.inv_d[row..row + nt];
        let hold = &fine.hold[row..row + nt];
        let mut put = |i: usize, v: f64| {
            out[i] = if inv[i] == 0.0 { hold[i] } else { v.max(0.0) };
        };
        for ic in 0..cnt {
            // Column ic + 1 wraps to 0 at the coarse grid's end.
            let ic1 = if ic + 1 == cnt { 0 } else { ic + 1 };
            let (a, b) = (c0[ic], c0[ic1]);
            if jo == 0 {
                put(ST * ic, a);
                if ST == 2 {
                    put(2 * ic + 1, 0.5 * (a + b));
                }
            } else {
                let (c, d) = (c1[ic], c1[ic1]);
                put(ST * ic, 0.5 * (a + c));
                if ST == 2 {
                    put(2 * ic + 1, 0.25 * (a + b + c + d));
                }
            }
        }
    }
}

/// Cubic interpolation at the midpoint of four equally spaced values `a, b, c, d` (between
/// `b` and `c`): `(−a + 9b + 9c − d)/16`, fourth order.
#[inline(always)]
pub(super) fn cubic_mid(a: f64, b: f64, c: f64, d: f64) -> f64 {
    (9.0 * (b + c) - (a + d)) * (1.0 / 16.0)
}

/// One-sided cubic interpolation at the midpoint of the first two of four equally spaced
/// values `a, b, c, d` (between `a` and `b`): `(5a + 15b − 5c + d)/16`, fourth order (the
/// Lagrange weights at 1/2 of the nodes 0, 1, 2, 3).
#[inline(always)]
pub(super) fn cubic_edge(a: f64, b: f64, c: f64, d: f64) -> f64 {
    (5.0 * a + 15.0 * b - 5.0 * c + d) * (1.0 / 16.0)
}

/// `out[i] = v(i)` clipped at 0, or the held value where `inv` is 0 (a fine row of an
/// FMG start): `hold[i]`, or `+0` where `hold` is `None` (every hold `+0`,
/// `Level::hold_zero`: the array not read; session 40).
#[inline(always)]
fn fill(out: &mut [f64], inv: &[f64], hold: Option<&[f64]>, v: impl Fn(usize) -> f64) {
    match hold {
        Some(hold) => {
            for i in 0..out.len() {
                out[i] = if inv[i] == 0.0 {
                    hold[i]
                } else {
                    v(i).max(0.0)
                };
            }
        }
        None => {
            for i in 0..out.len() {
                out[i] = if inv[i] == 0.0 { 0.0 } else { v(i).max(0.0) };
            }
        }
    }
}

/// `fine.p = P₄ coarse.p`: the FMG start of an explicit grid by cubic interpolation (the
/// tensor product of four-point Lagrange interpolation at the midpoints: periodic in θ, in
/// ζ one-sided next to the end faces, whose rows are 0), clipped at 0; held nodes at their
/// value. Fourth order, above the discretisation's second: the interpolated coarse
/// solution's error is then the coarse grid's discretisation error, which one V-cycle
/// reduces below the fine grid's (the classical FMG condition; bilinear interpolation,
/// [`prolong_solution`], is itself second order and leaves an `O(h²)` interpolation error
/// of the size of the discretisation error). Below four coarse rows in ζ (or columns in θ)
/// the direction falls back to linear interpolation.
pub(crate) fn prolong_solution_cubic(fine: &mut Level, coarse: &Level, c: Coarsen) {
    // Widened by the compiler (issue 20, session 38).
    lanes::widened(CubicStart { fine, coarse, c })
}

/// [`prolong_solution_cubic`]'s arguments, for [`lanes::widened`].
struct CubicStart<'a> {
    fine: &'a mut Level,
    coarse: &'a Level,
    c: Coarsen,
}

impl lanes::Widen for CubicStart<'_> {
    type Out = ();
    #[inline(always)]
    fn run(self) {
        prolong_solution_cubic_body(self.fine, self.coarse, self.c)
    }
}

/// [`prolong_solution_cubic`]'s body, for each instruction set.
#[inline(always)]
fn prolong_solution_cubic_body(fine: &mut Level, coarse: &Level, c: Coarsen) {
    let (st, sz) = strides(c);
    let (cnt, cnz) = (coarse.nt, coarse.nz);
    let nt = fine.nt;
    let cubic_t = st == 2 && cnt >= 4;
    let cubic_z = sz == 2 && cnz >= 3;
    // First each coarse row interpolated in θ onto the fine columns, into the fine
    // level's scratch `base` (rows 0 ..= cnz of length nt; restriction overwrites it
    // before a cycle reads it); then the fine rows from those in ζ.
    let rows = &mut fine.base[..(cnz + 1) * nt];
    for jc in 0..=cnz {
        let u = &coarse.p[jc * cnt..(jc + 1) * cnt];
        let out = &mut rows[jc * nt..(jc + 1) * nt];
        if st == 1 {
            out.copy_from_slice(u);
            continue;
        }
        for ic in 0..cnt {
            // Neighbours ic − 1, ic + 1, ic + 2 (periodic), comparisons rather than `%`.
            let i1 = if ic + 1 == cnt { 0 } else { ic + 1 };
            let i2 = if i1 + 1 == cnt { 0 } else { i1 + 1 };
            out[2 * ic] = u[ic];
            out[2 * ic + 1] = if cubic_t {
                let i0 = if ic == 0 { cnt - 1 } else { ic - 1 };
                cubic_mid(u[i0], u[ic], u[i1], u[i2])
            } else {
                0.5 * (u[ic] + u[i1])
            };
        }
    }
    let rows = &fine.base[..(cnz + 1) * nt];
    let row = |jc: usize| &rows[jc * nt..(jc + 1) * nt];
    for j in 1..fine.nz {
        let (jc, jo) = (j / sz, j % sz);
        let out = &mut fine.p[j * nt..(j + 1) * nt];
        let inv = &fine.inv_d[j * nt..(j + 1) * nt];
        let hold = (!fine.hold_zero).then(|| &fine.hold[j * nt..(j + 1) * nt]);
        if jo == 0 {
            let a = row(jc);
            fill(out, inv, hold, |i| a[i]);
        } else if !cubic_z {
            let (a, b) = (row(jc), row(jc + 1));
            fill(out, inv, hold, |i| 0.5 * (a[i] + b[i]));
        } else if jc == 0 {
            let (a, b, c, d) = (row(0), row(1), row(2), row(3));
            fill(out, inv, hold, |i| cubic_edge(a[i], b[i], c[i], d[i]));
        } else if jc + 1 == cnz {
            let (a, b, c, d) = (row(cnz), row(cnz - 1), row(cnz - 2), row(cnz - 3));
            fill(out, inv, hold, |i| cubic_edge(a[i], b[i], c[i], d[i]));
        } else {
            let (a, b, c, d) = (row(jc - 1), row(jc), row(jc + 1), row(jc + 2));
            fill(out, inv, hold, |i| cubic_mid(a[i], b[i], c[i], d[i]));
        }
    }
}

/// A grid hierarchy, coarsest first: `levels[0]` is the coarsest, `levels[l].coarsen`
/// says how `levels[l]` relates to `levels[l − 1]`.
#[derive(Default)]
pub(crate) struct Hierarchy {
    pub levels: Vec<Level>,
    /// Angle of node 0 on every level, rad (see [`Level::setup`]).
    pub theta0: f64,
    /// Relaxation node updates done (work measure: all levels, smoothing and coarsest).
    pub updates: u64,
    /// Levels of an earlier, taller hierarchy kept for their allocations: the accuracy
    /// ladder adds grids on top per state ([`Hierarchy::push_finer`]) and the next state's
    /// [`Hierarchy::build`] drops them again; allocated afresh each time, the finest
    /// (512 × 64: 11 arrays of 260 kB) came from and went back to the system per state.
    /// [`Level::setup`] writes every array a cycle reads before it is read, so a reused
    /// level is a fresh one.
    spare: Vec<Level>,
    /// Whether the correction grids freeze one node per row for the max-film inlet line
    /// (explicit grids, issue 20 pass 3) or every node whose stencil touches it (the
    /// accuracy ladder, unchanged: with node 0 on the maximum film the two rules coincide
    /// unless the journal is tilted out of the plane of its eccentricity). The WGSL kernel
    /// (`inlet_line` in shaders/finite_mg.wgsl) follows the same split. See [`freeze`].
    pub line_freeze: bool,
    /// Whether load vectors are summed by Simpson's rule in ζ (the accuracy ladder of the
    /// plain 360° film, issue 20 pass 4) instead of the rectangle rule (explicit grids,
    /// grooves and arcs); see [`super::solver::ladder_integrals_on`].
    pub simpson_z: bool,
    /// The V-cycle's smoother and sweeps (see [`MgCycle`]).
    pub cycle: MgCycle,
    /// Where the node updates go, for probes (`None`, the default: not kept; see
    /// [`WorkShare`]).
    pub tally: Option<Vec<WorkShare>>,
    /// The level [`Hierarchy::iterate`] last made the top one (the tally's key).
    cur_top: usize,
    /// Per V-cycle of [`Hierarchy::iterate`] on the field stop, for probes (`None`, the
    /// default: not kept; issue 20 session 41, the stall on fine grids): see [`CycleLog`].
    pub cycle_log: Option<Vec<CycleLog>>,

    /// Whether the coarse-grid correction is also truncated on the coarse side (see
    /// [`truncate_outside_zone`]; issue 20 session 41). Default false: the correction as
    /// the WGSL kernel mirrors it (shaders/finite_mg.wgsl `prolong_correction`). On, the
    /// V-cycle contracts on the fine grids where it stalls without it (ε 0.9, 4096 × 512:
    /// ~0.47 per cycle instead of ~1).
    pub coarse_truncation: bool,
    /// How the coarsest grid is solved inside a V-cycle.
    pub coarsest: CoarsestSolve,
    /// Smoothing sweeps (before, after the correction) on the levels below the grid being
    /// solved, instead of the cycle's (`None`, the default: the cycle's everywhere; a
    /// probe of cheaper coarse-level smoothing, issue 20 session 38).
    pub below_top: Option<(u32, u32)>,
}

/// How the coarsest grid is solved inside a V-cycle (issue 20, session 38; see
/// [`Level::solve_coarsest`]). The first grid of full multigrid or of the accuracy ladder,
/// solved as the grid itself, keeps its own stop (the solve's tolerance).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum CoarsestSolve {
    /// Projected SOR until the estimated remaining change is below this fraction of the
    /// field's largest value (1e-12: the rule before session 38).
    Field(f64),
    /// Projected SOR until the estimated remaining change is below this fraction of the
    /// coarse-grid correction's largest value `max |u_H − u₀|` (or 1e-12 of the field's,
    /// if larger). The default: [`COARSEST_CORRECTION`].
    Correction(f64),
    /// Exactly this many projected SOR sweeps (probes).
    Sweeps(u32),
}

impl Default for CoarsestSolve {
    fn default() -> Self {
        CoarsestSolve::Correction(COARSEST_CORRECTION)
    }
}

/// What a relaxation's node updates were for (the work breakdown of issue 20, session 38).
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
pub enum WorkRole {
    /// The coarsest grid solved as the grid being solved (the first grid of full
    /// multigrid, or of the accuracy ladder).
    Solve,
    /// Smoothing sweeps before the coarse-grid correction on a level.
    Pre,
    /// The coarsest grid's solve inside a V-cycle (the coarse-grid correction's end).
    Coarsest,
    /// Smoothing sweeps after the coarse-grid correction on a level.
    Post,
}

/// One entry of the work breakdown ([`Hierarchy::tally`]): node updates on the grid
/// `level` in the role `role` while the grid `top` was being solved.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct WorkShare {
    /// The grid being solved `(n_theta, n_z)`.
    pub top: (usize, usize),
    /// The grid relaxed `(n_theta, n_z)`.
    pub level: (usize, usize),
    /// What for.
    pub role: WorkRole,
    /// Relaxation node updates.
    pub updates: u64,
    /// Sweeps over the grid (updates over its interior nodes).
    pub sweeps: u64,
    /// Calls (smoothing stages, coarsest solves).
    pub calls: u64,
}

/// One V-cycle of [`Hierarchy::iterate`] on the field stop, as a probe sees it
/// ([`Hierarchy::cycle_log`]; issue 20 session 41).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CycleLog {
    /// The grid solved `(n_theta, n_z)`.
    pub grid: (usize, usize),
    /// The cycle's number on this grid (from 1).
    pub cycle: u32,
    /// The field's largest change over the cycle over its maximum.
    pub change: f64,
    /// Nodes whose pressure went from 0 to positive or back over the cycle.
    pub flips: usize,
    /// Where the largest change is: column, row, and the pressure there over the maximum.
    pub at: (usize, usize, f64),
}

/// The V-cycle: smoother and smoothing sweeps (issue 20, session 37).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct MgCycle {
    /// Smooth by zebra ζ-lines ([`Level::smooth_lines`], each line's complementarity
    /// problem solved exactly) on the grids where ζ is the strongly coupled direction
    /// (`1/Δζ² > λ/Δθ²`), red-black points elsewhere; false: red-black points everywhere.
    /// Default false.
    pub z_lines: bool,
    /// Smoothing sweeps before the coarse-grid correction (≥ 1: the residual is formed
    /// after a sweep). Default 2.
    pub pre: u32,
    /// Smoothing sweeps after the coarse-grid correction. Default 1.
    pub post: u32,
}

impl Default for MgCycle {
    fn default() -> Self {
        MgCycle {
            z_lines: false,
            pre: NU_PRE,
            post: NU_POST,
        }
    }
}

impl Hierarchy {
    /// Adds `sweeps` sweeps of level `l` in role `role` to the tally, if one is kept.
    fn count(&mut self, l: usize, role: WorkRole, sweeps: u64) {
        let Some(t) = self.tally.as_mut() else {
            return;
        };
        let dims = |lvl: &Level| (lvl.nt, lvl.nz);
        let (top, level) = (dims(&self.levels[self.cur_top]), dims(&self.levels[l]));
        let updates = sweeps * self.levels[l].interior() as u64;
        match t
            .iter_mut()
            .find(|w| w.top == top && w.level == level && w.role == role)
        {
            Some(w) => {
                w.updates += updates;
                w.sweeps += sweeps;
                w.calls += 1;
            }
            None => t.push(WorkShare {
                top,
                level,
                role,
                updates,
                sweeps,
                calls: 1,
            }),
        }
    }

    /// Builds (reusing allocations) the hierarchy below and including `nt × nz`.
    pub fn build(&mut self, job: &FiniteJob, nt: usize, nz: usize, g: &FiniteGrid) {
        let mut dims = vec![(nt, nz, None)];
        let (mut a, mut b) = (nt, nz);
        while let Some((c, d, how)) = coarser(a, b, job.aspect) {
            dims.last_mut().expect("nonempty").2 = Some(how);
            dims.push((c, d, None));
            a = c;
            b = d;
        }
        dims.reverse();
        // Levels beyond the new hierarchy go to the spares, missing ones come from them:
        // their arrays keep their capacity (see `Hierarchy::spare`).
        while self.levels.len() > dims.len() {
            let lvl = self.levels.pop().expect("nonempty");
            self.spare.push(lvl);
        }
        while self.levels.len() < dims.len() {
            self.levels.push(self.spare.pop().unwrap_or_default());
        }
        for (l, &(a, b, how)) in dims.iter().enumerate() {
            let (lo, hi) = self.levels.split_at_mut(l);
            let lvl = &mut hi[0];
            lvl.setup(
                job,
                a,
                b,
                g.max_film_inlet,
                &g.layout,
                self.theta0,
                lo.last(),
                // The coarsest grid's solve starts from 0; every finer grid's iterate is
                // written before it is read (the FMG start's interpolation, a warm start's
                // `load_field`, or a finer grid's restriction; issue 20, session 39: the
                // zeroing was a pass of `memset` over every level per state).
                l == 0,
            );
            lvl.coarsen = how;
        }
    }

    /// Adds a finer level on top (`how` relates it to the current top). Its iterate is 0 on
    /// the end rows only: the caller writes the interior before a cycle reads it (the
    /// accuracy ladder's interpolation from the level below, [`prolong_solution`]); zeroed
    /// too, it was a pass of `memset` over the ladder's largest arrays per state (issue 20,
    /// session 36).
    pub fn push_finer(
        &mut self,
        job: &FiniteJob,
        nt: usize,
        nz: usize,
        g: &FiniteGrid,
        how: Coarsen,
    ) {
        let mut lvl = self.spare.pop().unwrap_or_default();
        let below = self.levels.last();
        lvl.setup(
            job,
            nt,
            nz,
            g.max_film_inlet,
            &g.layout,
            self.theta0,
            below,
            false,
        );
        lvl.coarsen = Some(how);
        self.levels.push(lvl);
    }

    /// One V-cycle on level `l` (its `f` set by the caller).
    pub fn vcycle(&mut self, l: usize, aspect: f64) {
        if l == 0 || self.levels[l].coarsen.is_none() {
            // Coarse enough: solve (to what the correction needs, see `CoarsestSolve`).
            let u = match self.coarsest {
                CoarsestSolve::Field(t) => self.levels[l].solve_coarsest(aspect, t, 0.0, None),
                CoarsestSolve::Correction(r) => {
                    self.levels[l].solve_coarsest(aspect, 1e-12, r, None)
                }
                CoarsestSolve::Sweeps(n) => {
                    self.levels[l].solve_coarsest(aspect, 1e-12, 0.0, Some(n))
                }
            };
            self.updates += u;
            if self.tally.is_some() {
                let n = self.levels[l].interior() as u64;
                self.count(l, WorkRole::Coarsest, u / n.max(1));
            }
            return;
        }
        let how = self.levels[l].coarsen.expect("checked");
        let (nu_pre, nu_post) = match self.below_top {
            Some((pre, post)) if l != self.cur_top => (pre.max(1), post),
            _ => (self.cycle.pre.max(1), self.cycle.post),
        };
        let fine = &mut self.levels[l];
        let lines = self.cycle.z_lines && fine.z_strong;
        for _ in 0..nu_pre {
            if lines {
                fine.smooth_lines();
            } else {
                fine.smooth();
            }
        }
        self.updates += nu_pre as u64 * fine.interior() as u64;
        if self.tally.is_some() {
            self.count(l, WorkRole::Pre, nu_pre as u64);
        }
        let (lo, hi) = self.levels.split_at_mut(l);
        let fine = &mut hi[0];
        let coarse = &mut lo[l - 1];
        if lines {
            fine.residual_on::<true>();
        } else {
            fine.residual();
        }
        restrict_fas(fine, coarse, how);
        self.vcycle(l - 1, aspect);
        let (lo, hi) = self.levels.split_at_mut(l);
        let fine = &mut hi[0];
        prolong_correction(fine, &mut lo[l - 1], how, self.coarse_truncation);
        for _ in 0..nu_post {
            if lines {
                fine.smooth_lines();
            } else {
                fine.smooth();
            }
        }
        self.updates += nu_post as u64 * fine.interior() as u64;
        if self.tally.is_some() {
            self.count(l, WorkRole::Post, nu_post as u64);
        }
    }

    /// V-cycles on the top level `l` (own right-hand side) until the estimated iteration
    /// error is below the tolerance of `stop`, at most `max_cycles`; returns (cycles,
    /// estimated error, converged).
    pub fn iterate(
        &mut self,
        l: usize,
        aspect: f64,
        stop: Stop,
        max_cycles: u32,
    ) -> (u32, f64, bool) {
        self.make_top(l);
        if l == 0 || self.levels[l].coarsen.is_none() {
            let u = self.levels[l].solve_coarsest(aspect, stop.tolerance(), 0.0, None);
            self.updates += u;
            if self.tally.is_some() {
                let n = self.levels[l].interior() as u64;
                self.count(l, WorkRole::Solve, u / n.max(1));
            }
            return (1, 0.0, true);
        }
        let simpson = self.simpson_z;
        // The loads before the first cycle: only the load stop reads them.
        let mut prev_loads = match stop {
            Stop::Loads(_) => self.levels[l].loads(self.theta0, simpson),
            Stop::Field(_) => [0.0; 4],
        };
        let mut last_change = f64::INFINITY;
        let mut err = f64::INFINITY;
        for cycle in 1..=max_cycles {
            // The field before the cycle: copied before the first, and by the field stop's
            // loop after each (`change_and_max`: one pass over the field less per cycle).
            // In the grid's own `base` (its `u₀` as a coarse grid: unused while it is the
            // grid solved, written by the restriction before it serves as one again;
            // issue 20, session 39: a vector of the grid's size was allocated per call).
            if let (Stop::Field(_), 1) = (stop, cycle) {
                let lvl = &mut self.levels[l];
                let n = lvl.len();
                lvl.base[..n].copy_from_slice(&lvl.p[..n]);
            }
            self.vcycle(l, aspect);
            let lvl = &mut self.levels[l];
            let n = lvl.len();
            let (p, prev) = (&lvl.p[..n], &mut lvl.base[..n]);
            if let (Some(log), Stop::Field(_)) = (self.cycle_log.as_mut(), stop) {
                let (mut dm, mut at, mut flips, mut maxp) = (0.0f64, 0, 0, 0.0f64);
                for (k, (a, b)) in p.iter().zip(prev.iter()).enumerate() {
                    let d = (a - b).abs();
                    if d > dm {
                        dm = d;
                        at = k;
                    }
                    flips += usize::from((*a > 0.0) != (*b > 0.0));
                    maxp = maxp.max(*a);
                }
                log.push(CycleLog {
                    grid: (lvl.nt, lvl.nz),
                    cycle,
                    change: dm / maxp,
                    flips,
                    at: (at % lvl.nt, at / lvl.nt, p[at] / maxp),
                });
            }
            // The change of this cycle, relative: of the field over its maximum, or of
            // the load integrals over their norm.
            let change = match stop {
                Stop::Field(_) => {
                    // Widened (issue 20 session 38: this test was a fifth of a 128 × 32
                    // solve's instructions after the passes went into lanes).
                    let (change, max_p) = lanes::widened(ChangeAndMax(p, prev));
                    if max_p > 0.0 {
                        change / max_p
                    } else {
                        0.0
                    }
                }
                Stop::Loads(_) => {
                    let now = self.levels[l].loads(self.theta0, simpson);
                    let change = load_change(&now, &prev_loads);
                    prev_loads = now;
                    change
                }
            };
            err = tail_estimate(change, last_change);
            last_change = change;
            if change == 0.0 || err <= stop.tolerance() {
                return (cycle, err, true);
            }
        }
        (max_cycles, err, false)
    }

    /// One V-cycle on level `l` made the top one, as [`Hierarchy::iterate`] with one cycle
    /// does it, without its stop test (the change over the cycle, which only decides
    /// whether to stop and what to report): full multigrid's intermediate grids, whose
    /// one cycle's report no one reads (issue 20, session 39: the field's copy and the
    /// test's pass on each). The same fields, bit for bit.
    pub fn cycle_once(&mut self, l: usize, aspect: f64, stop: Stop) {
        if l == 0 || self.levels[l].coarsen.is_none() {
            self.iterate(l, aspect, stop, 1);
            return;
        }
        self.make_top(l);
        self.vcycle(l, aspect);
    }

    /// Makes level `l` the one solved: its holds and own right-hand side in force, the
    /// levels below it frozen as its correction grids (see [`freeze`]).
    fn make_top(&mut self, l: usize) {
        for (n, lvl) in self.levels.iter_mut().enumerate() {
            lvl.top = n == l;
        }
        self.cur_top = l;
        // Its own right-hand side (no copy: see `Level::f_is_own`).
        self.levels[l].f_is_own = true;
        for m in (1..=l).rev() {
            if let Some(how) = self.levels[m].coarsen {
                let (lo, hi) = self.levels.split_at_mut(m);
                freeze(&hi[0], &mut lo[m - 1], how, self.line_freeze);
            }
        }
    }
}

/// The largest `|p − prev|` and the largest `p` (from `+0`): the field stop's change and
/// maximum, in eight independent maxima (two AVX2 registers or one AVX-512 register once
/// [`lanes::widened`]) folded at the end. A maximum does not depend on the order it is
/// taken in (`d ≥ +0`; a `−0` field value never beats the `+0` start; comparisons, not
/// `f64::max`, whose NaN rule kept the loop scalar: the field is finite), so these are the
/// same maxima, bit for bit, as one running maximum (issue 20, session 38). `prev` is
/// left equal to `p` (the next cycle's `prev`).
struct ChangeAndMax<'a>(&'a [f64], &'a mut [f64]);

impl lanes::Widen for ChangeAndMax<'_> {
    type Out = (f64, f64);
    #[inline(always)]
    fn run(self) -> (f64, f64) {
        change_and_max(self.0, self.1)
    }
}

/// [`ChangeAndMax`]'s body.
#[inline(always)]
fn change_and_max(p: &[f64], prev: &mut [f64]) -> (f64, f64) {
    const CHAINS: usize = 8;
    let (mut ch, mut mp) = ([0.0_f64; CHAINS], [0.0_f64; CHAINS]);
    let n = p.len().min(prev.len());
    let (p, prev) = (&p[..n], &mut prev[..n]);
    let (pc, mut qc) = (p.chunks_exact(CHAINS), prev.chunks_exact_mut(CHAINS));
    let pr = pc.remainder();
    for (a, b) in pc.zip(&mut qc) {
        for k in 0..CHAINS {
            let d = (a[k] - b[k]).abs();
            ch[k] = if d > ch[k] { d } else { ch[k] };
            mp[k] = if a[k] > mp[k] { a[k] } else { mp[k] };
            b[k] = a[k];
        }
    }
    for (a, b) in pr.iter().zip(qc.into_remainder()) {
        let d = (*a - *b).abs();
        ch[0] = if d > ch[0] { d } else { ch[0] };
        mp[0] = if *a > mp[0] { *a } else { mp[0] };
        *b = *a;
    }
    let fold = |v: [f64; CHAINS]| v.iter().fold(0.0_f64, |m, &x| if x > m { x } else { m });
    (fold(ch), fold(mp))
}

/// Relative change of a load vector over a cycle, `|now − prev| / |now|` (0 for a zero
/// vector): what the load stop of [`Hierarchy::iterate`] and the accuracy ladder's
/// per-grid stop (`FiniteSolver::ladder_cycles`) measure.
pub(crate) fn load_change(now: &[f64; 4], prev: &[f64; 4]) -> f64 {
    let d = (0..4).map(|k| (now[k] - prev[k]).powi(2)).sum::<f64>();
    let norm = now.iter().map(|v| v * v).sum::<f64>().sqrt();
    if norm > 0.0 {
        d.sqrt() / norm
    } else {
        0.0
    }
}

/// Estimated iteration error after a cycle that changed the iterate by `change` when the
/// cycle before changed it by `last_change` (both relative): the geometric tail
/// `change ρ/(1 − ρ)` of the contraction per cycle `ρ`, measured as `change/last_change`
/// within [0.1, 0.95] (0.1: a typical multigrid factor), and 0.5 until measured.
pub(crate) fn tail_estimate(change: f64, last_change: f64) -> f64 {
    let rho = if last_change.is_finite() && last_change > 0.0 {
        (change / last_change).clamp(0.1, 0.95)
    } else {
        0.5
    };
    change * rho / (1.0 - rho)
}

/// Estimated iteration error of a load vector (relative to `norm`, its norm) after a
/// cycle that changed it by `delta` when the cycle before changed it by `last_delta`
/// (zero: not measured): the geometric tail `|δ| |ρ|/(1 − ρ)` of the contraction of the
/// vector itself, `ρ = δ·δ₋₁/|δ₋₁|²` (a negative ρ an alternating tail), within
/// [−0.95, 0.95] and |ρ| at least 0.1 (a typical multigrid factor, as
/// [`tail_estimate`]); 0.5 until measured, as there. What the accuracy ladder reports as
/// its last grid's iteration error (issue 20 session 41, s41-honest2): the norms' ratio
/// `|δ|/|δ₋₁|` of [`tail_estimate`] (the stop's) counts changes that turn direction from
/// cycle to cycle as contraction, and made the ε 0.7 squeezed test state's estimate 3.65×
/// its true error at accuracy 1e-3 (iteration term 1.51e-4 against a true 1.57e-5; this
/// one 5.9e-5, the estimate 2.60×; examples/bench_worst.rs).
pub(crate) fn load_tail_estimate(delta: &[f64; 4], last_delta: &[f64; 4], norm: f64) -> f64 {
    if norm <= 0.0 {
        return 0.0;
    }
    let d = delta.iter().map(|x| x * x).sum::<f64>().sqrt() / norm;
    let l2 = last_delta.iter().map(|x| x * x).sum::<f64>();
    let rho = if l2 > 0.0 {
        let dot = (0..4).map(|q| delta[q] * last_delta[q]).sum::<f64>();
        (dot / l2).clamp(-0.95, 0.95)
    } else {
        0.5
    };
    d * rho.abs().max(0.1) / (1.0 - rho)
}

/// When the V-cycles on a grid stop.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) enum Stop {
    /// Estimated iteration error of the field over its maximum below this (explicit
    /// grids: `finite.tolerance`).
    Field(f64),
    /// Estimated iteration error of the load integrals over their norm below this (the
    /// accuracy ladder: a fraction of the requested accuracy, see
    /// [`super::solver::ALGEBRAIC_FRACTION`]).
    Loads(f64),
}

impl Stop {
    fn tolerance(self) -> f64 {
        match self {
            Stop::Field(t) | Stop::Loads(t) => t,
        }
    }
}

impl Level {
    /// The discrete operator for post-processing a converged field ([`super::flow`]):
    /// east and north face coefficients, this grid's own right-hand side `f = −rhs`, and
    /// the inverse diagonal in force when solved (0 at held nodes).
    pub(crate) fn operator(&self) -> (&[f64], &[f64], &[f64], &[f64]) {
        (&self.ae, &self.an, &self.f_own, &self.inv_d)
    }

    /// Load integrals of the iterate, node 0 at angle `theta0`: by Simpson's rule in ζ
    /// when `simpson` (see [`Hierarchy::simpson_z`]), else by the rectangle rule.
    /// The column angles come from the level's table (the same bits as
    /// [`super::solver::ladder_integrals_on`]'s and [`super::solver::integrals_on`]'s own,
    /// see [`Level::set_trig`]) when `theta0` is the level's.
    pub(crate) fn loads(&self, theta0: f64, simpson: bool) -> [f64; 4] {
        let (nt, nz) = (self.nt, self.nz);
        if self.trig_of != (nt, theta0.to_bits()) {
            return if simpson {
                super::solver::ladder_integrals_on(&self.p, nt, nz, theta0)
            } else {
                super::solver::integrals_on(&self.p, nt, nz, theta0)
            };
        }
        // Odd `n_z` (never on the ladder): the rectangle rule, as `ladder_integrals_on`.
        if simpson && nz.is_multiple_of(2) {
            super::solver::row_weighted_with(&self.p, nt, nz, &self.cols, |j| {
                super::solver::simpson_row_weight(j)
            })
        } else {
            super::solver::row_weighted_with(&self.p, nt, nz, &self.cols, |_| 1.0)
        }
    }

    /// Copies a warm-start field of this grid's length in (held nodes set to their value).
    pub fn load_field(&mut self, field: &[f64]) {
        for (k, (p, v)) in self.p.iter_mut().zip(field).enumerate() {
            let interior = k >= self.nt && k < self.nt * self.nz;
            *p = if !interior {
                0.0
            } else if self.inv_d[k] != 0.0 {
                *v
            } else {
                self.hold[k]
            };
        }
    }
}

#[cfg(test)]
mod tests {
    use super::{
        change_and_max, lanes, line_lcp, prolong_correction_with, prolong_solution_with,
        restrict_fas_with, ChangeAndMax, Coarsen, CubicStart, Freeze, Hierarchy, Level,
        LineScratch, COARSEST_CORRECTION,
    };
    use crate::bearing::finite::{FiniteGrid, FiniteJob};
    use crate::bearing::LaneIsa;
    use crate::bearing::{pack_state, BearingParams, BearingState, FilmModel};

    /// The LCP of a correction grid (`f`, no holds, `inv_d_free`) by projected
    /// Gauss–Seidel node by node from `start` until a sweep changes nothing (the
    /// brute-force reference, written out here independently of `Level::relax`).
    fn level_pgs(lvl: &Level, start: &[f64]) -> Vec<f64> {
        let (nt, nz) = (lvl.nt, lvl.nz);
        let mut p = start.to_vec();
        for _ in 0..1_000_000 {
            let mut change = 0.0_f64;
            for j in 1..nz {
                for i in 0..nt {
                    let k = j * nt + i;
                    if lvl.inv_d_free[k] == 0.0 {
                        continue;
                    }
                    let (e, w) = (j * nt + (i + 1) % nt, j * nt + (i + nt - 1) % nt);
                    let s = lvl.ae[k] * p[e]
                        + lvl.ae[w] * p[w]
                        + lvl.an[k] * p[k + nt]
                        + lvl.an[k - nt] * p[k - nt];
                    let v = ((s + lvl.f[k]) / lvl.d[k]).max(0.0);
                    change = change.max((v - p[k]).abs());
                    p[k] = v;
                }
            }
            if change == 0.0 {
                break;
            }
        }
        p
    }

    /// The coarsest grid's solve inside a V-cycle stops at [`COARSEST_CORRECTION`] of the
    /// correction (issue 20, session 38): on the coarsest grids of the accuracy ladder
    /// (16 × 2) and of explicit grids (16 × 4) for random states (ε 0.05-0.95, tilted,
    /// squeezed), started from the exact solution perturbed (smoothly and node by node,
    /// some nodes cavitated or lifted), every node of the result is within that fraction
    /// of the correction's largest value `max |p − u₀|` of the exact solution (projected
    /// Gauss–Seidel to a fixed point), and the solve takes fewer sweeps than the 1e-12
    /// stop before it.
    /// The inlet line's angles taken from the coarser grid's rows (`Hierarchy::build`) are
    /// those each grid finds alone (every row by `atan2`), bit for bit, and so are its held
    /// columns and inverse diagonal: journals tilted out of the plane of their
    /// eccentricity, whose inlet column moves along ζ.
    #[test]
    fn inlet_angles_from_the_coarser_grid_match_each_grid_alone() {
        let mut rng = Lcg(20_39);
        let p = BearingParams {
            model: FilmModel::Finite,
            ..BearingParams::paper_table2()
        };
        let d = p.clearance;
        let mut rows = 0;
        for trial in 0..40 {
            let (ei, ej) = (0.05 + 0.9 * rng.next(), 0.05 + 0.9 * rng.next());
            let (ai, aj) = (6.3 * rng.next(), 6.3 * rng.next());
            let state = BearingState {
                xi: ei * d * ai.cos(),
                yi: ei * d * ai.sin(),
                xj: ej * d * aj.cos(),
                yj: ej * d * aj.sin(),
                vxi: 0.0,
                vyi: 0.0,
                vxj: 0.0,
                vyj: 0.0,
                omega: 400.0,
            };
            let job = FiniteJob::new(&p, &pack_state(&p, &state).expect("a valid state"));
            let (nt, nz) = [(128, 32), (64, 16), (96, 24), (128, 8)][trial % 4];
            let g = FiniteGrid {
                max_film_inlet: true,
                ..FiniteGrid::for_bearing(&p)
            };
            let mut h = Hierarchy::default();
            h.build(&job, nt, nz, &g);
            for lvl in &h.levels {
                let mut alone = Level::default();
                alone.setup(&job, lvl.nt, lvl.nz, true, &g.layout, 0.0, None, true);
                let angles = |l: &Level| -> Vec<u64> {
                    l.inlet_angles.iter().map(|a| a.2.to_bits()).collect()
                };
                assert_eq!(angles(lvl), angles(&alone), "{nt} x {nz}, trial {trial}");
                assert_eq!(lvl.inlet_col, alone.inlet_col);
                assert_eq!(bits(&lvl.inv_d), bits(&alone.inv_d));
                rows += lvl.inlet_col.iter().filter(|c| **c != usize::MAX).count();
            }
        }
        assert!(rows > 1000, "{rows} rows with an inlet node");
    }

    #[test]
    fn coarsest_correction_stop_is_within_its_bound() {
        let mut rng = Lcg(20_38);
        let p = BearingParams {
            model: FilmModel::Finite,
            ..BearingParams::paper_table2()
        };
        let d = p.clearance;
        let (mut loose, mut tight, mut worst) = (0u64, 0u64, 0.0_f64);
        for trial in 0..80 {
            let (e, tilt, ang) = (
                0.05 + 0.9 * rng.next(),
                0.1 * (rng.next() - 0.5),
                6.3 * rng.next(),
            );
            let sq = if trial % 3 == 0 {
                rng.next() - 0.5
            } else {
                0.0
            };
            let w = 400.0;
            let (ei, ej) = ((e + tilt).clamp(0.0, 0.95), (e - tilt).clamp(0.0, 0.95));
            let state = BearingState {
                xi: ei * d * ang.cos(),
                yi: ei * d * ang.sin(),
                xj: ej * d * ang.cos(),
                yj: ej * d * ang.sin(),
                vxi: sq * d * w * ang.cos(),
                vyi: sq * d * w * ang.sin(),
                vxj: sq * d * w * ang.cos(),
                vyj: sq * d * w * ang.sin(),
                omega: w,
            };
            let job = FiniteJob::new(&p, &pack_state(&p, &state).expect("a valid state"));
            let (nt, nz) = if trial % 2 == 0 { (16, 2) } else { (16, 4) };
            let g = FiniteGrid::for_bearing(&p);
            let mut h = Hierarchy::default();
            h.build(&job, nt, nz, &g);
            assert_eq!(h.levels.len(), 1, "{nt}×{nz} is a coarsest grid");
            let lvl = &mut h.levels[0];
            lvl.top = false;
            lvl.f = lvl.f_own.clone();
            // The correction grid's inverse diagonal without holds (`freeze`'s, with no
            // finer grid: 1/d inside, 0 on the end rows).
            lvl.inv_d_free = lvl
                .d
                .iter()
                .map(|d| if *d != 0.0 { 1.0 / d } else { 0.0 })
                .collect();
            let exact = level_pgs(lvl, &vec![0.0; lvl.len()]);
            let peak = exact.iter().fold(0.0_f64, |m, v| m.max(*v));
            // u₀: the solution with a smooth error and node noise, some nodes cavitated
            // (0) and some lifted off 0, as a fine iterate's injection is.
            let (amp, phase) = (0.3 * rng.next(), 6.3 * rng.next());
            let mut u0 = exact.clone();
            for j in 1..nz {
                for i in 0..nt {
                    let k = j * nt + i;
                    let th = i as f64 / nt as f64 * 6.3 + phase;
                    let r = rng.next();
                    let v = exact[k] * (1.0 + amp * th.sin()) + 0.05 * peak * (rng.next() - 0.5);
                    u0[k] = if r < 0.05 {
                        0.0
                    } else if r < 0.1 {
                        0.1 * peak * rng.next()
                    } else {
                        v.max(0.0)
                    };
                }
            }
            let run = |lvl: &mut Level, rel: f64| {
                lvl.base.copy_from_slice(&u0);
                lvl.p.copy_from_slice(&u0);
                lvl.solve_coarsest(job.aspect, 1e-12, rel, None) / lvl.interior() as u64
            };
            tight += run(lvl, 0.0);
            loose += run(lvl, COARSEST_CORRECTION);
            let c = lvl
                .p
                .iter()
                .zip(&u0)
                .fold(0.0_f64, |m, (a, b)| m.max((a - b).abs()));
            let err = lvl
                .p
                .iter()
                .zip(&exact)
                .fold(0.0_f64, |m, (a, b)| m.max((a - b).abs()));
            assert!(c > 0.0, "trial {trial}: a correction");
            worst = worst.max(err / c);
            assert!(
                err <= COARSEST_CORRECTION * c,
                "trial {trial} ({nt}×{nz}, ε {e:.2}): a node {err:.3e} off the exact \
                 solution, above {COARSEST_CORRECTION} of the correction {c:.3e}"
            );
        }
        println!("sweeps: {loose} to the correction's need, {tight} to 1e-12; worst {worst:.3e}");
        assert!(loose < tight, "{loose} sweeps, not below {tight}");
    }

    /// A small linear congruential generator (deterministic, no dependency): uniform in
    /// [0, 1).
    struct Lcg(u64);

    impl Lcg {
        fn next(&mut self) -> f64 {
            self.0 = self
                .0
                .wrapping_mul(6_364_136_223_846_793_005)
                .wrapping_add(1_442_695_040_888_963_407);
            (self.0 >> 11) as f64 / (1u64 << 53) as f64
        }
    }

    /// The same line by projected Gauss–Seidel to a fixed point (the brute-force
    /// reference: it converges for any M-matrix, slowly, from any start).
    fn projected_gs(l: &LineScratch, nz: usize) -> Vec<f64> {
        let mut p = l.val.clone();
        for (v, fixed) in p.iter_mut().zip(&l.fixed).take(nz).skip(1) {
            if !fixed {
                *v = 0.0;
            }
        }
        for _ in 0..2_000_000 {
            let mut change = 0.0_f64;
            for j in 1..nz {
                if l.fixed[j] {
                    continue;
                }
                let v =
                    ((l.b[j] + l.up[j] * p[j + 1] + l.up[j - 1] * p[j - 1]) / l.diag[j]).max(0.0);
                change = change.max((v - p[j]).abs());
                p[j] = v;
            }
            if change == 0.0 {
                break;
            }
        }
        p
    }

    /// `line_lcp` against projected Gauss–Seidel on random M-matrix lines (diagonal the
    /// two ζ-couplings plus a random θ share, as on a grid), right-hand sides that
    /// cavitate the ends, the middle, both or nothing, some rows fixed (held or frozen
    /// nodes), starts from 0, from random values and from the solution of a nearby line:
    /// the same solution to rounding, and the complementarity conditions hold.
    // Rows j − 1, j, j + 1 of several arrays of the line.
    #[allow(clippy::needless_range_loop)]
    #[test]
    fn line_lcp_matches_projected_gauss_seidel() {
        let mut rng = Lcg(20_37);
        let mut l = LineScratch::default();
        let mut passes = Vec::new();
        for trial in 0..600 {
            let nz = 3 + (rng.next() * 60.0) as usize;
            l.resize(nz + 1);
            let scale = 10f64.powf(4.0 * rng.next() - 1.0);
            for j in 0..=nz {
                l.up[j] = if j < nz {
                    scale * (0.2 + rng.next())
                } else {
                    0.0
                };
                l.fixed[j] = j == 0 || j == nz;
                l.val[j] = 0.0;
            }
            // Shape of the right-hand side: 0 all positive, 1 cavitated ends, 2 cavitated
            // middle, 3 random signs, 4 all negative.
            let shape = trial % 5;
            for j in 1..nz {
                l.diag[j] = l.up[j] + l.up[j - 1] + scale * (0.05 + 2.0 * rng.next());
                let x = j as f64 / nz as f64;
                let base = match shape {
                    0 => 1.0,
                    1 => (0.3 - (x - 0.5).abs()) * 4.0,
                    2 => ((x - 0.5).abs() - 0.2) * 4.0,
                    3 => rng.next() - 0.5,
                    _ => -1.0,
                };
                l.b[j] = scale * (base + 0.3 * (rng.next() - 0.5));
                if rng.next() < 0.05 {
                    l.fixed[j] = true;
                    l.val[j] = if rng.next() < 0.5 { 0.0 } else { rng.next() };
                }
            }
            let reference = projected_gs(&l, nz);
            let start = trial % 3;
            for j in 1..nz {
                if !l.fixed[j] {
                    l.val[j] = match start {
                        0 => 0.0,
                        1 => rng.next() * reference.iter().cloned().fold(0.0, f64::max),
                        _ => reference[j] * (0.9 + 0.2 * rng.next()),
                    };
                }
            }
            passes.push(line_lcp(&mut l, nz));
            let top = reference.iter().cloned().fold(1e-300, f64::max);
            for j in 1..nz {
                assert!(
                    (l.val[j] - reference[j]).abs() <= 1e-10 * top,
                    "trial {trial} (nz {nz}, shape {shape}, start {start}) row {j}: line_lcp \
                     {} against projected Gauss–Seidel {}",
                    l.val[j],
                    reference[j]
                );
                if l.fixed[j] {
                    continue;
                }
                // Complementarity: p ≥ 0, w = T p − b ≥ 0, p w = 0 (to rounding).
                let w = l.diag[j] * l.val[j]
                    - l.up[j] * l.val[j + 1]
                    - l.up[j - 1] * l.val[j - 1]
                    - l.b[j];
                let wscale = scale * (top + 1.0) * 1e-9;
                assert!(
                    l.val[j] >= 0.0 && w >= -wscale,
                    "trial {trial} row {j}: p {} w {w}",
                    l.val[j]
                );
                assert!(
                    l.val[j] <= 1e-12 * top || w.abs() <= wscale,
                    "trial {trial} row {j}: p {} and w {w} both nonzero",
                    l.val[j]
                );
            }
        }
        // Finite termination in a few passes (a pass moves rows in and out of the set).
        let most = passes.iter().copied().max().unwrap_or(0);
        assert!(most <= 12, "line_lcp took up to {most} passes");
    }

    /// A level of `nt × nz` with a random operator, right-hand side and field from `seed`:
    /// held (solved grid) or frozen (correction grid) nodes where `inv == 0` (a tenth of
    /// the nodes, both arrays independently), holds of 0, −0 and positive values, a field
    /// with exact zeros of both signs and small negative values (from a projection's
    /// roundoff elsewhere), right-hand sides of both signs (relaxed nodes projected to 0).
    fn random_level(seed: u64, nt: usize, nz: usize, top: bool) -> Level {
        let mut rng = Lcg(seed);
        let n = nt * (nz + 1);
        let mut l = Level {
            nt,
            nz,
            top,
            ..Level::default()
        };
        let mut vals = |f: &mut dyn FnMut(&mut Lcg) -> f64| -> Vec<f64> {
            (0..n).map(|_| f(&mut rng)).collect()
        };
        l.ae = vals(&mut |r| 0.1 + r.next());
        l.an = vals(&mut |r| 0.1 + r.next());
        l.d = vals(&mut |r| 0.5 + 4.0 * r.next());
        l.f = vals(&mut |r| 3.0 * r.next() - 1.2);
        l.hold = vals(&mut |r| match (r.next() * 3.0) as u32 {
            0 => 0.0,
            1 => -0.0,
            _ => r.next(),
        });
        l.p = vals(&mut |r| match (r.next() * 12.0) as u32 {
            0 => 0.0,
            1 => -0.0,
            2 => -1e-3 * r.next(),
            _ => r.next(),
        });
        let held = |r: &mut Lcg| r.next() < 0.1;
        let mut inv = |held_too: &mut dyn FnMut(&mut Lcg) -> bool| -> Vec<f64> {
            l.d.iter()
                .map(|d| if held_too(&mut rng) { 0.0 } else { 1.0 / d })
                .collect()
        };
        l.inv_d = inv(&mut { held });
        l.inv_d_free = inv(&mut { held });
        l.r = vec![f64::NAN; n];
        l.base = vec![f64::NAN; n];
        l.f_own = l.f.clone();
        l
    }

    /// The bits of a field.
    fn bits(v: &[f64]) -> Vec<u64> {
        v.iter().map(|x| x.to_bits()).collect()
    }

    /// Every hold `+0` and the level told so (`Level::hold_zero`, a film without held
    /// bands: the lanes and the FMG starts then take `+0` without reading `hold`).
    fn zero_holds(l: &mut Level) {
        l.hold.fill(0.0);
        l.hold_zero = true;
    }

    /// The instruction sets with SIMD lanes this CPU runs (none: the lanes are not run and
    /// the scalar passes are the only ones).
    fn lane_isas() -> Vec<LaneIsa> {
        let mut v = Vec::new();
        #[cfg(target_arch = "x86_64")]
        {
            if std::arch::is_x86_feature_detected!("avx2") {
                v.push(LaneIsa::Avx2);
            }
            if std::arch::is_x86_feature_detected!("avx512f") {
                v.push(LaneIsa::Avx512);
            }
        }
        v
    }

    /// Row lengths: odd and even, shorter than one vector of 4 or 8 lanes, and several
    /// vectors long with every remainder.
    const ROW_LENGTHS: [usize; 22] = [
        2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 16, 17, 18, 20, 24, 31, 32, 33, 64,
    ];

    /// The smoother and the residual in SIMD lanes against the scalar passes, bit for bit
    /// (issue 20, session 38): random levels of every row length in [`ROW_LENGTHS`], 2 to 6
    /// intervals in ζ, solved grids (held nodes set) and correction grids (frozen nodes
    /// kept), three sweeps each followed by the residual (both colours, fields after
    /// projections); solved grids also with every hold `+0` and known so
    /// (`Level::hold_zero`: the lanes' smoother then has no select; session 40). Any lane
    /// off by one bit fails.
    #[test]
    fn lanes_smoother_and_residual_match_scalar_bit_for_bit() {
        let isas = lane_isas();
        let mut compared = 0;
        for (t, &nt) in ROW_LENGTHS.iter().enumerate() {
            for nz in 2..=6 {
                for (top, hold0) in [(true, false), (true, true), (false, false)] {
                    let seed = (t * 100 + nz * 2 + top as usize) as u64;
                    for &isa in &isas {
                        let mut a = random_level(seed, nt, nz, top);
                        let mut b = random_level(seed, nt, nz, top);
                        if hold0 {
                            zero_holds(&mut a);
                            zero_holds(&mut b);
                        }
                        for sweep in 0..3 {
                            a.relax::<false>(1.0);
                            b.smooth_on(isa);
                            assert_eq!(
                                bits(&a.p),
                                bits(&b.p),
                                "{isa:?} smoother, {nt} x {nz}, top {top}, hold 0 {hold0}, sweep {sweep}: {:?} against scalar {:?}",
                                b.p,
                                a.p
                            );
                            a.residual_on::<false>();
                            b.residual_lanes(isa);
                            assert_eq!(
                                bits(&a.r),
                                bits(&b.r),
                                "{isa:?} residual, {nt} x {nz}, top {top}, sweep {sweep}: {:?} against scalar {:?}",
                                b.r,
                                a.r
                            );
                        }
                        compared += 1;
                    }
                }
            }
        }
        eprintln!("lanes against scalar: {compared} levels ({isas:?})");
    }

    /// The truncated correction in SIMD lanes against the scalar pass, bit for bit: random
    /// fine levels (as above) with a random coarse correction for each coarsening, large
    /// negative corrections among them so that corrected nodes are projected to 0 inside a
    /// chunk (the lanes' fallback to node-by-node), held and frozen nodes, odd and even row
    /// lengths (θ coarsening: even ones only, as [`super::coarser`]); solved grids also with
    /// every hold `+0` and known so (session 40).
    #[test]
    fn lanes_correction_matches_scalar_bit_for_bit() {
        let isas = lane_isas();
        let mut compared = 0;
        for (t, &nt) in ROW_LENGTHS.iter().enumerate() {
            for cnz in 1..=3 {
                for c in [Coarsen::Both, Coarsen::Theta, Coarsen::Zeta] {
                    let (st, sz) = super::strides(c);
                    if nt % st != 0 {
                        continue;
                    }
                    let (cnt, nz) = (nt / st, cnz * sz);
                    if nz < 2 {
                        continue;
                    }
                    for (top, hold0) in [(true, false), (true, true), (false, false)] {
                        let seed = (t * 1000 + cnz * 10 + sz * 3 + st + top as usize) as u64;
                        let coarse_of = |seed: u64| {
                            let mut rng = Lcg(seed ^ 0x5eed);
                            let cn = cnt * (cnz + 1);
                            let mut c = Level {
                                nt: cnt,
                                nz: cnz,
                                ..Level::default()
                            };
                            c.p = (0..cn).map(|_| rng.next()).collect();
                            // Corrections mostly small, a fifth large and negative.
                            c.base =
                                c.p.iter()
                                    .map(|p| {
                                        let big = rng.next() < 0.2;
                                        p - if big { -2.0 } else { 0.2 * (rng.next() - 0.5) }
                                    })
                                    .collect();
                            c.r = vec![0.0; cn];
                            c
                        };
                        for &isa in &isas {
                            let (mut fa, mut fb) = (
                                random_level(seed, nt, nz, top),
                                random_level(seed, nt, nz, top),
                            );
                            if hold0 {
                                zero_holds(&mut fa);
                                zero_holds(&mut fb);
                            }
                            let (mut ca, mut cb) = (coarse_of(seed), coarse_of(seed));
                            prolong_correction_with(LaneIsa::Baseline, &mut fa, &mut ca, c, false);
                            prolong_correction_with(isa, &mut fb, &mut cb, c, false);
                            assert_eq!(
                                bits(&fa.p),
                                bits(&fb.p),
                                "{isa:?} correction {c:?}, {nt} x {nz}, top {top}, hold 0 {hold0}: {:?} against scalar {:?}",
                                fb.p,
                                fa.p
                            );
                            compared += 1;
                        }
                    }
                }
            }
        }
        eprintln!("lanes' correction against scalar: {compared} levels ({isas:?})");
    }

    /// The FAS restriction in SIMD lanes against the scalar pass, bit for bit: random fine
    /// residuals and iterates, random coarse operators with held and frozen nodes, every
    /// coarsening and row length (θ coarsening: even ones). The injected `u₀`, the coarse
    /// start and the right-hand side must agree in every bit.
    #[test]
    fn lanes_restriction_matches_scalar_bit_for_bit() {
        let isas = lane_isas();
        let mut compared = 0;
        for (t, &nt) in ROW_LENGTHS.iter().enumerate() {
            for cnz in 1..=3 {
                for c in [Coarsen::Both, Coarsen::Theta, Coarsen::Zeta] {
                    let (st, sz) = super::strides(c);
                    if nt % st != 0 || nt / st < 1 {
                        continue;
                    }
                    let (cnt, nz) = (nt / st, cnz * sz);
                    if nz < 2 {
                        continue;
                    }
                    for top in [true, false] {
                        let seed = (t * 1000 + cnz * 10 + sz * 3 + st + top as usize) as u64;
                        for &isa in &isas {
                            let mut fine = random_level(seed, nt, nz, top);
                            let mut rng = Lcg(seed ^ 0xface);
                            for v in fine.r.iter_mut() {
                                *v = rng.next() - 0.5;
                            }
                            let (mut ca, mut cb) = (
                                random_level(seed + 7, cnt, cnz, !top),
                                random_level(seed + 7, cnt, cnz, !top),
                            );
                            restrict_fas_with(LaneIsa::Baseline, &fine, &mut ca, c);
                            restrict_fas_with(isa, &fine, &mut cb, c);
                            for (what, a, b) in [
                                ("u0", &ca.base, &cb.base),
                                ("p", &ca.p, &cb.p),
                                ("f", &ca.f, &cb.f),
                            ] {
                                assert_eq!(
                                    bits(a),
                                    bits(b),
                                    "{isa:?} restriction {c:?} {what}, {nt} x {nz}, top {top}: {b:?} against scalar {a:?}"
                                );
                            }
                            fine.r.clear();
                            compared += 1;
                        }
                    }
                }
            }
        }
        eprintln!("lanes' restriction against scalar: {compared} levels ({isas:?})");
    }

    /// The bilinear interpolation of a solution (the accuracy ladder's start) in SIMD lanes
    /// against the scalar pass, bit for bit: random coarse fields with zeros of both signs,
    /// fine levels with held nodes (random holds, or every hold `+0` and known so), every
    /// coarsening and row length.
    #[test]
    fn lanes_solution_interpolation_matches_scalar_bit_for_bit() {
        let isas = lane_isas();
        let mut compared = 0;
        for (t, &nt) in ROW_LENGTHS.iter().enumerate() {
            for cnz in 1..=3 {
                for c in [Coarsen::Both, Coarsen::Theta, Coarsen::Zeta] {
                    let (st, sz) = super::strides(c);
                    if nt % st != 0 {
                        continue;
                    }
                    let (cnt, nz) = (nt / st, cnz * sz);
                    if nz < 2 {
                        continue;
                    }
                    let seed = (t * 1000 + cnz * 10 + sz * 3 + st) as u64;
                    for (&isa, hold0) in isas.iter().flat_map(|i| [(i, false), (i, true)]) {
                        let (mut fa, mut fb) = (
                            random_level(seed, nt, nz, true),
                            random_level(seed, nt, nz, true),
                        );
                        if hold0 {
                            zero_holds(&mut fa);
                            zero_holds(&mut fb);
                        }
                        let coarse = random_level(seed + 11, cnt, cnz, true);
                        prolong_solution_with(LaneIsa::Baseline, &mut fa, &coarse, c);
                        prolong_solution_with(isa, &mut fb, &coarse, c);
                        assert_eq!(
                            bits(&fa.p),
                            bits(&fb.p),
                            "{isa:?} interpolation {c:?}, {nt} x {nz}, hold 0 {hold0}: {:?} against scalar {:?}",
                            fb.p,
                            fa.p
                        );
                        compared += 1;
                    }
                }
            }
        }
        eprintln!("lanes' interpolation against scalar: {compared} levels ({isas:?})");
    }

    /// The coarse grids' frozen nodes as `freeze` found them before session 38 (written
    /// out here: a mask of held fine columns per coarse row built node by node with the
    /// inlet line's test, and `1/d` divided for every free coarse node): the reference of
    /// the widened `freeze`.
    fn freeze_reference(fine: &Level, coarse: &mut Level, how: Coarsen, line: bool) {
        let (st, sz) = super::strides(how);
        let fine_inv = fine.inv();
        let fnt = fine.nt;
        let fine_inlet: &[usize] = if !line {
            &[]
        } else if fine.top {
            &fine.inlet_col
        } else {
            &fine.inlet_corr
        };
        for jc in 1..coarse.nz {
            let jf = jc * sz;
            let fi = fine_inlet.get(jf).copied().unwrap_or(usize::MAX);
            coarse.inlet_corr[jc] = if fi == usize::MAX {
                usize::MAX
            } else if st == 1 || fi % 2 == 0 {
                fi / st
            } else {
                let left = fi - 1;
                let right = if fi + 1 == fnt { 0 } else { fi + 1 };
                if fine.f_own[jf * fnt + left] <= fine.f_own[jf * fnt + right] {
                    left / 2
                } else {
                    right / 2
                }
            };
        }
        for jc in 1..coarse.nz {
            let jf = jc * sz;
            let (jlo, jhi) = if sz == 2 { (jf - 1, jf + 1) } else { (jf, jf) };
            let mut mask = vec![false; fnt];
            for j in jlo.max(1)..=jhi.min(fine.nz - 1) {
                let line = fine_inlet.get(j).copied();
                for (i, m) in mask.iter_mut().enumerate() {
                    *m |= fine_inv[j * fnt + i] == 0.0 && line != Some(i);
                }
            }
            for ic in 0..coarse.nt {
                let i0 = ic * st;
                let held = coarse.inlet_corr[jc] == ic
                    || if st == 2 {
                        let im = if i0 == 0 { fnt - 1 } else { i0 - 1 };
                        let ip = if i0 + 1 == fnt { 0 } else { i0 + 1 };
                        mask[im] || mask[i0] || mask[ip]
                    } else {
                        mask[i0]
                    };
                let k = jc * coarse.nt + ic;
                coarse.inv_d_free[k] = if held { 0.0 } else { 1.0 / coarse.d[k] };
            }
        }
    }

    /// The widened `freeze` (inlet-only rows counted, the mask without the line test, `1/d`
    /// from the coarse `inv_d`) against [`freeze_reference`], bit for bit, on the build's
    /// instruction set and on every SIMD one the CPU has: every coarsening and row length,
    /// solved and correction fine grids, inlet lines on and off the coarse nodes or absent,
    /// fine grids with held nodes off the line (a tenth) and with the line held alone (the
    /// counted path), coarse grids with their own held nodes (`inv_d` 0: `1/d` divided).
    #[test]
    fn widened_freeze_matches_reference_bit_for_bit() {
        let mut isas = lane_isas();
        isas.push(LaneIsa::Baseline);
        let mut compared = 0;
        for (t, &cnt) in ROW_LENGTHS.iter().enumerate() {
            for cnz in 2..=4 {
                for how in [Coarsen::Both, Coarsen::Theta, Coarsen::Zeta] {
                    for (top, line_only, line) in [
                        (true, false, true),
                        (false, false, true),
                        (true, true, true),
                        (false, true, true),
                        (true, false, false),
                    ] {
                        let (st, sz) = super::strides(how);
                        let (fnt, fnz) = (cnt * st, cnz * sz);
                        let seed = (t * 1000 + cnz * 100 + st * 10 + sz) as u64;
                        let make = || {
                            let mut fine = random_level(seed, fnt, fnz, top);
                            let mut rng = Lcg(seed + 7);
                            let cols: Vec<usize> = (0..=fnz)
                                .map(|_| match (rng.next() * 4.0) as usize {
                                    0 => usize::MAX,
                                    _ => ((rng.next() * fnt as f64) as usize).min(fnt - 1),
                                })
                                .collect();
                            if line_only {
                                // Only the line held: every other fine node free.
                                for (k, v) in fine.inv_d.iter_mut().enumerate() {
                                    let (j, i) = (k / fnt, k % fnt);
                                    *v = if cols[j] == i { 0.0 } else { 1.0 / fine.d[k] };
                                }
                                fine.inv_d_free = fine.inv_d.clone();
                            }
                            fine.inlet_col = cols.clone();
                            fine.inlet_corr = cols;
                            let mut coarse = random_level(seed + 3, cnt, cnz, false);
                            coarse.inlet_corr = vec![usize::MAX; cnz + 1];
                            (fine, coarse)
                        };
                        let (fine, mut want) = make();
                        freeze_reference(&fine, &mut want, how, line);
                        for &isa in &isas {
                            let (fine, mut got) = make();
                            lanes::widened_on(
                                isa,
                                Freeze {
                                    fine: &fine,
                                    coarse: &mut got,
                                    how,
                                    line,
                                },
                            );
                            assert_eq!(
                                bits(&got.inv_d_free),
                                bits(&want.inv_d_free),
                                "{isa:?} freeze {how:?}, coarse {cnt} x {cnz}, top {top}, \
                                 line only {line_only}, line {line}"
                            );
                            assert_eq!(got.inlet_corr, want.inlet_corr);
                            compared += 1;
                        }
                    }
                }
            }
        }
        eprintln!("widened freeze against the reference: {compared} levels ({isas:?})");
    }

    /// The field stop's maxima in eight chains, widened, against one running maximum (the
    /// same bits: a maximum is order-free), and the widened cubic FMG start against the
    /// same body as built, bit for bit: fields with zeros of both signs, every length.
    #[test]
    fn widened_stop_and_cubic_start_match_bit_for_bit() {
        let mut isas = lane_isas();
        isas.push(LaneIsa::Baseline);
        for n in 0..70 {
            let mut rng = Lcg(n as u64 + 5);
            let mut val = || match (rng.next() * 6.0) as u32 {
                0 => 0.0,
                1 => -0.0,
                _ => rng.next(),
            };
            let p: Vec<f64> = (0..n).map(|_| val()).collect();
            let mut q: Vec<f64> = (0..n).map(|_| val()).collect();
            let (mut ch, mut mp) = (0.0_f64, 0.0_f64);
            for (a, b) in p.iter().zip(&q) {
                let d = (a - b).abs();
                ch = if d > ch { d } else { ch };
                mp = if *a > mp { *a } else { mp };
            }
            let q0 = q.clone();
            assert_eq!(change_and_max(&p, &mut q).0.to_bits(), ch.to_bits());
            assert_eq!(bits(&q), bits(&p), "the next cycle's copy");
            for &isa in &isas {
                let mut q = q0.clone();
                let (c, m) = lanes::widened_on(isa, ChangeAndMax(&p, &mut q));
                assert_eq!(bits(&q), bits(&p), "{isa:?} {n}: the next cycle's copy");
                assert_eq!(
                    (c.to_bits(), m.to_bits()),
                    (ch.to_bits(), mp.to_bits()),
                    "{isa:?} {n}"
                );
            }
        }
        for (t, &cnt) in ROW_LENGTHS.iter().enumerate() {
            for cnz in 1..=5 {
                for c in [Coarsen::Both, Coarsen::Theta, Coarsen::Zeta] {
                    let (st, sz) = super::strides(c);
                    let (nt, nz) = (cnt * st, cnz * sz);
                    if nz < 2 {
                        continue;
                    }
                    let seed = (t * 100 + cnz * 10 + st * 3 + sz) as u64;
                    let coarse = random_level(seed + 1, cnt, cnz, true);
                    let mut want = random_level(seed, nt, nz, true);
                    want.base = vec![0.0; want.p.len()];
                    super::prolong_solution_cubic_body(&mut want, &coarse, c);
                    for &isa in &isas {
                        let mut got = random_level(seed, nt, nz, true);
                        got.base = vec![0.0; got.p.len()];
                        lanes::widened_on(
                            isa,
                            CubicStart {
                                fine: &mut got,
                                coarse: &coarse,
                                c,
                            },
                        );
                        assert_eq!(
                            bits(&got.p),
                            bits(&want.p),
                            "{isa:?} cubic {c:?} {nt} x {nz}"
                        );
                    }
                    // Every hold +0: read as such (`hold_zero` false) against not read.
                    let mut want = random_level(seed, nt, nz, true);
                    want.base = vec![0.0; want.p.len()];
                    want.hold.fill(0.0);
                    super::prolong_solution_cubic_body(&mut want, &coarse, c);
                    for &isa in &isas {
                        let mut got = random_level(seed, nt, nz, true);
                        got.base = vec![0.0; got.p.len()];
                        zero_holds(&mut got);
                        lanes::widened_on(
                            isa,
                            CubicStart {
                                fine: &mut got,
                                coarse: &coarse,
                                c,
                            },
                        );
                        assert_eq!(
                            bits(&got.p),
                            bits(&want.p),
                            "{isa:?} cubic {c:?} {nt} x {nz}, holds +0"
                        );
                    }
                }
            }
        }
    }
}
