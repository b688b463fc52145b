//! Eigenvalues of the linear rotor `M q̈ + D q̇ + K q = 0` as whirl modes: growth rate,
//! whirl frequency in the fixed frame (signed: forward positive), whirl ratio, damping
//! ratio, logarithmic decrement and shape, least damped first.

use nalgebra::{Complex, DMatrix, Matrix4};

use super::linear::{Frame, LinearRotor, M4};

/// One mode (one eigenvalue of each complex-conjugate pair, or one real eigenvalue).
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct Mode {
    /// Growth rate `Re λ`, 1/s (positive: unstable).
    pub sigma_1_s: f64,
    /// Whirl frequency of the mode's dominant circular component in the fixed frame,
    /// rad/s: positive for a forward whirl (with the spin), negative for a backward one.
    pub frequency_rad_s: f64,
    /// `frequency_rad_s / speed`.
    pub whirl_ratio: f64,
    /// `−σ / √(σ² + ν²)`, `ν` the fixed-frame frequency (negative when unstable).
    pub damping_ratio: f64,
    /// `−2π σ / |ν|`; `null` for a non-oscillating mode.
    pub log_dec: Option<f64>,
    /// `"forward"`, `"backward"` or `"none"` (no whirl).
    pub direction: &'static str,
    /// The eigenvalue in the analysis frame `[Re, Im]`, 1/s.
    pub eigenvalue: [f64; 2],
    /// Shape, normalised so that the largest journal end displacement is `1 + 0i`.
    pub shape: Shape,
}

/// A mode shape: complex amplitudes `[re, im]`.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct Shape {
    /// Shaft-axis point level with `G`, x (unit: the normalising journal displacement).
    pub x: [f64; 2],
    /// Same, y.
    pub y: [f64; 2],
    /// Tilt about x, per unit journal displacement, 1/m.
    pub tilt_x: [f64; 2],
    /// Tilt about y, 1/m.
    pub tilt_y: [f64; 2],
    /// Per bearing: amplitudes of the forward and backward circular whirl of the journal
    /// at its mid-plane `[forward, backward]`.
    pub journals: Vec<[f64; 2]>,
}

fn cabs(c: Complex<f64>) -> f64 {
    c.norm()
}

/// The imaginary unit.
const I: Complex<f64> = Complex::new(0.0, 1.0);

