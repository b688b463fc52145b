//! Dormand-Prince 8(5,3) in lockstep (Hairer, Nørsett, Wanner, Solving ODEs I, II.5 and
//! II.6; the coefficients of their DOP853): twelve batched stage calls per round (the
//! twelfth at `t + h` is the next step's first, first-same-as-last), the combined 5th/3rd
//! order error estimate with PI step-size control, and the 7th-order continuous extension
//! for samples, whose three extra stages are evaluated (in one batched call each) only for
//! the variants with a sample inside the accepted step.

// The tableau below keeps the coefficients with the digits Hairer's listing prints (more
// than an f64 holds); rounding them by hand would risk a transcription error for no gain,
// since the compiler rounds each literal to the nearest f64.
#![allow(clippy::excessive_precision)]

use std::time::Instant;

use super::common::{
    end, finite, h_floor, notify, plan_steps, start_explicit, status_after_accepted, Packed, Track,
};
use super::system::{BatchSystem, Settings, Stats, Status};

/// Stages of a step (the 13th, at `t + h`, is the FSAL stage).
const STAGES: usize = 12;

/// Nodes `c_s`, stages 1..=12 then the three dense-output stages 14..=16.
const C: [f64; 16] = [
    0.0,
    0.526001519587677318785587544488e-01,
    0.789002279381515978178381316732e-01,
    0.118350341907227396726757197510e+00,
    0.281649658092772603273242802490e+00,
    0.333333333333333333333333333333e+00,
    0.25e+00,
    0.307692307692307692307692307692e+00,
    0.651282051282051282051282051282e+00,
    0.6e+00,
    0.857142857142857142857142857142e+00,
    1.0,
    1.0,
    0.1e+00,
    0.2e+00,
    0.777777777777777777777777777778e+00,
];

/// Runge-Kutta matrix, row `s` holds `a_{s,0..s}` (0-based stages; rows 13..=15 are the
/// dense-output stages, which also use the FSAL stage 12 = f(t + h, y_new)).
const A: [&[f64]; 16] = [
    &[],
    &[5.26001519587677318785587544488e-2],
    &[
        1.97250569845378994544595329183e-2,
        5.91751709536136983633785987549e-2,
    ],
    &[
        2.95875854768068491816892993775e-2,
        0.0,
        8.87627564304205475450678981324e-2,
    ],
    &[
        2.41365134159266685502369798665e-1,
        0.0,
        -8.84549479328286085344864962717e-1,
        9.24834003261792003115737966543e-1,
    ],
    &[
        3.7037037037037037037037037037e-2,
        0.0,
        0.0,
        1.70828608729473871279604482173e-1,
        1.25467687566822425016691814123e-1,
    ],
    &[
        3.7109375e-2,
        0.0,
        0.0,
        1.70252211019544039314978060272e-1,
        6.02165389804559606850219397283e-2,
        -1.7578125e-2,
    ],
    &[
        3.70920001185047927108779319836e-2,
        0.0,
        0.0,
        1.70383925712239993810214054705e-1,
        1.07262030446373284651809199168e-1,
        -1.53194377486244017527936158236e-2,
        8.27378916381402288758473766002e-3,
    ],
    &[
        6.24110958716075717114429577812e-1,
        0.0,
        0.0,
        -3.36089262944694129406857109825e0,
        -8.68219346841726006818189891453e-1,
        2.75920996994467083049415600797e1,
        2.01540675504778934086186788979e1,
        -4.34898841810699588477366255144e1,
    ],
    &[
        4.77662536438264365890433908527e-1,
        0.0,
        0.0,
        -2.48811461997166764192642586468e0,
        -5.90290826836842996371446475743e-1,
        2.12300514481811942347288949897e1,
        1.52792336328824235832596922938e1,
        -3.32882109689848629194453265587e1,
        -2.03312017085086261358222928593e-2,
    ],
    &[
        -9.3714243008598732571704021658e-1,
        0.0,
        0.0,
        5.18637242884406370830023853209e0,
        1.09143734899672957818500254654e0,
        -8.14978701074692612513997267357e0,
        -1.85200656599969598641566180701e1,
        2.27394870993505042818970056734e1,
        2.49360555267965238987089396762e0,
        -3.0467644718982195003823669022e0,
    ],
    &[
        2.27331014751653820792359768449e0,
        0.0,
        0.0,
        -1.05344954667372501984066689879e1,
        -2.00087205822486249909675718444e0,
        -1.79589318631187989172765950534e1,
        2.79488845294199600508499808837e1,
        -2.85899827713502369474065508674e0,
        -8.87285693353062954433549289258e0,
        1.23605671757943030647266201528e1,
        6.43392746015763530355970484046e-1,
    ],
    // Row 12: the 8th-order solution `b` (stage 12 is f at the new point).
    &[
        5.42937341165687622380535766363e-2,
        0.0,
        0.0,
        0.0,
        0.0,
        4.45031289275240888144113950566e0,
        1.89151789931450038304281599044e0,
        -5.8012039600105847814672114227e0,
        3.1116436695781989440891606237e-1,
        -1.52160949662516078556178806805e-1,
        2.01365400804030348374776537501e-1,
        4.47106157277725905176885569043e-2,
    ],
    // Row 13: dense stage at c = 0.1.
    &[
        5.61675022830479523392909219681e-2,
        0.0,
        0.0,
        0.0,
        0.0,
        0.0,
        2.53500210216624811088794765333e-1,
        -2.46239037470802489917441475441e-1,
        -1.24191423263816360469010140626e-1,
        1.5329179827876569731206322685e-1,
        8.20105229563468988491666602057e-3,
        7.56789766054569976138603589584e-3,
        -8.298e-3,
    ],
    // Row 14: dense stage at c = 0.2.
    &[
        3.18346481635021405060768473261e-2,
        0.0,
        0.0,
        0.0,
        0.0,
        2.83009096723667755288322961402e-2,
        5.35419883074385676223797384372e-2,
        -5.49237485713909884646569340306e-2,
        0.0,
        0.0,
        -1.08347328697249322858509316994e-4,
        3.82571090835658412954920192323e-4,
        -3.40465008687404560802977114492e-4,
        1.41312443674632500278074618366e-1,
    ],
    // Row 15: dense stage at c = 7/9.
    &[
        -4.28896301583791923408573538692e-1,
        0.0,
        0.0,
        0.0,
        0.0,
        -4.69762141536116384314449447206e0,
        7.68342119606259904184240953878e0,
        4.06898981839711007970213554331e0,
        3.56727187455281109270669543021e-1,
        0.0,
        0.0,
        0.0,
        -1.39902416515901462129418009734e-3,
        2.9475147891527723389556272149e0,
        -9.15095847217987001081870187138e0,
    ],
];

