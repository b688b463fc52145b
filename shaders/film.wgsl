// Film-load kernel: the default rule of src/bearing/rule.rs (`FilmRule::integrate`) for
// packed, nondimensional states, LANES invocations per state (one by default): each state's
// Gauss slices are dealt round-robin over its lanes and the lanes' sums added by a tree in
// workgroup memory, so that a state's latency is its root search plus ~slices/LANES slices
// instead of all of them (issue 26 item 3).
//
// Inputs are the host's `PackedState` (eccentricity vectors over radial clearance and
// rate vectors scaled to order one at both end faces); outputs are the four film
// integrals `[J_c, J_s, K_c, K_s]` that the host turns into loads. No trigonometric,
// exponential or power function is used in `real` precision (several drivers mishandle
// them in f64): Gauss-Legendre nodes and weights and the root finder's start angles come
// from the `table` buffer, `atan2` is evaluated arithmetically (`atan2_arith`), sin and
// cos of the arc's half-length by series, and only the root finder's start radius uses an
// f32 `pow`, as on the CPU.
//
// The block between the PRECISION markers is swapped by the host for an f32 variant
// (`bearing_sweep::backend::kernel_source`); the rest is precision-agnostic.

// BEGIN PRECISION
alias real = f64;
// Durand-Kerner stops when no root moves more than this (relative): ~450 ulp of f64.
const ROOT_TOL: real = 1e-13;
// Leading quartic terms below this fraction of the polynomial's size at |t| = 2 are
// dropped (their roots lie far outside the interval).
const DROP_TOL: real = 1e-13;
// The poles |eps(s)| = 1 are kept at least this far outside [0, 1] under rounding.
const POLE_PAD: real = 1e-14;
// END PRECISION

// Invocations per state, a power of two dividing WG_SIZE. The host swaps this line for
// the lane count it runs (`kernel_source_lanes`); with 1 every state is summed by one
// invocation in the order of rule.rs.
const LANES: u32 = 1u;
// Invocations per workgroup (`WORKGROUP_SIZE` in gpu.rs).
const WG_SIZE: u32 = 64u;

// Sentinel for "no pole on this side": far beyond any panel length (finite, so that no
// infinity literal is needed; 1e30 is representable in f32 too).
const FAR: real = 1e30;
// Largest magnitude accepted as a finite root (NaN fails the comparison too).
const FINITE_MAX: real = 1e30;
// Floor of a denominator that may vanish, representable in f32 and f64 alike.
const TINY: real = 1e-30;
// Durand-Kerner iterations at most (quadratic convergence: ~10 suffice for simple roots).
const ROOT_ITERATIONS: u32 = 64u;
const PI: real = 3.141592653589793;

struct PackedState {
    ecc: vec4<real>,
    rate: vec4<real>,
}

struct Params {
    // States in this dispatch.
    count: u32,
    // Gauss-Legendre nodes per panel.
    nodes: u32,
    // Hard cap on panels per state.
    max_panels: u32,
    _pad: u32,
}

// Table layout (all `real`): [kappa_ahead, kappa_behind, kink_floor, complex_ellipse,
//   nodes[0..n], weights[0..n], start angles: 10 (cos, sin) pairs for quartic degree
//   m = 1..4, root k < m at offset 2 (m(m-1)/2 + k)].
const T_KAPPA_AHEAD: u32 = 0u;
const T_KAPPA_BEHIND: u32 = 1u;
const T_KINK_FLOOR: u32 = 2u;
const T_COMPLEX_ELLIPSE: u32 = 3u;
const T_NODES: u32 = 4u;

@group(0) @binding(0) var<uniform> params: Params;
@group(0) @binding(1) var<storage, read> table: array<real>;
@group(0) @binding(2) var<storage, read> states: array<PackedState>;
@group(0) @binding(3) var<storage, read_write> out: array<vec4<real>>;

