//! The rigid-rotor equations (MODEL.md section 8): state layout, initial state,
//! kinematics of the journal end centres, and the derivative from the film end-point
//! loads (bearing model) or from the pinned axis (ideal joints).
//!
//! State (12 components): `G = (x, y)` m, `v_G` m/s, attitude quaternion `(w, x, y, z)`
//! (body to global; normalised in every use and projected back to unit length after
//! every accepted step, so it cannot drift), body angular velocity rad/s, and the work
//! done on the rotor by all applied loads, J (a quadrature: `f` does not depend on it).
//! Axial motion is constrained (`z_G = 0`); the axial force is the constraint's.
//!
//! A scene whose bearings name a lubricant (bearing model) carries one more component
//! per such bearing after these 12: its lumped effective oil temperature above the
//! supply temperature, K ([`RotorModel::state_dim`], docs/thermal.md "Rotor scenes").

use nalgebra::{Matrix3, Quaternion, Rotation3, UnitQuaternion, Vector3};

use super::scene::{ModelKind, Scene, SpinMode};
use crate::bearing::{friction, BearingParams, BearingState};

/// State dimension of the rigid rotor (scenes without a lubricant; thermal bearings add
/// one component each after these, [`RotorModel::state_dim`]).
pub const DIM: usize = 12;
/// Components `f` depends on (all but the work quadrature).
pub const JAC_DIM: usize = 11;
pub(crate) const X: usize = 0;
pub(crate) const VX: usize = 2;
pub(crate) const Q: usize = 4;
pub(crate) const W: usize = 8;
pub(crate) const WORK: usize = 11;

// In-plane quantities (`G`, `v_G`, end-centre velocities, film forces) stay `[f64; 2]`:
// they are the film's interface (`BearingState`, `contact_force`), plain components.
pub(crate) type V3 = Vector3<f64>;
pub(crate) type M3 = Matrix3<f64>;

/// Rotation matrix (body to global) of the state's quaternion `(w, x, y, z)`, normalised
/// first.
pub(crate) fn quat_matrix(q: &[f64]) -> M3 {
    UnitQuaternion::from_quaternion(Quaternion::new(q[0], q[1], q[2], q[3]))
        .to_rotation_matrix()
        .into_inner()
}

/// Rotation by `angle` rad about body axis `axis` (x, y, z).
fn axis_rotation(axis: usize, angle: f64) -> UnitQuaternion<f64> {
    let axis = match axis {
        0 => Vector3::x_axis(),
        1 => Vector3::y_axis(),
        _ => Vector3::z_axis(),
    };
    UnitQuaternion::from_axis_angle(&axis, angle)
}

/// One bearing as the rotor sees it.
#[derive(Clone, Copy, Debug)]
pub(crate) struct BearingGeom {
    pub params: BearingParams,
    /// Journal end centres in the body frame (on the shaft axis, at the end faces), m.
    pub p_i: V3,
    pub p_j: V3,
    /// Mid-plane axial coordinate from `G` along the shaft, m.
    pub axial: f64,
    /// Index of this bearing's lumped oil temperature among the thermal components
    /// (state component `DIM + index`); `None` without a lubricant or with ideal joints.
    pub thermal: Option<usize>,
}

/// Kinematics of one state.
pub(crate) struct Kin {
    pub r: M3,
    pub w_body: V3,
    pub w_global: V3,
    pub g: [f64; 2],
    pub v: [f64; 2],
}

/// End-centre kinematics of one bearing: arms from `G` (global) and velocities.
#[derive(Clone, Copy, Debug, Default)]
pub(crate) struct EndKin {
    pub r_i: V3,
    pub r_j: V3,
    pub v_i: [f64; 2],
    pub v_j: [f64; 2],
}

/// A scene compiled for the right-hand side.
#[derive(Clone, Debug)]
pub struct RotorModel {
    pub(crate) kind: ModelKind,
    pub(crate) mass: f64,
    pub(crate) inertia: M3,
    pub(crate) inertia_inv: M3,
    pub(crate) unbalance: [f64; 2],
    pub(crate) gravity: [f64; 2],
    pub(crate) held: bool,
    pub(crate) bearings: Vec<BearingGeom>,
    pub(crate) threshold: f64,
    /// Penalty contact `(k N/m, c N·s/m)` below the threshold, if the scene asks.
    pub(crate) contact: Option<(f64, f64)>,
    /// Moment of inertia about the shaft axis (ideal joints), kg·m².
    pub(crate) j_axis: f64,
    pub(crate) scales: [f64; DIM],
    /// Natural magnitudes of the components (the stiffness test's unit).
    pub(crate) natural_scales: [f64; DIM],
}

