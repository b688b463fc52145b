//! The whirl of a journal centre: the windowed amplitude spectrum of `z = x + iy` over
//! nonuniform samples, its dominant and sub-synchronous peaks and the oil-whirl test
//! (definitions in `super::reduce`).

use super::reduce::{fin, trapezoid_weights, Whirl};
use super::reduction_options::WhirlOptions;

/// The windowed spectrum of `z = x + iy` at angular frequency `omega` (rad/s).
struct Spectrum {
    t: Vec<f64>,
    zr: Vec<f64>,
    zi: Vec<f64>,
    w: Vec<f64>,
    wsum: f64,
}

impl Spectrum {
    fn new(t: &[f64], x: &[f64], y: &[f64]) -> Option<Self> {
        let n = t.len();
        let span = t[n - 1] - t[0];
        if n < 4 || span <= 0.0 {
            return None;
        }
        let mut w = trapezoid_weights(t);
        for (wi, &ti) in w.iter_mut().zip(t) {
            *wi *= 0.5 - 0.5 * (std::f64::consts::TAU * (ti - t[0]) / span).cos();
        }
        let wsum: f64 = w.iter().sum();
        if wsum <= 0.0 {
            return None;
        }
        let mx = w.iter().zip(x).map(|(a, b)| a * b).sum::<f64>() / wsum;
        let my = w.iter().zip(y).map(|(a, b)| a * b).sum::<f64>() / wsum;
        Some(Spectrum {
            t: t.iter().map(|&ti| ti - t[0]).collect(),
            zr: x.iter().map(|&a| a - mx).collect(),
            zi: y.iter().map(|&b| b - my).collect(),
            w,
            wsum,
        })
    }

    /// `A(ω)`, m.
    fn amplitude(&self, omega: f64) -> f64 {
        let (mut re, mut im) = (0.0, 0.0);
        for i in 0..self.t.len() {
            let (s, c) = (omega * self.t[i]).sin_cos();
            // (zr + i zi)(c − i s)
            re += self.w[i] * (self.zr[i] * c + self.zi[i] * s);
            im += self.w[i] * (self.zi[i] * c - self.zr[i] * s);
        }
        re.hypot(im) / self.wsum
    }

    /// `d|Z|²/dω / 2 = Re(conj(Z) dZ/dω)` (unnormalised): positive left of a peak,
    /// negative right of it, and linear through it, so its zero locates the peak to
    /// rounding (a search on `A` itself stalls at `sqrt(eps)` of the lobe width).
    fn slope(&self, omega: f64) -> f64 {
        let (mut re, mut im, mut dre, mut dim) = (0.0, 0.0, 0.0, 0.0);
        for i in 0..self.t.len() {
            let (s, c) = (omega * self.t[i]).sin_cos();
            let pr = self.w[i] * (self.zr[i] * c + self.zi[i] * s);
            let pi = self.w[i] * (self.zi[i] * c - self.zr[i] * s);
            re += pr;
            im += pi;
            // d/dω of p e^{−iωt} = −i t p e^{−iωt}
            dre += self.t[i] * pi;
            dim -= self.t[i] * pr;
        }
        re * dre + im * dim
    }