// atan(u) for |u| <= 1: two half-angle reductions, atan(u) = 2 atan(u / (1 + sqrt(1 + u²))),
// bring |v| <= tan(pi/16) < 0.2, then the odd Taylor series to v^23 (truncation
// < 0.2^25 / 25 < 2e-19 relative).
fn atan_unit(u: real) -> real {
    var v = u / (1.0 + sqrt(1.0 + u * u));
    v = v / (1.0 + sqrt(1.0 + v * v));
    let v2 = v * v;
    var p: real = 1.0 / 23.0;
    p = 1.0 / 21.0 - v2 * p;
    p = 1.0 / 19.0 - v2 * p;
    p = 1.0 / 17.0 - v2 * p;
    p = 1.0 / 15.0 - v2 * p;
    p = 1.0 / 13.0 - v2 * p;
    p = 1.0 / 11.0 - v2 * p;
    p = 1.0 / 9.0 - v2 * p;
    p = 1.0 / 7.0 - v2 * p;
    p = 1.0 / 5.0 - v2 * p;
    p = 1.0 / 3.0 - v2 * p;
    p = 1.0 - v2 * p;
    return 4.0 * v * p;
}

// atan2(y, x) in (-pi, pi] without a trigonometric builtin. Half angle first:
// x >= 0: atan2 = 2 atan(y / (r + x)); x < 0: atan2 = 2 (sign(y) pi/2 - atan(y / (r - x))),
// both arguments in [-1, 1] and free of cancellation.
fn atan2_arith(y: real, x: real) -> real {
    let r = sqrt(x * x + y * y);
    if r == 0.0 {
        return 0.0;
    }
    if x >= 0.0 {
        return 2.0 * atan_unit(y / (r + x));
    }
    let half_pi_signed = select(0.5 * PI, -0.5 * PI, y < 0.0);
    return 2.0 * (half_pi_signed - atan_unit(y / (r - x)));
}

// sin and cos of q in [0, pi/2] by their Taylor series (truncation < 1e-18).
fn sin_cos_small(q: real) -> vec2<real> {
    let q2 = q * q;
    var ps: real = 1.9572941063391263e-20;
    ps = -8.22063524662433e-18 + q2 * ps;
    ps = 2.8114572543455206e-15 + q2 * ps;
    ps = -7.647163731819816e-13 + q2 * ps;
    ps = 1.6059043836821613e-10 + q2 * ps;
    ps = -2.505210838544172e-08 + q2 * ps;
    ps = 2.7557319223985893e-06 + q2 * ps;
    ps = -0.0001984126984126984 + q2 * ps;
    ps = 0.008333333333333333 + q2 * ps;
    ps = -0.16666666666666666 + q2 * ps;
    ps = 1.0 + q2 * ps;
    var pc: real = -8.896791392450574e-22;
    pc = 4.110317623312165e-19 + q2 * pc;
    pc = -1.5619206968586225e-16 + q2 * pc;
    pc = 4.779477332387385e-14 + q2 * pc;
    pc = -1.1470745597729725e-11 + q2 * pc;
    pc = 2.08767569878681e-09 + q2 * pc;
    pc = -2.755731922398589e-07 + q2 * pc;
    pc = 2.48015873015873e-05 + q2 * pc;
    pc = -0.001388888888888889 + q2 * pc;
    pc = 0.041666666666666664 + q2 * pc;
    pc = -0.5 + q2 * pc;
    pc = 1.0 + q2 * pc;
    return vec2<real>(q * ps, pc);
}

