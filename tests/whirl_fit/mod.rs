//! The whirl fit shared by tests/whirl.rs and tests/stability.rs: growth rate and whirl
//! ratio of bearing 1's journal centre from least-squares fits over a window of samples.

use bearing_sweep::rotor::SimResult;

/// Least-squares slope of `y` against `x`.
pub fn slope(x: &[f64], y: &[f64]) -> f64 {
    let n = x.len() as f64;
    let (mx, my) = (x.iter().sum::<f64>() / n, y.iter().sum::<f64>() / n);
    let sxy: f64 = x.iter().zip(y).map(|(a, b)| (a - mx) * (b - my)).sum();
    let sxx: f64 = x.iter().map(|a| (a - mx) * (a - mx)).sum();
    sxy / sxx
}

/// Growth rate of ln |e| and whirl ratio of the unwrapped angle of
/// bearing 1's journal, over samples with `t >= t_from` and `r_lo <= |e| <= r_hi`.
pub fn growth_and_ratio(
    r: &SimResult,
    t_from: f64,
    r_lo: f64,
    r_hi: f64,
    spin: f64,
) -> (f64, f64, usize) {
    let s = &r.samples;
    let b = &s.bearings[0];
    let (mut t, mut lr, mut ang) = (Vec::new(), Vec::new(), Vec::new());
    let mut prev: Option<f64> = None;
    let mut unwrapped = 0.0;
    for k in 0..s.t.len() {
        let a = b.yi[k].atan2(b.xi[k]);
        if let Some(p) = prev {
            let mut d = a - p;
            d -= std::f64::consts::TAU * (d / std::f64::consts::TAU).round();
            unwrapped += d;
        } else {
            unwrapped = a;
        }
        prev = Some(a);
        let rad = b.xi[k].hypot(b.yi[k]);
        if s.t[k] >= t_from && rad >= r_lo && rad <= r_hi {
            t.push(s.t[k]);
            lr.push(rad.ln());
            ang.push(unwrapped);
        }
    }
    (slope(&t, &lr), slope(&t, &ang) / spin, t.len())
}
