//! Issue 23 item 4: Campbell and damping diagrams follow modes by the continuity of their
//! shapes. A rigid rotor on isotropic-in-tilt, anisotropic-in-translation supports with a
//! disc-like inertia (`I_p > I_d`): its forward conical mode rises with speed (gyroscopic
//! stiffening, closed form `I_d ω² − I_p Ω ω − k_t = 0`) and crosses the two translational
//! modes (`√(k_x/m)`, `√(k_y/m)`, constant). Ranked by frequency, the curves would swap
//! modes at the crossings; tracked, each keeps its shape and its closed-form frequency.

use bearing_sweep::stability::{
    campbell_figure, damping_figure, modes, track_modes, Frame, LinearRotor, Mode, SpeedAnalysis,
    M4,
};

/// Mass, kg; transverse and polar inertia, kg·m²; stiffnesses, N/m and N·m/rad; damping.
const M: f64 = 10.0;
const ID: f64 = 0.1;
const IP: f64 = 0.15;
const KX: f64 = 1.0e6;
const KY: f64 = 1.44e6;
const KT: f64 = 4.0e3;
/// Light damping (damping ratios below 1 %), N·s/m and N·m·s/rad.
const C: f64 = 20.0;
const CT: f64 = 0.5;

fn rotor(speed: f64, kt: f64, cross: f64) -> LinearRotor {
    let mut mass: M4 = [[0.0; 4]; 4];
    let mut stiffness: M4 = [[0.0; 4]; 4];
    let mut damping: M4 = [[0.0; 4]; 4];
    for (i, (m, k, c)) in [(M, KX, C), (M, KY, C), (ID, kt, CT), (ID, kt, CT)]
        .into_iter()
        .enumerate()
    {
        mass[i][i] = m;
        stiffness[i][i] = k;
        damping[i][i] = c;
    }
    // Gyroscopic coupling of the tilts, −I_p Ω J (as src/stability/linear.rs builds it).
    damping[2][3] = IP * speed;
    damping[3][2] = -IP * speed;
    // Optional cross-coupled translational stiffness (a film's destabilising term).
    stiffness[0][1] = cross;
    stiffness[1][0] = -cross;
    LinearRotor {
        speed,
        frame: Frame::Fixed,
        equilibrium: [0.0; 4],
        newton_iterations: 0,
        bearings: Vec::new(),
        mass,
        damping,
        stiffness,
    }
}

fn runs(speeds: &[f64], kt: f64, cross: f64) -> Vec<SpeedAnalysis> {
    // Bearings 0.1 m either side of G, 20 mm long.
    let axial = [(-0.1, 0.02), (0.1, 0.02)];
    speeds
        .iter()
        .map(|&w| {
            let lin = rotor(w, kt, cross);
            SpeedAnalysis {
                speed_rad_s: w,
                modes: modes(&lin, &axial),
                linear: lin,
            }
        })
        .collect()
}

/// Share of a mode's kinetic energy in translation.
fn translation_share(m: &Mode) -> f64 {
    let n = |c: [f64; 2]| c[0] * c[0] + c[1] * c[1];
    let t = M * (n(m.shape.x) + n(m.shape.y));
    t / (t + ID * (n(m.shape.tilt_x) + n(m.shape.tilt_y)))
}

fn forward_conical(w: f64) -> f64 {
    (IP * w + (IP * IP * w * w + 4.0 * ID * KT).sqrt()) / (2.0 * ID)
}

#[test]
fn tracked_modes_keep_their_shape_where_frequencies_cross() {
    let speeds: Vec<f64> = (0..=40).map(|k| 10.0 * k as f64).collect();
    let r = runs(&speeds, KT, 0.0);
    // The case does cross: the forward conical mode starts below both translational
    // modes and ends above both.
    let (wx, wy) = ((KX / M).sqrt(), (KY / M).sqrt());
    assert!(forward_conical(0.0) < wx && forward_conical(400.0) > wy);
    let steps: Vec<(&[Mode], &M4)> = r
        .iter()
        .map(|a| (a.modes.as_slice(), &a.linear.mass))
        .collect();
    let tracks = track_modes(&steps);
    assert_eq!(
        tracks.len(),
        4,
        "two translational and two conical modes: {tracks:?}"
    );
    let tol = 0.01;
    let mut seen = [false; 3];
    for (t, idx) in tracks.iter().enumerate() {
        assert!(
            idx.iter().all(Option::is_some),
            "track {t} misses a speed: {idx:?}"
        );
        let at = |s: usize| &r[s].modes[idx[s].unwrap()];
        let first = translation_share(at(0));
        for (s, &w) in speeds.iter().enumerate() {
            let m = at(s);
            let share = translation_share(m);
            assert!(
                (share > 0.99) == (first > 0.99),
                "track {t}, speed index {s} ({w} rad/s): translation share {share}, at the start {first}"
            );
            let f = m.frequency_rad_s.abs();
            if first > 0.99 {
                // A translational track keeps its frequency: √(k_x/m) or √(k_y/m).
                let expected = if (at(0).frequency_rad_s.abs() - wx).abs() < 1.0 {
                    wx
                } else {
                    wy
                };
                assert!(
                    (f / expected - 1.0).abs() < tol,
                    "track {t}, speed index {s}: frequency {f}, expected {expected}, tolerance {tol} relative"
                );
                seen[if expected == wx { 0 } else { 1 }] = true;
            } else if m.frequency_rad_s > 0.0 {
                let expected = forward_conical(w);
                assert!(
                    (f / expected - 1.0).abs() < tol,
                    "track {t}, speed index {s}: forward conical {f}, closed form {expected}, tolerance {tol} relative"
                );
                seen[2] = true;
            }
        }
    }
    assert_eq!(seen, [true; 3], "x, y and forward conical tracks found");
    // Ranked by frequency instead, the second-lowest curve would change mode: the check
    // above is not vacuous.
    let second = |s: usize| {
        let mut m: Vec<&Mode> = r[s]
            .modes
            .iter()
            .filter(|m| m.frequency_rad_s != 0.0)
            .collect();
        m.sort_by(|a, b| a.frequency_rad_s.abs().total_cmp(&b.frequency_rad_s.abs()));
        translation_share(m[1])
    };
    assert!(
        (second(0) > 0.99) != (second(40) > 0.99),
        "ranking would not swap here"
    );
}