// Closed-form loaded-arc integrals of one slice, |r| (C, S) in the bearing frame: the
// rule of `slice_integrals` in rule.rs, with the arc's integrals in the Sommerfeld angle
// written about the arc's midpoint so that they keep their relative accuracy in f32.
//
// On the arc [gamma_a, gamma_b] = [m - h, m + h] the three integrands are
// (eps + cos g)^2, sin^2 g and sin g (eps + cos g). On the low-pressure side they are
// small, O((1 - eps)^2), while the antiderivatives of rule.rs are O(1) at both ends: their
// difference loses ~log10(1/(1-eps)^2) digits, harmless in f64 but 1e-4 in f32. About the
// midpoint, with A = eps + cos m, the odd parts cancel exactly and
//   A_cc = 2h A^2 - 4 A cos m f1 + cos^2 m f2 + sin^2 m f3,
//   A_ss = sin^2 m (h + sin h cos h) + cos^2 m f3,
//   A_sc = 2 sin m sin h (A - 2 cos m sin^2(h/2)),
// f1 = h - sin h, f2 = 3h + sin h cos h - 4 sin h, f3 = h - sin h cos h, all O(h^3) or
// smaller and taken from their Taylor series for h <= 1.5 (cancellation-free; truncation
// < 1e-17), directly above (cancellation at most a factor ~8).
fn slice_integrals(ex: real, ey: real, rx: real, ry: real) -> vec2<real> {
    let r = sqrt(rx * rx + ry * ry);
    if r == 0.0 {
        return vec2<real>(0.0, 0.0);
    }
    let eps = sqrt(ex * ex + ey * ey);
    var cphi: real = 1.0;
    var sphi: real = 0.0;
    if eps > 0.0 {
        cphi = ex / eps;
        sphi = ey / eps;
    }
    let ca = rx / r;
    let sa = ry / r;
    let cb = ca * cphi + sa * sphi;
    let sb = sa * cphi - ca * sphi;
    let sq2 = (1.0 - eps) * (1.0 + eps);
    let sq = sqrt(sq2);
    let da = 1.0 + eps * cb;
    let db = 1.0 - eps * cb;
    let cga = (-cb - eps) / da;
    let sga = -sq * sb / da;
    let cgb = (cb - eps) / db;
    let sgb = sq * sb / db;
    let dot_ab = cga * cgb + sga * sgb;
    var dg = atan2_arith(cga * sgb - sga * cgb, dot_ab);
    if dg <= 0.0 {
        dg = dg + 2.0 * PI;
    }
    let h = 0.5 * dg;
    // Midpoint direction of the counter-clockwise arc, from whichever of a + b and b - a
    // is the longer (|.| >= sqrt 2): well conditioned for every arc length.
    var cm: real;
    var sm: real;
    if dot_ab > 0.0 {
        let x = cga + cgb;
        let y = sga + sgb;
        let n = select(real(-1.0), real(1.0), dg < PI) / sqrt(x * x + y * y);
        cm = x * n;
        sm = y * n;
    } else {
        let x = cgb - cga;
        let y = sgb - sga;
        let n = 1.0 / sqrt(x * x + y * y);
        cm = y * n;
        sm = -x * n;
    }
    let half = sin_cos_small(0.5 * h);
    let s2 = half.x;
    let sh = 2.0 * half.x * half.y;
    let ch = 1.0 - 2.0 * s2 * s2;
    var f1: real;
    var f2: real;
    var f3: real;
    if h <= 1.5 {
        let u = h * h;
        var p1: real = 9.183689863795546e-29;
        p1 = -6.446950284384474e-26 + u * p1;
        p1 = 3.868170170630684e-23 + u * p1;
        p1 = -1.9572941063391263e-20 + u * p1;
        p1 = 8.22063524662433e-18 + u * p1;
        p1 = -2.8114572543455206e-15 + u * p1;
        p1 = 7.647163731819816e-13 + u * p1;
        p1 = -1.6059043836821613e-10 + u * p1;
        p1 = 2.505210838544172e-08 + u * p1;
        p1 = -2.7557319223985893e-06 + u * p1;
        p1 = 0.0001984126984126984 + u * p1;
        p1 = -0.008333333333333333 + u * p1;
        p1 = 0.16666666666666666 + u * p1;
        var p2: real = -6.1630695735287436e-21;
        p2 = 1.081618516745786e-18 + u * p2;
        p2 = -1.6224266146676277e-16 + u * p2;
        p2 = 2.05236379567223e-14 + u * p2;
        p2 = -2.154957323550102e-12 + u * p2;
        p2 = 1.8424041679177067e-10 + u * p2;
        p2 = -1.252605419272086e-08 + u * p2;
        p2 = 6.571360738027404e-07 + u * p2;
        p2 = -2.5553150553150554e-05 + u * p2;
        p2 = 0.0006944444444444445 + u * p2;
        p2 = -0.011904761904761904 + u * p2;
        p2 = 0.1 + u * p2;
        p2 = 0.0 + u * p2;
        var p3: real = 6.163069940876338e-21;
        p3 = -1.0816187746237974e-18 + u * p3;
        p3 = 1.622428161935696e-16 + u * p3;
        p3 = -2.0523716248486557e-14 + u * p3;
        p3 = 2.1549902060910882e-12 + u * p3;
        p3 = -1.8425166262078804e-10 + u * p3;
        p3 = 1.2529113058213587e-08 + u * p3;
        p3 = -6.577784355562133e-07 + u * p3;
        p3 = 2.565335898669232e-05 + u * p3;
        p3 = -0.0007054673721340388 + u * p3;
        p3 = 0.012698412698412698 + u * p3;
        p3 = -0.13333333333333333 + u * p3;
        p3 = 0.6666666666666666 + u * p3;
        f1 = h * u * p1;
        f2 = h * u * p2;
        f3 = h * u * p3;
    } else {
        f1 = h - sh;
        f2 = 3.0 * h + sh * ch - 4.0 * sh;
        f3 = h - sh * ch;
    }
    let a = eps + cm;
    let a_cc = 2.0 * h * a * a - 4.0 * a * cm * f1 + cm * cm * f2 + sm * sm * f3;
    let a_ss = sm * sm * (h + sh * ch) + cm * cm * f3;
    let a_sc = 2.0 * sm * sh * (a - 2.0 * cm * s2 * s2);
    let i_sc = a_sc / (sq2 * sq2);
    let i_cc = a_cc / (sq2 * sq2 * sq);
    let i_ss = a_ss / (sq2 * sq);
    let c_arc = cb * i_sc - sb * i_cc;
    let s_arc = cb * i_ss - sb * i_sc;
    return vec2<real>(r * (c_arc * cphi - s_arc * sphi), r * (s_arc * cphi + c_arc * sphi));
}

