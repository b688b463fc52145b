// Finite-length Reynolds film by projected full-approximation multigrid (issue 20 item 2,
// issue 26 item 3): the algorithm of src/bearing/finite/multigrid.rs and the accuracy
// ladder of src/bearing/finite/solver.rs, on the device. Driver: src/backend/finite_mg.rs;
// docs/finite-film.md "Backends".
//
// One workgroup per bearing state ("slot"), looping over the levels of its grid hierarchy
// with workgroup barriers; every level's fields live in a storage buffer (`scr`, one
// region per slot), so the grid is not bounded by workgroup memory. Per level the slot
// holds 8 arrays of n_theta × (n_z + 1) f64 (end rows included): the east and north face
// coefficients, the inverse diagonal as the solved grid and as a correction grid, the
// right-hand side in use, the iterate, the injected fine iterate u0 and the residual.
//
// The same discrete problem, smoother, FAS coarse problem, truncated correction,
// coarsest-grid projected SOR, stopping rules, full-multigrid start and ladder (grids,
// per-grid stop on the loads, Richardson estimate, stop at the requested accuracy) as the
// CPU; on the plain film's ladder the CPU's `LadderRule` (solver.rs, session 36; the
// kernel since session 37): each grid after the first starts from the bilinear
// interpolation with its in-between rows redone by cubics in ζ (`cubic_rows_in_zeta`), a
// grid stops loosely by its role and the grid that ends the ladder at the rule's floor
// (`stop_tolerance`, `finish_level`). Red-black Gauss-Seidel within a colour is
// order-independent, so the smoothing is the CPU's exactly; the truncated correction tests
// its neighbours' signs on the field before the correction (the CPU walks the nodes in order and sees the already corrected
// ones), which changes the path of the iteration where a correction empties a node, not
// its fixed point: the loads agree to the iteration tolerance.
//
// No trigonometric function is evaluated in f64: the host supplies cos and sin at every
// half grid step of every level (`trig`), cos/sin of the state's node-0 angle (rotation by
// the angle-addition formulas), the coarsest grid's SOR factor and the inlet columns.

// Invocations per workgroup (one workgroup per state) and log2 of it: the host sets both
// (src/backend/finite_mg.rs): 256 on llvmpipe, whose loop cap the budget is calibrated on;
// on hardware GPUs chosen per chunk by its number of states since session 42
// (`workgroup_for`: 64, 128 or 256); `BEARING_SWEEP_MG_WG` forces one. The same
// arithmetic in the same order for any size (the loads' sums run in SUM_LANES fixed
// lanes): the same bits.
const WG: u32 = 256u;
const LOG2_WG: u32 = 8u;
// Lanes of the loads' sums (`loads`, `reduce_sum4`), fixed whatever WG (≥ 64, the host's
// smallest workgroup) so that the sums run in one order: the kernel's results do not
// depend on WG, and the host may choose WG per chunk (src/backend/finite_mg.rs).
const SUM_LANES: u32 = 64u;
const LOG2_SUM_LANES: u32 = 6u;
// Levels of a hierarchy (coarse levels of the first grid plus the ladder's grids).
const MAX_LEVELS: u32 = 24u;
// Ladder grids (src/bearing/finite/solver.rs accuracy_ladder: at most 7 below 1024 around).
const MAX_RUNGS: u32 = 12u;
const NO_INLET: u32 = 0xffffffffu;
// Per job (stride 16 f64): ecc[4], rate[4], aspect B/r0, supply, coarsest SOR factor,
// theta0, cos theta0, sin theta0, warm (1: `fields` holds a start), unused.
const JOB_STRIDE: u32 = 16u;
// Per result (stride 121 f64): integrals[4], sweeps, iteration error, converged, n_theta,
// n_z, error estimate, accuracy met, then the state block (OUT_STATE: status first,
// ST_*: 1 done; 2 the dispatch's grids were not enough for the accuracy, the host solves
// it again with the full ladder), then the diagnostic tally (OUT_TALLY, N_TALLY f64).
const OUT_STRIDE: u32 = 121u;
// Arrays of a level (offsets in units of the level's node count).
const A_AE: u32 = 0u;
const A_AN: u32 = 1u;
const A_INV: u32 = 2u;
const A_INVF: u32 = 3u;
const A_F: u32 = 4u;
const A_P: u32 = 5u;
const A_BASE: u32 = 6u;
const A_R: u32 = 7u;
// Smoothing sweeps before / after the coarse-grid correction (multigrid.rs NU_PRE, NU_POST).
const NU_PRE: u32 = 2u;
const NU_POST: u32 = 1u;
// Sweep limit of the coarsest-grid projected SOR (multigrid.rs COARSEST_SWEEPS).
const COARSEST_SWEEPS: u32 = 4000u;
// Coarsest-grid tolerance inside a V-cycle, of the field's largest value (multigrid.rs
// Hierarchy::vcycle), and of the correction's largest value |p − u₀| if that is larger
// (multigrid.rs COARSEST_CORRECTION; issue 20, session 38).
const COARSEST_TOL: f64 = 1e-12;
const COARSEST_CORRECTION: f64 = 0.1;
// Explicit grids: the first grid of full multigrid solved to at least this tolerance
// (solver.rs FMG_FIRST_TOLERANCE; issue 20, session 38).
const FMG_FIRST_TOLERANCE: f64 = 1e-3;
// Coarsenings (levels' `coarsen`): none (coarsest), both directions, θ only, ζ only.
const C_NONE: u32 = 0u;
const C_BOTH: u32 = 1u;
const C_THETA: u32 = 2u;
const PI: f64 = 3.141592653589793;

struct Params {
    // States in this dispatch (one workgroup each).
    count: u32,
    // Levels set up in this dispatch: the first grid's hierarchy (0..=top0) and, in
    // accuracy mode, the ladder's further grids (one level each).
    n_levels: u32,
    top0: u32,
    // 0: fixed grid (stop on the field, warm start allowed); 1: accuracy ladder.
    mode: u32,
    // f64 per slot in `scr`, u32 per state in `inlets`, f64 per state in `fields`.
    stride: u32,
    inlet_stride: u32,
    field_stride: u32,
    // 1: grooves or arcs (geo table in use; the banded ladder estimate).
    banded: u32,
    // 1: the full ladder has grids beyond this dispatch's (status 2 when not met).
    more: u32,
    // V-cycle limit of a grid (solver.rs MAX_CYCLES).
    max_cycles: u32,
    // Loop iterations of a dispatch after which it starts no further step (resumable: see
    // `main`), and beyond which its results are void (ST_OVERRUN).
    budget: u32,
    limit: u32,
    // Ladder grids after the first (plain film, `LadderRule::cubic_start`): 1 when their
    // start's in-between rows are redone by cubics in ζ.
    cubic_start: u32,
    // Ladder grids after the first: post-smoothing sweeps of their V-cycles on every
    // level (LadderRule::post; solver.rs solve_accuracy). Fixed grids and the first
    // grid's full multigrid: NU_POST.
    ladder_post: u32,
    // Ladder: 1 when the grid that ends it does at least two V-cycles
    // (LadderRule::measured_last; solver.rs solve_accuracy).
    measured_last: u32,
    pad2: u32,
    // Fixed grid: tolerance on the field; ladder: on the loads of the first grid and its
    // full-multigrid levels (max(accuracy/10, tol)).
    tolerance: f64,
    // Ladder: requested accuracy.
    accuracy: f64,
    // Ladder grids after the first: the stop's floor, max(LadderRule::floor × accuracy,
    // tol), and the loose factor of an intermediate grid (LadderRule::loose; 0: every grid
    // to the floor, grooves and arcs).
    floor: f64,
    loose: f64,
    // Per level: n_theta, n_z, coarsening to the level below, offset in the slot.
    lv: array<vec4<u32>, MAX_LEVELS>,
    // Per level: offset in `trig`, in `geo`, in a state's `inlets`, unused.
    lw: array<vec4<u32>, MAX_LEVELS>,
}

@group(0) @binding(0) var<uniform> params: Params;
// Per level: cos and sin of k Δθ/2, k = 0 .. 2 n_theta − 1, interleaved.
@group(0) @binding(1) var<storage, read> trig: array<f64>;
@group(0) @binding(2) var<storage, read> jobs: array<f64>;
// Per state: warm start in (fixed grids), solution of the last grid out.
@group(0) @binding(3) var<storage, read_write> fields: array<f64>;
@group(0) @binding(4) var<storage, read_write> results: array<f64>;
// Per state and level: the held inlet column of each row (NO_INLET: none).
@group(0) @binding(5) var<storage, read> inlets: array<u32>;
// Per level (grooves and arcs only): east factor, north factor, held pressure in Pa
// (negative: free) per node.
@group(0) @binding(6) var<storage, read> geo: array<f64>;
// Per slot: the levels' arrays.
@group(0) @binding(7) var<storage, read_write> scr: array<f64>;

// The reductions' scratch: reduce_max2's 2 × WG values, reduce_sum4's 4 × SUM_LANES.
var<workgroup> red: array<f64, max(2u * WG, 4u * SUM_LANES)>;
var<workgroup> wu: array<f64, 4>;
// reduce_max2's fan-in (WG/FAN ≤ 64 partial maxima) and its result.
const FAN: u32 = 1u << ((LOG2_WG + 1u) / 2u);
var<workgroup> wm: array<vec2<f64>, 64>;
var<workgroup> wv: vec2<f64>;
// Correction candidates that the truncated correction would empty (prolong_correction),
// and the sort's scratch.
const CAND_CAP: u32 = 512u;
var<workgroup> cand: array<u32, CAND_CAP>;
var<workgroup> cand_zero: array<u32, CAND_CAP>;
var<workgroup> ncand: atomic<u32>;
var<workgroup> wn: u32;
// Loop iterations of the serial part of prolong_correction (invocation 0's count).
var<workgroup> wcost: u32;

