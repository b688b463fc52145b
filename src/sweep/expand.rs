//! Expansion of a spec into variants with stable ids (the index in the full expansion),
//! so that sharding and resuming are deterministic. Variants are built on demand: a
//! sweep of 1e6 variants never holds 1e6 scenes.
//!
//! - Grid: axes sharing a `zip` group move together and form one factor; factors are
//!   ordered by their first axis in the spec; the first factor varies slowest (nested
//!   loops in spec order, the last axis innermost). Id = mixed-radix number of the factor
//!   indices.
//! - Zip: variant `k` takes value `k` of every axis.
//! - Latin hypercube: `samples` variants; for each factor a seeded random permutation of
//!   the strata `0..samples` and a uniform offset in each stratum give `u` in `[0, 1)`;
//!   a range axis (linspace, logspace) takes the continuous value at `u` between its
//!   bounds (log-uniform for logspace, whose `n` is ignored), a list axis takes the value
//!   at index `floor(u · len)`. Axes of one zip group share `u`. The PRNG is SplitMix64
//!   seeded from the seed and the factor's index, so the samples of one factor do not
//!   change when another factor is added after it.

use serde_json::{Map, Value};

use super::spec::{set_path, AxisMode, SweepSpec};
use super::SweepError;

/// A scene validator: `Err((JSON path inside the scene, reason))`.
pub type SceneValidator = dyn Fn(&Value) -> Result<(), (String, String)>;

/// A variant: its id, the value of each axis (spec order), and its scene.
#[derive(Clone, Debug, PartialEq)]
pub struct Variant {
    /// Index in the full expansion.
    pub id: u64,
    /// Axis values in spec order.
    pub values: Vec<Value>,
    /// The base scene with every axis value applied.
    pub scene: Value,
}

impl Variant {
    /// `{"path": value, ...}` for outputs.
    pub fn params(&self, spec: &SweepSpec) -> Value {
        let mut m = Map::new();
        for (a, v) in spec.axes.iter().zip(&self.values) {
            m.insert(a.path.clone(), v.clone());
        }
        Value::Object(m)
    }

    /// `path = value, ...` for messages.
    pub fn assignment(&self, spec: &SweepSpec) -> String {
        if spec.axes.is_empty() {
            return "base scene".into();
        }
        spec.axes
            .iter()
            .zip(&self.values)
            .map(|(a, v)| format!("{} = {v}", a.path))
            .collect::<Vec<_>>()
            .join(", ")
    }
}

/// SplitMix64 (Steele, Lea, Flood 2014): a small, fast, well-mixed 64-bit generator,
/// plenty for stratified sampling and stable across platforms and releases.
#[derive(Clone, Debug)]
pub struct SplitMix64(u64);

impl SplitMix64 {
    /// Generator seeded with `seed`.
    pub fn new(seed: u64) -> Self {
        SplitMix64(seed)
    }

    /// Next 64 random bits.
    pub fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }

    /// Uniform in `[0, 1)` with 53 random bits.
    pub fn next_f64(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 * (1.0 / (1u64 << 53) as f64)
    }

    /// Uniform integer in `0..n` (`n > 0`), by rejection (no modulo bias).
    pub fn below(&mut self, n: u64) -> u64 {
        let zone = u64::MAX - u64::MAX % n;
        loop {
            let r = self.next_u64();
            if r < zone {
                return r % n;
            }
        }
    }
}

/// How variant ids map to axis values.
#[derive(Clone, Debug)]
enum Plan {
    /// Factors (lists of axis indices) with their lengths; first factor slowest.
    Grid {
        factors: Vec<Vec<usize>>,
        lens: Vec<u64>,
    },
    /// All axes together.
    Zip { len: u64 },
    /// Per factor, the stratified `u` of every sample.
    Lhs {
        factors: Vec<Vec<usize>>,
        u: Vec<Vec<f64>>,
        samples: u64,
    },
}

