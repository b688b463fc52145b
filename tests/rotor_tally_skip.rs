//! The rotor's model-reduction tally skips the short-model error look-up for a state less
//! eccentric than one already looked up at the same `B/D` (issue 28, eighth pass). That is
//! exact only because the model-error map's load error strictly increases with `ε` up to
//! the map's last eccentricity 0.95 at every positive `B/D`, by more than the look-up's
//! rounding over the skip's margin of 1e-9 in `ε`: checked here, together with the
//! tally's fields against the look-up of every state written out (the code before the
//! skip).

use bearing_sweep::bearing::finite::short_model_error;
use bearing_sweep::bearing::{BearingParams, BearingState};
use bearing_sweep::rotor::simplifications::{SimplificationSpec, SimplificationTally};

/// Deterministic xorshift generator (no dependency).
struct Rng(u64);

impl Rng {
    fn next(&mut self) -> f64 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        (self.0 >> 11) as f64 / (1u64 << 53) as f64
    }
    fn range(&mut self, a: f64, b: f64) -> f64 {
        a + (b - a) * self.next()
    }
}

/// Aspect ratios below, on, between and above the map's rows (0.1 .. 1.0).
const ASPECTS: [f64; 9] = [0.03, 0.1, 0.137, 0.25, 0.5, 0.5731, 0.9, 1.0, 1.7];

#[test]
fn map_load_error_strictly_increases_with_eccentricity_beyond_the_skip_margin() {
    let mut rng = Rng(0x5EED_1234_ABCD_0001);
    for &bd in &ASPECTS {
        // A fine grid through every cell, and random pairs 1e-9 apart.
        let mut prev = short_model_error(bd, 0.0).load;
        for k in 1..=9500 {
            let e = k as f64 * 1e-4;
            let v = short_model_error(bd, e).load;
            assert!(
                v > prev,
                "B/D {bd}: load error {v} at ε {e} not above {prev}"
            );
            prev = v;
        }
        for _ in 0..20_000 {
            let e = rng.range(0.0, 0.95 - 1e-9);
            let (lo, hi) = (
                short_model_error(bd, e).load,
                short_model_error(bd, e + 1e-9).load,
            );
            // The skip needs `lo < hi` with room for rounding: at least 1e-12 of the
            // value's scale (the map's smallest slope gives 1.8e-12 times the aspect
            // scale).
            let scale = (bd / 0.1).min(1.0).powi(2);
            assert!(
                hi - lo > 1e-12 * scale,
                "B/D {bd}, ε {e}: {lo} → {hi} over 1e-9 (margin)"
            );
        }
    }
}

/// The tally's short-model fields with a look-up for every state (the code before the
/// skip).
fn full_lookups(states: &[(BearingParams, BearingState)]) -> (f64, f64, (f64, f64), bool) {
    let mut best = (0.0, 0.0, (0.0, 0.0), false);
    for (p, s) in states {
        let bd = p.length / (2.0 * p.radius);
        let (ei, ej) = s.eccentricity_ratios(p.clearance);
        let e = short_model_error(bd, ei.max(ej));
        if e.load.abs() >= best.0 {
            best = (
                e.load.abs(),
                e.attitude_deg,
                (bd, ei.max(ej)),
                e.extrapolated,
            );
        }
    }
    best
}

#[test]
fn tally_with_skips_equals_a_look_up_of_every_state() {
    let spec = SimplificationSpec::default();
    let mut rng = Rng(0xC0FF_EE00_1357_9BDF);
    let geometries: Vec<BearingParams> = [0.02, 0.011, 0.035]
        .iter()
        .map(|&len| BearingParams {
            length: len,
            ..BearingParams::paper_table2()
        })
        .collect();
    let mut skipped_some = false;
    for case in 0..200 {
        // Runs of states whose eccentricity drifts up and down (as a rotor's do), some
        // beyond the map's 0.95 (its flat edge), some repeated exactly, two or three
        // geometries interleaved.
        let n_geom = 1 + case % 3;
        let mut states = Vec::new();
        let mut e = rng.range(0.0, 0.5);
        for k in 0..400 {
            let p = geometries[k % n_geom];
            let c = p.clearance;
            e = (e + rng.range(-0.02, 0.021)).clamp(0.0, 0.99);
            if case % 7 == 0 && k > 10 && k % 5 == 0 {
                // An exact repeat of the last state of this geometry.
                if let Some(&(q, s)) = states.iter().rev().nth(n_geom - 1) {
                    states.push((q, s));
                    continue;
                }
            }
            let a = rng.range(0.0, std::f64::consts::TAU);
            let tilt = rng.range(-0.05, 0.05);
            let s = BearingState {
                xi: e * c * a.cos(),
                yi: e * c * a.sin(),
                xj: (e + tilt).clamp(0.0, 0.99) * c * (a + 0.1).cos(),
                yj: (e + tilt).clamp(0.0, 0.99) * c * (a + 0.1).sin(),
                omega: 100.0,
                ..BearingState::default()
            };
            states.push((p, s));
        }
        let mut tally = SimplificationTally::default();
        for (p, s) in &states {
            let mut s = *s;
            tally.observe(&spec, p, &mut s);
        }
        let want = full_lookups(&states);
        let got = (
            tally.short_error_max,
            tally.short_attitude_at_max,
            tally.short_error_at,
            tally.short_error_extrapolated,
        );
        assert_eq!(got, want, "case {case}: tally against every look-up");
        assert_eq!(tally.short_states, states.len() as u64);
        // Some state below an earlier one's eccentricity (so skipped).
        skipped_some |= states.windows(2).any(|w| {
            w[1].1.eccentricity_ratios(w[1].0.clearance).0
                < w[0].1.eccentricity_ratios(w[0].0.clearance).0 - 1e-6
        });
    }
    assert!(skipped_some, "the states must exercise the skip");
}
