//! Oil-supply grooves and partial arcs of a bearing (issue 24 item 2; docs/grooves.md):
//! the JSON geometry, its validation, and the held bands the finite film solver imposes.
//!
//! Angles are in degrees in the bearing frame, measured like the finite solver's `θ`:
//! from `+x` toward `+y` (MODEL.md section 1). Gravity in a rotor scene is `−y`, so the
//! bottom of the bore is 270°, the top 90° and the horizontal split line 0° and 180°.
//! The film thickness is smallest at the angle of the journal's displacement.

use std::f64::consts::PI;

use serde::{Deserialize, Deserializer, Serialize, Serializer};

/// Most grooves one bearing may have (the list is a fixed array so that
/// [`crate::bearing::BearingParams`] stays `Copy`).
pub const MAX_GROOVES: usize = 8;
/// Most arcs (lands) one bearing may have.
pub const MAX_ARCS: usize = 8;

/// One axial oil-supply groove (JSON object in a bearing's `"grooves"` list).
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Groove {
    /// Angle of the groove's centre line, degrees, from `+x` toward `+y` in the bearing
    /// frame (gravity `−y` is 270°). Any finite value (taken modulo 360). Required.
    pub angle: f64,
    /// Angular width, degrees, in (0, 180). Required.
    pub width: f64,
    /// Supply pressure, Pa gauge (above the ambient pressure of the film ends and the
    /// cavitated zone), ≥ 0. Default 0 (an ambient-pressure supply).
    #[serde(default)]
    pub supply_pressure: f64,
    /// Axial length, m, in (0, bearing length], centred on the mid-plane. Default: the
    /// full bearing length.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub length: Option<f64>,
}

/// One land (arc) of a partial-arc bearing (JSON object in `"arcs"`); outside every arc
/// there is no film (ambient pressure).
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Arc {
    /// Angle where the arc starts, degrees (same convention as [`Groove::angle`]).
    pub start: f64,
    /// Angular extent from `start` toward `+θ`, degrees, in (0, 360).
    pub extent: f64,
}

/// A list of at most `N` items stored in place (`Copy`), written in JSON as a list.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FixedList<T: Copy + Default, const N: usize> {
    len: u8,
    items: [T; N],
}

impl<T: Copy + Default, const N: usize> Default for FixedList<T, N> {
    fn default() -> Self {
        FixedList {
            len: 0,
            items: [T::default(); N],
        }
    }
}

impl<T: Copy + Default, const N: usize> FixedList<T, N> {
    /// The list of `items`; `None` when there are more than `N`.
    pub fn new(items: &[T]) -> Option<Self> {
        if items.len() > N {
            return None;
        }
        let mut out = Self::default();
        out.items[..items.len()].copy_from_slice(items);
        out.len = items.len() as u8;
        Some(out)
    }

    /// The items.
    pub fn as_slice(&self) -> &[T] {
        &self.items[..self.len as usize]
    }

    /// Whether the list is empty.
    pub fn is_empty(&self) -> bool {
        self.len == 0
    }
}

impl<T: Copy + Default + Serialize, const N: usize> Serialize for FixedList<T, N> {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        self.as_slice().serialize(s)
    }
}

impl<'de, T: Copy + Default + Deserialize<'de>, const N: usize> Deserialize<'de>
    for FixedList<T, N>
{
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        let v: Vec<T> = Vec::deserialize(d)?;
        FixedList::new(&v).ok_or_else(|| {
            serde::de::Error::custom(format!("at most {N} entries, got {}", v.len()))
        })
    }
}

/// A bearing's grooves (JSON list, at most [`MAX_GROOVES`]).
pub type Grooves = FixedList<Groove, MAX_GROOVES>;
/// A bearing's arcs (JSON list, at most [`MAX_ARCS`]; empty: the full 360° land).
pub type Arcs = FixedList<Arc, MAX_ARCS>;

/// JSON paths of groove and arc fields (static, so the error type stays `Copy`-friendly).
macro_rules! paths {
    ($list:literal, $($i:literal),*; $fields:tt) => {
        [$(paths!(@one $list, $i, $fields)),*]
    };
    (@one $list:literal, $i:literal, [$($f:literal),*]) => {
        [$(concat!($list, "[", $i, "].", $f)),*]
    };
}
const GROOVE_PATHS: [[&str; 4]; MAX_GROOVES] =
    paths!("grooves", 0, 1, 2, 3, 4, 5, 6, 7; ["angle", "width", "supply_pressure", "length"]);