struct Roots {
    z: array<vec2<real>, 4>,
    n: u32,
}

// Roots of c0 + c1 t + ... + c4 t^4 that matter for |t| <~ 2 by Durand-Kerner
// (`quartic_roots` in rule.rs, the same operations in the same order).
fn quartic_roots(c_in: array<real, 5>) -> Roots {
    var c = c_in;
    var res: Roots;
    for (var k = 0u; k < 4u; k++) {
        res.z[k] = vec2<real>(0.0, 0.0);
    }
    var norm: real = 0.0;
    var scale: real = 1.0;
    for (var k = 0u; k < 5u; k++) {
        norm = max(norm, abs(c[k]) * scale);
        scale = scale * 2.0;
    }
    var n = 4u;
    var pow2n: real = 16.0;
    while n > 0u && abs(c[n]) * pow2n <= DROP_TOL * norm {
        n = n - 1u;
        pow2n = pow2n * 0.5;
    }
    res.n = n;
    if n == 0u {
        return res;
    }
    let lead = c[n];
    var a: array<real, 4>;
    for (var k = 0u; k < 4u; k++) {
        a[k] = select(0.0, c[k] / lead, k < n);
    }
    // Start radius ~ the roots' geometric mean, in f32 as on the CPU.
    var radius: real = 1.0;
    let a0 = min(abs(a[0]), FINITE_MAX);
    if a0 > 0.0 {
        let r32 = pow(f32(a0), 1.0 / f32(n));
        if r32 > 0.0 && r32 < 3.0e38 {
            radius = real(r32);
        }
    }
    let start = 4u + 2u * params.nodes + n * (n - 1u);
    for (var k = 0u; k < n; k++) {
        res.z[k] = radius * vec2<real>(table[start + 2u * k], table[start + 2u * k + 1u]);
    }
    for (var it = 0u; it < ROOT_ITERATIONS; it++) {
        var moved: real = 0.0;
        for (var i = 0u; i < n; i++) {
            let z = res.z[i];
            var p = vec2<real>(1.0, 0.0);
            for (var kk = 0u; kk < n; kk++) {
                let k = n - 1u - kk;
                p = vec2<real>(p.x * z.x - p.y * z.y + a[k], p.x * z.y + p.y * z.x);
            }
            var q = vec2<real>(1.0, 0.0);
            for (var j = 0u; j < n; j++) {
                if j != i {
                    let d = z - res.z[j];
                    q = vec2<real>(q.x * d.x - q.y * d.y, q.x * d.y + q.y * d.x);
                }
            }
            let den = q.x * q.x + q.y * q.y;
            if den == 0.0 {
                continue;
            }
            let step = vec2<real>((p.x * q.x + p.y * q.y) / den, (p.y * q.x - p.x * q.y) / den);
            res.z[i] = z - step;
            moved = max(moved, max(abs(step.x), abs(step.y)) / (1.0 + max(abs(z.x), abs(z.y))));
        }
        if moved < ROOT_TOL {
            break;
        }
    }
    return res;
}