/// The expansion of one spec.
#[derive(Clone, Debug)]
pub struct Expansion {
    plan: Plan,
}

fn factors(spec: &SweepSpec) -> Vec<Vec<usize>> {
    let mut out: Vec<Vec<usize>> = Vec::new();
    let mut names: Vec<Option<&str>> = Vec::new();
    for (k, a) in spec.axes.iter().enumerate() {
        match a.zip.as_deref() {
            Some(g) => match names.iter().position(|n| *n == Some(g)) {
                Some(f) => out[f].push(k),
                None => {
                    names.push(Some(g));
                    out.push(vec![k]);
                }
            },
            None => {
                names.push(None);
                out.push(vec![k]);
            }
        }
    }
    out
}

impl Expansion {
    /// Plans the expansion (Latin hypercube strata are drawn here, `O(samples · axes)`).
    pub fn new(spec: &SweepSpec) -> Self {
        let plan = match &spec.mode {
            AxisMode::Grid => {
                let factors = factors(spec);
                let lens = factors
                    .iter()
                    .map(|f| spec.axes[f[0]].values.len() as u64)
                    .collect();
                Plan::Grid { factors, lens }
            }
            AxisMode::Zip => Plan::Zip {
                len: spec.axes.first().map_or(1, |a| a.values.len() as u64),
            },
            AxisMode::LatinHypercube { samples, seed } => {
                let factors = factors(spec);
                let n = *samples;
                let u = (0..factors.len())
                    .map(|f| {
                        // One stream per factor: seed mixed with the factor index.
                        let mut rng = SplitMix64::new(
                            seed ^ (f as u64 + 1).wrapping_mul(0xD1B5_4A32_D192_ED03),
                        );
                        let mut perm: Vec<u64> = (0..n).collect();
                        // Fisher-Yates.
                        for i in (1..perm.len()).rev() {
                            let j = rng.below(i as u64 + 1) as usize;
                            perm.swap(i, j);
                        }
                        perm.iter()
                            .map(|&s| (s as f64 + rng.next_f64()) / n as f64)
                            .collect()
                    })
                    .collect();
                Plan::Lhs {
                    factors,
                    u,
                    samples: n,
                }
            }
        };
        Expansion { plan }
    }

    /// Number of variants (saturating at `u64::MAX`).
    pub fn count(&self) -> u64 {
        match &self.plan {
            Plan::Grid { lens, .. } => lens.iter().fold(1u64, |p, &l| p.saturating_mul(l)),
            Plan::Zip { len } => *len,
            Plan::Lhs { samples, .. } => *samples,
        }
    }

    /// Axis values of variant `id` (`id < count`), spec order.
    pub fn values(&self, spec: &SweepSpec, id: u64) -> Vec<Value> {
        let mut out = vec![Value::Null; spec.axes.len()];
        match &self.plan {
            Plan::Grid { factors, lens } => {
                let mut rest = id;
                for (f, len) in factors.iter().zip(lens).rev() {
                    let k = (rest % len) as usize;
                    rest /= len;
                    for &a in f {
                        out[a] = spec.axes[a].values.value(k);
                    }
                }
            }
            Plan::Zip { .. } => {
                for (a, axis) in spec.axes.iter().enumerate() {
                    out[a] = axis.values.value(id as usize);
                }
            }
            Plan::Lhs { factors, u, .. } => {
                for (f, axes) in factors.iter().enumerate() {
                    let uf = u[f][id as usize];
                    for &a in axes {
                        let vals = &spec.axes[a].values;
                        out[a] = match vals.continuous(uf) {
                            Some(x) => serde_json::Number::from_f64(x)
                                .map(Value::Number)
                                .unwrap_or(Value::Null),
                            None => {
                                let k = ((uf * vals.len() as f64) as usize).min(vals.len() - 1);
                                vals.value(k)
                            }
                        };
                    }
                }
            }
        }
        out
    }