const ARC_PATHS: [[&str; 2]; MAX_ARCS] =
    paths!("arcs", 0, 1, 2, 3, 4, 5, 6, 7; ["start", "extent"]);

/// A groove or arc that cannot be used: the JSON path below the bearing, the value, why.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GeometryError {
    /// JSON path below the bearing, e.g. `grooves[1].width`.
    pub field: &'static str,
    /// The offending value.
    pub value: f64,
    /// Why it is rejected.
    pub reason: &'static str,
}

/// Angular interval `[lo, lo + w)` in degrees, `lo` in [0, 360).
fn interval(centre_or_start: f64, width: f64, centred: bool) -> (f64, f64) {
    let lo = if centred {
        centre_or_start - 0.5 * width
    } else {
        centre_or_start
    };
    (lo.rem_euclid(360.0), width)
}

/// Whether two angular intervals (start in [0, 360), width) overlap (touching is allowed).
fn overlaps(a: (f64, f64), b: (f64, f64)) -> bool {
    // Start of b relative to a, in [0, 360).
    let d = (b.0 - a.0).rem_euclid(360.0);
    let e = (a.0 - b.0).rem_euclid(360.0);
    d < a.1 - 1e-9 || e < b.1 - 1e-9
}

/// Checks the grooves and arcs of a bearing of length `length_m`.
pub fn validate(grooves: &Grooves, arcs: &Arcs, length_m: f64) -> Result<(), GeometryError> {
    let err = |field, value, reason| {
        Err(GeometryError {
            field,
            value,
            reason,
        })
    };
    let gs = grooves.as_slice();
    for (k, g) in gs.iter().enumerate() {
        let p = &GROOVE_PATHS[k];
        if !g.angle.is_finite() {
            return err(p[0], g.angle, "must be a finite angle in degrees");
        }
        if !(g.width > 0.0 && g.width < 180.0) {
            return err(p[1], g.width, "must be a width in degrees in (0, 180)");
        }
        if !(g.supply_pressure >= 0.0 && g.supply_pressure.is_finite()) {
            return err(
                p[2],
                g.supply_pressure,
                "must be a finite gauge pressure >= 0 Pa (the film cannot hold a pressure below ambient: Swift-Stieber cavitation)",
            );
        }
        if let Some(l) = g.length {
            if !(l > 0.0 && l <= length_m * (1.0 + 1e-12)) {
                return err(p[3], l, "must be in (0, bearing length] (m)");
            }
        }
        let a = interval(g.angle, g.width, true);
        for h in &gs[..k] {
            if overlaps(a, interval(h.angle, h.width, true)) {
                return err(p[0], g.angle, "this groove overlaps an earlier one");
            }
        }
    }
    let arcs_s = arcs.as_slice();
    let mut total = 0.0;
    for (k, a) in arcs_s.iter().enumerate() {
        let p = &ARC_PATHS[k];
        if !a.start.is_finite() {
            return err(p[0], a.start, "must be a finite angle in degrees");
        }
        if !(a.extent > 0.0 && a.extent < 360.0) {
            return err(p[1], a.extent, "must be an extent in degrees in (0, 360)");
        }
        total += a.extent;
        let iv = interval(a.start, a.extent, false);
        for b in &arcs_s[..k] {
            if overlaps(iv, interval(b.start, b.extent, false)) {
                return err(p[0], a.start, "this arc overlaps an earlier one");
            }
        }
    }
    if total >= 360.0 - 1e-9 && !arcs_s.is_empty() {
        return err(
            ARC_PATHS[arcs_s.len() - 1][1],
            arcs_s[arcs_s.len() - 1].extent,
            "the arcs cover the whole circle: leave `arcs` out for a 360-degree land",
        );
    }
    Ok(())
}

/// Most held bands of one film: every groove and every gap between arcs.
pub const MAX_BANDS: usize = MAX_GROOVES + MAX_ARCS;

/// A region of the film held at a given pressure (a groove, or a gap between arcs): an
/// angular interval (rad) times an axial interval (fraction of the length).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct HeldBand {
    /// Start angle, rad, in [0, 2π).
    pub lo: f64,
    /// Angular width, rad, > 0 (the band is `[lo, lo + width]`, wrapping).
    pub width: f64,
    /// Axial start, fraction of the length `ζ = z/B`.
    pub z_lo: f64,
    /// Axial end, fraction of the length.
    pub z_hi: f64,
    /// Held pressure, Pa gauge (0: ambient).
    pub pressure_pa: f64,
}