/// 3rd-order embedded weights on stages 0, 8 and 11 (`b − bhh` estimates the error of a
/// 3rd-order solution; Hairer's `bhh1..3`).
const BHH: [f64; 3] = [
    0.244094488188976377952755905512e+00,
    0.733846688281611857341361741547e+00,
    0.220588235294117647058823529412e-01,
];

/// 5th-order error weights on stages 0..=11 (Hairer's `er1, er6..er12`).
const ER: [f64; STAGES] = [
    0.1312004499419488073250102996e-01,
    0.0,
    0.0,
    0.0,
    0.0,
    -0.1225156446376204440720569753e+01,
    -0.4957589496572501915214079952e+00,
    0.1664377182454986536961530415e+01,
    -0.3503288487499736816886487290e+00,
    0.3341791187130174790297318841e+00,
    0.8192320648511571246570742613e-01,
    -0.2235530786388629525884427845e-01,
];

/// Dense-output weights `d4..d7` on stages 0..=15 (Hairer's `d41..d716`; index 12 is the
/// FSAL stage `f(t + h, y_new)`).
const D: [[f64; 16]; 4] = [
    [
        -0.84289382761090128651353491142e+01,
        0.0,
        0.0,
        0.0,
        0.0,
        0.56671495351937776962531783590e+00,
        -0.30689499459498916912797304727e+01,
        0.23846676565120698287728149680e+01,
        0.21170345824450282767155149946e+01,
        -0.87139158377797299206789907490e+00,
        0.22404374302607882758541771650e+01,
        0.63157877876946881815570249290e+00,
        -0.88990336451333310820698117400e-01,
        0.18148505520854727256656404962e+02,
        -0.91946323924783554000451984436e+01,
        -0.44360363875948939664310572000e+01,
    ],
    [
        0.10427508642579134603413151009e+02,
        0.0,
        0.0,
        0.0,
        0.0,
        0.24228349177525818288430175319e+03,
        0.16520045171727028198505394887e+03,
        -0.37454675472269020279518312152e+03,
        -0.22113666853125306036270938578e+02,
        0.77334326684722638389603898808e+01,
        -0.30674084731089398182061213626e+02,
        -0.93321305264302278729567221706e+01,
        0.15697238121770843886131091075e+02,
        -0.31139403219565177677282850411e+02,
        -0.93529243588444783865713862664e+01,
        0.35816841486394083752465898540e+02,
    ],
    [
        0.19985053242002433820987653617e+02,
        0.0,
        0.0,
        0.0,
        0.0,
        -0.38703730874935176555105901742e+03,
        -0.18917813819516756882830838328e+03,
        0.52780815920542364900561016686e+03,
        -0.11573902539959630126141871134e+02,
        0.68812326946963000169666922661e+01,
        -0.10006050966910838403183860980e+01,
        0.77771377980534432092869265740e+00,
        -0.27782057523535084065932004339e+01,
        -0.60196695231264120758267380846e+02,
        0.84320405506677161018159903784e+02,
        0.11992291136182789328035130030e+02,
    ],
    [
        -0.25693933462703749003312586129e+02,
        0.0,
        0.0,
        0.0,
        0.0,
        -0.15418974869023643374053993627e+03,
        -0.23152937917604549567536039109e+03,
        0.35763911791061412378285349910e+03,
        0.93405324183624310003907691704e+02,
        -0.37458323136451633156875139351e+02,
        0.10409964950896230045147246184e+03,
        0.29840293426660503123344363579e+02,
        -0.43533456590011143754432175058e+02,
        0.96324553959188282948394950600e+02,
        -0.39177261675615439165231486172e+02,
        -0.14972683625798562581422125276e+03,
    ],
];