// Singularities of the axial integrand (`Singularities` in rule.rs); FAR / -FAR mark a
// missing pole, kink_s < 0 a missing kink.
struct Sing {
    pole_lo: real,
    pole_hi: real,
    kink_s: real,
    complex: array<vec2<real>, 5>,
    count: u32,
}

fn singularities(st: PackedState) -> Sing {
    let e0 = st.ecc.xy;
    let e1 = st.ecc.zw - st.ecc.xy;
    let r0 = st.rate.xy;
    let r1 = st.rate.zw - st.rate.xy;
    var sing: Sing;
    sing.pole_lo = -FAR;
    sing.pole_hi = FAR;
    sing.kink_s = -1.0;
    sing.count = 0u;
    for (var k = 0u; k < 5u; k++) {
        sing.complex[k] = vec2<real>(0.0, 0.0);
    }
    let e1sq = e1.x * e1.x + e1.y * e1.y;
    if e1sq > 0.0 {
        let sm = -(e0.x * e1.x + e0.y * e1.y) / e1sq;
        let cross = e0.x * e1.y - e0.y * e1.x;
        let emin2 = cross * cross / e1sq;
        let half = sqrt(max(1.0 - emin2, 0.0)) / sqrt(e1sq);
        sing.pole_lo = min(sm - half, -POLE_PAD);
        sing.pole_hi = max(sm + half, 1.0 + POLE_PAD);
    }
    let r1sq = r1.x * r1.x + r1.y * r1.y;
    let kink_floor = table[T_KINK_FLOOR];
    // The rate vector's zero: graded toward when d_r >= floor (`has_zero`), else a
    // (near-)kink wherever it lies (`has_kink`; a panel boundary inside the bearing).
    var has_zero = false;
    var zero_s: real = 0.0;
    var zero_d: real = 0.0;
    var has_kink = false;
    if r1sq > 0.0 {
        let s_r = -(r0.x * r1.x + r0.y * r1.y) / r1sq;
        let d_r = abs(r0.x * r1.y - r0.y * r1.x) / r1sq;
        if d_r >= kink_floor {
            sing.complex[sing.count] = vec2<real>(s_r, d_r);
            sing.count = sing.count + 1u;
            has_zero = true;
            zero_s = s_r;
            zero_d = d_r;
        } else {
            has_kink = true;
            if s_r > 0.0 && s_r < 1.0 {
                sing.kink_s = s_r;
            }
        }
    }
    if has_kink {
        // The quartic has a (near-)double root at the kink, no singularity of either
        // one-sided integrand; the arc ends point along ∓r̂1 and meet the pole of 1/h³
        // where ε(s)·r̂1 = ±1: two real points outside [0, 1] (rule.rs explains).
        let r1n = sqrt(r1sq);
        let a = e0.x * r1.x + e0.y * r1.y;
        let b = e1.x * r1.x + e1.y * r1.y;
        if b != 0.0 {
            for (var k = 0u; k < 2u; k++) {
                let side = select(-r1n, r1n, k == 0u);
                let s_root = (side - a) / b;
                if abs(s_root) <= FINITE_MAX {
                    sing.complex[sing.count] = vec2<real>(s_root, 0.0);
                    sing.count = sing.count + 1u;
                }
            }
        }
        return sing;
    }
    let ec = e0 + 0.5 * e1;
    let rc = r0 + 0.5 * r1;
    let a0 = ec.x * rc.x + ec.y * rc.y;
    let a1 = ec.x * r1.x + ec.y * r1.y + e1.x * rc.x + e1.y * rc.y;
    let a2 = e1.x * r1.x + e1.y * r1.y;
    let b0 = rc.x * rc.x + rc.y * rc.y;
    let b1 = 2.0 * (rc.x * r1.x + rc.y * r1.y);
    let b2 = r1sq;
    let roots = quartic_roots(array<real, 5>(
        a0 * a0 - b0,
        2.0 * a0 * a1 - b1,
        a1 * a1 + 2.0 * a0 * a2 - b2,
        2.0 * a1 * a2,
        a2 * a2,
    ));
    // Roots clustered at a graded rate zero get at least half their local bound as
    // imaginary part (Durand-Kerner can return them almost real; rule.rs derives it).
    var reach: real = -1.0;
    var im_floor: real = 0.0;
    if has_zero {
        let ez = e0 + e1 * zero_s;
        let gap = max(1.0 - (ez.x * ez.x + ez.y * ez.y), 0.0);
        reach = 2.0 * zero_d / max(gap, TINY);
        im_floor = 0.5 * zero_d * sqrt(gap);
    }
    for (var k = 0u; k < roots.n; k++) {
        let z = roots.z[k];
        if abs(z.x) <= FINITE_MAX && abs(z.y) <= FINITE_MAX {
            let s_root = z.x + 0.5;
            var im = abs(z.y);
            if has_zero && abs(s_root - zero_s) <= reach {
                im = max(im, im_floor);
            }
            sing.complex[sing.count] = vec2<real>(s_root, im);
            sing.count = sing.count + 1u;
        }
    }
    return sing;
}