    /// Largest `A` over ratios in `[lo, hi]` (times `spin`): grid of step `step`, then
    /// bisection on the slope of `|Z|²` inside the best grid cell's neighbours (the main
    /// lobe: one maximum), or golden-section search on `A` when the maximum sits on an
    /// end of `[lo, hi]`.
    /// Returns `(ratio, amplitude, interior)`, `interior` when the maximum is a true
    /// peak of the spectrum inside `[lo, hi]` (not the flank of a peak outside it).
    fn peak(&self, spin: f64, lo: f64, hi: f64, step: f64) -> (f64, f64, bool) {
        let cells = (((hi - lo) / step).ceil() as usize).max(1);
        let h = (hi - lo) / cells as f64;
        let mut best = (lo, -1.0);
        for k in 0..=cells {
            let r = lo + h * k as f64;
            let a = self.amplitude(r * spin);
            if a > best.1 {
                best = (r, a);
            }
        }
        let (mut a, mut b) = ((best.0 - h).max(lo), (best.0 + h).min(hi));
        // Slope in the ratio variable: d/dr = spin · d/dω.
        let g = |r: f64| spin * self.slope(r * spin);
        let interior = g(a) > 0.0 && g(b) < 0.0;
        if interior {
            while b - a > 1e-14 * (1.0 + best.0.abs()) {
                let m = 0.5 * (a + b);
                if m <= a || m >= b {
                    break;
                }
                if g(m) > 0.0 {
                    a = m;
                } else {
                    b = m;
                }
            }
        } else {
            let gr = 0.5 * (5f64.sqrt() - 1.0);
            let mut c = b - gr * (b - a);
            let mut d = a + gr * (b - a);
            let (mut fc, mut fd) = (self.amplitude(c * spin), self.amplitude(d * spin));
            while b - a > 1e-10 * (1.0 + best.0.abs()) {
                if fc > fd {
                    b = d;
                    d = c;
                    fd = fc;
                    c = b - gr * (b - a);
                    fc = self.amplitude(c * spin);
                } else {
                    a = c;
                    c = d;
                    fc = fd;
                    d = a + gr * (b - a);
                    fd = self.amplitude(d * spin);
                }
            }
        }
        let r = 0.5 * (a + b);
        let ar = self.amplitude(r * spin);
        if ar >= best.1 {
            (r, ar, interior)
        } else {
            (best.0, best.1, false)
        }
    }
}

/// Whirl of the journal centre `(x, y)` over window samples `t`, given the mean spin
/// (rad/s) and the radial clearance (m).
pub fn whirl(
    t: &[f64],
    x: &[f64],
    y: &[f64],
    spin_mean: f64,
    clearance_m: f64,
    opts: &WhirlOptions,
) -> Option<Whirl> {
    if spin_mean == 0.0 || !spin_mean.is_finite() {
        return None;
    }
    let sp = Spectrum::new(t, x, y)?;
    let n = t.len();
    let span = t[n - 1] - t[0];
    let revs = spin_mean.abs() * span / std::f64::consts::TAU;
    if revs < 1.0 {
        // Less than a revolution: no frequency is resolved.
        return None;
    }
    let step = 1.0 / (4.0 * revs);
    let dt_max = t.windows(2).map(|p| p[1] - p[0]).fold(0.0, f64::max);
    // Nyquist: |ω| dt < π, with a 10 % margin.
    let nyquist = 0.9 * std::f64::consts::PI / (dt_max * spin_mean.abs());
    let r_max = opts.max_ratio.min(nyquist);
    let (ratio, amp, _) = sp.peak(spin_mean, -r_max, r_max, step);
    let (lo, hi) = (opts.band.0.min(r_max), opts.band.1.min(r_max));
    let (sub_r, sub_a, interior) = if hi > lo {
        sp.peak(spin_mean, lo, hi, step)
    } else {
        (lo, 0.0, false)
    };
    // A band maximum on the flank of the dominant peak is leakage, not a whirl: the
    // sub-synchronous peak must be a true peak, and either the dominant one or resolved
    // from it (farther than the Hann main-lobe half-width, 2 / revolutions).
    let resolved = (sub_r - ratio).abs() < 1e-6 || (sub_r - ratio).abs() > 2.0 / revs;
    let oil = interior
        && resolved
        && sub_a > 0.0
        && sub_a >= opts.relative_threshold * amp
        && sub_a >= opts.min_amplitude_ratio * clearance_m;
    Some(Whirl {
        ratio: fin(ratio)?,
        amplitude_m: fin(amp)?,
        subsync_ratio: fin(sub_r)?,
        subsync_amplitude_m: fin(sub_a)?,
        oil_whirl: oil,
        searched_up_to_ratio: (r_max < opts.max_ratio).then_some(r_max),
        samples: None,
        t_start_s: None,
    })
}