var<private> lid: u32;
var<private> sb: u32;
var<private> jb: u32;
var<private> ib: u32;
var<private> ecc: array<f64, 4>;
var<private> rate: array<f64, 4>;
var<private> aspect2: f64;
var<private> supply: f64;
var<private> omega0: f64;
var<private> cos0: f64;
var<private> sin0: f64;
// Relaxation node updates (work), uniform across the workgroup.
var<private> updates: f64;
// Loop iterations this dispatch has run so far (an upper bound on what the invocation
// with the most runs, local index 0, ran), uniform across the workgroup: the budget that
// makes the kernel resumable (see `main`).
var<private> spent: u32;
// Loop iterations of invocation 0's serial walks (prolong_correction, `emptied`).
var<private> serial: u32;

// Diagnostics (BEARING_SWEEP_MG_COUNT, src/backend/finite_mg.rs `Tally`): counts of this
// dispatch, added to the slot's tally block (OUT_TALLY) at its end. T_* below: the
// barriers (workgroupBarrier and workgroupUniformLoad, each one step of the state's chain)
// per part of the solve, then serial iterations and events. Uniform except the serial
// counts (invocation 0's, which is the one that writes the block).
const N_TALLY: u32 = 34u;
const OUT_TALLY: u32 = 87u;
// Barriers by part: set-up of the first grid's levels (PH_INIT); a next grid's set-up and
// prolongation (PH_PREP); a level's entry (PH_ENTER: own right-hand side, freezes, loads);
// the coarsest grid solved by itself (PH_COARSE); a V-cycle's start and descent; its
// coarsest solve; its ascent; its stop test with the level's finish (loads, estimate);
// the field and report out (PH_DONE); the dispatch's own state in and out.
const T_INIT: u32 = 0u;
const T_PREP: u32 = 1u;
const T_ENTER: u32 = 2u;
const T_COARSE: u32 = 3u;
const T_DESCENT: u32 = 4u;
const T_CSOLVE: u32 = 5u;
const T_ASCENT: u32 = 6u;
const T_STOP: u32 = 7u;
const T_DONE: u32 = 8u;
const T_MAIN: u32 = 9u;
// Serial chains: the candidates' sort (each invocation's inner loop), the walk over them,
// the in-place walk beyond the list; then coarsest sweeps inside V-cycles and alone,
// V-cycles, dispatches that ran the slot, truncated corrections, their candidates,
// relaxation sweeps (any level), reductions; invocation 0's loop iterations.
const T_SORT: u32 = 10u;
const T_WALK: u32 = 11u;
const T_INPLACE: u32 = 12u;
const T_CSWEEPS: u32 = 13u;
const T_COARSE_SWEEPS: u32 = 14u;
const T_CYCLES: u32 = 15u;
const T_DISPATCHES: u32 = 16u;
const T_CORRECTIONS: u32 = 17u;
const T_CANDIDATES: u32 = 18u;
const T_SWEEPS: u32 = 19u;
const T_REDUCTIONS: u32 = 20u;
// Loop iterations of invocation 0 as the budget counts them (`spent`, all dispatches).
const T_SPENT: u32 = 21u;
// Of those, the reductions' loops over workgroup memory (the rest: loops over the levels'
// nodes in device memory, and the serial walks).
const T_RED_SPENT: u32 = 22u;
// Then invocation 0's loop iterations (`spent`) by part, T_INIT .. T_MAIN from here on
// (the part a step ends in; the reductions' loops included).
const T_SPENT_PART: u32 = 24u;
var<private> tally: array<u32, N_TALLY>;
// The part the barriers count to (T_INIT .. T_MAIN).
var<private> cat: u32;

// A workgroup barrier, counted.
fn bar() {
    tally[cat] += 1u;
    workgroupBarrier();
}

// Iterations of a loop `for (var m = lid; m < n; m += WG)` for invocation 0, plus its
// exit test.
fn loops(n: u32) -> u32 {
    return (n + WG - 1u) / WG + 1u;
}

fn nt_of(l: u32) -> u32 {
    return params.lv[l].x;
}
fn nz_of(l: u32) -> u32 {
    return params.lv[l].y;
}
fn full_of(l: u32) -> u32 {
    return params.lv[l].x * (params.lv[l].y + 1u);
}
fn interior_of(l: u32) -> u32 {
    return params.lv[l].x * (max(params.lv[l].y, 1u) - 1u);
}
// Index of node k of array a of level l in `scr`.
fn at(l: u32, a: u32, k: u32) -> u32 {
    return sb + params.lv[l].w + a * full_of(l) + k;
}

// cos, sin of half step h of level l, rotated by the state's node-0 angle.
fn trig_at(l: u32, h: u32) -> vec2<f64> {
    let o = params.lw[l].x + 2u * h;
    let c = trig[o];
    let s = trig[o + 1u];
    return vec2<f64>(cos0 * c - sin0 * s, sin0 * c + cos0 * s);
}

// H = h/δ at axial fraction zeta and angle (c, s) (solver.rs `film`).
fn film(zeta: f64, c: f64, s: f64) -> f64 {
    let ex = ecc[0] + (ecc[2] - ecc[0]) * zeta;
    let ey = ecc[1] + (ecc[3] - ecc[1]) * zeta;
    return 1.0 - ex * c - ey * s;
}

// The level's own right-hand side f = −rhs at node k (row j, column i).
fn f_own(l: u32, j: u32, i: u32) -> f64 {
    let zeta = f64(j) * (1.0 / f64(nz_of(l)));
    let a = rate[0] + (rate[2] - rate[0]) * zeta;
    let b = rate[1] + (rate[3] - rate[1]) * zeta;
    let t = trig_at(l, 2u * i);
    return -6.0 * (a * t.y - b * t.x);
}

// Held value of node k of level l (grooves' supply pressure; 0 at the inlet line).
fn hold_of(l: u32, k: u32) -> f64 {
    if params.banded == 0u {
        return 0.0;
    }
    let h = geo[params.lw[l].y + 3u * k + 2u];
    if h >= 0.0 {
        return h * supply;
    }
    return 0.0;
}

// Diagonal of node (j, i) of level l: the sum of its four face coefficients.
fn diag(l: u32, j: u32, i: u32) -> f64 {
    let nt = nt_of(l);
    let k = j * nt + i;
    let im = select(i - 1u, nt - 1u, i == 0u);
    return scr[at(l, A_AE, k)] + scr[at(l, A_AE, j * nt + im)] + scr[at(l, A_AN, k)]
        + scr[at(l, A_AN, k - nt)];
}

// Σ a_nb u_nb of array a at interior node (j, i) of level l.
fn neighbours(l: u32, a: u32, j: u32, i: u32) -> f64 {
    let nt = nt_of(l);
    let row = j * nt;
    let k = row + i;
    let ip = select(k + 1u, row, i + 1u == nt);
    let im = select(k - 1u, row + nt - 1u, i == 0u);
    return scr[at(l, A_AE, k)] * scr[at(l, a, ip)] + scr[at(l, A_AE, im)] * scr[at(l, a, im)]
        + scr[at(l, A_AN, k)] * scr[at(l, a, k + nt)]
        + scr[at(l, A_AN, k - nt)] * scr[at(l, a, k - nt)];
}

// Max-reduction of (a, b) over the workgroup; uniform results. Two rounds of FAN values
// (WG/FAN invocations take FAN each, then invocation 0 their WG/FAN maxima): three
// barriers where a halving tree takes log2(WG) + 4 (the maximum is exact in any order).
fn reduce_max2(a: f64, b: f64) -> vec2<f64> {
    tally[T_REDUCTIONS] += 1u;
    // The two rounds' loops and their exit tests.
    spent += FAN + WG / FAN + 2u;
    tally[T_RED_SPENT] += FAN + WG / FAN + 2u;
    red[lid] = a;
    red[WG + lid] = b;
    bar();
    let parts = WG / FAN;
    if lid < parts {
        var x = red[lid * FAN];
        var y = red[WG + lid * FAN];
        for (var q = 1u; q < FAN; q++) {
            x = max(x, red[lid * FAN + q]);
            y = max(y, red[WG + lid * FAN + q]);
        }
        wm[lid] = vec2<f64>(x, y);
    }
    bar();
    if lid == 0u {
        var v = wm[0];
        for (var q = 1u; q < parts; q++) {
            v = max(v, wm[q]);
        }
        wv = v;
    }
    // No barrier after: the next writes to red, wm and wv are two barriers away.
    tally[cat] += 1u;
    return workgroupUniformLoad(&wv);
}

// Sum-reduction of four values held by the first SUM_LANES invocations (the others hold
// zeros and take no part); uniform results. A halving tree over the SUM_LANES lanes: the
// same sums in the same order whatever the workgroup size (WG ≥ SUM_LANES), so the loads,
// and every decision taken on them, are bit for bit the same at any WG.
fn reduce_sum4(v: array<f64, 4>) -> array<f64, 4> {
    tally[T_REDUCTIONS] += 1u;
    // The 4-value loops around and inside log2(SUM_LANES) halvings.
    spent += 8u * (LOG2_SUM_LANES + 1u);
    tally[T_RED_SPENT] += 8u * (LOG2_SUM_LANES + 1u);
    let h = SUM_LANES;
    if lid < h {
        for (var q = 0u; q < 4u; q++) {
            red[q * h + lid] = v[q];
        }
    }
    bar();
    for (var s = h / 2u; s > 0u; s = s / 2u) {
        if lid < s {
            for (var q = 0u; q < 4u; q++) {
                red[q * h + lid] += red[q * h + lid + s];
            }
        }
        bar();
    }
    if lid == 0u {
        for (var q = 0u; q < 4u; q++) {
            wu[q] = red[q * h];
        }
    }
    // One barrier for the four (the whole array at once).
    tally[cat] += 1u;
    let out = workgroupUniformLoad(&wu);
    bar();
    return out;
}

