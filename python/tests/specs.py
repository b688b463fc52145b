"""Small specs and scenes for the tests (seconds on 2 cores)."""

from __future__ import annotations

# A stability sweep (linearised films, no time integration): 3 x 2 variants.
STABILITY_SWEEP = {
    "kind": "stability",
    "name": "pytest stability map",
    "base": {
        "name": "loaded-rotor",
        "rotor": {"mass": 3.0, "inertia": [0.03, 0.03, 0.02]},
        "bearings": [
            {"radius": 0.02, "length": 0.015, "clearance": 0.0001, "viscosity": 0.02, "axial_position": 0.12},
            {"radius": 0.02, "length": 0.015, "clearance": 0.0001, "viscosity": 0.02, "axial_position": -0.08},
        ],
        "gravity": [0.0, -9.81, 0.0],
        "spin": "held",
        "initial": {"spin": 500.0},
        "integrator": {"method": "dopri5", "rtol": 1e-6, "atol": 1e-6, "t_end": 0.5, "sample_interval": 5e-4},
    },
    "axes": [
        {"path": "bearings[*].clearance", "values": [0.00008, 0.0001, 0.00015]},
        {"path": "bearings[*].viscosity", "values": [0.01, 0.03]},
    ],
}

# A time-integrated rotor sweep: 2 x 2 variants of a short run.
ROTOR_SWEEP = {
    "name": "pytest rotor sweep",
    "base": {
        "name": "paper-rotor",
        "rotor": {"mass": 1.0, "inertia": [0.01, 0.01, 0.3], "static_unbalance": [0.001, 0.0]},
        "bearings": [
            {"radius": 0.02, "length": 0.02, "clearance": 0.0003, "viscosity": 0.0242, "axial_position": 0.2},
            {"radius": 0.02, "length": 0.02, "clearance": 0.0003, "viscosity": 0.0242, "axial_position": -0.2},
        ],
        "gravity": [0.0, -9.81, 0.0],
        "spin": "held",
        "initial": {"spin": 300.0},
        "integrator": {"method": "dopri5", "rtol": 1e-6, "atol": 1e-8, "t_end": 0.05, "sample_interval": 1e-3},
    },
    "axes": [
        {"path": "bearings[*].clearance", "values": [0.0002, 0.0003]},
        {"path": "bearings[*].viscosity", "values": [0.02, 0.03]},
    ],
}


def symmetric_rotor(model: str = "short", spin: float = 400.0) -> dict:
    """A rigid rotor on two equal bearings at ±0.5 m from G, loaded by gravity: both
    journals stay aligned (no force-tilt coupling), and the bearings' tilt blocks add
    (B²/20)/a² ≈ 2e-5 of the rotor's tilt stiffness, below the 1e-4 of the ROSS checks
    (ROSS cannot hold them)."""
    brg = {"radius": 0.025, "length": 0.01, "clearance": 5e-5, "viscosity": 0.02, "model": model}
    if model == "finite":
        # An explicit 64 x 16 grid: the check is ROSS against `stability` on the same
        # coefficients, not the film's accuracy, and the default accuracy (5e-4, grids
        # up to 1024 x 128 near the wall) makes the threshold scan take many minutes.
        brg["finite"] = {"n_theta": 64, "n_z": 16}
    return {
        "name": f"symmetric-{model}",
        "rotor": {"mass": 10.0, "inertia": [0.8, 0.8, 0.05]},
        "bearings": [dict(brg, axial_position=0.5), dict(brg, axial_position=-0.5)],
        "gravity": [0.0, -9.81, 0.0],
        "spin": "held",
        "initial": {"spin": spin},
        "integrator": {"method": "dopri5", "rtol": 1e-6, "atol": 1e-8, "t_end": 0.1, "sample_interval": 1e-3},
    }