impl HeldBand {
    /// Angle `θ` (rad) relative to the band's start, in `[−π, π)` shifted so that the
    /// band is `[0, width]`: `θ − lo` wrapped to `[width/2 − π, width/2 + π)`.
    fn rel(&self, theta: f64) -> f64 {
        let c = 0.5 * self.width;
        (theta - self.lo - c + PI).rem_euclid(2.0 * PI) - PI + c
    }
}

/// The held bands of one film (what the finite solvers need of the grooves and arcs);
/// empty for the plain 360° bearing.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct FilmLayout {
    /// Bands in use.
    pub count: u8,
    /// The bands (`count` first entries).
    pub bands: [HeldBand; MAX_BANDS],
}

/// Node classification on a grid: held value (Pa) or free, and the face factors.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct HeldNodes {
    /// Per node (`n_theta × (n_z + 1)`, row-major in ζ): the held pressure in Pa, or a
    /// negative value where the node is free.
    pub held_pa: Vec<f64>,
    /// Per node: factor on its east face coefficient (between θ_i and θ_{i+1}).
    pub east: Vec<f64>,
    /// Per node: factor on its north face coefficient (between ζ_j and ζ_{j+1}).
    pub north: Vec<f64>,
}

/// Smallest and largest distance, in grid steps, from a free node to a band edge
/// across the face it shares with a held node (nearest-node holding guarantees [½, 3/2]).
const EDGE_MIN: f64 = 0.5;
const EDGE_MAX: f64 = 1.5;

impl FilmLayout {
    /// The layout of a bearing's grooves and arcs (validated beforehand) for length
    /// `length_m`.
    pub fn new(grooves: &Grooves, arcs: &Arcs, length_m: f64) -> FilmLayout {
        let mut out = FilmLayout::default();
        let mut push = |b: HeldBand| {
            out.bands[out.count as usize] = b;
            out.count += 1;
        };
        // Gaps between arcs first (ambient), then grooves (a groove in a gap wins).
        let arcs = arcs.as_slice();
        if !arcs.is_empty() {
            let mut iv: Vec<(f64, f64)> = arcs
                .iter()
                .map(|a| interval(a.start, a.extent, false))
                .collect();
            iv.sort_by(|a, b| a.0.total_cmp(&b.0));
            for k in 0..iv.len() {
                let end = iv[k].0 + iv[k].1;
                let next = if k + 1 < iv.len() {
                    iv[k + 1].0
                } else {
                    iv[0].0 + 360.0
                };
                let gap = next - end;
                if gap > 1e-9 {
                    push(HeldBand {
                        lo: end.rem_euclid(360.0).to_radians(),
                        width: gap.to_radians(),
                        z_lo: 0.0,
                        z_hi: 1.0,
                        pressure_pa: 0.0,
                    });
                }
            }
        }
        for g in grooves.as_slice() {
            let (lo, w) = interval(g.angle, g.width, true);
            let frac = g.length.map_or(1.0, |l| (l / length_m).min(1.0));
            push(HeldBand {
                lo: lo.to_radians(),
                width: w.to_radians(),
                z_lo: 0.5 - 0.5 * frac,
                z_hi: 0.5 + 0.5 * frac,
                pressure_pa: g.supply_pressure,
            });
        }
        out
    }

    /// The bands in use.
    pub fn bands(&self) -> &[HeldBand] {
        &self.bands[..self.count as usize]
    }

    /// Whether the film is the plain 360° land (no band).
    pub fn is_empty(&self) -> bool {
        self.count == 0
    }

    /// Largest held pressure, Pa.
    pub fn max_pressure_pa(&self) -> f64 {
        self.bands()
            .iter()
            .fold(0.0_f64, |m, b| m.max(b.pressure_pa))
    }

    /// Which band (the last that holds it) holds the node at angle `theta` (rad) and
    /// axial fraction `zeta`, on a grid of steps `dt` (rad) and `dz`: a node is held when
    /// it is within half a step of the band (so a band narrower than a step still holds
    /// its nearest nodes, and the free node next to a held one is between ½ and 3/2 steps
    /// from the band's edge).
    fn band_at(&self, theta: f64, zeta: f64, dt: f64, dz: f64) -> Option<usize> {
        let mut hit = None;
        for (n, b) in self.bands().iter().enumerate() {
            let r = b.rel(theta);
            let in_t = r >= -0.5 * dt && r < b.width + 0.5 * dt;
            // Axially: full-length bands cover every interior row.
            let in_z = (b.z_lo <= 0.0 && b.z_hi >= 1.0)
                || (zeta >= b.z_lo - 0.5 * dz && zeta < b.z_hi + 0.5 * dz);
            if in_t && in_z {
                hit = Some(n);
            }
        }
        hit
    }

