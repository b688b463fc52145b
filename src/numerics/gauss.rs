//! Gauss-Legendre rules on the unit interval.

/// An `n`-point Gauss-Legendre rule on `[0, 1]`: exact for polynomials of degree `2n - 1`.
#[derive(Clone, Debug, PartialEq)]
pub struct GaussRule {
    /// Nodes in `(0, 1)`, ascending.
    pub nodes: Vec<f64>,
    /// Weights, summing to 1.
    pub weights: Vec<f64>,
}

/// The `n`-point Gauss-Legendre rule on `[0, 1]` (Newton iteration on `P_n` from
/// Tricomi's initial guesses; converged to rounding for any `n >= 1`).
pub fn gauss_legendre_unit(n: usize) -> GaussRule {
    assert!(n >= 1, "a Gauss rule needs at least one node");
    let mut nodes = vec![0.0; n];
    let mut weights = vec![0.0; n];
    let nf = n as f64;
    for k in 0..n.div_ceil(2) {
        // k-th root of P_n on [-1, 1], counted from the right end.
        let mut x = (std::f64::consts::PI * (k as f64 + 0.75) / (nf + 0.5)).cos();
        let mut dp = 1.0;
        for _ in 0..100 {
            let (p, d) = legendre_and_derivative(n, x);
            dp = d;
            let dx = p / d;
            x -= dx;
            if dx.abs() <= 1e-16 * x.abs().max(1.0) {
                break;
            }
        }
        let (_, d) = legendre_and_derivative(n, x);
        dp = if d != 0.0 { d } else { dp };
        let w = 2.0 / ((1.0 - x * x) * dp * dp);
        // Map [-1, 1] -> [0, 1]: node (1 ± x)/2, weight w/2.
        nodes[k] = 0.5 * (1.0 - x);
        weights[k] = 0.5 * w;
        nodes[n - 1 - k] = 0.5 * (1.0 + x);
        weights[n - 1 - k] = 0.5 * w;
    }
    GaussRule { nodes, weights }
}

fn legendre_and_derivative(n: usize, x: f64) -> (f64, f64) {
    let (mut p0, mut p1) = (1.0, x);
    if n == 0 {
        return (1.0, 0.0);
    }
    for k in 2..=n {
        let kf = k as f64;
        let p2 = ((2.0 * kf - 1.0) * x * p1 - (kf - 1.0) * p0) / kf;
        p0 = p1;
        p1 = p2;
    }
    let d = n as f64 * (x * p1 - p0) / (x * x - 1.0);
    (p1, d)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn integrates_polynomials_of_degree_2n_minus_1_exactly() {
        for n in 1..=24 {
            let rule = gauss_legendre_unit(n);
            for deg in 0..(2 * n) {
                let approx: f64 = rule
                    .nodes
                    .iter()
                    .zip(&rule.weights)
                    .map(|(x, w)| w * x.powi(deg as i32))
                    .sum();
                let exact = 1.0 / (deg as f64 + 1.0);
                assert!(
                    (approx - exact).abs() < 1e-14,
                    "n={n} deg={deg}: {approx} vs {exact}"
                );
            }
        }
    }
}