    /// Variant `id` with its scene.
    pub fn variant(&self, spec: &SweepSpec, id: u64) -> Variant {
        let values = self.values(spec, id);
        let mut scene = spec.base.clone();
        for (axis, v) in spec.axes.iter().zip(&values) {
            set_path(&mut scene, &axis.segments, v);
        }
        Variant { id, values, scene }
    }

    /// Checks the spec's variants with `validator` (the scene validator: `Err((json
    /// path, reason))`), before any computation, at a cost in proportion to the spec, not
    /// to the grid. Up to [`VALIDATE_EVERY_VARIANT_BELOW`] variants every one is checked.
    /// Above that (grid and zip modes) every value of every factor is checked once, with
    /// the other factors at their first value, a range axis (linspace, logspace) at
    /// [`RANGE_CHECKS`] evenly spread values including both ends; then
    /// [`SAMPLED_VARIANTS`] variants spread evenly over the ids (Latin hypercube: these
    /// only, and the first and last). A variant that fails later anyway (a constraint
    /// coupling two axes inside the grid) fails alone at run time with status
    /// `invalid_scene`; the sweep goes on. Reports the first failing variant checked.
    pub fn validate_all(
        &self,
        spec: &SweepSpec,
        validator: &SceneValidator,
    ) -> Result<(), SweepError> {
        let count = self.count();
        if count <= VALIDATE_EVERY_VARIANT_BELOW {
            return (0..count).try_for_each(|id| self.validate_one(spec, id, validator));
        }
        if let Plan::Grid { factors, lens } = &self.plan {
            for (f, axes) in factors.iter().enumerate() {
                let ranges_only = axes
                    .iter()
                    .all(|&a| !matches!(spec.axes[a].values, super::AxisValues::List(_)));
                for k in spread(lens[f], ranges_only) {
                    // Mixed-radix id with every other factor at index 0.
                    let stride: u64 = lens[f + 1..].iter().product();
                    self.validate_one(spec, k * stride, validator)?;
                }
            }
        }
        if let Plan::Zip { len } = &self.plan {
            let ranges_only = spec
                .axes
                .iter()
                .all(|a| !matches!(a.values, super::AxisValues::List(_)));
            for k in spread(*len, ranges_only) {
                self.validate_one(spec, k, validator)?;
            }
        }
        let step = (count / SAMPLED_VARIANTS).max(1);
        (0..count)
            .step_by(step as usize)
            .chain([count - 1])
            .try_for_each(|id| self.validate_one(spec, id, validator))
    }

    /// Validates variant `id`, as a located error.
    fn validate_one(
        &self,
        spec: &SweepSpec,
        id: u64,
        validator: &SceneValidator,
    ) -> Result<(), SweepError> {
        let v = self.variant(spec, id);
        match validator(&v.scene) {
            Ok(()) => Ok(()),
            Err((mut path, reason)) => {
                if path == "$" {
                    path = self.locate(spec, &v, validator).unwrap_or(path);
                }
                Err(SweepError::Variant {
                    id,
                    assignment: v.assignment(spec),
                    path,
                    reason,
                })
            }
        }
    }

    /// For an error the validator could not place (e.g. serde's "invalid type"): when the
    /// base alone is valid, the first axis whose value alone breaks the base, as the
    /// concrete path it sets.
    fn locate(&self, spec: &SweepSpec, v: &Variant, validator: &SceneValidator) -> Option<String> {
        validator(&spec.base).ok()?;
        spec.axes.iter().zip(&v.values).find_map(|(axis, value)| {
            let mut scene = spec.base.clone();
            set_path(&mut scene, &axis.segments, value);
            validator(&scene).err()?;
            super::spec::resolve(&spec.base, &axis.segments)
                .ok()
                .and_then(|t| t.first().map(|(p, _)| p.clone()))
        })
    }
}