// Discretises the state's equation on level l (multigrid.rs Level::setup): face
// coefficients, own right-hand side, holds; iterate, u0 and residual zero.
fn setup(l: u32) {
    let nt = nt_of(l);
    let nz = nz_of(l);
    let n = full_of(l);
    let dt = 2.0 * PI / f64(nt);
    let dz = 1.0 / f64(nz);
    let ct = aspect2 / (dt * dt);
    let cz = 1.0 / (dz * dz);
    let gb = params.lw[l].y;
    spent += loops(n) + loops(interior_of(l));
    for (var k = lid; k < n; k += WG) {
        let j = k / nt;
        let i = k % nt;
        let zeta = f64(j) * dz;
        let zh = (f64(j) + 0.5) * dz;
        let tf = trig_at(l, 2u * i + 1u);
        let tn = trig_at(l, 2u * i);
        var east: f64 = 1.0;
        var north: f64 = 1.0;
        if params.banded != 0u {
            east = geo[gb + 3u * k];
            north = geo[gb + 3u * k + 1u];
        }
        let hf = film(zeta, tf.x, tf.y);
        scr[at(l, A_AE, k)] = ct * hf * hf * hf * east;
        var an: f64 = 0.0;
        if j < nz {
            let hn = film(zh, tn.x, tn.y);
            an = cz * hn * hn * hn * north;
        }
        scr[at(l, A_AN, k)] = an;
        scr[at(l, A_F, k)] = f_own(l, j, i);
        scr[at(l, A_INV, k)] = 0.0;
        scr[at(l, A_INVF, k)] = 0.0;
        scr[at(l, A_P, k)] = 0.0;
        scr[at(l, A_BASE, k)] = 0.0;
        scr[at(l, A_R, k)] = 0.0;
    }
    bar();
    let interior = interior_of(l);
    let io = ib + params.lw[l].z;
    for (var m = lid; m < interior; m += WG) {
        let k = m + nt;
        let j = k / nt;
        let i = k % nt;
        let d = diag(l, j, i);
        scr[at(l, A_INVF, k)] = 1.0 / d;
        var held = false;
        if params.banded != 0u {
            held = geo[gb + 3u * k + 2u] >= 0.0;
        }
        if inlets[io + j] == i {
            held = true;
        }
        scr[at(l, A_INV, k)] = select(1.0 / d, 0.0, held);
    }
    bar();
}

// One red-black projected SOR sweep of level l with factor omega (1: Gauss-Seidel);
// `top`: the solved grid (holds applied) or a correction grid (frozen nodes skipped).
// Returns, when `want` (else zeros, no reduction), the largest change and the coarsest
// solve's stop scale: the largest value times `tol`, or with `rel` > 0 the larger of that
// and `rel` times the largest correction |p − u₀| (u₀ in A_BASE; a correction grid's
// frozen node keeps p = u₀; the held nodes of the solved grid, `top`, count by their value
// only: `rel` is for correction grids), in one reduction (tol·max p = max tol·p exactly:
// rounding is monotone). multigrid.rs Level::solve_coarsest's scale, without the second
// pass over the level that its correction's maximum took here before.
fn sweep(l: u32, omega: f64, top: bool, want: bool, tol: f64, rel: f64) -> vec2<f64> {
    let nt = nt_of(l);
    let nz = nz_of(l);
    let half = nt / 2u;
    let cnt = half * (nz - 1u);
    let ia = select(A_INVF, A_INV, top);
    var my_dp: f64 = 0.0;
    var my_p: f64 = 0.0;
    spent += 1u + 2u * loops(cnt);
    tally[T_SWEEPS] += 1u;
    for (var colour = 0u; colour < 2u; colour++) {
        for (var m = lid; m < cnt; m += WG) {
            let j = 1u + m / half;
            let i = 2u * (m % half) + ((colour + j) % 2u);
            let k = j * nt + i;
            let ik = scr[at(l, ia, k)];
            let old = scr[at(l, A_P, k)];
            if ik == 0.0 {
                if top {
                    let h = hold_of(l, k);
                    scr[at(l, A_P, k)] = h;
                    my_dp = max(my_dp, abs(h - old));
                    my_p = max(my_p, tol * h);
                }
                continue;
            }
            let s = neighbours(l, A_P, j, i);
            let new_p = max(old + omega * ((s + scr[at(l, A_F, k)]) * ik - old), 0.0);
            scr[at(l, A_P, k)] = new_p;
            my_dp = max(my_dp, abs(new_p - old));
            my_p = max(my_p, tol * new_p);
            if want && rel > 0.0 {
                my_p = max(my_p, rel * abs(new_p - scr[at(l, A_BASE, k)]));
            }
        }
        bar();
    }
    if want {
        return reduce_max2(my_dp, my_p);
    }
    return vec2<f64>(0.0, 0.0);
}

// r = f − A p at the interior of level l after a sweep, zero at held nodes and where the
// constraint is active (multigrid.rs Level::residual): computed at the sweep's first colour
// ((i + j) even); the second colour's is zero to rounding after the sweep, written as 0.
// No barrier: `restrict_fas` runs it beside the injection, before its own.
fn residual(l: u32, top: bool) {
    let nt = nt_of(l);
    let interior = interior_of(l);
    spent += loops(interior);
    let ia = select(A_INVF, A_INV, top);
    for (var m = lid; m < interior; m += WG) {
        let k = m + nt;
        let j = k / nt;
        let i = k % nt;
        var r: f64 = 0.0;
        if ((i + j) & 1u) == 0u && scr[at(l, ia, k)] != 0.0 {
            let row = j * nt;
            let ip = select(k + 1u, row, i + 1u == nt);
            let im = select(k - 1u, row + nt - 1u, i == 0u);
            let pk = scr[at(l, A_P, k)];
            let v = scr[at(l, A_F, k)] - diag(l, j, i) * pk
                + scr[at(l, A_AE, k)] * scr[at(l, A_P, ip)]
                + scr[at(l, A_AE, im)] * scr[at(l, A_P, im)]
                + scr[at(l, A_AN, k)] * scr[at(l, A_P, k + nt)]
                + scr[at(l, A_AN, k - nt)] * scr[at(l, A_P, k - nt)];
            if !(pk <= 0.0 && v < 0.0) {
                r = v;
            }
        }
        scr[at(l, A_R, k)] = r;
    }
}

// Strides of level l's coarsening in (θ, ζ).
fn strides(l: u32) -> vec2<u32> {
    let c = params.lv[l].z;
    if c == C_BOTH {
        return vec2<u32>(2u, 2u);
    }
    if c == C_THETA {
        return vec2<u32>(2u, 1u);
    }
    return vec2<u32>(1u, 2u);
}

// The FAS coarse problem of fine level l on level l − 1: u0 = injection of the iterate
// (also the coarse start), f_H = A_H u0 + R r (full weighting), zero at frozen nodes; the
// residual r of level l (`residual`, `top`: l is the solved grid) in the same pass as the
// injection (it writes the fine A_R, the injection the coarse A_BASE and A_P from the fine
// A_P, which neither changes): one barrier less than after each (multigrid.rs
// Level::residual, then restrict).
fn restrict_fas(l: u32, top: bool) {
    let c = l - 1u;
    let st = strides(l);
    let fnt = nt_of(l);
    let cnt = nt_of(c);
    let cnz = nz_of(c);
    let nc = full_of(c);
    spent += 2u * loops(nc);
    for (var kc = lid; kc < nc; kc += WG) {
        let jc = kc / cnt;
        let ic = kc % cnt;
        let v = scr[at(l, A_P, jc * st.y * fnt + ic * st.x)];
        scr[at(c, A_BASE, kc)] = v;
        scr[at(c, A_P, kc)] = v;
    }
    residual(l, top);
    bar();
    for (var kc = lid; kc < nc; kc += WG) {
        let jc = kc / cnt;
        let ic = kc % cnt;
        var out: f64 = 0.0;
        if jc >= 1u && jc < cnz && scr[at(c, A_INVF, kc)] != 0.0 {
            let jf = jc * st.y;
            let i0 = ic * st.x;
            var rr: f64;
            if st.y == 2u {
                rr = 0.25 * along(l, jf - 1u, i0, st.x) + 0.5 * along(l, jf, i0, st.x)
                    + 0.25 * along(l, jf + 1u, i0, st.x);
            } else {
                rr = along(l, jf, i0, st.x);
            }
            let a = diag(c, jc, ic) * scr[at(c, A_BASE, kc)] - neighbours(c, A_BASE, jc, ic);
            out = rr + a;
        }
        scr[at(c, A_F, kc)] = out;
    }
    bar();
}