// End of the panel that starts at s (at most 1), `Singularities::panel_end` in rule.rs.
fn panel_end(sing: Sing, s: real) -> real {
    let kappa_ahead = table[T_KAPPA_AHEAD];
    let kappa_behind = table[T_KAPPA_BEHIND];
    var step = 1.0 - s;
    step = min(step, kappa_behind * (s - sing.pole_lo));
    step = min(step, kappa_ahead * (sing.pole_hi - s));
    // Complex singularities: the longest panel whose Bernstein ellipse with focal-distance
    // sum `ell` times its length leaves the singularity outside.
    let ell = table[T_COMPLEX_ELLIPSE];
    let inv = 2.0 / (ell * ell - 1.0);
    for (var k = 0u; k < sing.count; k++) {
        let c = sing.complex[k];
        let dx = c.x - s;
        let d = sqrt(dx * dx + c.y * c.y);
        step = min(step, inv * (ell * d - dx));
    }
    var end = s + step;
    if sing.kink_s > s && sing.kink_s < end {
        end = sing.kink_s;
    }
    return min(end, 1.0);
}

// One invocation's whole state (LANES = 1): the panels and their nodes in two nested loops,
// the loop of rule.rs. On lavapipe this form runs ~15-25 % faster than the lane walk below
// with one lane (BENCHMARKS.md "Issue 26, kernel pass"); both sum in the same order.
fn integrate_serial(st: PackedState) -> vec4<real> {
    let e0 = st.ecc.xy;
    let e1 = st.ecc.zw - st.ecc.xy;
    let r0 = st.rate.xy;
    let r1 = st.rate.zw - st.rate.xy;
    if all(e1 == vec2<real>(0.0, 0.0)) && all(r1 == vec2<real>(0.0, 0.0)) {
        // Aligned: constant slice loads; integral of s(1-s) is 1/6, of s^2(1-s) is 1/12.
        let f = slice_integrals(e0.x, e0.y, r0.x, r0.y);
        return vec4<real>(f.x / 6.0, f.y / 6.0, f.x / 12.0, f.y / 12.0);
    }
    let sing = singularities(st);
    let nodes = params.nodes;
    var acc = vec4<real>(0.0, 0.0, 0.0, 0.0);
    var s: real = 0.0;
    var panels = 0u;
    // `panels <= max_panels` cannot bind (the last panel ends at 1); it guarantees
    // termination even if a comparison misbehaves.
    while s < 1.0 && panels <= params.max_panels {
        panels = panels + 1u;
        var end: real = 1.0;
        if panels < params.max_panels {
            end = panel_end(sing, s);
        }
        let len = end - s;
        for (var k = 0u; k < nodes; k++) {
            let x = table[T_NODES + k];
            let w = table[T_NODES + nodes + k];
            let z = s + len * x;
            let f = slice_integrals(e0.x + e1.x * z, e0.y + e1.y * z, r0.x + r1.x * z, r0.y + r1.y * z);
            let wg = w * len * z * (1.0 - z);
            acc = acc + vec4<real>(wg * f.x, wg * f.y, wg * z * f.x, wg * z * f.y);
        }
        s = end;
    }
    return acc;
}