impl RotorModel {
    /// Components of this scene's integrator state: [`DIM`] plus one lumped oil
    /// temperature per thermal bearing.
    pub fn state_dim(&self) -> usize {
        DIM + self.thermal_count()
    }

    /// Bearings carrying a lumped oil temperature state.
    pub fn thermal_count(&self) -> usize {
        self.bearings.iter().filter(|b| b.thermal.is_some()).count()
    }

    /// Compiles a (validated) scene.
    pub fn new(scene: &Scene) -> Self {
        let r = &scene.rotor;
        let rc = (Rotation3::from_axis_angle(&Vector3::x_axis(), r.couple_unbalance[0])
            * Rotation3::from_axis_angle(&Vector3::y_axis(), r.couple_unbalance[1]))
        .into_inner();
        let principal = Vector3::from(r.inertia);
        let inertia = rc * Matrix3::from_diagonal(&principal) * rc.transpose();
        // The inverse of R D Rᵀ in closed form (positive moments: scene validation).
        let inertia_inv = rc * Matrix3::from_diagonal(&principal.map(f64::recip)) * rc.transpose();
        let u = r.static_unbalance;
        let mut n_thermal = 0;
        let bearings: Vec<BearingGeom> = scene
            .bearings
            .iter()
            .map(|b| {
                let params = b.params();
                // A lumped oil temperature for each film bearing with a lubricant.
                let thermal = (scene.model == ModelKind::Bearing
                    && params.lubricant.is_some()
                    && params.supply_temperature.is_some())
                .then(|| {
                    n_thermal += 1;
                    n_thermal - 1
                });
                BearingGeom {
                    params,
                    p_i: Vector3::new(-u[0], -u[1], b.axial_position - 0.5 * b.length),
                    p_j: Vector3::new(-u[0], -u[1], b.axial_position + 0.5 * b.length),
                    axial: b.axial_position,
                    thermal,
                }
            })
            .collect();
        let clearance = bearings
            .iter()
            .map(|b| b.params.clearance)
            .fold(f64::INFINITY, f64::min);
        let spin = scene.initial.spin.abs().max(1.0);
        let ke = 0.5 * r.inertia[2] * spin * spin
            + 0.5 * r.mass * (spin * (u[0].hypot(u[1]) + clearance)).powi(2);
        let mut scales = [1.0; DIM];
        scales[0] = clearance;
        scales[1] = clearance;
        scales[2] = clearance * spin;
        scales[3] = clearance * spin;
        for s in &mut scales[W..W + 3] {
            *s = spin;
        }
        scales[WORK] = ke;
        // The natural magnitudes, before the tilt components are weighted for error
        // control below: the stiffness test of method `auto` measures in these (with the
        // tilt weighted 1400 times more it sees the tilt modes only and missed the stiff
        // translational one of the clearance x viscosity sweep).
        let natural_scales = scales;
        // Error control on what users read (issue 28): the journal centres at the end
        // faces, not only G. A quaternion error δ in its x or y component tilts the shaft
        // by 2δ and moves an end centre at lever arm ℓ (from G) by 2ℓδ; a tilt-rate error
        // moves its velocity by ℓ times it. With the scale clearance / (2ℓ) on those
        // quaternion components and clearance·spin / ℓ on the body's x, y angular
        // velocity (ℓ the largest end lever), the tolerance met on them is met on every
        // end centre as on G (unit 1 and `spin` before, which let tilt errors 10-50x
        // larger than G's through: BENCHMARKS.md "Issue 28").
        let lever = bearings
            .iter()
            .map(|b| b.p_i.norm().max(b.p_j.norm()))
            .fold(0.0, f64::max);
        if lever > 0.0 && lever.is_finite() {
            for s in &mut scales[Q + 1..Q + 3] {
                *s = (clearance / (2.0 * lever)).min(1.0);
            }
            for s in &mut scales[W..W + 2] {
                *s = (clearance * spin / lever).min(spin);
            }
        }
        RotorModel {
            kind: scene.model,
            mass: r.mass,
            inertia,
            inertia_inv,
            unbalance: u,
            gravity: [scene.gravity[0], scene.gravity[1]],
            held: scene.spin == SpinMode::Held,
            bearings,
            threshold: scene.film.threshold,
            contact: scene
                .film
                .contact
                .as_ref()
                .map(|c| (c.stiffness, c.damping)),
            j_axis: inertia[(2, 2)] + r.mass * (u[0] * u[0] + u[1] * u[1]),
            scales,
            natural_scales,
        }
    }