/// Sweeps up to this many variants have every variant validated before running.
pub const VALIDATE_EVERY_VARIANT_BELOW: u64 = 10_000;

/// Values of a range axis (linspace, logspace) checked in a large sweep: both ends and
/// evenly spread values between (validators check ranges such as "positive" or "below
/// 1", which a monotone axis meets everywhere once it meets them at its ends).
pub const RANGE_CHECKS: u64 = 65;

/// Variants spread evenly over the ids checked in a large sweep after the per-factor pass.
pub const SAMPLED_VARIANTS: u64 = 1000;

/// Indices of a factor of `len` values to check: all of them for a list (their number
/// is in the spec), else [`RANGE_CHECKS`] evenly spread ones with both ends.
fn spread(len: u64, ranges_only: bool) -> Vec<u64> {
    if !ranges_only || len <= RANGE_CHECKS {
        return (0..len).collect();
    }
    let mut out: Vec<u64> = (0..RANGE_CHECKS)
        .map(|i| i * (len - 1) / (RANGE_CHECKS - 1))
        .collect();
    out.dedup();
    out
}

/// A validator that accepts every scene (for scene kinds validated elsewhere).
pub fn accept_any(_: &Value) -> Result<(), (String, String)> {
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sweep::spec::parse_spec;
    use serde_json::json;

    fn base() -> Value {
        json!({"a": 0.0, "b": 0.0, "c": "x", "list": [{"v": 0.0}, {"v": 0.0}]})
    }

    fn expand(doc: Value) -> (SweepSpec, Expansion) {
        let spec = parse_spec(&doc, None).unwrap();
        let e = Expansion::new(&spec);
        (spec, e)
    }

    #[test]
    fn grid_order_is_nested_loops_in_spec_order() {
        let (spec, e) = expand(json!({"base": base(), "axes": [
            {"path": "a", "values": [1, 2]},
            {"path": "b", "linspace": [10, 30, 3]},
        ]}));
        assert_eq!(e.count(), 6);
        let got: Vec<(f64, f64)> = (0..6)
            .map(|id| {
                let v = e.values(&spec, id);
                (v[0].as_f64().unwrap(), v[1].as_f64().unwrap())
            })
            .collect();
        let expected = vec![
            (1.0, 10.0),
            (1.0, 20.0),
            (1.0, 30.0),
            (2.0, 10.0),
            (2.0, 20.0),
            (2.0, 30.0),
        ];
        assert_eq!(got, expected);
        let v = e.variant(&spec, 4);
        assert_eq!(v.scene["a"], json!(2));
        assert_eq!(v.scene["b"], json!(20.0));
        assert_eq!(v.params(&spec), json!({"a": 2, "b": 20.0}));
    }

    #[test]
    fn zip_groups_inside_a_grid_move_together() {
        let (spec, e) = expand(json!({"base": base(), "axes": [
            {"path": "a", "values": [1, 2], "zip": "g"},
            {"path": "c", "values": ["p", "q", "r"]},
            {"path": "b", "values": [10, 20], "zip": "g"},
        ]}));
        assert_eq!(e.count(), 6);
        for id in 0..6 {
            let v = e.values(&spec, id);
            let k = (id / 3) as usize;
            assert_eq!(v[0], json!([1, 2][k]), "variant {id}");
            assert_eq!(v[2], json!([10, 20][k]), "variant {id}");
            assert_eq!(
                v[1],
                json!(["p", "q", "r"][(id % 3) as usize]),
                "variant {id}"
            );
        }
    }

    #[test]
    fn zip_mode_pairs_values() {
        let (spec, e) = expand(json!({"base": base(), "mode": "zip", "axes": [
            {"path": "a", "values": [1, 2, 3]},
            {"path": "list[*].v", "linspace": [0, 1, 3]},
        ]}));
        assert_eq!(e.count(), 3);
        let v = e.variant(&spec, 1);
        assert_eq!(v.scene["a"], json!(2));
        assert_eq!(v.scene["list"], json!([{"v": 0.5}, {"v": 0.5}]));
    }

    #[test]
    fn no_axes_is_one_variant_the_base() {
        let (spec, e) = expand(json!({"base": base()}));
        assert_eq!(e.count(), 1);
        assert_eq!(e.variant(&spec, 0).scene, base());
    }

    #[test]
    fn latin_hypercube_is_stratified_seeded_and_in_bounds() {
        let n = 50u64;
        let doc = |seed: u64| {
            json!({"base": base(), "mode": {"latin_hypercube": {"samples": n, "seed": seed}}, "axes": [
                {"path": "a", "linspace": [2.0, 4.0, 2]},
                {"path": "b", "logspace": [1e-3, 1e1, 2]},
                {"path": "c", "values": ["p", "q", "r", "s", "t"]},
            ]})
        };
        let (spec, e) = expand(doc(7));
        assert_eq!(e.count(), n);
        let mut strata_a = vec![0; n as usize];
        let mut strata_b = vec![0; n as usize];
        let mut picks = std::collections::BTreeMap::new();
        for id in 0..n {
            let v = e.values(&spec, id);
            let a = v[0].as_f64().unwrap();
            let b = v[1].as_f64().unwrap();
            assert!(
                (2.0..4.0).contains(&a),
                "variant {id}: a = {a} outside [2, 4)"
            );
            assert!(
                (1e-3..1e1).contains(&b),
                "variant {id}: b = {b} outside [1e-3, 10)"
            );
            strata_a[((a - 2.0) / 2.0 * n as f64) as usize] += 1;
            // log-uniform: strata equal in log10 b.
            strata_b[(((b.log10() + 3.0) / 4.0) * n as f64) as usize] += 1;
            *picks.entry(v[2].as_str().unwrap().to_string()).or_insert(0) += 1;
        }
        assert!(strata_a.iter().all(|&c| c == 1), "a strata: {strata_a:?}");
        assert!(strata_b.iter().all(|&c| c == 1), "b strata: {strata_b:?}");
        // 50 samples over 5 list values: each value exactly 10 times.
        assert!(picks.values().all(|&c| c == 10), "list picks: {picks:?}");
        // Same seed, same samples; another seed, others.
        let (spec2, e2) = expand(doc(7));
        let (spec3, e3) = expand(doc(8));
        assert_eq!(e.values(&spec, 3), e2.values(&spec2, 3));
        assert_ne!(e.values(&spec, 3), e3.values(&spec3, 3));
    }

    #[test]
    fn splitmix_reference_values() {
        // First outputs for seed 0 (published with the algorithm, e.g. in Vigna's
        // reference implementation): 0xE220A8397B1DCDAF, 0x6E789E6AA1B965F4.
        let mut r = SplitMix64::new(0);
        assert_eq!(r.next_u64(), 0xE220_A839_7B1D_CDAF);
        assert_eq!(r.next_u64(), 0x6E78_9E6A_A1B9_65F4);
    }

    #[test]
    fn validator_errors_name_the_variant_and_path() {
        let (spec, e) = expand(json!({"base": base(), "axes": [{"path": "a", "values": [1, -1]}]}));
        let validator = |scene: &Value| -> Result<(), (String, String)> {
            if scene["a"].as_f64().unwrap() < 0.0 {
                Err(("a".into(), "must be positive".into()))
            } else {
                Ok(())
            }
        };
        match e.validate_all(&spec, &validator) {
            Err(SweepError::Variant {
                id,
                assignment,
                path,
                reason,
            }) => {
                assert_eq!(
                    (id, assignment.as_str(), path.as_str(), reason.as_str()),
                    (1, "a = -1", "a", "must be positive")
                );
            }
            other => panic!("expected a variant error, got {other:?}"),
        }
    }
}