    /// Held nodes and face factors on an `nt × nz` grid whose node 0 is at angle
    /// `theta0` (rad). Between a free node and a held one, the face coefficient is divided
    /// by the free node's distance to the band's edge in steps (in [½, 3/2]): the held
    /// pressure then acts at the edge itself (Shortley–Weller), which keeps the
    /// discretisation second order when an edge falls between nodes.
    pub fn held_nodes(&self, nt: usize, nz: usize, theta0: f64) -> HeldNodes {
        let n = nt * (nz + 1);
        let mut out = HeldNodes {
            held_pa: vec![-1.0; n],
            east: vec![1.0; n],
            north: vec![1.0; n],
        };
        if self.is_empty() {
            return out;
        }
        let dt = 2.0 * PI / nt as f64;
        let dz = 1.0 / nz as f64;
        let mut band = vec![usize::MAX; n];
        for j in 1..nz {
            let zeta = j as f64 * dz;
            for i in 0..nt {
                let th = theta0 + i as f64 * dt;
                if let Some(b) = self.band_at(th, zeta, dt, dz) {
                    let k = j * nt + i;
                    band[k] = b;
                    out.held_pa[k] = self.bands[b].pressure_pa;
                }
            }
        }
        let clamp = |s: f64| s.clamp(EDGE_MIN, EDGE_MAX);
        for j in 1..nz {
            let zeta = j as f64 * dz;
            for i in 0..nt {
                let k = j * nt + i;
                let ip = j * nt + (i + 1) % nt;
                let th = theta0 + i as f64 * dt;
                // East face: free k, held ip (edge is the band's start), or held k, free
                // ip (edge is the band's end).
                match (band[k] == usize::MAX, band[ip] == usize::MAX) {
                    (true, false) => {
                        let b = &self.bands[band[ip]];
                        let s = -b.rel(th) / dt;
                        out.east[k] = 1.0 / clamp(s);
                    }
                    (false, true) => {
                        let b = &self.bands[band[k]];
                        let s = (b.rel(th + dt) - b.width) / dt;
                        out.east[k] = 1.0 / clamp(s);
                    }
                    _ => {}
                }
                if j + 1 < nz {
                    let kn = k + nt;
                    match (band[k] == usize::MAX, band[kn] == usize::MAX) {
                        (true, false) => {
                            let b = &self.bands[band[kn]];
                            out.north[k] = 1.0 / clamp((b.z_lo - zeta) / dz);
                        }
                        (false, true) => {
                            let b = &self.bands[band[k]];
                            out.north[k] = 1.0 / clamp((zeta + dz - b.z_hi) / dz);
                        }
                        _ => {}
                    }
                }
            }
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn grooves(g: &[Groove]) -> Grooves {
        Grooves::new(g).unwrap()
    }

    #[test]
    fn paths_name_the_field() {
        assert_eq!(GROOVE_PATHS[1][1], "grooves[1].width");
        assert_eq!(ARC_PATHS[7][0], "arcs[7].start");
    }

    #[test]
    fn bad_geometry_is_located() {
        let ok = Groove {
            angle: 0.0,
            width: 20.0,
            supply_pressure: 0.0,
            length: None,
        };
        let cases = [
            (vec![ok, Groove { width: 0.0, ..ok }], "grooves[1].width"),
            (
                vec![
                    ok,
                    Groove {
                        angle: f64::NAN,
                        ..ok
                    },
                ],
                "grooves[1].angle",
            ),
            (
                vec![Groove {
                    supply_pressure: -1.0,
                    ..ok
                }],
                "grooves[0].supply_pressure",
            ),
            (
                vec![Groove {
                    length: Some(1.0),
                    ..ok
                }],
                "grooves[0].length",
            ),
            (vec![ok, Groove { angle: 355.0, ..ok }], "grooves[1].angle"),
        ];
        for (g, path) in cases {
            let e = validate(&grooves(&g), &Arcs::default(), 0.05).unwrap_err();
            assert_eq!(e.field, path, "{e:?}");
        }
        // Touching grooves are fine; the two-axial-groove bearing is.
        validate(
            &grooves(&[
                ok,
                Groove { angle: 20.0, ..ok },
                Groove { angle: 180.0, ..ok },
            ]),
            &Arcs::default(),
            0.05,
        )
        .unwrap();
        let arcs = |a: &[(f64, f64)]| {
            Arcs::new(
                &a.iter()
                    .map(|&(start, extent)| Arc { start, extent })
                    .collect::<Vec<_>>(),
            )
            .unwrap()
        };
        let e = validate(
            &Grooves::default(),
            &arcs(&[(0.0, 200.0), (190.0, 20.0)]),
            0.05,
        )
        .unwrap_err();
        assert_eq!(e.field, "arcs[1].start");
        let e = validate(
            &Grooves::default(),
            &arcs(&[(0.0, 180.0), (180.0, 180.0)]),
            0.05,
        )
        .unwrap_err();
        assert_eq!(e.field, "arcs[1].extent");
        let e = validate(&Grooves::default(), &arcs(&[(0.0, 400.0)]), 0.05).unwrap_err();
        assert_eq!(e.field, "arcs[0].extent");
    }

    #[test]
    fn too_many_grooves_are_refused_by_the_parser() {
        let one = r#"{"angle": 0, "width": 1}"#;
        let list = format!("[{}]", [one; MAX_GROOVES + 1].join(","));
        let e = serde_json::from_str::<Grooves>(&list).unwrap_err();
        assert!(e.to_string().contains("at most 8"), "{e}");
        let list = format!("[{}]", [one; MAX_GROOVES].join(","));
        let g: Grooves = serde_json::from_str(&list).unwrap();
        assert_eq!(g.as_slice().len(), MAX_GROOVES);
        assert_eq!(
            serde_json::to_value(g).unwrap(),
            serde_json::from_str::<serde_json::Value>(
                &list
                    .replace(r#""width": 1}"#, r#""width": 1.0, "supply_pressure": 0.0}"#)
                    .replace(r#""angle": 0"#, r#""angle": 0.0"#)
            )
            .unwrap()
        );
    }

    #[test]
    fn arcs_leave_gaps_held_at_ambient_and_edges_are_scaled() {
        // Two 160° pads with 20° gaps at 0° and 180°: the same held bands as two 20°
        // grooves there.
        let arcs = Arcs::new(&[
            Arc {
                start: 10.0,
                extent: 160.0,
            },
            Arc {
                start: 190.0,
                extent: 160.0,
            },
        ])
        .unwrap();
        let a = FilmLayout::new(&Grooves::default(), &arcs, 0.05);
        let g = FilmLayout::new(
            &grooves(&[
                Groove {
                    angle: 0.0,
                    width: 20.0,
                    supply_pressure: 0.0,
                    length: None,
                },
                Groove {
                    angle: 180.0,
                    width: 20.0,
                    supply_pressure: 0.0,
                    length: None,
                },
            ]),
            &Arcs::default(),
            0.05,
        );
        let (ha, hg) = (a.held_nodes(72, 8, 0.0), g.held_nodes(72, 8, 0.0));
        assert_eq!(ha.held_pa, hg.held_pa);
        for (x, y) in ha.east.iter().zip(&hg.east) {
            assert!((x - y).abs() < 1e-9, "{x} {y}");
        }
        // 72 intervals: 5° steps; the 20° groove at 0° holds θ = −10..10° (5 nodes, the
        // edges exactly on nodes: factor 1 on the faces to the free neighbours).
        let held: Vec<usize> = (0..72).filter(|&i| hg.held_pa[72 + i] >= 0.0).collect();
        assert_eq!(held, vec![0, 1, 2, 34, 35, 36, 37, 38, 70, 71]);
        assert!((hg.east[72 + 69] - 1.0).abs() < 1e-9);
        // 64 intervals (5.625°): node 2 at 11.25° is outside the groove (edge 10°) but
        // within half a step of it, so held; node 3 is free.
        let h = g.held_nodes(64, 8, 0.0);
        let held: Vec<usize> = (0..4).filter(|&i| h.held_pa[64 + i] >= 0.0).collect();
        assert_eq!(held, vec![0, 1, 2]);
        // Free node 3 at 16.875°, edge at 10°: 6.875/5.625 = 1.222 steps.
        let s = 1.0 / h.east[64 + 2];
        assert!((s - 6.875 / 5.625).abs() < 1e-12, "{s}");
    }
}
