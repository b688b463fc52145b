"""ROSS round trip: a rigid rotor built in ROSS on bearings from `.to_ross()` and from
the `ross-toml` export gives the threshold speed and the log decrements `stability`
gives (within 1e-4), short and finite film.

The rotor (tests/specs.py `symmetric_rotor`): 10 kg, I_d 0.8 kg·m², I_p 0.05 kg·m², on
two equal bearings at ±0.5 m, gravity along -y. In ROSS: a shaft of two elements, stiff
enough to be rigid here (E = 1e17 Pa: its bending stiffness is ~1e7 times the films')
and light (its mass and inertia, 1e-3 of the rotor's, are taken off the disk at G so the
rigid body is the same), the disk at the middle node, a bearing at each end node. ROSS's
BearingElement holds no tilt blocks; this rotor's journals stay aligned, and the tilt
blocks add (B²/20)/a² = 2e-5 of the rotor's tilt stiffness, so both models agree to that.
Skips with a notice without ROSS unless BEARING_SWEEP_REQUIRE_ROSS is set.
"""

from __future__ import annotations

import math
import time

import numpy as np
import pytest

import bearing_sweep as bs
from conftest import skip_or_fail
from specs import symmetric_rotor

try:
    import ross as rs
except Exception as e:  # pragma: no cover - depends on the environment
    rs = None
    ROSS_ERROR = f"{type(e).__name__}: {e}"

TOL = 1e-4
SHAFT_D = 0.05  # m
SHAFT_RHO = 0.01  # kg/m³ (a light shaft: 2e-5 kg, compensated on the disk)
SHAFT_E = 1e17  # Pa


@pytest.fixture(scope="module")
def ross():
    if rs is None:
        skip_or_fail("ROSS", f"ROSS (ross-rotordynamics) is not importable ({ROSS_ERROR})")
    return rs


def ross_rotor(scene: dict, bearings: list):
    """The scene's rigid rotor in ROSS on `bearings` (one per end node, built by the
    caller at nodes 0 and 2)."""
    mat = rs.Material(name="rigid_light", rho=SHAFT_RHO, E=SHAFT_E, Poisson=0.3)
    a = scene["bearings"][0]["axial_position"]
    shaft = [rs.ShaftElement(L=a, idl=0.0, odl=SHAFT_D, material=mat, shear_effects=True, rotary_inertia=True, gyroscopic=True) for _ in range(2)]
    m_s = SHAFT_RHO * math.pi * SHAFT_D**2 / 4 * 2 * a
    L = 2 * a
    r = SHAFT_D / 2
    rotor = scene["rotor"]
    disk = rs.DiskElement(
        n=1,
        m=rotor["mass"] - m_s,
        Id=rotor["inertia"][0] - m_s * (L**2 / 12 + r**2 / 4),
        Ip=rotor["inertia"][2] - m_s * r**2 / 2,
    )
    return rs.Rotor(shaft, [disk], bearings)


def lateral_modes(rotor, speed: float):
    """(wd, log_dec) of ROSS's whirling modes, least damped first: below the shaft's
    own (huge) frequencies and above the numerical noise of the free axial and torsional
    rigid-body modes (zero eigenvalues that come out at a few rad/s, log dec 0); the
    rotor's whirl modes here are above a third of the speed."""
    modal = rotor.run_modal(speed=speed, num_modes=2 * rotor.ndof, sparse=False)
    wd = np.asarray(modal.wd)
    ld = np.asarray(modal.log_dec)
    keep = (wd > 0.05 * speed) & (wd < 1e5) & np.isfinite(ld)
    order = np.argsort(ld[keep])
    return wd[keep][order], ld[keep][order]


def our_modes(result: dict):
    modes = [m for m in result["scenes"][0]["modes"] if abs(m["frequency_rad_s"]) > 1e-6] if "scenes" in result else [m for m in result["modes"] if abs(m["frequency_rad_s"]) > 1e-6]
    return modes


def ross_threshold(make_rotor, lo: float, hi: float) -> float:
    """The speed where ROSS's least log decrement crosses zero, by bisection to 1e-9."""
    from scipy.optimize import brentq

    return brentq(lambda w: lateral_modes(make_rotor(), w)[1][0], lo, hi, xtol=1e-9 * hi, rtol=1e-12)


def check_log_decs(ours: list, wd: np.ndarray, ld: np.ndarray, where: str) -> None:
    for k, m in enumerate(ours):
        j = int(np.argmin(np.abs(wd - abs(m["frequency_rad_s"]))))
        rel_f = abs(wd[j] - abs(m["frequency_rad_s"])) / abs(m["frequency_rad_s"])
        assert rel_f < TOL, f"{where} mode {k}: ROSS frequency {wd[j]} vs ours {m['frequency_rad_s']} (relative {rel_f:.2e}, tolerance {TOL})"
        d = abs(ld[j] - m["log_dec"])
        assert d < TOL * max(1.0, abs(m["log_dec"])), f"{where} mode {k}: ROSS log dec {ld[j]} vs ours {m['log_dec']} (difference {d:.2e}, tolerance {TOL})"