    /// The initial state of `scene` (a rigid rotation about the shaft axis).
    pub fn initial_state(&self, scene: &Scene) -> [f64; DIM] {
        let i = &scene.initial;
        let q =
            axis_rotation(0, i.tilt[0]) * axis_rotation(1, i.tilt[1]) * axis_rotation(2, i.angle);
        let r0 = q.to_rotation_matrix().into_inner();
        let ug = r0 * self.unbalance_body();
        let wg = Vector3::new(0.0, 0.0, i.spin);
        let wb = r0.tr_mul(&wg);
        let vu = wg.cross(&ug);
        let mut y = [0.0; DIM];
        y[0] = i.offset[0] + ug[0];
        y[1] = i.offset[1] + ug[1];
        y[2] = i.velocity[0] + vu[0];
        y[3] = i.velocity[1] + vu[1];
        y[Q..Q + 4].copy_from_slice(&[q.w, q.i, q.j, q.k]);
        y[W..W + 3].copy_from_slice(wb.as_slice());
        y
    }

    /// Minimum film thickness of each bearing in state `y`, m (`δ − max |e|`).
    pub fn initial_film(&self, y: &[f64]) -> Vec<f64> {
        let k = self.kin(y);
        self.bearings
            .iter()
            .map(|b| {
                let e = self.end_kin(&k, b);
                let s = self.bearing_state(&k, &e);
                s.h_min(b.params.clearance)
            })
            .collect()
    }

    // Inlined so that `film_pass` builds it in its slot of `kins` (out of line it was
    // built on the stack and copied by `memcpy`, ~1 % of a rotor run; issue 28,
    // sixteenth pass).
    #[inline(always)]
    pub(crate) fn kin(&self, y: &[f64]) -> Kin {
        let r = quat_matrix(&y[Q..Q + 4]);
        let w_body = Vector3::new(y[W], y[W + 1], y[W + 2]);
        Kin {
            w_global: r * w_body,
            r,
            w_body,
            g: [y[X], y[X + 1]],
            v: [y[VX], y[VX + 1]],
        }
    }

    pub(crate) fn end_kin(&self, k: &Kin, b: &BearingGeom) -> EndKin {
        let r_i = k.r * b.p_i;
        let r_j = k.r * b.p_j;
        let wi = k.w_global.cross(&r_i);
        let wj = k.w_global.cross(&r_j);
        EndKin {
            r_i,
            r_j,
            v_i: [k.v[0] + wi[0], k.v[1] + wi[1]],
            v_j: [k.v[0] + wj[0], k.v[1] + wj[1]],
        }
    }

    /// The film's input: end centres relative to the bore axis (bores coaxial with `z`).
    pub(crate) fn bearing_state(&self, k: &Kin, e: &EndKin) -> BearingState {
        BearingState {
            xi: k.g[0] + e.r_i[0],
            yi: k.g[1] + e.r_i[1],
            xj: k.g[0] + e.r_j[0],
            yj: k.g[1] + e.r_j[1],
            vxi: e.v_i[0],
            vyi: e.v_i[1],
            vxj: e.v_j[0],
            vyj: e.v_j[1],
            omega: k.w_global[2],
        }
    }

    /// Kinetic energy of state `y`, J.
    pub fn kinetic_energy(&self, y: &[f64]) -> f64 {
        let w = Vector3::new(y[W], y[W + 1], y[W + 2]);
        0.5 * self.mass * (y[VX] * y[VX] + y[VX + 1] * y[VX + 1]) + 0.5 * w.dot(&(self.inertia * w))
    }

