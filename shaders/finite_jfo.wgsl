// Mass-conserving (JFO, Elrod–Adams p-θ) cavitation of the finite film on a fixed grid
// (src/bearing/finite/jfo.rs, docs/jfo.md): one workgroup per bearing state, the same
// discrete problem as the CPU solver. The host sets the problem up with the CPU's code
// (`JfoProblem`: face coefficients, diagonal, upwind Couette coefficients, storage in its
// steady or time-step form, held supply nodes, the start) and sums the loads of the
// returned field; this kernel only iterates.
//
// Node equation (free node k, surface moving towards +θ; mirrored for s < 0):
//   d P_k + c_φ φ_k = q_k,  c_φ = c_e,k + c_s,k,
//   q_k = a_e,k P_E + a_e,W P_W + a_n,k P_N + a_n,S P_S + c_e,W φ_W − c_0,k,
// whose unique monotone root is P = r/d with φ = 1 if positive (over-relaxed by ω), else
// P = 0, φ = 1 + r/c_φ clipped to [0, 1], where r = q − c_φ is formed from the full
// node's storage s_f = c_s + c_0 directly (r = Σ a P_nb + c_e,W φ_W − c_e,k − s_f), as
// on the CPU: c_s and c_0 are each O(12 H/Δτ) in a time step and their difference would
// leave its rounding in P (issue 27, docs/jfo.md "Iteration error").
//
// Ordering: zebra lines. The odd interior rows are updated first, each by one invocation
// marching its row in the direction of the surface motion (so the film fraction is carried
// through the cavitated zone in one sweep, as the CPU's Gauss–Seidel does), then the even
// rows. Rows of one colour only read the other colour's pressure, so the sweep is
// deterministic; it converges to the same fixed point as the CPU's row-by-row order (the
// node equations), not along the same iterates.
//
// Stopping (issue 27, session 35): the kernel does not decide. It pauses each state at
// the end of every block of `block` sweeps (or at a sweep that changes nothing) and the
// host applies the CPU's block rule to the field (`BlockStop` in
// src/bearing/finite/jfo.rs: the block extrapolation and the rounding floor), then
// resumes or finishes the state. Per sweep the kernel keeps the last six changes
// max(|ΔP|/max P, |Δφ|) and the last halving of the change, for the host's stagnation
// rule (the CPU's `window`).
//
// The fields and coefficients live in storage buffers (no size limit from workgroup
// memory); the pressure and film fraction are updated in place. One dispatch runs at most
// `per_dispatch` sweeps; the host dispatches again until every state is done.

const WG: u32 = 64u;
// Values per node in `coef` (src/bearing/finite/jfo.rs JFO_NODE_STRIDE): a_e, a_n, d, c_e,
// c_s, c_0, held pressure (negative: free), s_f (the full node's storage).
const NODE_STRIDE: u32 = 8u;
// Per job (stride 4 f64): ω (SOR factor), spin sign (1 or −1), sweeps per block of the
// host's stop rule (a pause after every `block` sweeps, ≥ 1), unused.
const JOB_STRIDE: u32 = 4u;
// Per result (stride 12 f64), also the iteration's state between dispatches (the host
// starts it at 0, 0, 0, 0, −1 × 6, 1e300, 0): sweeps, the last change, a sweep without
// change seen (1/0), state (0: running, 1: at the sweep limit or finished by the host,
// 2: paused for the host's decision), the last six changes, the last halved change and
// the sweep it was reached at.
const OUT_STRIDE: u32 = 12u;

struct Params {
    // States in this dispatch.
    count: u32,
    // Grid intervals around the circumference and along the length.
    n_theta: u32,
    n_z: u32,
    // Sweep limit.
    max_sweeps: u32,
    // Sweeps per dispatch at most: llvmpipe (lavapipe) ends any shader loop after 65 535
    // iterations in all (seen as every slow state stopping at exactly 237 sweeps of
    // 128 × 32), so the host bounds one dispatch's loop iterations and dispatches again;
    // the iteration resumes from `results`.
    per_dispatch: u32,
    _pad0: u32,
    _pad1: u32,
    _pad2: u32,
}

@group(0) @binding(0) var<uniform> params: Params;
// NODE_STRIDE f64 per node of the full grid n_theta × (n_z + 1), per job.
@group(0) @binding(1) var<storage, read> coef: array<f64>;
@group(0) @binding(2) var<storage, read> jobs: array<f64>;
// Per job: pressure then film fraction, n_theta × (n_z + 1) each; start in, solution out.
@group(0) @binding(3) var<storage, read_write> fields: array<f64>;
@group(0) @binding(4) var<storage, read_write> results: array<f64>;

// Per-invocation maxima of |ΔP|, P and |Δφ| (stride WG).
var<workgroup> red: array<f64, 192>;

fn c(base: u32, k: u32, q: u32) -> f64 {
    return coef[base + k * NODE_STRIDE + q];
}