@pytest.mark.parametrize("model", ["short", "finite"])
def test_ross_rotor_on_our_bearings_matches_stability(ross, tmp_path, model):
    scene = symmetric_rotor(model)
    spin = scene["initial"]["spin"]
    st = bs.stability(scene, backend="cpu")
    w_star = st.threshold_speed
    assert w_star is not None and math.isfinite(w_star), f"no threshold in the scan: {st.scene.get('threshold')}"
    brg = scene["bearings"][0]
    bearing = {k: v for k, v in brg.items() if k != "axial_position"}
    load = [0.0, -scene["rotor"]["mass"] * 9.81 / 2]

    # Log decrements at the scene's speed: one-speed coefficients (constant in ROSS).
    k1 = bs.coefficients(bearing, speed=spin, load=load, backend="cpu")
    rot = ross_rotor(scene, [k1.to_ross(n=0), k1.to_ross(n=2)])
    wd, ld = lateral_modes(rot, spin)
    check_log_decs(our_modes(st), wd, ld, f"{model} film at {spin} rad/s, to_ross()")

    # Threshold: coefficients over a bracket around it; ROSS's least log dec crosses
    # zero where `stability` says.
    speeds = list(w_star * np.array([0.9, 0.95, 1.0, 1.05, 1.1]))
    k5 = bs.coefficients(bearing, speeds=speeds, load=load, backend="cpu")
    w_ross = ross_threshold(lambda: ross_rotor(scene, [k5.to_ross(n=0), k5.to_ross(n=2)]), speeds[0], speeds[-1])
    rel = abs(w_ross - w_star) / w_star
    print(f"{model}: threshold stability {w_star:.6f} rad/s, ROSS on to_ross() {w_ross:.6f} (relative {rel:.1e})")
    assert rel < TOL, f"{model}: ROSS threshold {w_ross} vs stability {w_star} (relative {rel:.2e}, tolerance {TOL})"

    # The same through the TOML file ROSS reads as is (3 speeds: ROSS interpolates
    # them exactly with a quadratic).
    k3 = bs.coefficients(bearing, speeds=list(w_star * np.array([0.97, 1.0, 1.03])), load=load, backend="cpu")
    path = tmp_path / "brg.toml"
    k3.to_ross_toml(path)

    def from_toml():
        b0 = rs.BearingElement.load(str(path))
        b2 = rs.BearingElement.load(str(path))
        b2.n = 2
        return ross_rotor(scene, [b0, b2])

    w_toml = ross_threshold(from_toml, w_star * 0.97, w_star * 1.03)
    rel = abs(w_toml - w_star) / w_star
    print(f"{model}: threshold ROSS on the TOML export {w_toml:.6f} (relative {rel:.1e})")
    assert rel < TOL, f"{model}: ROSS (TOML) threshold {w_toml} vs stability {w_star} (relative {rel:.2e}, tolerance {TOL})"
    # Log decrements at a node speed of the file (no interpolation there).
    st_star = bs.stability(dict(scene, initial={"spin": w_star}), backend="cpu")
    wd, ld = lateral_modes(from_toml(), w_star)
    check_log_decs(our_modes(st_star), wd, ld, f"{model} film at the threshold, TOML")


def test_to_ross_interpolates_the_given_speeds_exactly(ross):
    """ROSS 2.x smooths 4+ speeds with a spline that misses the values; to_ross() makes
    the element pass through them (and between them stays within the spline's error)."""
    bearing = {"radius": 0.05, "length": 0.03, "clearance": 1e-4, "viscosity": 0.1}
    speeds = [100.0, 150.0, 200.0, 300.0, 500.0]
    k = bs.coefficients(bearing, speeds=speeds, load=[0.0, -525.0], backend="cpu")
    brg = k.to_ross()
    for i, w in enumerate(speeds):
        K = np.asarray(brg.K(w))
        C = np.asarray(brg.C(w))
        for (a, b), name in zip([(0, 0), (0, 1), (1, 0), (1, 1)], ["xx", "xy", "yx", "yy"]):
            assert abs(K[a, b] - k[f"k{name}"].iloc[i]) <= 1e-12 * abs(k[f"k{name}"].iloc[i]), f"k{name} at {w}: {K[a, b]} vs {k[f'k{name}'].iloc[i]}"
            assert abs(C[a, b] - k[f"c{name}"].iloc[i]) <= 1e-12 * abs(k[f"c{name}"].iloc[i]), f"c{name} at {w}: {C[a, b]} vs {k[f'c{name}'].iloc[i]}"
    assert bs.ross_speed_keyword() in ("speed", "frequency")