    /// Rigid-body derivative from the total in-plane force `f` (N, without gravity) and
    /// torque about `G` `tau` (N·m, global), plus the power of those loads `power` (W).
    pub(crate) fn rigid_derivative(
        &self,
        y: &[f64],
        k: &Kin,
        f: [f64; 2],
        tau: V3,
        power: f64,
        dy: &mut [f64],
    ) {
        let m = self.mass;
        dy[X] = y[VX];
        dy[X + 1] = y[VX + 1];
        dy[VX] = f[0] / m + self.gravity[0];
        dy[VX + 1] = f[1] / m + self.gravity[1];
        quat_rate(&y[Q..Q + 4], k.w_body, &mut dy[Q..Q + 4]);
        let w = k.w_body;
        let tau_b = k.r.tr_mul(&tau);
        let gyro = w.cross(&(self.inertia * w));
        let mut wd = self.inertia_inv * (tau_b - gyro);
        let mut p = power + m * (self.gravity[0] * y[VX] + self.gravity[1] * y[VX + 1]);
        if self.held {
            // Drive torque lambda about global z: (R wdot)_z = a . wdot = 0, a = Rᵀ e_z.
            let a: V3 = k.r.row(2).transpose();
            let ia = self.inertia_inv * a;
            let lambda = -a.dot(&wd) / a.dot(&ia);
            wd += lambda * ia;
            p += lambda * k.w_global[2];
        }
        dy[W..W + 3].copy_from_slice(wd.as_slice());
        dy[WORK] = p;
    }

    /// Ideal joints: the shaft axis is the bore axis; the state keeps `ω_body = (0, 0, ω)`
    /// and `G = R u`. Returns the joint loads on the rotor per bearing `(R_x, R_y, M_z,
    /// friction coefficient)` and writes the derivative.
    ///
    /// Joint reactions: the total in-plane force gives `m a_G − m g`; the moments about
    /// body `x, y` give `dH/dt`; for two bearings this is statically determinate, for
    /// more the minimum-norm distribution linear in the axial position is used, and a
    /// single bearing carries the whole force (its moment reaction is not modelled).
    /// The friction torque of each joint is MODEL.md section 5 with `|W| = |R|`; since
    /// `R` depends on the angular acceleration (tangential part of `a_G`), three
    /// fixed-point passes resolve it (the tangential term is ~1e-4 of the centripetal one
    /// in the paper's example, so the iteration converges at once).
    pub(crate) fn ideal_derivative(&self, y: &[f64], dy: &mut [f64], loads: &mut Vec<[f64; 4]>) {
        let r = quat_matrix(&y[Q..Q + 4]);
        let w = y[W + 2];
        let u = r * self.unbalance_body();
        let m = self.mass;
        let n = self.bearings.len() as f64;
        let (sa, saa) = self.bearings.iter().fold((0.0, 0.0), |(s, ss), b| {
            (s + b.axial, ss + b.axial * b.axial)
        });
        let det = n * saa - sa * sa;
        let ig = r * self.inertia * r.transpose();
        let grav_torque = m * (u[0] * self.gravity[1] - u[1] * self.gravity[0]);
        let mut wdot = 0.0;
        let mut mz_total = 0.0;
        for _ in 0..3 {
            loads.clear();
            let a = [-wdot * u[1] - w * w * u[0], wdot * u[0] - w * w * u[1]];
            let t = [m * (a[0] - self.gravity[0]), m * (a[1] - self.gravity[1])];
            let spin = Vector3::new(0.0, 0.0, w);
            let gy = spin.cross(&(ig * spin));
            let iwd = ig * Vector3::new(0.0, 0.0, wdot);
            let dh = [iwd[0] + gy[0], iwd[1] + gy[1]];
            // R_kx = ax + bx a_k with sum R_kx = T_x, sum a_k R_kx = dH_y;
            // R_ky = ay + by a_k with sum R_ky = T_y, sum a_k R_ky = -dH_x.
            let solve = |total: f64, moment: f64| {
                if det.abs() <= 1e-300 || self.bearings.len() == 1 {
                    (total / n, 0.0)
                } else {
                    (
                        (saa * total - sa * moment) / det,
                        (n * moment - sa * total) / det,
                    )
                }
            };
            let (ax, bx) = solve(t[0], dh[1]);
            let (ay, by) = solve(t[1], -dh[0]);
            mz_total = 0.0;
            for b in &self.bearings {
                let rx = ax + bx * b.axial;
                let ry = ay + by * b.axial;
                let fr = friction(&b.params, rx.hypot(ry), w);
                mz_total += fr.mz;
                loads.push([rx, ry, fr.mz, fr.coefficient.unwrap_or(f64::NAN)]);
            }
            wdot = if self.held {
                0.0
            } else {
                (mz_total + grav_torque) / self.j_axis
            };
        }
        let wb = Vector3::new(0.0, 0.0, w);
        dy[X] = y[VX];
        dy[X + 1] = y[VX + 1];
        dy[VX] = -wdot * u[1] - w * w * u[0];
        dy[VX + 1] = wdot * u[0] - w * w * u[1];
        quat_rate(&y[Q..Q + 4], wb, &mut dy[Q..Q + 4]);
        dy[W] = 0.0;
        dy[W + 1] = 0.0;
        dy[W + 2] = wdot;
        let vg = [-w * u[1], w * u[0]];
        let p_grav = m * (self.gravity[0] * vg[0] + self.gravity[1] * vg[1]);
        dy[WORK] = if self.held {
            // The drive cancels friction and the gravity torque.
            p_grav - grav_torque * w
        } else {
            mz_total * w + p_grav
        };
    }

