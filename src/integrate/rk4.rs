//! Classical Runge-Kutta at a fixed step, in lockstep: four batched calls per step, and
//! the 3rd-order continuous extension (weights `b_i(theta)`) for samples.

use std::time::Instant;

use super::common::{admit, end, end_with_fault, finite, notify, reached, Packed, Track};
use super::system::{BatchSystem, Settings, Stats, Status};

/// Stage nodes and the coefficient of the previous stage in each stage's input.
const C: [f64; 4] = [0.0, 0.5, 0.5, 1.0];

/// Continuous-extension weights at `theta` (they equal 1/6, 1/3, 1/3, 1/6 at 1).
fn weights(th: f64) -> [f64; 4] {
    let (t2, t3) = (th * th, th * th * th);
    let mid = t2 - 2.0 * t3 / 3.0;
    [
        th - 1.5 * t2 + 2.0 * t3 / 3.0,
        mid,
        mid,
        -0.5 * t2 + 2.0 * t3 / 3.0,
    ]
}

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
    let mut k: [Vec<f64>; 4] = std::array::from_fn(|_| vec![0.0; n * d]);
    let mut hs = vec![0.0; n];
    let mut ok = vec![true; n];
    let mut ynew = vec![0.0; d];
    let mut buf = Packed::new();
    let mut rec = Packed::new();
    let mut ended = Vec::new();
    let mut active = admit(&mut tracks, settings, &y, d, &mut rec, &mut ended, start);
    for &id in &active {
        tracks[id].h = settings[id]
            .fixed_step
            .unwrap_or(settings[id].sample_interval);
    }
    rec.flush_records(sys);
    notify(sys, &tracks, &mut ended);
    while !active.is_empty() {
        for &id in &active {
            let left = settings[id].t_end - tracks[id].t;
            let h = tracks[id].h;
            hs[id] = if h >= left || left - h < 1e-6 * h {
                left
            } else {
                h
            };
            ok[id] = true;
        }
        for st in 0..4 {
            buf.clear();
            for &id in &active {
                if !ok[id] {
                    continue;
                }
                let h = hs[id];
                let slot = buf.push(id, tracks[id].t + C[st] * h, d);
                let base = id * d;
                for (i, o) in slot.iter_mut().enumerate() {
                    *o = if st == 0 {
                        y[base + i]
                    } else {
                        y[base + i] + C[st] * h * k[st - 1][base + i]
                    };
                }
            }
            buf.eval(sys, &mut tracks);
            for e in 0..buf.len() {
                let id = buf.ids[e];
                match &buf.faults[e] {
                    Some(f) => {
                        ok[id] = false;
                        end_with_fault(&mut tracks, id, f, start, &mut ended);
                    }
                    None => {
                        k[st][id * d..(id + 1) * d].copy_from_slice(&buf.dys[e * d..(e + 1) * d])
                    }
                }
            }
        }
        for &id in &active {
            if !ok[id] {
                continue;
            }
            let s = &settings[id];
            let tr = &mut tracks[id];
            let h = hs[id];
            let t0 = tr.t;
            let base = id * d;
            for (i, o) in ynew.iter_mut().enumerate() {
                *o = y[base + i]
                    + h * (k[0][base + i]
                        + 2.0 * (k[1][base + i] + k[2][base + i])
                        + k[3][base + i])
                        / 6.0;
            }
            if !finite(&ynew) {
                end(tr, Status::NonFinite { time: t0 }, start);
                ended.push(id);
                continue;
            }
            {
                let (yv, k) = (&y[base..base + d], &k);
                tr.emit(id, s, t0, h, d, &mut rec, |th, out| {
                    let b = weights(th);
                    for (i, o) in out.iter_mut().enumerate() {
                        let mut acc = 0.0;
                        for (j, bj) in b.iter().enumerate() {
                            acc += bj * k[j][base + i];
                        }
                        *o = yv[i] + h * acc;
                    }
                });
            }
            y[base..base + d].copy_from_slice(&ynew);
            sys.project(id, &mut y[base..base + d]);
            tr.t = if h == s.t_end - t0 { s.t_end } else { t0 + h };
            tr.stats.steps += 1;
            if reached(tr.t, s.t_end) {
                end(tr, Status::Finished, start);
                ended.push(id);
            } else if tr.stats.steps >= s.max_steps {
                let (time, steps) = (tr.t, tr.stats.steps);
                end(tr, Status::MaxSteps { time, steps }, start);
                ended.push(id);
            }
        }
        active.retain(|&id| matches!(tracks[id].status, Status::Running));
        rec.flush_records(sys);
        notify(sys, &tracks, &mut ended);
    }
    tracks.into_iter().map(|t| (t.status, t.stats)).collect()
}
