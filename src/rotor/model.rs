//! The rigid-rotor equations (MODEL.md section 8): state layout, initial state,
//! kinematics of the journal end centres, and the derivative from the film end-point
//! loads (bearing model) or from the pinned axis (ideal joints).
//!
//! State (12 components): `G = (x, y)` m, `v_G` m/s, attitude quaternion `(w, x, y, z)`
//! (body to global; normalised in every use and projected back to unit length after
//! every accepted step, so it cannot drift), body angular velocity rad/s, and the work
//! done on the rotor by all applied loads, J (a quadrature: `f` does not depend on it).
//! Axial motion is constrained (`z_G = 0`); the axial force is the constraint's.

// Index loops mirror the matrix subscripts.
#![allow(clippy::needless_range_loop)]

use super::scene::{ModelKind, Scene, SpinMode};
use crate::bearing::{friction, BearingParams, BearingState};

/// State dimension.
pub const DIM: usize = 12;
/// Components `f` depends on (all but the work quadrature).
pub const JAC_DIM: usize = 11;
pub(crate) const X: usize = 0;
pub(crate) const VX: usize = 2;
pub(crate) const Q: usize = 4;
pub(crate) const W: usize = 8;
pub(crate) const WORK: usize = 11;

pub(crate) type V3 = [f64; 3];
pub(crate) type M3 = [[f64; 3]; 3];

pub(crate) fn cross(a: V3, b: V3) -> V3 {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

pub(crate) fn dot(a: V3, b: V3) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

pub(crate) fn mv(m: &M3, v: V3) -> V3 {
    [dot(m[0], v), dot(m[1], v), dot(m[2], v)]
}

/// `mᵀ v`.
pub(crate) fn mtv(m: &M3, v: V3) -> V3 {
    [
        m[0][0] * v[0] + m[1][0] * v[1] + m[2][0] * v[2],
        m[0][1] * v[0] + m[1][1] * v[1] + m[2][1] * v[2],
        m[0][2] * v[0] + m[1][2] * v[1] + m[2][2] * v[2],
    ]
}

fn mm(a: &M3, b: &M3) -> M3 {
    let mut r = [[0.0; 3]; 3];
    for i in 0..3 {
        for j in 0..3 {
            r[i][j] = (0..3).map(|k| a[i][k] * b[k][j]).sum();
        }
    }
    r
}

fn transpose(a: &M3) -> M3 {
    let mut r = [[0.0; 3]; 3];
    for i in 0..3 {
        for j in 0..3 {
            r[i][j] = a[j][i];
        }
    }
    r
}

fn inverse(a: &M3) -> M3 {
    let c = |i: usize, j: usize| {
        let (i1, i2) = ((i + 1) % 3, (i + 2) % 3);
        let (j1, j2) = ((j + 1) % 3, (j + 2) % 3);
        a[i1][j1] * a[i2][j2] - a[i1][j2] * a[i2][j1]
    };
    let det = a[0][0] * c(0, 0) + a[0][1] * c(0, 1) + a[0][2] * c(0, 2);
    let mut r = [[0.0; 3]; 3];
    for i in 0..3 {
        for j in 0..3 {
            r[i][j] = c(j, i) / det;
        }
    }
    r
}

fn rot_x(a: f64) -> M3 {
    let (s, c) = a.sin_cos();
    [[1.0, 0.0, 0.0], [0.0, c, -s], [0.0, s, c]]
}

fn rot_y(a: f64) -> M3 {
    let (s, c) = a.sin_cos();
    [[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]]
}

/// Rotation matrix of a quaternion `(w, x, y, z)`, normalised first.
pub(crate) fn quat_matrix(q: &[f64]) -> M3 {
    let n = (q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]).sqrt();
    let (w, x, y, z) = (q[0] / n, q[1] / n, q[2] / n, q[3] / n);
    [
        [
            1.0 - 2.0 * (y * y + z * z),
            2.0 * (x * y - w * z),
            2.0 * (x * z + w * y),
        ],
        [
            2.0 * (x * y + w * z),
            1.0 - 2.0 * (x * x + z * z),
            2.0 * (y * z - w * x),
        ],
        [
            2.0 * (x * z - w * y),
            2.0 * (y * z + w * x),
            1.0 - 2.0 * (x * x + y * y),
        ],
    ]
}

fn quat_mul(a: [f64; 4], b: [f64; 4]) -> [f64; 4] {
    [
        a[0] * b[0] - a[1] * b[1] - a[2] * b[2] - a[3] * b[3],
        a[0] * b[1] + a[1] * b[0] + a[2] * b[3] - a[3] * b[2],
        a[0] * b[2] - a[1] * b[3] + a[2] * b[0] + a[3] * b[1],
        a[0] * b[3] + a[1] * b[2] - a[2] * b[1] + a[3] * b[0],
    ]
}

fn quat_axis(axis: usize, angle: f64) -> [f64; 4] {
    let (s, c) = (0.5 * angle).sin_cos();
    let mut q = [c, 0.0, 0.0, 0.0];
    q[1 + axis] = s;
    q
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
}