    /// The static unbalance as a body-frame vector (`G` from the shaft axis), m.
    fn unbalance_body(&self) -> V3 {
        Vector3::new(self.unbalance[0], self.unbalance[1], 0.0)
    }

    /// `G`'s position in state `y`: the state's `(x, y)` for the bearing model, `R u` for
    /// ideal joints (exactly on the circle of radius `|u|`).
    pub fn g_position(&self, y: &[f64]) -> [f64; 2] {
        match self.kind {
            ModelKind::Bearing => [y[X], y[X + 1]],
            ModelKind::Ideal => {
                let u = quat_matrix(&y[Q..Q + 4]) * self.unbalance_body();
                [u.x, u.y]
            }
        }
    }
}

/// Penalty contact force at one journal end centre `e` (bearing frame, m) moving at `v`
/// (m/s): radial, toward the bore axis, when the film `δ − |e|` is below `threshold`.
pub(crate) fn contact_force(
    e: [f64; 2],
    v: [f64; 2],
    clearance: f64,
    threshold: f64,
    (k, c): (f64, f64),
) -> [f64; 2] {
    let r = e[0].hypot(e[1]);
    let depth = threshold - (clearance - r);
    if depth <= 0.0 || r == 0.0 {
        return [0.0, 0.0];
    }
    let n = [e[0] / r, e[1] / r];
    let vr = v[0] * n[0] + v[1] * n[1];
    let f = (k * depth + c * vr).max(0.0);
    [-f * n[0], -f * n[1]]
}

/// [`contact_force`] at both end centres of bearing state `st` (their velocities from
/// `e`), added to the end forces `fi`, `fj` (N): the rotor's right-hand side and its
/// linearised Jacobian model (`super::jacobian`) apply the same contact.
pub(crate) fn add_contact_forces(
    st: &BearingState,
    e: &EndKin,
    clearance: f64,
    threshold: f64,
    kc: (f64, f64),
    fi: &mut [f64; 2],
    fj: &mut [f64; 2],
) {
    let ci = contact_force([st.xi, st.yi], e.v_i, clearance, threshold, kc);
    let cj = contact_force([st.xj, st.yj], e.v_j, clearance, threshold, kc);
    for c in 0..2 {
        fi[c] += ci[c];
        fj[c] += cj[c];
    }
}

/// `q̇ = ½ q ⊗ (0, ω_body)`, written as `(w, x, y, z)`.
pub(crate) fn quat_rate(q: &[f64], w: V3, out: &mut [f64]) {
    let rate = Quaternion::new(q[0], q[1], q[2], q[3]) * Quaternion::from_imag(w) * 0.5;
    out.copy_from_slice(&[rate.w, rate.i, rate.j, rate.k]);
}
