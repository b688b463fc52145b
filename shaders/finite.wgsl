// Finite-length Reynolds film (src/bearing/finite/solver.rs, docs/finite-film.md): one
// workgroup per bearing state, the pressure field in workgroup memory, red-black
// projected SOR (Swift–Stieber cavitation P >= 0), the same discretisation, update order
// within a colour, stopping rule and load sums as the CPU solver.
//
// Nondimensional equation: λ ∂θ(H³ ∂θP) + ∂ζ(H³ ∂ζP) = 6 (a(ζ) sin θ − b(ζ) cos θ),
// P = 0 at ζ = 0 and 1, periodic in θ; H = 1 − εx(ζ) cos θ − εy(ζ) sin θ.
//
// No trigonometric function is evaluated in f64 (several drivers mishandle them): the
// host supplies cos and sin at every half grid step (`trig`), the relaxation factor and
// the inlet columns. Only the contraction estimate of the stopping rule uses an f32 pow.

// Largest field held in workgroup memory: interior nodes n_theta × (n_z − 1), f64
// (13 KiB); with the 2 KiB reduction buffer the workgroup uses 15 KiB of the 16 KiB that
// WebGPU guarantees. Larger grids run on the CPU (the host checks).
const MAX_NODES: u32 = 1664u;
const WG: u32 = 64u;
// Column value meaning "no inlet on this row".
const NO_INLET: u32 = 0xffffffffu;

struct Params {
    // States in this dispatch.
    count: u32,
    // Grid intervals around the circumference (even) and along the length.
    n_theta: u32,
    n_z: u32,
    // Sweep limit.
    max_sweeps: u32,
    // Relative iteration tolerance.
    tolerance: f64,
}

// Per job (stride 12 f64): ecc[4], rate[4], lambda_dtheta (λ/Δθ²), omega (SOR factor),
// warm (1: `fields` holds a start), supply (nondimensional pressure per Pa: a held node's
// value is its pressure in Pa times this).
const JOB_STRIDE: u32 = 12u;
// Per result (stride 8 f64): integrals[4], sweeps, iteration error, converged, unused.
const OUT_STRIDE: u32 = 8u;

@group(0) @binding(0) var<uniform> params: Params;
// cos and sin of k Δθ/2 for k = 0 .. 2 n_theta − 1, interleaved (cos, sin).
@group(0) @binding(1) var<storage, read> trig: array<f64>;
@group(0) @binding(2) var<storage, read> jobs: array<f64>;
// Full fields, n_theta × (n_z + 1) per job (end rows included, always 0): warm start in,
// solution out.
@group(0) @binding(3) var<storage, read_write> fields: array<f64>;
@group(0) @binding(4) var<storage, read_write> results: array<f64>;
// Inlet column per row, (n_z + 1) per job; NO_INLET where none.
@group(0) @binding(5) var<storage, read> inlets: array<u32>;
// Grooves and arcs (src/bearing/groove.rs, shared by every job of the dispatch), 3 f64
// per node of the full grid: east-face factor, north-face factor (Shortley–Weller at a
// held band's edge; 1 elsewhere), held pressure in Pa (negative: free).
@group(0) @binding(6) var<storage, read> geo: array<f64>;

var<workgroup> p: array<f64, MAX_NODES>;
var<workgroup> red: array<f64, 256>;

struct Row {
    ex: f64,
    ey: f64,
}

fn ecc_at(base: u32, zeta: f64) -> Row {
    let ex = jobs[base] + (jobs[base + 2u] - jobs[base]) * zeta;
    let ey = jobs[base + 1u] + (jobs[base + 3u] - jobs[base + 1u]) * zeta;
    return Row(ex, ey);
}

// H³ at half-step angle index k (θ = k Δθ/2) and eccentricity e.
fn h3(e: Row, k: u32) -> f64 {
    let h = 1.0 - e.ex * trig[2u * k] - e.ey * trig[2u * k + 1u];
    return h * h * h;
}

// Tree reduction of red[0..WG) (op 0: max) or red[0..4 WG) (op 1: four sums, stride WG).
fn reduce(lid: u32, four: bool) {
    var s = WG / 2u;
    loop {
        if s == 0u {
            break;
        }
        if lid < s {
            if four {
                for (var q = 0u; q < 4u; q++) {
                    red[q * WG + lid] += red[q * WG + lid + s];
                }
            } else {
                red[lid] = max(red[lid], red[lid + s]);
                red[WG + lid] = max(red[WG + lid], red[WG + lid + s]);
            }
        }
        workgroupBarrier();
        s = s / 2u;
    }
}