impl RotorModel {
    /// Compiles a (validated) scene.
    pub fn new(scene: &Scene) -> Self {
        let r = &scene.rotor;
        let rc = mm(&rot_x(r.couple_unbalance[0]), &rot_y(r.couple_unbalance[1]));
        let diag = [
            [r.inertia[0], 0.0, 0.0],
            [0.0, r.inertia[1], 0.0],
            [0.0, 0.0, r.inertia[2]],
        ];
        let inertia = mm(&mm(&rc, &diag), &transpose(&rc));
        let u = r.static_unbalance;
        let bearings: Vec<BearingGeom> = scene
            .bearings
            .iter()
            .map(|b| BearingGeom {
                params: b.params(),
                p_i: [-u[0], -u[1], b.axial_position - 0.5 * b.length],
                p_j: [-u[0], -u[1], b.axial_position + 0.5 * b.length],
                axial: b.axial_position,
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
        RotorModel {
            kind: scene.model,
            mass: r.mass,
            inertia,
            inertia_inv: inverse(&inertia),
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
            j_axis: inertia[2][2] + r.mass * (u[0] * u[0] + u[1] * u[1]),
            scales,
        }
    }

    /// The initial state of `scene` (a rigid rotation about the shaft axis).
    pub fn initial_state(&self, scene: &Scene) -> [f64; DIM] {
        let i = &scene.initial;
        let q = quat_mul(
            quat_mul(quat_axis(0, i.tilt[0]), quat_axis(1, i.tilt[1])),
            quat_axis(2, i.angle),
        );
        let r0 = quat_matrix(&q);
        let ug = mv(&r0, [self.unbalance[0], self.unbalance[1], 0.0]);
        let wg = [0.0, 0.0, i.spin];
        let wb = mtv(&r0, wg);
        let vu = cross(wg, ug);
        let mut y = [0.0; DIM];
        y[0] = i.offset[0] + ug[0];
        y[1] = i.offset[1] + ug[1];
        y[2] = i.velocity[0] + vu[0];
        y[3] = i.velocity[1] + vu[1];
        y[Q..Q + 4].copy_from_slice(&q);
        y[W..W + 3].copy_from_slice(&wb);
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

    pub(crate) fn kin(&self, y: &[f64]) -> Kin {
        let r = quat_matrix(&y[Q..Q + 4]);
        let w_body = [y[W], y[W + 1], y[W + 2]];
        Kin {
            w_global: mv(&r, w_body),
            r,
            w_body,
            g: [y[X], y[X + 1]],
            v: [y[VX], y[VX + 1]],
        }
    }

    pub(crate) fn end_kin(&self, k: &Kin, b: &BearingGeom) -> EndKin {
        let r_i = mv(&k.r, b.p_i);
        let r_j = mv(&k.r, b.p_j);
        let wi = cross(k.w_global, r_i);
        let wj = cross(k.w_global, r_j);
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
        let w = [y[W], y[W + 1], y[W + 2]];
        0.5 * self.mass * (y[VX] * y[VX] + y[VX + 1] * y[VX + 1])
            + 0.5 * dot(w, mv(&self.inertia, w))
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
        let tau_b = mtv(&k.r, tau);
        let gyro = cross(w, mv(&self.inertia, w));
        let rhs = [tau_b[0] - gyro[0], tau_b[1] - gyro[1], tau_b[2] - gyro[2]];
        let mut wd = mv(&self.inertia_inv, rhs);
        let mut p = power + m * (self.gravity[0] * y[VX] + self.gravity[1] * y[VX + 1]);
        if self.held {
            // Drive torque lambda about global z: (R wdot)_z = a . wdot = 0, a = Rᵀ e_z.
            let a = k.r[2];
            let ia = mv(&self.inertia_inv, a);
            let lambda = -dot(a, wd) / dot(a, ia);
            for c in 0..3 {
                wd[c] += lambda * ia[c];
            }
            p += lambda * k.w_global[2];
        }
        dy[W..W + 3].copy_from_slice(&wd);
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
        let u = mv(&r, [self.unbalance[0], self.unbalance[1], 0.0]);
        let m = self.mass;
        let n = self.bearings.len() as f64;
        let (sa, saa) = self.bearings.iter().fold((0.0, 0.0), |(s, ss), b| {
            (s + b.axial, ss + b.axial * b.axial)
        });
        let det = n * saa - sa * sa;
        let ig = mm(&mm(&r, &self.inertia), &transpose(&r));
        let grav_torque = m * (u[0] * self.gravity[1] - u[1] * self.gravity[0]);
        let mut wdot = 0.0;
        let mut mz_total = 0.0;
        for _ in 0..3 {
            loads.clear();
            let a = [-wdot * u[1] - w * w * u[0], wdot * u[0] - w * w * u[1]];
            let t = [m * (a[0] - self.gravity[0]), m * (a[1] - self.gravity[1])];
            let iw = mv(&ig, [0.0, 0.0, w]);
            let gy = cross([0.0, 0.0, w], iw);
            let iwd = mv(&ig, [0.0, 0.0, wdot]);
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
        let wb = [0.0, 0.0, w];
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

    /// `G`'s position in state `y`: the state's `(x, y)` for the bearing model, `R u` for
    /// ideal joints (exactly on the circle of radius `|u|`).
    pub fn g_position(&self, y: &[f64]) -> [f64; 2] {
        match self.kind {
            ModelKind::Bearing => [y[X], y[X + 1]],
            ModelKind::Ideal => {
                let u = mv(
                    &quat_matrix(&y[Q..Q + 4]),
                    [self.unbalance[0], self.unbalance[1], 0.0],
                );
                [u[0], u[1]]
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

/// `q̇ = ½ q ⊗ (0, ω_body)`.
pub(crate) fn quat_rate(q: &[f64], w: V3, out: &mut [f64]) {
    let (q0, x, y, z) = (q[0], q[1], q[2], q[3]);
    out[0] = -0.5 * (x * w[0] + y * w[1] + z * w[2]);
    out[1] = 0.5 * (q0 * w[0] + y * w[2] - z * w[1]);
    out[2] = 0.5 * (q0 * w[1] + z * w[0] - x * w[2]);
    out[3] = 0.5 * (q0 * w[2] + x * w[1] - y * w[0]);
}