/// The modes of `lin`, least damped first (ascending damping ratio, then descending σ).
/// `axial` gives each bearing's mid-plane position from `G` and length, m.
pub fn modes(lin: &LinearRotor, axial: &[(f64, f64)]) -> Vec<Mode> {
    let m = Matrix4::from_fn(|i, j| lin.mass[i][j]);
    let k = Matrix4::from_fn(|i, j| lin.stiffness[i][j]);
    let d = Matrix4::from_fn(|i, j| lin.damping[i][j]);
    let Some(minv) = m.try_inverse() else {
        return Vec::new();
    };
    let mut a = DMatrix::<f64>::zeros(8, 8);
    let mk = -minv * k;
    let md = -minv * d;
    for i in 0..4 {
        a[(i, i + 4)] = 1.0;
        for j in 0..4 {
            a[(i + 4, j)] = mk[(i, j)];
            a[(i + 4, j + 4)] = md[(i, j)];
        }
    }
    let eig = a.clone().complex_eigenvalues();
    let scale = eig.iter().map(|c| c.norm()).fold(0.0, f64::max).max(1e-300);
    let ac = a.map(|v| Complex::new(v, 0.0));
    let frame_rate = match lin.frame {
        Frame::Fixed => 0.0,
        Frame::Rotating => lin.speed,
    };
    let mut out = Vec::new();
    for lam in eig.iter() {
        // One of each conjugate pair: the one with Im λ > 0, and the real ones.
        if lam.im < -1e-10 * scale {
            continue;
        }
        let lam = if lam.im.abs() <= 1e-10 * scale {
            Complex::new(lam.re, 0.0)
        } else {
            *lam
        };
        // Eigenvector: the right singular vector of A − λI with the least singular value.
        let shifted = &ac - DMatrix::<Complex<f64>>::identity(8, 8) * lam;
        let svd = shifted.svd(false, true);
        let Some(vt) = svd.v_t else { continue };
        let idx = svd
            .singular_values
            .iter()
            .enumerate()
            .min_by(|x, y| x.1.total_cmp(y.1))
            .map(|(i, _)| i)
            .unwrap_or(0);
        let v: Vec<Complex<f64>> = (0..4).map(|c| vt[(idx, c)].conj()).collect();
        // Journal end displacements (complex) of every bearing.
        let mut ends = Vec::new();
        let mut journals = Vec::new();
        let (mut fwd, mut bwd) = (0.0, 0.0);
        for &(a_mid, len) in axial {
            let mid = (v[0] + v[3] * a_mid, v[1] - v[2] * a_mid);
            for z in [a_mid - 0.5 * len, a_mid + 0.5 * len] {
                let e = (v[0] + v[3] * z, v[1] - v[2] * z);
                let f = cabs(e.0 + I * e.1);
                let b = cabs(e.0 - I * e.1);
                fwd += f * f;
                bwd += b * b;
                ends.push(e);
            }
            journals.push((cabs(mid.0 + I * mid.1), cabs(mid.0 - I * mid.1)));
        }
        // Normalise on the largest end displacement component.
        let mut norm = Complex::new(1.0, 0.0);
        let mut best = 0.0;
        for e in &ends {
            for c in [e.0, e.1] {
                if cabs(c) > best {
                    best = cabs(c);
                    norm = c;
                }
            }
        }
        let inv = if best > 0.0 {
            Complex::new(1.0, 0.0) / norm
        } else {
            Complex::new(1.0, 0.0)
        };
        let nv: Vec<Complex<f64>> = v.iter().map(|c| c * inv).collect();
        let nb = inv.norm();
        let nu = lam.im;
        let freq = if fwd >= bwd {
            nu + frame_rate
        } else {
            -nu + frame_rate
        };
        let sigma = lam.re;
        let mag = sigma.hypot(freq);
        let damping_ratio = if mag > 0.0 { -sigma / mag } else { 0.0 };
        out.push(Mode {
            sigma_1_s: sigma,
            frequency_rad_s: freq,
            whirl_ratio: if lin.speed != 0.0 {
                freq / lin.speed
            } else {
                0.0
            },
            damping_ratio,
            log_dec: (freq != 0.0).then(|| -2.0 * std::f64::consts::PI * sigma / freq.abs()),
            direction: if freq > 0.0 {
                "forward"
            } else if freq < 0.0 {
                "backward"
            } else {
                "none"
            },
            eigenvalue: [lam.re, lam.im],
            shape: Shape {
                x: [nv[0].re, nv[0].im],
                y: [nv[1].re, nv[1].im],
                tilt_x: [nv[2].re, nv[2].im],
                tilt_y: [nv[3].re, nv[3].im],
                journals: journals.iter().map(|(f, b)| [f * nb, b * nb]).collect(),
            },
        });
    }
    out.sort_by(|x, y| {
        x.damping_ratio
            .total_cmp(&y.damping_ratio)
            .then(y.sigma_1_s.total_cmp(&x.sigma_1_s))
    });
    out
}

/// Largest growth rate among `modes`, 1/s (`-inf` when empty).
pub fn max_growth(modes: &[Mode]) -> f64 {
    modes
        .iter()
        .map(|m| m.sigma_1_s)
        .fold(f64::NEG_INFINITY, f64::max)
}