// The θ-stencil of the full weighting on fine row j at column i0.
fn along(l: u32, j: u32, i0: u32, st: u32) -> f64 {
    let fnt = nt_of(l);
    let row = j * fnt;
    if st == 2u {
        let im = select(i0 - 1u, fnt - 1u, i0 == 0u);
        let ip = select(i0 + 1u, 0u, i0 + 1u == fnt);
        return 0.25 * scr[at(l, A_R, row + im)] + 0.5 * scr[at(l, A_R, row + i0)]
            + 0.25 * scr[at(l, A_R, row + ip)];
    }
    return scr[at(l, A_R, row + i0)];
}

// Coarse-grid correction e = p − u0 of level l − 1 at fine node (j, i) (bilinear).
fn corr(l: u32, j: u32, i: u32) -> f64 {
    let c = l - 1u;
    let st = strides(l);
    let cnt = nt_of(c);
    var jc = j;
    var jo = 0u;
    if st.y == 2u {
        jc = j / 2u;
        jo = j % 2u;
    }
    var ic = i;
    var io = 0u;
    if st.x == 2u {
        ic = i / 2u;
        io = i % 2u;
    }
    let ic1 = select(ic + 1u, 0u, ic + 1u == cnt);
    let k00 = jc * cnt + ic;
    let k01 = jc * cnt + ic1;
    let e00 = scr[at(c, A_P, k00)] - scr[at(c, A_BASE, k00)];
    if jo == 0u && io == 0u {
        return e00;
    }
    let e01 = scr[at(c, A_P, k01)] - scr[at(c, A_BASE, k01)];
    if jo == 0u {
        return 0.5 * (e00 + e01);
    }
    let k10 = k00 + cnt;
    let e10 = scr[at(c, A_P, k10)] - scr[at(c, A_BASE, k10)];
    if io == 0u {
        return 0.5 * (e00 + e10);
    }
    let k11 = k01 + cnt;
    let e11 = scr[at(c, A_P, k11)] - scr[at(c, A_BASE, k11)];
    return 0.25 * (e00 + e01 + e10 + e11);
}

// Whether node k of level l is in the pressure zone before the correction: the node and
// its four neighbours positive (the end rows count as positive neighbours).
fn inside_before(l: u32, k: u32) -> bool {
    let nt = nt_of(l);
    let nz = nz_of(l);
    let j = k / nt;
    let i = k % nt;
    let row = j * nt;
    let ip = select(k + 1u, row, i + 1u == nt);
    let im = select(k - 1u, row + nt - 1u, i == 0u);
    return scr[at(l, A_P, k)] > 0.0 && scr[at(l, A_P, ip)] > 0.0 && scr[at(l, A_P, im)] > 0.0
        && (j + 1u == nz || scr[at(l, A_P, k + nt)] > 0.0)
        && (j == 1u || scr[at(l, A_P, k - nt)] > 0.0);
}

// Whether node x of level l (array ia: its inverse diagonals) was emptied by the truncated
// correction in progress: a candidate (free, inside before the correction, corrected to
// zero or below; its new value in A_R is 0 unless the walk shut it out, then its old,
// positive value). Final for the nodes the walk has passed.
fn gone(l: u32, ia: u32, x: u32) -> bool {
    if scr[at(l, A_R, x)] != 0.0 || scr[at(l, ia, x)] == 0.0 || !inside_before(l, x) {
        return false;
    }
    let nt = nt_of(l);
    return max(scr[at(l, A_P, x)] + corr(l, x / nt, x % nt), 0.0) <= 0.0;
}

// p += P(u_H − u0) at the nodes inside the pressure zone (node and four neighbours
// positive), projected; held nodes set (solved grid). The CPU walks the nodes in order,
// in place: a node whose earlier neighbour (west, south, or the row's first node for the
// last column) the correction emptied is not inside any more. Here: every node's new
// value from the field before the correction (into the residual array, dead here); the
// candidates that the correction empties (few: at the free boundary) go to a workgroup
// list, sorted by node (ranks, all invocations), that one invocation walks in node order
// to find which are really emptied (`gone`: a node's own test, O(1)) and which later
// neighbours they shut out; then the new field is copied back. Beyond the list's
// capacity one invocation does the CPU's in-place walk. The same result as the CPU's.
fn prolong_correction(l: u32, top: bool) {
    let nt = nt_of(l);
    let interior = interior_of(l);
    let ia = select(A_INVF, A_INV, top);
    if lid == 0u {
        atomicStore(&ncand, 0u);
    }
    serial = 0u;
    spent += 2u * loops(interior) + 2u;
    bar();
    for (var m = lid; m < interior; m += WG) {
        let k = m + nt;
        let pk = scr[at(l, A_P, k)];
        var v = pk;
        if scr[at(l, ia, k)] == 0.0 {
            if top {
                v = hold_of(l, k);
            }
        } else if inside_before(l, k) {
            v = max(pk + corr(l, k / nt, k % nt), 0.0);
            if v <= 0.0 {
                let slot = atomicAdd(&ncand, 1u);
                if slot < CAND_CAP {
                    cand[slot] = k;
                }
            }
        }
        scr[at(l, A_R, k)] = v;
    }
    bar();
    if lid == 0u {
        wn = atomicLoad(&ncand);
    }
    tally[cat] += 1u;
    let n = workgroupUniformLoad(&wn);
    tally[T_CORRECTIONS] += 1u;
    tally[T_CANDIDATES] += n;
    if n > CAND_CAP {
        // Too many: the CPU's walk, in place, by one invocation.
        if lid == 0u {
            let nz = nz_of(l);
            wcost = nt * nz;
            tally[T_INPLACE] += nt * nz - nt;
            for (var k = nt; k < nt * nz; k++) {
                if scr[at(l, ia, k)] == 0.0 {
                    if top {
                        scr[at(l, A_P, k)] = hold_of(l, k);
                    }
                } else if inside_before(l, k) {
                    let pk = scr[at(l, A_P, k)];
                    scr[at(l, A_P, k)] = max(pk + corr(l, k / nt, k % nt), 0.0);
                }
            }
        }
        tally[cat] += 1u;
        spent += workgroupUniformLoad(&wcost);
        return;
    }
    if n > 0u {
        // Sort the candidates by node: each one's rank in the list (all invocations), into
        // cand_zero, then back.
        spent += loops(n) * (n + 1u) + loops(n) + 2u;
        tally[T_SORT] += ((n + WG - 1u) / WG) * n;
        for (var a = lid; a < n; a += WG) {
            let x = cand[a];
            var r = 0u;
            for (var b = 0u; b < n; b++) {
                if cand[b] < x {
                    r += 1u;
                }
            }
            cand_zero[r] = x;
        }
        bar();
        for (var a = lid; a < n; a += WG) {
            cand[a] = cand_zero[a];
        }
        bar();
    }
    if n > 0u && lid == 0u {
        // Walk them in node order: shut out (unchanged) where an earlier neighbour was
        // emptied.
        for (var a = 0u; a < n; a++) {
            serial += 1u;
            let k = cand[a];
            let i = k % nt;
            let j = k / nt;
            var shut = (i > 0u && gone(l, ia, k - 1u)) || (j > 1u && gone(l, ia, k - nt));
            if i + 1u == nt {
                shut = shut || gone(l, ia, j * nt);
            }
            if shut {
                // Not inside any more: unchanged.
                scr[at(l, A_R, k)] = scr[at(l, A_P, k)];
            }
        }
        // Later neighbours of the emptied nodes are shut out: unchanged.
        let nz = nz_of(l);
        for (var a = 0u; a < n; a++) {
            serial += 1u;
            let z = cand[a];
            if !gone(l, ia, z) {
                continue;
            }
            let i = z % nt;
            let j = z / nt;
            var later = array<u32, 3>(0u, 0u, 0u);
            if i + 1u < nt {
                later[0] = z + 1u;
            }
            if j + 1u < nz {
                later[1] = z + nt;
            }
            if i == 0u {
                later[2] = z + nt - 1u;
            }
            for (var q = 0u; q < 3u; q++) {
                serial += 1u;
                let k = later[q];
                if k != 0u && !gone(l, ia, k) && scr[at(l, ia, k)] != 0.0 {
                    scr[at(l, A_R, k)] = scr[at(l, A_P, k)];
                }
            }
        }
    }
    if lid == 0u {
        wcost = serial;
        tally[T_WALK] += serial;
    }
    bar();
    tally[cat] += 1u;
    spent += workgroupUniformLoad(&wcost);
    for (var m = lid; m < interior; m += WG) {
        let k = m + nt;
        scr[at(l, A_P, k)] = scr[at(l, A_R, k)];
    }
    bar();
}

// p = P p_coarse on level l (the full-multigrid start), held nodes at their value.
// Cubic interpolation at the midpoint of four equally spaced values (between b and c),
// fourth order (multigrid.rs cubic_mid).
fn cubic_mid(a: f64, b: f64, c: f64, d: f64) -> f64 {
    return (9.0 * (b + c) - (a + d)) * (1.0 / 16.0);
}

// One-sided cubic at the midpoint of the first two of four values (multigrid.rs cubic_edge).
fn cubic_edge(a: f64, b: f64, c: f64, d: f64) -> f64 {
    return (5.0 * a + 15.0 * b - 5.0 * c + d) * (1.0 / 16.0);
}

// Row jc of level c's solution at fine column i (θ stride st): the coincident node, or
// between two the periodic four-point cubic (linear below four columns).
fn row_cubic(c: u32, jc: u32, i: u32, st: u32) -> f64 {
    let cnt = nt_of(c);
    let b = jc * cnt;
    if st == 1u || i % 2u == 0u {
        return scr[at(c, A_P, b + i / st)];
    }
    let ic = i / 2u;
    let i1 = (ic + 1u) % cnt;
    if cnt < 4u {
        return 0.5 * (scr[at(c, A_P, b + ic)] + scr[at(c, A_P, b + i1)]);
    }
    let i0 = (ic + cnt - 1u) % cnt;
    let i2 = (ic + 2u) % cnt;
    return cubic_mid(scr[at(c, A_P, b + i0)], scr[at(c, A_P, b + ic)],
        scr[at(c, A_P, b + i1)], scr[at(c, A_P, b + i2)]);
}