#[test]
fn the_campbell_diagram_draws_tracked_curves_with_whirl_direction_and_stability() {
    let speeds: Vec<f64> = (0..=40).map(|k| 10.0 + 10.0 * k as f64).collect();
    let r = runs(&speeds, KT, 0.0);
    let fig = campbell_figure("Campbell diagram: disc rotor", &r, None, Some(300.0)).unwrap();
    let svg = fig.svg().unwrap();
    // The drawn x-mode curve stays at √(k_x/m) (within the cross-coupling's shift) at
    // every speed: its points are one mode, not a rank.
    let wx = (KX / M).sqrt();
    let near_x: Vec<&bearing_sweep::plot::Curve> = fig
        .curves
        .iter()
        .filter(|c| {
            c.dash.is_some() && !c.points.is_empty() && (c.points[0].1 / wx - 1.0).abs() < 0.05
        })
        .collect();
    assert!(!near_x.is_empty(), "no curve starts at the x mode");
    for c in &near_x {
        for (i, p) in c.points.iter().enumerate() {
            assert!(
                (p.1 / wx - 1.0).abs() < 0.05,
                "curve {:?} point {i}: {p:?}, expected ~{wx}",
                c.label
            );
        }
    }
    assert!(
        svg.contains("operating speed 300 rad/s"),
        "no operating-speed line"
    );
    assert!(svg.contains(">1x<"), "no 1x line in the legend");
    assert!(svg.contains("backward whirl"), "no backward-whirl key");
    assert!(
        !svg.contains("tests/") && !svg.contains(".rs"),
        "a source path in the figure"
    );
    // Legend only for drawn modes.
    assert_eq!(
        svg.matches(">mode ").count(),
        4,
        "the four drawn modes in the legend"
    );
    // Cross-coupled stiffness beyond the anisotropy ((k_y − k_x)/2) turns the
    // translational modes into circular whirls and destabilises the forward one.
    let r = runs(&speeds, KT, 3.0e5);
    let svg = campbell_figure("Campbell diagram: cross-coupled", &r, None, Some(300.0))
        .unwrap()
        .svg()
        .unwrap();
    // Unstable points (log dec < 0) are marked, and only those.
    let unstable: usize = r
        .iter()
        .map(|a| {
            a.modes
                .iter()
                .filter(|m| m.log_dec.is_some_and(|d| d < 0.0))
                .count()
        })
        .sum();
    assert!(unstable > 0, "the cross-coupled case has unstable modes");
    let triangles = svg.matches("class=\"marker\" d=\"M").count();
    assert_eq!(triangles, unstable, "one triangle per unstable point");
    assert!(
        svg.contains("unstable (log dec &lt; 0)"),
        "no key for the unstable marker"
    );
    let d = damping_figure("Log dec", &r, Some(300.0))
        .unwrap()
        .svg()
        .unwrap();
    assert!(d.contains("stability limit"));
}

#[test]
fn a_far_mode_does_not_stretch_the_frequency_window() {
    // Tilt stiffness 1e4 times larger: the conical modes near 2e4 rad/s, speeds to 400.
    let speeds: Vec<f64> = (1..=20).map(|k| 20.0 * k as f64).collect();
    let r = runs(&speeds, KT * 1e4, 0.0);
    let fig = campbell_figure("far", &r, None, None).unwrap();
    let (lo, hi) = fig.y_range.unwrap();
    assert!(
        lo == 0.0 && hi < 2.5 * 400.0 * 1.07,
        "window {lo}..{hi} stretched by the far modes"
    );
    let svg = fig.svg().unwrap();
    assert_eq!(
        svg.matches(">mode ").count(),
        2,
        "only the two drawn modes in the legend"
    );
    assert!(
        svg.contains("2 modes above"),
        "no note of the modes left out"
    );
}