// This lane's share of the state's integrals: slices g = lane, lane + LANES, ... in the
// order (panel, node) of the serial rule, the panels walked as `FilmRule::integrate` walks
// them (every lane walks them; only the slice evaluations are divided).
fn integrate(st: PackedState, lane: u32) -> vec4<real> {
    let e0 = st.ecc.xy;
    let e1 = st.ecc.zw - st.ecc.xy;
    let r0 = st.rate.xy;
    let r1 = st.rate.zw - st.rate.xy;
    if all(e1 == vec2<real>(0.0, 0.0)) && all(r1 == vec2<real>(0.0, 0.0)) {
        if lane != 0u {
            return vec4<real>(0.0, 0.0, 0.0, 0.0);
        }
        // Aligned: constant slice loads; integral of s(1-s) is 1/6, of s^2(1-s) is 1/12.
        let f = slice_integrals(e0.x, e0.y, r0.x, r0.y);
        return vec4<real>(f.x / 6.0, f.y / 6.0, f.x / 12.0, f.y / 12.0);
    }
    let sing = singularities(st);
    let nodes = params.nodes;
    var acc = vec4<real>(0.0, 0.0, 0.0, 0.0);
    // The current panel is number `begun - 1`, spanning [s, end).
    var s: real = 0.0;
    var end: real = 0.0;
    var begun = 0u;
    var more = true;
    var g = lane;
    loop {
        let want = g / nodes;
        // Begin panels until panel `want` is current; `begun <= max_panels` cannot bind
        // (the last panel ends at 1): it guarantees termination even if a comparison
        // misbehaves.
        while more && begun <= want {
            s = end;
            if s < 1.0 && begun <= params.max_panels {
                begun = begun + 1u;
                end = 1.0;
                if begun < params.max_panels {
                    end = panel_end(sing, s);
                }
            } else {
                more = false;
            }
        }
        if !more {
            break;
        }
        let len = end - s;
        let k = g - want * nodes;
        let x = table[T_NODES + k];
        let w = table[T_NODES + nodes + k];
        let z = s + len * x;
        let f = slice_integrals(e0.x + e1.x * z, e0.y + e1.y * z, r0.x + r1.x * z, r0.y + r1.y * z);
        let wg = w * len * z * (1.0 - z);
        acc = acc + vec4<real>(wg * f.x, wg * f.y, wg * z * f.x, wg * z * f.y);
        g = g + LANES;
    }
    return acc;
}

// The lanes' partial sums of one workgroup.
var<workgroup> partial: array<vec4<real>, WG_SIZE>;

// Workgroups run along x, then y (a dispatch may need more than the 65 535 per dimension).
@compute @workgroup_size(WG_SIZE)
fn main(
    @builtin(local_invocation_index) lid: u32,
    @builtin(workgroup_id) wid: vec3<u32>,
    @builtin(num_workgroups) groups: vec3<u32>,
) {
    let group = wid.x + wid.y * groups.x;
    let lane = lid % LANES;
    let i = group * (WG_SIZE / LANES) + lid / LANES;
    if LANES == 1u {
        if i < params.count {
            out[i] = integrate_serial(states[i]);
        }
    } else {
        var acc = vec4<real>(0.0, 0.0, 0.0, 0.0);
        if i < params.count {
            acc = integrate(states[i], lane);
        }
        partial[lid] = acc;
        workgroupBarrier();
        for (var stride = LANES / 2u; stride > 0u; stride = stride / 2u) {
            if lane < stride {
                partial[lid] = partial[lid] + partial[lid + stride];
            }
            workgroupBarrier();
        }
        if lane == 0u && i < params.count {
            out[i] = partial[lid];
        }
    }
}