// Explicit grids' FMG start (multigrid.rs prolong_solution_cubic): the tensor product of
// four-point cubic interpolation, periodic in θ, one-sided in ζ next to the end rows
// (linear below three coarse intervals), at fine node (j, i) of level l.
fn cubic_at(l: u32, j: u32, i: u32) -> f64 {
    let c = l - 1u;
    let st = strides(l);
    let cnz = nz_of(c);
    let jc = j / st.y;
    if j % st.y == 0u {
        return row_cubic(c, jc, i, st.x);
    }
    if cnz < 3u {
        return 0.5 * (row_cubic(c, jc, i, st.x) + row_cubic(c, jc + 1u, i, st.x));
    }
    if jc == 0u {
        return cubic_edge(row_cubic(c, 0u, i, st.x), row_cubic(c, 1u, i, st.x),
            row_cubic(c, 2u, i, st.x), row_cubic(c, 3u, i, st.x));
    }
    if jc + 1u == cnz {
        return cubic_edge(row_cubic(c, cnz, i, st.x), row_cubic(c, cnz - 1u, i, st.x),
            row_cubic(c, cnz - 2u, i, st.x), row_cubic(c, cnz - 3u, i, st.x));
    }
    return cubic_mid(row_cubic(c, jc - 1u, i, st.x), row_cubic(c, jc, i, st.x),
        row_cubic(c, jc + 1u, i, st.x), row_cubic(c, jc + 2u, i, st.x));
}

// The FMG start of level l from level l − 1's solution: cubic on explicit grids (mode 0),
// bilinear on the accuracy ladder (multigrid.rs prolong_solution).
fn prolong_solution(l: u32) {
    let c = l - 1u;
    let st = strides(l);
    let nt = nt_of(l);
    let cnt = nt_of(c);
    let interior = interior_of(l);
    let cubic = params.mode == 0u;
    spent += loops(interior);
    for (var m = lid; m < interior; m += WG) {
        let k = m + nt;
        let j = k / nt;
        let i = k % nt;
        let jc = j / st.y;
        let jo = j % st.y;
        let ic = i / st.x;
        let io = i % st.x;
        let ic1 = (ic + 1u) % cnt;
        let u00 = scr[at(c, A_P, jc * cnt + ic % cnt)];
        var v: f64;
        if cubic {
            v = cubic_at(l, j, i);
        } else if jo == 0u && io == 0u {
            v = u00;
        } else if jo == 0u {
            v = 0.5 * (u00 + scr[at(c, A_P, jc * cnt + ic1)]);
        } else if io == 0u {
            v = 0.5 * (u00 + scr[at(c, A_P, (jc + 1u) * cnt + ic % cnt)]);
        } else {
            v = 0.25 * (u00 + scr[at(c, A_P, jc * cnt + ic1)]
                + scr[at(c, A_P, (jc + 1u) * cnt + ic % cnt)]
                + scr[at(c, A_P, (jc + 1u) * cnt + ic1)]);
        }
        if scr[at(l, A_INV, k)] == 0.0 {
            v = hold_of(l, k);
        } else {
            v = max(v, 0.0);
        }
        scr[at(l, A_P, k)] = v;
    }
    bar();
}

// A ladder grid's start (solver.rs cubic_rows_in_zeta, LadderRule::cubic_start): after
// the bilinear prolongation, the rows between the coarse rows (odd j; the even rows are the
// coarse solution, interpolated in θ) again by cubics in ζ through the four nearest even
// rows, (−1, 9, 9, −1)/16, next to an end face (5, 15, −5, 1)/16 (n_z ≥ 6) or the
// quadratic (3, 6, −1)/8 through rows 0, 2, 4 (n_z = 4); clipped at 0; held nodes keep
// their value. Reads even rows only, writes odd ones: order-independent. n_z even.
fn cubic_rows_in_zeta(l: u32) {
    let nt = nt_of(l);
    let nz = nz_of(l);
    let cnt = nt * (nz / 2u);
    spent += loops(cnt);
    for (var m = lid; m < cnt; m += WG) {
        let j = 2u * (m / nt) + 1u;
        let i = m % nt;
        let k = j * nt + i;
        if scr[at(l, A_INV, k)] == 0.0 {
            continue;
        }
        var v: f64;
        if nz < 6u {
            // Rows 0, 2, 4 from the nearer end face (p = 0 on the end rows).
            var a = 0u;
            var c = 4u;
            if j != 1u {
                a = 4u;
                c = 0u;
            }
            v = (3.0 * scr[at(l, A_P, a * nt + i)] + 6.0 * scr[at(l, A_P, 2u * nt + i)]
                - scr[at(l, A_P, c * nt + i)]) / 8.0;
        } else if j == 1u {
            v = cubic_edge(scr[at(l, A_P, i)], scr[at(l, A_P, 2u * nt + i)],
                scr[at(l, A_P, 4u * nt + i)], scr[at(l, A_P, 6u * nt + i)]);
        } else if j == nz - 1u {
            v = cubic_edge(scr[at(l, A_P, nz * nt + i)], scr[at(l, A_P, (nz - 2u) * nt + i)],
                scr[at(l, A_P, (nz - 4u) * nt + i)], scr[at(l, A_P, (nz - 6u) * nt + i)]);
        } else {
            v = cubic_mid(scr[at(l, A_P, (j - 3u) * nt + i)], scr[at(l, A_P, (j - 1u) * nt + i)],
                scr[at(l, A_P, (j + 1u) * nt + i)], scr[at(l, A_P, (j + 3u) * nt + i)]);
        }
        scr[at(l, A_P, k)] = max(v, 0.0);
    }
    bar();
}

// Fixed grids (multigrid.rs `Hierarchy::line_freeze`): the column of level c's row jc that
// stands for the max-film inlet line of the solved level t (NO_INLET: none): from t's held
// column down, per coarsening the coincident node or, between two, the one on the side of
// the smaller right-hand side (upstream). Level t itself: its held column.
fn inlet_line(c: u32, jc: u32, t: u32) -> u32 {
    var j = jc;
    for (var m = c + 1u; m <= t; m++) {
        j = j * strides(m).y;
    }
    var i = inlets[ib + params.lw[t].z + j];
    for (var m = t; m > c; m--) {
        if i == NO_INLET {
            return NO_INLET;
        }
        let st = strides(m);
        if st.x == 2u && i % 2u == 1u {
            let left = i - 1u;
            let right = select(i + 1u, 0u, i + 1u == nt_of(m));
            i = select(right / 2u, left / 2u, f_own(m, j, left) <= f_own(m, j, right));
        } else {
            i = i / st.x;
        }
        j = j / st.y;
    }
    return i;
}

// Freezes the nodes of level l − 1 (a correction grid of l, solved level t) whose
// restriction stencil touches a held or frozen node of l; on fixed grids the inlet line
// freezes one node per row instead, `inlet_line` (multigrid.rs `freeze`).
fn freeze(l: u32, top: bool, t: u32) {
    let line = params.mode == 0u;
    let c = l - 1u;
    let st = strides(l);
    let fnt = nt_of(l);
    let fnz = nz_of(l);
    let cnt = nt_of(c);
    let ia = select(A_INVF, A_INV, top);
    let interior = interior_of(c);
    // Per node: inlet_line's two walks over the levels between c and t, and up to three
    // fine rows each with its own walk.
    var per_node = 4u;
    if line {
        per_node = 4u + 2u * (t - c) + 3u * (3u + 2u * (t - l));
    }
    spent += 1u + loops(interior) * per_node;
    for (var m = lid; m < interior; m += WG) {
        let kc = m + cnt;
        let jc = kc / cnt;
        let ic = kc % cnt;
        let jf = jc * st.y;
        var jlo = jf;
        var jhi = jf;
        if st.y == 2u {
            jlo = jf - 1u;
            jhi = jf + 1u;
        }
        let i0 = ic * st.x;
        var held = false;
        if line {
            held = inlet_line(c, jc, t) == ic;
        }
        for (var j = max(jlo, 1u); j <= min(jhi, fnz - 1u); j++) {
            var fi = NO_INLET;
            if line {
                fi = inlet_line(l, j, t);
            }
            if st.x == 2u {
                let im = select(i0 - 1u, fnt - 1u, i0 == 0u);
                let ip = select(i0 + 1u, 0u, i0 + 1u == fnt);
                held = held || (scr[at(l, ia, j * fnt + im)] == 0.0 && im != fi)
                    || (scr[at(l, ia, j * fnt + i0)] == 0.0 && i0 != fi)
                    || (scr[at(l, ia, j * fnt + ip)] == 0.0 && ip != fi);
            } else {
                held = held || (scr[at(l, ia, j * fnt + i0)] == 0.0 && i0 != fi);
            }
        }
        scr[at(c, A_INVF, kc)] = select(1.0 / diag(c, jc, ic), 0.0, held);
    }
    bar();
}

