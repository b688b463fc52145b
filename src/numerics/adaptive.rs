//! Globally adaptive Gauss-Kronrod (7-15) quadrature of vector-valued integrands.
//! Slow and robust: used for reference values in tests and benchmarks, never on a hot path.

/// Result of an adaptive integration.
#[derive(Clone, Copy, Debug)]
pub struct AdaptiveResult<const N: usize> {
    /// Integral estimate.
    pub value: [f64; N],
    /// Estimated absolute error (max-norm over components).
    pub error: f64,
    /// Integrand evaluations used.
    pub evaluations: usize,
}

// The tables are quoted to 33 digits as published; f64 rounds them (hence the allow).
// Kronrod 15-point nodes on [-1, 1] (non-negative half) with the weights of the
// 15-point Kronrod rule and of the embedded 7-point Gauss rule (standard tables).
#[allow(clippy::excessive_precision)]
const XGK: [f64; 8] = [
    0.991455371120812639206854697526329,
    0.949107912342758524526189684047851,
    0.864864423359769072789712788640926,
    0.741531185599394439863864773280788,
    0.586087235467691130294144845693013,
    0.405845151377397166906606412076961,
    0.207784955007898467600689403773245,
    0.000000000000000000000000000000000,
];
#[allow(clippy::excessive_precision)]
const WGK: [f64; 8] = [
    0.022935322010529224963732008058970,
    0.063092092629978553290700663189204,
    0.104790010322250183839876322541518,
    0.140653259715525918745189590510238,
    0.169004726639267902826583426598550,
    0.190350578064785409913256402421014,
    0.204432940075298892414161999234649,
    0.209482141084727828012999174891714,
];
#[allow(clippy::excessive_precision)]
const WG: [f64; 4] = [
    0.129484966168869693270611432679082,
    0.279705391489276667901467771423780,
    0.381830050505118944950369775488975,
    0.417959183673469387755102040816327,
];

fn gk15<const N: usize>(f: &mut impl FnMut(f64) -> [f64; N], a: f64, b: f64) -> ([f64; N], f64) {
    let c = 0.5 * (a + b);
    let h = 0.5 * (b - a);
    let mut k = [0.0; N];
    let mut g = [0.0; N];
    let fc = f(c);
    for m in 0..N {
        k[m] = WGK[7] * fc[m];
        g[m] = WG[3] * fc[m];
    }
    for j in 0..7 {
        let f1 = f(c - h * XGK[j]);
        let f2 = f(c + h * XGK[j]);
        for m in 0..N {
            k[m] += WGK[j] * (f1[m] + f2[m]);
            if j % 2 == 1 {
                g[m] += WG[j / 2] * (f1[m] + f2[m]);
            }
        }
    }
    let mut err: f64 = 0.0;
    for m in 0..N {
        k[m] *= h;
        g[m] *= h;
        err = err.max((k[m] - g[m]).abs());
    }
    (k, err)
}

/// Integrates `f` over each of the consecutive intervals between `breakpoints`
/// (ascending) until the summed error estimate is below `atol + rtol·|value|` (max-norm)
/// or `max_intervals` is reached.
pub fn adaptive_gauss_kronrod<const N: usize>(
    mut f: impl FnMut(f64) -> [f64; N],
    breakpoints: &[f64],
    rtol: f64,
    atol: f64,
    max_intervals: usize,
) -> AdaptiveResult<N> {
    let mut pieces: Vec<(f64, f64, [f64; N], f64)> = Vec::new();
    let mut evaluations = 0;
    for w in breakpoints.windows(2) {
        if w[1] > w[0] {
            let (v, e) = gk15(&mut f, w[0], w[1]);
            evaluations += 15;
            pieces.push((w[0], w[1], v, e));
        }
    }
    // Summed value and error estimate over all pieces.
    let total = |pieces: &[(f64, f64, [f64; N], f64)]| {
        let mut value = [0.0; N];
        let mut error = 0.0;
        for (_, _, v, e) in pieces {
            for (acc, x) in value.iter_mut().zip(v) {
                *acc += x;
            }
            error += e;
        }
        (value, error)
    };
    loop {
        let (value, error) = total(&pieces);
        let scale = value.iter().fold(0.0_f64, |s, v| s.max(v.abs()));
        if error <= atol + rtol * scale || pieces.len() >= max_intervals || pieces.is_empty() {
            return AdaptiveResult {
                value,
                error,
                evaluations,
            };
        }
        // Bisect the piece with the largest error estimate.
        let worst = pieces
            .iter()
            .enumerate()
            .max_by(|a, b| a.1 .3.total_cmp(&b.1 .3))
            .map(|(i, _)| i)
            .unwrap_or(0);
        let (a, b) = (pieces[worst].0, pieces[worst].1);
        let m = 0.5 * (a + b);
        if !(m > a && m < b) {
            // Interval exhausted to rounding: nothing more can be gained.
            return AdaptiveResult {
                value,
                error,
                evaluations,
            };
        }
        pieces.swap_remove(worst);
        let (v1, e1) = gk15(&mut f, a, m);
        let (v2, e2) = gk15(&mut f, m, b);
        evaluations += 30;
        pieces.push((a, m, v1, e1));
        pieces.push((m, b, v2, e2));
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn integrates_a_peaked_function() {
        // ∫_0^1 1/(x + 1e-3) dx = ln(1001/1) ... exact: ln((1 + 1e-3)/1e-3)
        let r = adaptive_gauss_kronrod(|x| [1.0 / (x + 1e-3)], &[0.0, 1.0], 1e-13, 0.0, 10_000);
        let exact = ((1.0 + 1e-3) / 1e-3_f64).ln();
        assert!(
            (r.value[0] - exact).abs() < 1e-11 * exact,
            "{} vs {}",
            r.value[0],
            exact
        );
    }
}