// Updates node i of row j in place; returns (|ΔP|, P, |Δφ|).
fn update(cb: u32, fb: u32, n: u32, nt: u32, j: u32, i: u32, omega: f64, forward: bool) -> vec3<f64> {
    let row = j * nt;
    let k = row + i;
    let held = c(cb, k, 6u);
    if held >= 0.0 {
        return vec3<f64>(0.0, fields[fb + k], 0.0);
    }
    let ip = select(k + 1u, row, i + 1u == nt);
    let im = select(k - 1u, row + nt - 1u, i == 0u);
    let sum = c(cb, k, 0u) * fields[fb + ip] + c(cb, im, 0u) * fields[fb + im]
        + c(cb, k, 1u) * fields[fb + k + nt] + c(cb, k - nt, 1u) * fields[fb + k - nt];
    var c_out: f64;
    var inflow: f64;
    if forward {
        c_out = c(cb, k, 3u);
        inflow = c(cb, im, 3u) * fields[fb + n + im];
    } else {
        c_out = -c(cb, im, 3u);
        inflow = -c(cb, k, 3u) * fields[fb + n + ip];
    }
    let c_phi = c_out + c(cb, k, 4u);
    let r = sum + inflow - c_out - c(cb, k, 7u);
    let pg = r / c(cb, k, 2u);
    let old_p = fields[fb + k];
    let old_phi = fields[fb + n + k];
    var np: f64 = 0.0;
    var nphi: f64 = 1.0;
    if pg > 0.0 {
        np = max(old_p + omega * (pg - old_p), 0.0);
    } else if c_phi > 0.0 {
        nphi = clamp(1.0 + r / c_phi, 0.0, 1.0);
    }
    // else: no outflow and no inflow, nothing moves (P = 0, φ = 1), as on the CPU.
    fields[fb + k] = np;
    fields[fb + n + k] = nphi;
    return vec3<f64>(abs(np - old_p), np, abs(nphi - old_phi));
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
    let n = nt * (nz + 1u);
    let cb = job * n * NODE_STRIDE;
    let fb = job * 2u * n;
    let o = job * OUT_STRIDE;
    let omega = jobs[job * JOB_STRIDE];
    let forward = jobs[job * JOB_STRIDE + 1u] >= 0.0;
    let block = max(u32(jobs[job * JOB_STRIDE + 2u]), 1u);

    // Resume: the state of the iteration from the previous dispatch (sweeps, state,
    // change history), read through workgroup memory so that the decisions stay
    // workgroup-uniform.
    if lid == 0u {
        for (var q = 0u; q < 12u; q++) {
            red[q] = results[o + q];
        }
    }
    workgroupBarrier();
    var sweeps = u32(workgroupUniformLoad(&red[0]));
    var last: f64 = workgroupUniformLoad(&red[1]);
    var still = workgroupUniformLoad(&red[2]) > 0.5;
    // Running (0) only; paused or finished states wait for the host.
    let done = workgroupUniformLoad(&red[3]) > 0.5;
    var best: f64 = workgroupUniformLoad(&red[10]);
    var best_at: f64 = workgroupUniformLoad(&red[11]);
    var hist: array<f64, 6>;
    hist[0] = workgroupUniformLoad(&red[4]);
    hist[1] = workgroupUniformLoad(&red[5]);
    hist[2] = workgroupUniformLoad(&red[6]);
    hist[3] = workgroupUniformLoad(&red[7]);
    hist[4] = workgroupUniformLoad(&red[8]);
    hist[5] = workgroupUniformLoad(&red[9]);
    if done {
        return;
    }
    // 1: at the sweep limit; 2: paused for the host.
    var state: f64 = 0.0;
    for (var run = 0u; run < params.per_dispatch; run++) {
        if sweeps >= params.max_sweeps {
            state = 1.0;
            break;
        }
        var m = vec3<f64>(0.0, 0.0, 0.0);
        // Colour 0: rows 1, 3, 5, ...; colour 1: rows 2, 4, ...
        for (var colour = 0u; colour < 2u; colour++) {
            for (var j = 1u + colour + 2u * lid; j < nz; j += 2u * WG) {
                for (var s = 0u; s < nt; s++) {
                    let i = select(nt - 1u - s, s, forward);
                    let r = update(cb, fb, n, nt, j, i, omega, forward);
                    m = max(m, r);
                }
            }
            storageBarrier();
        }
        red[lid] = m.x;
        red[WG + lid] = m.y;
        red[2u * WG + lid] = m.z;
        workgroupBarrier();
        var h = WG / 2u;
        loop {
            if h == 0u {
                break;
            }
            if lid < h {
                for (var q = 0u; q < 3u; q++) {
                    red[q * WG + lid] = max(red[q * WG + lid], red[q * WG + lid + h]);
                }
            }
            workgroupBarrier();
            h = h / 2u;
        }
        // Uniform loads: the stopping decision must be workgroup-uniform.
        let dp = workgroupUniformLoad(&red[0]);
        let pmax = workgroupUniformLoad(&red[WG]);
        let dphi = workgroupUniformLoad(&red[2u * WG]);
        sweeps += 1u;
        var change: f64 = dphi;
        if pmax > 0.0 {
            change = max(dp / pmax, dphi);
        }
        for (var q = 0u; q < 5u; q++) {
            hist[q] = hist[q + 1u];
        }
        hist[5] = change;
        last = change;
        if change < 0.5 * best {
            best = change;
            best_at = f64(sweeps);
        }
        if change == 0.0 {
            still = true;
            state = 2.0;
            break;
        }
        if sweeps % block == 0u {
            state = 2.0;
            break;
        }
        // A non-finite iterate runs to the sweep limit and the host sees its non-finite
        // loads (the evaluator recomputes those on the CPU).
    }
    if lid == 0u {
        results[o] = f64(sweeps);
        results[o + 1u] = last;
        results[o + 2u] = select(f64(0.0), f64(1.0), still);
        results[o + 3u] = state;
        for (var q = 0u; q < 6u; q++) {
            results[o + 4u + q] = hist[q];
        }
        results[o + 10u] = best;
        results[o + 11u] = best_at;
    }
}