// Load integrals −⅓ (∬P cos θ, ∬P sin θ, ∬P ζ cos θ, ∬P ζ sin θ) of level l's iterate:
// rectangle rule in θ; in ζ Simpson's rule on the ladder of the plain film (accuracy mode
// without held bands, even n_z: weights 4/3 on odd rows, 2/3 on even ones; solver.rs
// ladder_integrals_on), else the rectangle rule (explicit grids, grooves and arcs).
fn loads(l: u32) -> array<f64, 4> {
    let nt = nt_of(l);
    let nz = nz_of(l);
    let dt = 2.0 * PI / f64(nt);
    let dz = 1.0 / f64(nz);
    let interior = interior_of(l);
    let simpson = params.mode != 0u && params.banded == 0u && nz % 2u == 0u;
    var acc = array<f64, 4>(0.0, 0.0, 0.0, 0.0);
    // Lane `lid` (< SUM_LANES) sums nodes lid, lid + SUM_LANES, … in order: the same
    // partial sums at any workgroup size (reduce_sum4).
    spent += (interior + SUM_LANES - 1u) / SUM_LANES + 1u;
    let lanes = select(0u, interior, lid < SUM_LANES);
    for (var m = lid; m < lanes; m += SUM_LANES) {
        let k = m + nt;
        let j = k / nt;
        let i = k % nt;
        var w: f64 = 1.0;
        if simpson {
            let even: f64 = 2.0 / 3.0;
            let odd: f64 = 4.0 / 3.0;
            w = select(even, odd, j % 2u == 1u);
        }
        let v = w * scr[at(l, A_P, k)];
        let t = trig_at(l, 2u * i);
        let zeta = f64(j) * dz;
        let c = v * t.x;
        let s = v * t.y;
        acc[0] += c;
        acc[1] += s;
        acc[2] += c * zeta;
        acc[3] += s * zeta;
    }
    let sum = reduce_sum4(acc);
    var out: array<f64, 4>;
    for (var q = 0u; q < 4u; q++) {
        out[q] = -sum[q] * dt * dz / 3.0;
    }
    return out;
}

// x^(1/5) in f64 for x > 0 (f32 start, two Newton steps: no f64 pow on the device).
fn root5(x: f64) -> f64 {
    let y0 = f64(pow(f32(x), 0.2));
    if !(y0 > 0.0) || x <= 0.0 {
        return 0.0;
    }
    var y = y0;
    for (var n = 0u; n < 2u; n++) {
        let y4 = y * y * y * y;
        y = y - (y4 * y - x) / (5.0 * y4);
    }
    return y;
}

// The resumable solve (see `main`): its phases.
// Set up the first grid's levels (and load a warm start).
const PH_INIT: u32 = 0u;
// Next grid of the sequence: set it up (ladder grids) and prolong the solution onto it.
const PH_PREP: u32 = 1u;
// Start iterating on level `cur`: its own right-hand side, the freezes below it.
const PH_ENTER: u32 = 2u;
// Level 0 solved by itself: its projected SOR to the tolerance, one sweep per step.
const PH_COARSE: u32 = 3u;
// A V-cycle on level `cur`, at step `vs`.
const PH_CYCLE: u32 = 4u;
// Field, loads and report out.
const PH_DONE: u32 = 5u;
// Written out: nothing left to do.
const PH_OUT: u32 = 6u;
// The state block of a slot, in `results` from OUT_STATE on (f64 each): status, phase,
// level, cycle, cycle limit, last change, iteration error, converged, node updates, ladder
// values kept, estimate, met, V-cycle step, coarsest sweep, coarsest history (6),
// previous loads (4), ladder loads (48), loose factor in force, dispatches run (written
// last: see OUT_BEGIN).
const OUT_STATE: u32 = 11u;
const WS_LEN: u32 = 74u;
// The dispatch count of the dispatch that last ran the slot, written before its steps: a
// dispatch whose loops llvmpipe cut short leaves the state's own count (written last)
// behind it, which the host reports as an error.
const OUT_BEGIN: u32 = 85u;
// Status (result 11): 0 running; 1 done; 2 done, more grids needed (host); 3 the
// dispatch ran more loop iterations than `params.limit` (results void: the host errs).
const ST_RUN: f64 = 0.0;
const ST_OVERRUN: f64 = 3.0;

// The state block and OUT_BEGIN (which follows it).
var<workgroup> ws: array<f64, 75>;

var<private> ph: u32;
var<private> cur: u32;
var<private> cyc: u32;
var<private> maxc: u32;
var<private> last_change: f64;
var<private> err: f64;
var<private> conv: bool;
var<private> nv: u32;
var<private> est: f64;
var<private> met: bool;
var<private> vs: u32;
var<private> cs: u32;
var<private> hist: array<f64, 6>;
var<private> prev: array<f64, 4>;
var<private> vals: array<f64, 48>;
// Ladder grids after the first: the loose factor of the stop in force (LadderRule::loose
// while the grid may be an intermediate one, 0 once it is iterated on to the floor).
var<private> loose_now: f64;
// Ladder grids after the first: the last cycle's change of the load vector (`dl`) and the
// estimated iteration error of the loads the estimate reports (`itr`, solver.rs
// LadderCycles::reported_iteration), both of the step that ends the cycle; the change of
// the cycle before is kept across dispatches in the free load slot `vals[4 nv ..]` (the
// current grid's, written by finish_level only once its cycles are over).
var<private> dl: array<f64, 4>;
var<private> itr: f64;

// One sweep of the projected SOR on the coarsest level (0) and its stop test: the solve
// ends when the estimated change is below `tol` of the largest value or, with `rel` > 0
// (inside a V-cycle), below `rel` of the correction's largest value if that is larger
// (from the second sweep on, the contraction as measured over the last sweep, at least
// ω − 1), or after COARSEST_SWEEPS (multigrid.rs Level::solve_coarsest). True when the
// solve is over.
fn coarsest_step(tol: f64, top: bool, rel: f64) -> bool {
    let omega = omega0;
    let floor = min(omega - 1.0, 0.9999);
    let min_tail = floor / (1.0 - floor);
    let r = sweep(0u, omega, top, true, tol, rel);
    let dp = r.x;
    updates += f64(interior_of(0u));
    // The history shift and root5's Newton steps.
    spent += 8u;
    for (var q = 0u; q < 5u; q++) {
        hist[q] = hist[q + 1u];
    }
    hist[5] = dp;
    let s = cs;
    cs += 1u;
    if cs >= COARSEST_SWEEPS {
        return true;
    }
    // max(tol × largest value, rel × largest correction) from the sweep's reduction.
    let tol_abs = r.y;
    if rel > 0.0 {
        if s >= 1u && dp != 0.0 {
            let rho1 = min(max(dp / hist[4], omega - 1.0), 0.9999);
            if dp * rho1 / (1.0 - rho1) <= tol_abs {
                return true;
            }
        }
    }
    if dp != 0.0 && dp * min_tail > tol_abs {
        return false;
    }
    var measured: f64 = 0.0;
    if hist[0] > 0.0 {
        measured = root5(hist[5] / hist[0]);
    }
    let rho = min(max(measured, omega - 1.0), 0.9999);
    return dp == 0.0 || (s >= 5u && dp * rho / (1.0 - rho) <= tol_abs);
}

fn start_coarsest() {
    spent += 7u;
    cs = 0u;
    for (var q = 0u; q < 6u; q++) {
        hist[q] = -1.0;
    }
}

fn norm4(a: array<f64, 4>) -> f64 {
    var s: f64 = 0.0;
    for (var q = 0u; q < 4u; q++) {
        s += a[q] * a[q];
    }
    return sqrt(s);
}

fn dist4(a: array<f64, 4>, b: array<f64, 4>) -> f64 {
    var s: f64 = 0.0;
    for (var q = 0u; q < 4u; q++) {
        s += (a[q] - b[q]) * (a[q] - b[q]);
    }
    return sqrt(s);
}

// Largest d₀/d₋₁ of the last two pairs taken as asymptotic (solver.rs LADDER_PAIR_RATIO).
const LADDER_PAIR_RATIO: f64 = 1.0;

// Whether the pair ending at value m − 1 (of m values) is out of its asymptotic range:
// its difference above LADDER_PAIR_RATIO × the pair before's.
fn pair_out(vals: array<f64, 48>, m: u32) -> bool {
    if m < 4u {
        return false;
    }
    var a: array<f64, 4>;
    var b: array<f64, 4>;
    var c: array<f64, 4>;
    for (var q = 0u; q < 4u; q++) {
        a[q] = vals[4u * (m - 3u) + q];
        b[q] = vals[4u * (m - 2u) + q];
        c[q] = vals[4u * (m - 1u) + q];
    }
    return dist4(c, b) > LADDER_PAIR_RATIO * dist4(b, a);
}

// Whether the plain film's ladder goes on one more grid though its bound is met on the
// last of `n` values (solver.rs ladder_extends): the last pair out of its asymptotic
// range, the one before not; never with held bands, nor on the ladder's last grid.
fn ladder_extends(vals: array<f64, 48>, n: u32) -> bool {
    if params.banded != 0u || cur + 1u >= params.n_levels {
        return false;
    }
    return pair_out(vals, n) && !pair_out(vals, n - 1u);
}