/// Mass-weighted modal assurance criterion of two shapes,
/// `|aᴴ M b|² / ((aᴴ M a)(bᴴ M b))`, in `0..=1` (1: the same shape up to a complex
/// factor). `M` weighs translations (kg) and tilts (kg·m²) by their kinetic energy, so the
/// shapes' mixed units (per unit journal displacement, 1/m) compare consistently.
pub fn mac(a: &Shape, b: &Shape, mass: &M4) -> f64 {
    let v = |s: &Shape| -> [Complex<f64>; 4] {
        [s.x, s.y, s.tilt_x, s.tilt_y].map(|[re, im]| Complex::new(re, im))
    };
    let (a, b) = (v(a), v(b));
    let form = |p: &[Complex<f64>; 4], q: &[Complex<f64>; 4]| -> Complex<f64> {
        p.iter()
            .zip(mass)
            .map(|(pi, row)| {
                pi.conj()
                    * row
                        .iter()
                        .zip(q)
                        .map(|(m, qj)| qj * *m)
                        .sum::<Complex<f64>>()
            })
            .sum()
    };
    let (ab, aa, bb) = (form(&a, &b), form(&a, &a).re, form(&b, &b).re);
    if aa > 0.0 && bb > 0.0 {
        (ab.norm_sqr() / (aa * bb)).clamp(0.0, 1.0)
    } else {
        0.0
    }
}

/// Least MAC at which a mode continues a track from the neighbouring speed (below it the
/// mode starts a new track: its shape is not the one the track followed).
pub const TRACK_MIN_MAC: f64 = 0.3;

/// Modes followed over ascending speeds by continuity of their shapes (not by frequency
/// rank, which swaps curves where two modes cross): at each speed every oscillating mode
/// joins the track whose last shape it matches best by [`mac`] (largest MAC first, each
/// track and mode once, at least [`TRACK_MIN_MAC`]); a mode matching none starts a track.
/// `steps[k]` holds speed `k`'s modes and mass matrix; the answer lists per track the index
/// of its mode at each speed (`None` where it has none). Non-oscillating modes (real
/// eigenvalues) are left out. Tracks are ordered by their frequency where they start.
pub fn track_modes(steps: &[(&[Mode], &M4)]) -> Vec<Vec<Option<usize>>> {
    // Per track: (last shape, last |frequency|, indices).
    let mut tracks: Vec<(Shape, f64, Vec<Option<usize>>)> = Vec::new();
    for (k, (modes, mass)) in steps.iter().enumerate() {
        let osc: Vec<usize> = (0..modes.len())
            .filter(|&i| modes[i].frequency_rad_s != 0.0 && modes[i].frequency_rad_s.is_finite())
            .collect();
        let mut pairs: Vec<(f64, f64, usize, usize)> = Vec::new();
        for (t, (shape, freq, _)) in tracks.iter().enumerate() {
            for &i in &osc {
                let m = mac(shape, &modes[i].shape, mass);
                if m >= TRACK_MIN_MAC {
                    // Ties (e.g. repeated frequencies) go to the nearer frequency.
                    let df = (modes[i].frequency_rad_s.abs() - freq).abs();
                    pairs.push((m, df, t, i));
                }
            }
        }
        pairs.sort_by(|a, b| b.0.total_cmp(&a.0).then(a.1.total_cmp(&b.1)));
        let mut track_used = vec![false; tracks.len()];
        let mut mode_used = vec![false; modes.len()];
        for t in tracks.iter_mut() {
            t.2.push(None);
        }
        for (_, _, t, i) in pairs {
            if track_used[t] || mode_used[i] {
                continue;
            }
            track_used[t] = true;
            mode_used[i] = true;
            tracks[t].0 = modes[i].shape.clone();
            tracks[t].1 = modes[i].frequency_rad_s.abs();
            tracks[t].2[k] = Some(i);
        }
        for &i in &osc {
            if !mode_used[i] {
                let mut idx = vec![None; k + 1];
                idx[k] = Some(i);
                tracks.push((modes[i].shape.clone(), modes[i].frequency_rad_s.abs(), idx));
            }
        }
    }
    let first_freq = |t: &(Shape, f64, Vec<Option<usize>>)| -> f64 {
        t.2.iter()
            .enumerate()
            .find_map(|(k, i)| i.map(|i| steps[k].0[i].frequency_rad_s.abs()))
            .unwrap_or(f64::INFINITY)
    };
    let first_speed = |t: &(Shape, f64, Vec<Option<usize>>)| t.2.iter().position(Option::is_some);
    tracks.sort_by(|a, b| {
        first_speed(a)
            .cmp(&first_speed(b))
            .then(first_freq(a).total_cmp(&first_freq(b)))
    });
    tracks.into_iter().map(|t| t.2).collect()
}