@compute @workgroup_size(64)
fn main(@builtin(workgroup_id) wid: vec3<u32>, @builtin(local_invocation_index) lid: u32) {
    let job = wid.x + wid.y * 65535u;
    // Uniform across the workgroup: every invocation leaves together.
    if job >= params.count {
        return;
    }
    let nt = params.n_theta;
    let nz = params.n_z;
    let half = nt / 2u;
    let interior = nt * (nz - 1u);
    let base = job * JOB_STRIDE;
    let full = nt * (nz + 1u);
    let fbase = job * full;
    let ibase = job * (nz + 1u);
    let ct = jobs[base + 8u];
    let omega = jobs[base + 9u];
    let warm = jobs[base + 10u] > 0.5;
    let supply = jobs[base + 11u];
    let dz = 1.0 / f64(nz);
    let cz = f64(nz) * f64(nz);

    for (var k = lid; k < interior; k += WG) {
        if warm {
            p[k] = fields[fbase + nt + k];
        } else {
            p[k] = 0.0;
        }
    }
    workgroupBarrier();

    var hist: array<f64, 6>;
    for (var q = 0u; q < 6u; q++) {
        hist[q] = -1.0;
    }
    var sweeps = 0u;
    var err: f64 = 0.0;
    var converged = false;
    loop {
        if sweeps >= params.max_sweeps {
            break;
        }
        var my_dp: f64 = 0.0;
        var my_p: f64 = 0.0;
        for (var colour = 0u; colour < 2u; colour++) {
            for (var m = lid; m < interior / 2u; m += WG) {
                let j = 1u + m / half;
                let i = 2u * (m % half) + ((colour + j) % 2u);
                let k = (j - 1u) * nt + i;
                let zeta = f64(j) * dz;
                let e = ecc_at(base, zeta);
                let en = ecc_at(base, zeta + 0.5 * dz);
                let es = ecc_at(base, zeta - 0.5 * dz);
                let im = select(i - 1u, nt - 1u, i == 0u);
                let ip = select(i + 1u, 0u, i + 1u == nt);
                // Face coefficients: θ faces at half steps 2i + 1 and 2 im + 1, ζ faces
                // at node angle 2i.
                let kf = j * nt + i;
                let ae = ct * h3(e, 2u * i + 1u) * geo[3u * kf];
                let aw = ct * h3(e, 2u * im + 1u) * geo[3u * (j * nt + im)];
                let an = cz * h3(en, 2u * i) * geo[3u * kf + 1u];
                let as_ = cz * h3(es, 2u * i) * geo[3u * (kf - nt) + 1u];
                let held = geo[3u * kf + 2u];
                var pn: f64 = 0.0;
                if j + 1u < nz {
                    pn = p[k + nt];
                }
                var ps: f64 = 0.0;
                if j > 1u {
                    ps = p[k - nt];
                }
                let row = (j - 1u) * nt;
                let s = ae * p[row + ip] + aw * p[row + im] + an * pn + as_ * ps;
                let a = jobs[base + 4u] + (jobs[base + 6u] - jobs[base + 4u]) * zeta;
                let b = jobs[base + 5u] + (jobs[base + 7u] - jobs[base + 5u]) * zeta;
                let rhs = 6.0 * (a * trig[4u * i + 1u] - b * trig[4u * i]);
                let old = p[k];
                var new_p: f64 = 0.0;
                if held >= 0.0 {
                    new_p = held * supply;
                } else if inlets[ibase + j] != i {
                    let gs = (s - rhs) / (ae + aw + an + as_);
                    new_p = max(old + omega * (gs - old), 0.0);
                }
                p[k] = new_p;
                my_dp = max(my_dp, abs(new_p - old));
                my_p = max(my_p, new_p);
            }
            workgroupBarrier();
        }
        red[lid] = my_dp;
        red[WG + lid] = my_p;
        workgroupBarrier();
        reduce(lid, false);
        // Uniform loads: the stopping decision below must be workgroup-uniform (every
        // invocation reaches the same barriers).
        let max_dp = workgroupUniformLoad(&red[0]);
        let max_p = workgroupUniformLoad(&red[WG]);
        sweeps += 1u;
        for (var q = 0u; q < 5u; q++) {
            hist[q] = hist[q + 1u];
        }
        hist[5] = max_dp;
        var measured: f64 = 0.0;
        if hist[0] > 0.0 {
            measured = f64(pow(f32(hist[5] / hist[0]), 0.2));
        }
        let rho = min(max(measured, omega - 1.0), 0.9999);
        if max_p > 0.0 {
            err = max_dp * rho / (1.0 - rho) / max_p;
        } else {
            err = 0.0;
        }
        if max_dp == 0.0 || (sweeps >= 6u && err <= params.tolerance) {
            converged = true;
            break;
        }
    }

    // Field out (end rows 0) and the load sums −⅓ ∬ P (cos, sin, ζ cos, ζ sin).
    var acc = array<f64, 4>(0.0, 0.0, 0.0, 0.0);
    for (var k = lid; k < full; k += WG) {
        let j = k / nt;
        var v: f64 = 0.0;
        if j >= 1u && j < nz {
            v = p[k - nt];
        }
        fields[fbase + k] = v;
        let i = k % nt;
        let c = v * trig[4u * i];
        let s = v * trig[4u * i + 1u];
        let zeta = f64(j) * dz;
        acc[0] += c;
        acc[1] += s;
        acc[2] += c * zeta;
        acc[3] += s * zeta;
    }
    for (var q = 0u; q < 4u; q++) {
        red[q * WG + lid] = acc[q];
    }
    workgroupBarrier();
    reduce(lid, true);
    if lid == 0u {
        let w = -(1.0 / f64(nt)) * 2.0 * 3.141592653589793 * dz / 3.0;
        let o = job * OUT_STRIDE;
        for (var q = 0u; q < 4u; q++) {
            results[o + q] = red[q * WG] * w;
        }
        results[o + 4u] = f64(sweeps);
        results[o + 5u] = err;
        results[o + 6u] = select(f64(0.0), f64(1.0), converged);
        results[o + 7u] = 0.0;
    }
}