// The bound the ladder stops on for the last of `n` ladder values (solver.rs
// simpson_stop_bound and, with held bands, banded_estimate); negative below three grids.
fn estimate(vals: array<f64, 48>, n: u32) -> f64 {
    if n < 3u {
        return -1.0;
    }
    var a: array<f64, 4>;
    var b: array<f64, 4>;
    var c: array<f64, 4>;
    for (var q = 0u; q < 4u; q++) {
        a[q] = vals[4u * (n - 3u) + q];
        b[q] = vals[4u * (n - 2u) + q];
        c[q] = vals[4u * (n - 1u) + q];
    }
    let d1 = dist4(b, a);
    let d2 = dist4(c, b);
    let norm = norm4(c);
    if norm == 0.0 {
        return 0.0;
    }
    if params.banded != 0u {
        return 1.5 * max(d2, 0.25 * d1) / norm;
    }
    // Second order (loads summed by Simpson in ζ, see `loads`), the last pair's and the
    // pair two grids back carried to the last grid: 3 = 2² − 1, 48 = 4² (2² − 1).
    var bound = d2 / 3.0;
    if n >= 4u {
        var z: array<f64, 4>;
        for (var q = 0u; q < 4u; q++) {
            z[q] = vals[4u * (n - 4u) + q];
        }
        bound = max(bound, dist4(a, z) / 48.0);
    }
    return bound / norm;
}

// The estimate reported with the bound `e` of `estimate` (solver.rs simpson_reported):
// with held bands the bound itself, else √(max(bound, d₁/12) × d₂/3) + the level's
// estimated iteration error `it` (d₁ the pair one back carried one grid on at second
// order: 12 = 4 (2² − 1)).
fn reported(vals: array<f64, 48>, n: u32, e: f64, it: f64) -> f64 {
    if e < 0.0 || params.banded != 0u {
        return e;
    }
    var a: array<f64, 4>;
    var b: array<f64, 4>;
    var c: array<f64, 4>;
    for (var q = 0u; q < 4u; q++) {
        a[q] = vals[4u * (n - 3u) + q];
        b[q] = vals[4u * (n - 2u) + q];
        c[q] = vals[4u * (n - 1u) + q];
    }
    let norm = norm4(c);
    if norm == 0.0 {
        return 0.0;
    }
    var bound = e;
    if n >= 4u {
        bound = max(bound, dist4(b, a) / 12.0 / norm);
    }
    return sqrt(bound * dist4(c, b) / 3.0 / norm) + max(it, 0.0);
}

// The stop of level t's V-cycles on the estimated iteration error (solver.rs
// FiniteSolver::ladder_cycles): explicit grids, the ladder's first grid and its
// full-multigrid levels `params.tolerance`; a ladder grid after the first
// max(floor, loose × |v − v_below| / 4 / |v|) with v its loads after the last cycle (`prev`)
// and v_below the grid below's (`|v − v_below|/4`: about the next grid's difference at
// second order, through which alone v enters the estimate), the floor alone once the grid
// is iterated on to end the ladder (`loose_now` 0).
fn stop_tolerance(t: u32) -> f64 {
    if params.mode == 0u || t <= params.top0 {
        return params.tolerance;
    }
    spent += 8u;
    let norm = norm4(prev);
    if loose_now > 0.0 && norm > 0.0 && nv > 0u {
        var below: array<f64, 4>;
        for (var q = 0u; q < 4u; q++) {
            below[q] = vals[4u * (nv - 1u) + q];
        }
        // 4: the next grid's difference at second order.
        return max(params.floor, loose_now * dist4(prev, below) / 4.0 / norm);
    }
    return params.floor;
}

// Level `cur`'s iteration is over (multigrid.rs Hierarchy::iterate returned): the next
// grid of the full multigrid start (one V-cycle per intermediate level), of the ladder
// (with its loads, Richardson estimate and stop at the requested accuracy), or done.
fn finish_level() {
    let top0 = params.top0;
    if cur < top0 {
        cur += 1u;
        maxc = select(1u, params.max_cycles, cur == top0);
        ph = PH_PREP;
        return;
    }
    if params.mode == 0u {
        ph = PH_DONE;
        return;
    }
    spent += 24u;
    if cur == top0 {
        let v0 = loads(top0);
        for (var q = 0u; q < 4u; q++) {
            vals[q] = v0[q];
        }
        nv = 1u;
        est = -1.0;
    } else {
        let v = loads(cur);
        var n = nv;
        if n < MAX_RUNGS {
            for (var q = 0u; q < 4u; q++) {
                vals[4u * n + q] = v[q];
            }
            n += 1u;
        }
        let e = estimate(vals, n);
        let ext = ladder_extends(vals, n);
        let short = params.measured_last != 0u && cyc < 2u;
        if e >= 0.0 && e <= params.accuracy && !ext
            && ((loose_now > 0.0 && err > params.floor) || short) && cyc < maxc {
            // Stopped loosely as an intermediate grid, but it ends the ladder: on to the
            // floor, and to a second cycle with `measured_last` (the cycles continue, none
            // is repeated; solver.rs solve_accuracy);
            // the grid's load slot holds the last cycle's change again (see `dl`).
            loose_now = 0.0;
            if nv < MAX_RUNGS {
                for (var q = 0u; q < 4u; q++) {
                    vals[4u * nv + q] = dl[q];
                }
            }
            ph = PH_CYCLE;
            return;
        }
        nv = n;
        if e >= 0.0 {
            est = reported(vals, n, e, itr);
            // A grid whose cycles did not reach their stop does not end the ladder
            // (solver.rs solve_accuracy: `res.2`).
            if e <= params.accuracy && !ext && conv {
                met = true;
                ph = PH_DONE;
                return;
            }
        }
    }
    if cur + 1u < params.n_levels {
        cur += 1u;
        maxc = params.max_cycles;
        ph = PH_PREP;
    } else {
        ph = PH_DONE;
    }
}

// One V-cycle step on level t = `cur` (multigrid.rs Hierarchy::vcycle and iterate):
// vs = 0 starts a cycle; 1 ..= t the descent (pre-smoothing, residual, FAS restriction of
// level t + 1 − vs); t + 1 the coarsest solve (a sweep per step); t + 2 ..= 2t + 1 the
// ascent (truncated correction and post-smoothing of level vs − t − 1); 2t + 2 the
// cycle's stop test (the estimated iteration error against the tolerance).
fn cycle_step() {
    let t = cur;
    let nt = nt_of(t);
    let interior = interior_of(t);
    let field_stop = params.mode == 0u;
    cat = T_STOP;
    if vs == 0u {
        cat = T_DESCENT;
        tally[T_CYCLES] += 1u;
        cyc += 1u;
        if field_stop {
            spent += loops(interior);
            for (var m = lid; m < interior; m += WG) {
                scr[at(t, A_BASE, m + nt)] = scr[at(t, A_P, m + nt)];
            }
            bar();
        }
        vs = 1u;
    } else if vs <= t {
        cat = T_DESCENT;
        let m = t + 1u - vs;
        for (var s = 0u; s < NU_PRE; s++) {
            sweep(m, 1.0, m == t, false, 0.0, 0.0);
        }
        updates += f64(NU_PRE * interior_of(m));
        restrict_fas(m, m == t);
        vs += 1u;
        if vs == t + 1u {
            start_coarsest();
        }
    } else if vs == t + 1u {
        cat = T_CSOLVE;
        tally[T_CSWEEPS] += 1u;
        if coarsest_step(COARSEST_TOL, false, COARSEST_CORRECTION) {
            vs += 1u;
        }
    } else if vs <= 2u * t + 1u {
        cat = T_ASCENT;
        let m = vs - t - 1u;
        prolong_correction(m, m == t);
        let nu_post = select(NU_POST, params.ladder_post, params.mode != 0u && t > params.top0);
        for (var s = 0u; s < nu_post; s++) {
            sweep(m, 1.0, m == t, false, 0.0, 0.0);
        }
        updates += f64(nu_post * interior_of(m));
        vs += 1u;
    } else {
        var change: f64 = 0.0;
        if field_stop {
            var dmax: f64 = 0.0;
            var pmax: f64 = 0.0;
            spent += loops(interior);
            for (var m = lid; m < interior; m += WG) {
                let a = scr[at(t, A_P, m + nt)];
                dmax = max(dmax, abs(a - scr[at(t, A_BASE, m + nt)]));
                pmax = max(pmax, a);
            }
            let r = reduce_max2(dmax, pmax);
            if r.y > 0.0 {
                change = r.x / r.y;
            }
        } else {
            let now = loads(t);
            let d = dist4(now, prev);
            let norm = norm4(now);
            for (var q = 0u; q < 4u; q++) {
                dl[q] = now[q] - prev[q];
            }
            prev = now;
            if norm > 0.0 {
                change = d / norm;
            }
            // The reported iteration error (multigrid.rs load_tail_estimate): the tail of
            // the load vector's own contraction ρ = δ·δ₋₁/|δ₋₁|² within [−0.95, 0.95],
            // |ρ| at least 0.1; 0.5 on the grid's first cycle (last_change < 0).
            itr = 0.0;
            if norm > 0.0 {
                var rho: f64 = 0.5;
                if last_change > 0.0 && nv < MAX_RUNGS {
                    var dot: f64 = 0.0;
                    var l2: f64 = 0.0;
                    for (var q = 0u; q < 4u; q++) {
                        let b = vals[4u * nv + q];
                        dot += dl[q] * b;
                        l2 += b * b;
                    }
                    if l2 > 0.0 {
                        rho = clamp(dot / l2, -0.95, 0.95);
                    }
                }
                itr = norm4(dl) / norm * max(abs(rho), 0.1) / (1.0 - rho);
            }
            if nv < MAX_RUNGS {
                for (var q = 0u; q < 4u; q++) {
                    vals[4u * nv + q] = dl[q];
                }
            }
            spent += 16u;
        }
        // Contraction per cycle: measured, within [0.1, 0.95]; 0.5 until measured.
        var rho: f64 = 0.5;
        if last_change > 0.0 {
            rho = clamp(change / last_change, 0.1, 0.95);
        }
        last_change = change;
        err = change * rho / (1.0 - rho);
        vs = 0u;
        if change == 0.0 || err <= stop_tolerance(t) {
            conv = true;
            finish_level();
        } else if cyc >= maxc {
            conv = false;
            finish_level();
        }
    }
}