/// PI controller (Hairer's DOP853: exponent `1/8 − 0.2 β`, `β = 0.04`), safety 0.9.
const BETA: f64 = 0.04;
const ALPHA: f64 = 1.0 / 8.0 - 0.2 * BETA;
const SAFETY: f64 = 0.9;
/// Step-size change bounds per step (Hairer's DOP853: 1/3 .. 6).
const FAC_MIN: f64 = 1.0 / 3.0;
const FAC_MAX: f64 = 6.0;
/// Step shrink after a right-hand-side fault in a stage.
const FAULT_SHRINK: f64 = 0.25;

/// Hairer's DOP853 error norm: the 5th-order estimate `err5` damped by the 3rd-order one
/// `err3` as `|h| err5² / sqrt(n (err5² + 0.01 err3²))`, each weighted by
/// `atol · scale + rtol · max(|y|, |y_new|)` like the other methods' norms.
#[allow(clippy::too_many_arguments, clippy::needless_range_loop)]
fn err_norm_853(
    h: f64,
    k: &[Vec<f64>],
    base: usize,
    d: usize,
    y: &[f64],
    ynew: &[f64],
    scale: &[f64],
    s: &Settings,
) -> f64 {
    let (mut e5, mut e3) = (0.0, 0.0);
    for i in 0..d {
        let w = s.atol * scale[i] + s.rtol * y[i].abs().max(ynew[i].abs());
        let mut inc = 0.0;
        let mut er = 0.0;
        for j in 0..STAGES {
            let kj = k[j][base + i];
            inc += A[12][j] * kj;
            er += ER[j] * kj;
        }
        let e3i =
            inc - BHH[0] * k[0][base + i] - BHH[1] * k[8][base + i] - BHH[2] * k[11][base + i];
        e3 += (e3i / w).powi(2);
        e5 += (er / w).powi(2);
    }
    let mut deno = e5 + 0.01 * e3;
    if deno <= 0.0 {
        deno = 1.0;
    }
    h.abs() * e5 * (1.0 / (d as f64 * deno)).sqrt()
}