// One step of the solve (a phase's unit of work), then the phase that follows.
fn step(slot: u32, warm: bool) {
    let top0 = params.top0;
    let before = spent;
    if ph == PH_INIT {
        cat = T_INIT;
        spent += top0 + 1u;
        for (var l = 0u; l <= top0; l++) {
            setup(l);
        }
        cur = 0u;
        maxc = params.max_cycles;
        if params.mode == 0u && warm {
            // Warm start (multigrid.rs Level::load_field): interior free nodes from the
            // given field, held nodes at their value; V-cycles on the grid itself.
            let nt = nt_of(top0);
            let interior = interior_of(top0);
            let fb = slot * params.field_stride;
            spent += loops(interior);
            for (var m = lid; m < interior; m += WG) {
                let k = m + nt;
                var v = fields[fb + k];
                if scr[at(top0, A_INV, k)] == 0.0 {
                    v = hold_of(top0, k);
                }
                scr[at(top0, A_P, k)] = v;
            }
            bar();
            cur = top0;
        }
        ph = PH_ENTER;
    } else if ph == PH_PREP {
        cat = T_PREP;
        if cur > top0 {
            setup(cur);
        }
        prolong_solution(cur);
        if cur > top0 && params.cubic_start != 0u {
            cubic_rows_in_zeta(cur);
        }
        ph = PH_ENTER;
    } else if ph == PH_ENTER {
        cat = T_ENTER;
        // multigrid.rs Hierarchy::iterate: the level's own right-hand side, then the
        // freezes of its correction grids.
        let l = cur;
        let nt = nt_of(l);
        let n = full_of(l);
        spent += loops(n) + l + 1u;
        for (var k = lid; k < n; k += WG) {
            scr[at(l, A_F, k)] = f_own(l, k / nt, k % nt);
        }
        bar();
        for (var m = l; m >= 1u; m--) {
            freeze(m, m == l, l);
        }
        if l == 0u {
            start_coarsest();
            ph = PH_COARSE;
        } else {
            prev = loads(l);
            last_change = -1.0;
            err = -1.0;
            cyc = 0u;
            vs = 0u;
            // A ladder grid after the first may be an intermediate one: the loose stop.
            loose_now = 0.0;
            if params.mode != 0u && l > top0 {
                loose_now = params.loose;
            }
            ph = PH_CYCLE;
        }
    } else if ph == PH_COARSE {
        cat = T_COARSE;
        tally[T_COARSE_SWEEPS] += 1u;
        // Explicit grids: the first grid of full multigrid only starts the next one
        // (solver.rs fmg_with, FMG_FIRST_TOLERANCE).
        var tol = params.tolerance;
        if params.mode == 0u && params.top0 > 0u {
            tol = max(tol, FMG_FIRST_TOLERANCE);
        }
        if coarsest_step(tol, true, 0.0) {
            cyc = 1u;
            err = 0.0;
            conv = true;
            finish_level();
        }
    } else if ph == PH_CYCLE {
        cycle_step();
    } else if ph == PH_DONE {
        cat = T_DONE;
        // Field of the last grid out, loads, report.
        let n = full_of(cur);
        let fb = slot * params.field_stride;
        spent += loops(n);
        for (var k = lid; k < n; k += WG) {
            fields[fb + k] = scr[at(cur, A_P, k)];
        }
        let ints = loads(cur);
        if lid == 0u {
            let o = slot * OUT_STRIDE;
            for (var q = 0u; q < 4u; q++) {
                results[o + q] = ints[q];
            }
            let interior = f64(max(interior_of(cur), 1u));
            results[o + 4u] = ceil(updates / interior);
            results[o + 5u] = err;
            results[o + 6u] = select(f64(0.0), f64(1.0), conv);
            results[o + 7u] = f64(nt_of(cur));
            results[o + 8u] = f64(nz_of(cur));
            results[o + 9u] = est;
            results[o + 10u] = select(f64(0.0), f64(1.0), met);
        }
        spent += 8u;
        ph = PH_OUT;
    }
    tally[T_SPENT_PART + cat] += spent - before;
}

// Resumable: a dispatch runs steps of the solve until its loop iterations reach
// `params.budget`, keeps the state in the slot's `results` block (the fields stay in
// `scr`) and returns; the host dispatches again until every slot's status is set. So no
// invocation runs more than `params.limit` loop iterations per dispatch: llvmpipe
// (lavapipe) ends a shader's loops after 65 535 iterations in all, which had stopped
// large grids early with wrong loads (BENCHMARKS "Issue 20/26: the multigrid kernel").
// A dispatch that counted more than the limit marks its slot ST_OVERRUN: the host reports
// an error instead of loads a cut loop may have spoiled.
@compute @workgroup_size(WG)
fn main(@builtin(workgroup_id) wid: vec3<u32>, @builtin(local_invocation_index) li: u32) {
    let slot = wid.x + wid.y * 65535u;
    if slot >= params.count {
        return;
    }
    lid = li;
    cat = T_MAIN;
    sb = slot * params.stride;
    jb = slot * JOB_STRIDE;
    ib = slot * params.inlet_stride;
    let o = slot * OUT_STRIDE;
    if li == 0u {
        for (var q = 0u; q < WS_LEN + 1u; q++) {
            ws[q] = results[o + OUT_STATE + q];
        }
    }
    tally[cat] += 1u;
    let st = workgroupUniformLoad(&ws);
    if st[0] != ST_RUN {
        return;
    }
    if st[74] != st[73] {
        // The last dispatch did not save the state whole (llvmpipe cut its loops).
        if li == 0u {
            results[o + OUT_STATE] = ST_OVERRUN;
        }
        return;
    }
    let count = st[73] + 1.0;
    if li == 0u {
        results[o + OUT_BEGIN] = count;
    }
    ph = u32(st[1]);
    cur = u32(st[2]);
    cyc = u32(st[3]);
    maxc = u32(st[4]);
    last_change = st[5];
    err = st[6];
    conv = st[7] > 0.5;
    updates = st[8];
    nv = u32(st[9]);
    est = st[10];
    met = st[11] > 0.5;
    vs = u32(st[12]);
    cs = u32(st[13]);
    for (var q = 0u; q < 6u; q++) {
        hist[q] = st[14u + q];
    }
    for (var q = 0u; q < 4u; q++) {
        prev[q] = st[20u + q];
    }
    for (var q = 0u; q < 48u; q++) {
        vals[q] = st[24u + q];
    }
    loose_now = st[72];
    for (var q = 0u; q < 4u; q++) {
        ecc[q] = jobs[jb + q];
        rate[q] = jobs[jb + 4u + q];
    }
    let aspect = jobs[jb + 8u];
    aspect2 = aspect * aspect;
    supply = jobs[jb + 9u];
    cos0 = jobs[jb + 12u];
    sin0 = jobs[jb + 13u];
    if li == 0u {
        wu[0] = jobs[jb + 10u];
        wu[1] = jobs[jb + 14u];
    }
    tally[cat] += 1u;
    omega0 = workgroupUniformLoad(&wu[0]);
    tally[cat] += 1u;
    let warm = workgroupUniformLoad(&wu[1]) > 0.5;
    bar();
    // The loops above (the state in, its copy and the tally out below) and this one's
    // exit test.
    spent = 2u * WS_LEN + N_TALLY + 96u;

    loop {
        if ph == PH_OUT || spent >= params.budget {
            break;
        }
        spent += 1u;
        step(slot, warm);
    }
    cat = T_MAIN;
    tally[T_DISPATCHES] += 1u;
    // The state in and out, and the loop's exit tests (spent minus the steps' parts).
    var steps = 0u;
    for (var q = T_INIT; q < T_MAIN; q++) {
        steps += tally[T_SPENT_PART + q];
    }
    tally[T_SPENT_PART + T_MAIN] = spent - steps;
    tally[T_SPENT] = spent;

    if lid == 0u {
        var status = ST_RUN;
        if ph == PH_OUT {
            status = 1.0;
            if params.mode != 0u && !met && params.more != 0u {
                status = 2.0;
            }
        }
        if spent > params.limit {
            status = ST_OVERRUN;
        }
        var out: array<f64, WS_LEN>;
        out[0] = status;
        out[1] = f64(ph);
        out[2] = f64(cur);
        out[3] = f64(cyc);
        out[4] = f64(maxc);
        out[5] = last_change;
        out[6] = err;
        out[7] = select(f64(0.0), f64(1.0), conv);
        out[8] = updates;
        out[9] = f64(nv);
        out[10] = est;
        out[11] = select(f64(0.0), f64(1.0), met);
        out[12] = f64(vs);
        out[13] = f64(cs);
        for (var q = 0u; q < 6u; q++) {
            out[14u + q] = hist[q];
        }
        for (var q = 0u; q < 4u; q++) {
            out[20u + q] = prev[q];
        }
        for (var q = 0u; q < 48u; q++) {
            out[24u + q] = vals[q];
        }
        out[72] = loose_now;
        out[73] = count;
        for (var q = 0u; q < WS_LEN; q++) {
            results[o + OUT_STATE + q] = out[q];
        }
        for (var q = 0u; q < N_TALLY; q++) {
            results[o + OUT_TALLY + q] += f64(tally[q]);
        }
    }
}