/// Integrates the batch with DOP853.
pub(crate) fn run<S: BatchSystem>(
    sys: &mut S,
    y0: &[f64],
    settings: &[Settings],
    start: Instant,
) -> Vec<(Status<S::Fault>, Stats)> {
    let n = settings.len();
    let d = sys.dim();
    let mut tracks: Vec<Track<S::Fault>> = settings.iter().map(Track::new).collect();
    let mut y = y0.to_vec();
    let mut ynew = vec![0.0; n * d];
    // k[0..12]: stages (k[12] = f(t + h, y_new), the next step's k[0]); k[13..16]: dense.
    let mut k: Vec<Vec<f64>> = (0..16).map(|_| vec![0.0; n * d]).collect();
    let mut scale = vec![1.0; n * d];
    for id in 0..n {
        sys.scales(id, &mut scale[id * d..(id + 1) * d]);
    }
    let mut err_old: Vec<f64> = vec![1e-4; n];
    let mut hs = vec![0.0; n];
    let mut stage_ok = vec![true; n];
    let mut buf = Packed::new();
    let mut rec = Packed::new();
    let mut ended = Vec::new();
    // Variants accepted this round with a sample inside the step: (id, t0, h).
    let mut dense: Vec<(usize, f64, f64)> = Vec::new();
    // The previous point of each such variant (y before the step).
    let mut yold = vec![0.0; n * d];
    let mut dense_ok = vec![true; n];

    let mut active = start_explicit(
        sys,
        &mut tracks,
        settings,
        &y,
        &scale,
        &mut k[0],
        &mut buf,
        &mut rec,
        &mut ended,
        start,
    );

    while !active.is_empty() {
        plan_steps(&active, &tracks, settings, &mut hs, &mut stage_ok);
        // Stages 1..=11, then the new point (row 12) whose f is stage 12.
        for st in 1..=12 {
            buf.clear();
            for &id in &active {
                if !stage_ok[id] {
                    continue;
                }
                let h = hs[id];
                let slot = buf.push(id, tracks[id].t + C[st] * h, d);
                let base = id * d;
                for (i, out) in slot.iter_mut().enumerate() {
                    let mut acc = 0.0;
                    for (j, a) in A[st].iter().enumerate() {
                        acc += a * k[j][base + i];
                    }
                    *out = y[base + i] + h * acc;
                }
                if st == 12 {
                    ynew[base..base + d].copy_from_slice(slot);
                }
            }
            buf.eval(sys, &mut tracks);
            // Rows 1..=11 fill k[1..=11] (k[11]: the stage at c = 1); row 12 is the new
            // point, its f fills k[12].
            for e in 0..buf.len() {
                let id = buf.ids[e];
                match &buf.faults[e] {
                    Some(f) => {
                        stage_ok[id] = false;
                        tracks[id].fault = Some(f.clone());
                    }
                    None => {
                        k[st][id * d..(id + 1) * d].copy_from_slice(&buf.dys[e * d..(e + 1) * d])
                    }
                }
            }
        }
        dense.clear();
        for &id in &active {
            let s = &settings[id];
            let tr = &mut tracks[id];
            let h = hs[id];
            let t0 = tr.t;
            let r = id * d..(id + 1) * d;
            let fixed = s.fixed_step.is_some();
            if !stage_ok[id] {
                tr.stats.rejected += 1;
                tr.last_rejected = true;
                tr.h = h * FAULT_SHRINK;
                if fixed || tr.h < h_floor(t0, s.t_end) {
                    let fault = tr.fault.clone().expect("a stage fault was recorded");
                    end(tr, Status::Fault { time: t0, fault }, start);
                    ended.push(id);
                }
                continue;
            }
            let norm = if fixed {
                0.0
            } else {
                err_norm_853(
                    h,
                    &k,
                    id * d,
                    d,
                    &y[r.clone()],
                    &ynew[r.clone()],
                    &scale[r.clone()],
                    s,
                )
            };
            if !norm.is_finite() || !finite(&ynew[r.clone()]) {
                tr.stats.rejected += 1;
                tr.last_rejected = true;
                tr.h = h * FAC_MIN;
                if fixed || tr.h < h_floor(t0, s.t_end) {
                    end(tr, Status::NonFinite { time: t0 }, start);
                    ended.push(id);
                }
                continue;
            }
            if norm <= 1.0 {
                // Samples inside the step need the dense stages: emitted below, after
                // they have been evaluated for every such variant in one call each.
                let t1 = t0 + h;
                let next = tr.next_sample as f64 * s.sample_interval;
                if tr.next_sample < tr.n_samples && next <= t1 + 1e-9 * s.sample_interval {
                    dense.push((id, t0, h));
                    yold[r.clone()].copy_from_slice(&y[r.clone()]);
                }
                tr.t = if h == s.t_end - t0 { s.t_end } else { t0 + h };
                y[r.clone()].copy_from_slice(&ynew[r.clone()]);
                sys.project(id, &mut y[r.clone()]);
                tr.stats.steps += 1;
                let fac_max = if tr.last_rejected { 1.0 } else { FAC_MAX };
                let fac = if norm == 0.0 {
                    FAC_MAX
                } else {
                    SAFETY * norm.powf(-ALPHA) * err_old[id].powf(BETA)
                };
                tr.h = if fixed {
                    s.fixed_step.unwrap_or(h)
                } else {
                    h * fac.clamp(FAC_MIN, fac_max)
                };
                err_old[id] = norm.max(1e-4);
                tr.last_rejected = false;
            } else {
                tr.stats.rejected += 1;
                tr.last_rejected = true;
                tr.h = h * (SAFETY * norm.powf(-ALPHA)).max(FAC_MIN);
                if tr.h < h_floor(t0, s.t_end) {
                    let step = tr.h;
                    end(tr, Status::StepSizeTooSmall { time: t0, step }, start);
                    ended.push(id);
                }
            }
        }
        // Dense stages 13..=15 for the variants with samples in their step.
        for &(id, _, _) in &dense {
            dense_ok[id] = true;
        }
        for st in 13..16 {
            buf.clear();
            for &(id, t0, h) in &dense {
                let slot = buf.push(id, t0 + C[st] * h, d);
                let base = id * d;
                for (i, out) in slot.iter_mut().enumerate() {
                    let mut acc = 0.0;
                    for (j, a) in A[st].iter().enumerate() {
                        acc += a * k[j][base + i];
                    }
                    *out = yold[base + i] + h * acc;
                }
            }
            buf.eval(sys, &mut tracks);
            for e in 0..buf.len() {
                let id = buf.ids[e];
                // A fault in a dense stage: this step's samples fall back to cubic
                // Hermite interpolation (the step itself stands).
                match &buf.faults[e] {
                    Some(_) => dense_ok[id] = false,
                    None => {
                        k[st][id * d..(id + 1) * d].copy_from_slice(&buf.dys[e * d..(e + 1) * d])
                    }
                }
            }
        }
        for &(id, t0, h) in &dense {
            let s = &settings[id];
            let base = id * d;
            // Without its dense stages (a fault there) the variant's samples in this step
            // come from the cubic Hermite part of the same formula.
            let full = dense_ok[id];
            let (ya, yb) = (&yold[base..base + d], &ynew[base..base + d]);
            let k = &k;
            tracks[id].emit(id, s, t0, h, d, &mut rec, |th, out| {
                let th1 = 1.0 - th;
                for (i, o) in out.iter_mut().enumerate() {
                    let r1 = ya[i];
                    let ydiff = yb[i] - ya[i];
                    let bspl = h * k[0][base + i] - ydiff;
                    let r3 = bspl;
                    let r4 = ydiff - h * k[12][base + i] - bspl;
                    let mut r = [0.0; 4];
                    if full {
                        for (m, row) in D.iter().enumerate() {
                            let mut acc = 0.0;
                            for (j, dj) in row.iter().enumerate() {
                                acc += dj * k[j][base + i];
                            }
                            r[m] = h * acc;
                        }
                    }
                    *o = r1
                        + th * (ydiff
                            + th1
                                * (r3
                                    + th * (r4
                                        + th1 * (r[0] + th * (r[1] + th1 * (r[2] + th * r[3]))))));
                }
            });
        }
        // The accepted variants' next first stage: f(t + h, y_new) = k[12] (before the
        // projection, as dopri5 does with its FSAL stage).
        for &id in &active {
            let tr = &tracks[id];
            if tr.stats.steps > 0 && !tr.last_rejected && stage_ok[id] {
                let r = id * d..(id + 1) * d;
                let (lo, hi) = k.split_at_mut(12);
                lo[0][r.clone()].copy_from_slice(&hi[0][r]);
            }
        }
        for &id in &active {
            let s = &settings[id];
            let tr = &mut tracks[id];
            if matches!(tr.status, Status::Running) && !tr.last_rejected && stage_ok[id] {
                if let Some(status) = status_after_accepted(tr, s) {
                    end(tr, status, start);
                    ended.push(id);
                }
            }
        }
        active.retain(|&id| matches!(tracks[id].status, Status::Running));
        rec.flush_records(sys);
        notify(sys, &tracks, &mut ended);
    }
    tracks.into_iter().map(|t| (t.status, t.stats)).collect()
}
