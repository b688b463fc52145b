"""Benchmarks of issue 25 (BENCHMARKS.md "Python package and ROSS"):

1. Python call overhead of ``bs.eval`` against the CLI's ``eval`` (1 state and 1e5
   states per call), on the CPU backend at accuracy 1e-6; the loads are bit for bit the
   same both ways (python/tests/test_eval.py).
2. A ROSS analysis (rigid rotor, modal analysis over a speed list) on our coefficients
   (``bs.coefficients(...).to_ross()``) against ROSS's own bearings: ``CylindricalBearing``
   (the short-bearing closed form) and ``BearingFluidFlow`` (its finite-difference
   Reynolds solver) at the grids that reach our finite-film coefficients' accuracy.

    python python/bench/bench_python.py [--quick]

Prints Markdown tables. Timing is the best of several repetitions (time.perf_counter).
"""

from __future__ import annotations

import argparse
import json
import math
import os
import subprocess
import sys
import tempfile
import time
import warnings
from pathlib import Path

import numpy as np

import bearing_sweep as bs

REPO = Path(__file__).resolve().parents[2]
BIN = Path(os.environ.get("BEARING_SWEEP_BIN", Path(os.environ.get("CARGO_TARGET_DIR", REPO / "target")) / "release" / "bearing-sweep"))
BEARING = {"radius": 0.02, "length": 0.02, "clearance": 0.0003, "viscosity": 0.0242}


def states(n: int, seed: int = 0) -> np.ndarray:
    rng = np.random.default_rng(seed)
    c = BEARING["clearance"]
    r = 0.8 * c * np.sqrt(rng.random((n, 2)))
    a = 2 * np.pi * rng.random((n, 2))
    out = np.zeros((n, 9))
    out[:, 0], out[:, 1] = r[:, 0] * np.cos(a[:, 0]), r[:, 0] * np.sin(a[:, 0])
    out[:, 2], out[:, 3] = r[:, 1] * np.cos(a[:, 1]), r[:, 1] * np.sin(a[:, 1])
    out[:, 4:8] = rng.normal(scale=0.01, size=(n, 4))
    out[:, 8] = rng.uniform(50, 1000, n)
    return out


def best(f, reps: int) -> float:
    t = math.inf
    for _ in range(reps):
        t0 = time.perf_counter()
        f()
        t = min(t, time.perf_counter() - t0)
    return t


def overhead(quick: bool) -> None:
    print("### bs.eval against the CLI's eval (CPU backend, accuracy 1e-6)\n")
    print("| states per call | bs.eval (s/call) | of which Python (conversion, s) | CLI `eval FILE` (s/call, process + JSON) | CLI / bs.eval |")
    print("| ---: | ---: | ---: | ---: | ---: |")
    with tempfile.TemporaryDirectory() as d:
        for n in (1, 100_000):
            s = states(n)
            reps = (200 if n == 1 else 3) if not quick else (20 if n == 1 else 1)
            t_py = best(lambda: bs.eval(BEARING, s, backend="cpu"), reps)
            # The Python side alone: the same call's conversions without the core (the
            # packing of states and unpacking of loads), measured on a no-op state count.
            t_conv = best(lambda: (np.ascontiguousarray(s, dtype="<f8").tobytes(), np.frombuffer(np.zeros(n * 9).tobytes(), "<f8").reshape(n, 9)[:, 0].copy()), reps)
            f = Path(d) / f"states-{n}.json"
            f.write_text(json.dumps({"bearing": BEARING, "states": [dict(zip(bs.STATE_FIELDS, map(float, x))) for x in s]}))
            reps_cli = (20 if n == 1 else 3) if not quick else 1
            t_cli = best(lambda: subprocess.run([str(BIN), "eval", str(f), "--backend", "cpu"], stdout=subprocess.DEVNULL, check=True), reps_cli)
            print(f"| {n} | {t_py:.3g} | {t_conv:.2g} | {t_cli:.3g} | {t_cli / t_py:.3g} |")
    print()


def rigid_rotor(rs, bearings, mass=10.0, i_d=0.8, i_p=0.05, a=0.5):
    mat = rs.Material(name="rigid_light", rho=0.01, E=1e17, Poisson=0.3)
    shaft = [rs.ShaftElement(L=a, idl=0.0, odl=0.05, material=mat) for _ in range(2)]
    disk = rs.DiskElement(n=1, m=mass, Id=i_d, Ip=i_p)
    return rs.Rotor(shaft, [disk], bearings)


def ross_times(quick: bool) -> None:
    try:
        import ross as rs
    except ImportError:
        print("(ROSS not installed: no ROSS figures)\n")
        return
    warnings.simplefilter("ignore")
    speeds = list(np.linspace(100.0, 1000.0, 10 if quick else 19))
    brg = {"radius": 0.025, "length": 0.01, "clearance": 5e-5, "viscosity": 0.02}
    weight = 10.0 * 9.81 / 2
    print(f"### ROSS analysis of a rigid rotor on two bearings, {len(speeds)} speeds ({speeds[0]:g}-{speeds[-1]:g} rad/s)\n")
    print("Time to build the bearings (both ends share one set of coefficients) and run ROSS's modal analysis (`run_modal(speed, sparse=False)`, a fresh rotor: ROSS caches it) at every speed; the coefficient difference is the largest relative difference of the force block (over the speeds, relative to the largest entry) from our coefficients of the same film model: the short film for the closed form, our finite film (default grid, 64 x 16) for ROSS's Reynolds solver.\n")
    print("| bearing model | bearings (s) | modal analysis (s) | total (s) | coefficient difference |")
    print("| --- | ---: | ---: | ---: | ---: |")

    def modal(rotor):
        for w in speeds:
            rotor.run_modal(speed=w, num_modes=2 * rotor.ndof, sparse=False)

    def row(name, build, ref):
        t0 = time.perf_counter()
        b = build()
        t_b = time.perf_counter() - t0
        b = _at(rs, b, 0)  # untouched by any Rotor (a Rotor tags its bearings)
        # ROSS caches run_modal per rotor (lru_cache): a fresh rotor for every timing.
        t_m = math.inf
        for _ in range(1 if quick else 2):
            rotor = rigid_rotor(rs, [_at(rs, b, 0), _at(rs, b, 2)])
            t0 = time.perf_counter()
            modal(rotor)
            t_m = min(t_m, time.perf_counter() - t0)
        err = 0.0
        if ref is not None:
            for i, w in enumerate(speeds):
                K = np.asarray(b.K(w))[:2, :2]
                C = np.asarray(b.C(w))[:2, :2]
                Kr = ref.stiffness[i][:2, :2]
                Cr = ref.damping[i][:2, :2]
                err = max(err, np.abs(K - Kr).max() / np.abs(Kr).max(), np.abs(C - Cr).max() / np.abs(Cr).max())
        print(f"| {name} | {t_b:.3g} | {t_m:.3g} | {t_b + t_m:.3g} | {err:.1e} |")
        return b

    short_ref = bs.coefficients(brg, speeds=speeds, load=[0.0, -weight], backend="cpu")
    finite_ref = bs.coefficients(dict(brg, model="finite"), speeds=speeds, load=[0.0, -weight], backend="cpu")
    row("bearing-sweep short film, `bs.coefficients(...).to_ross()`", lambda: bs.coefficients(brg, speeds=speeds, load=[0.0, -weight], backend="cpu").to_ross(n=0), short_ref)
    row("ROSS `CylindricalBearing` (short-bearing closed form)", lambda: rs.CylindricalBearing(n=0, speed=speeds, weight=weight, bearing_length=brg["length"], journal_diameter=2 * brg["radius"], radial_clearance=brg["clearance"], oil_viscosity=brg["viscosity"]), short_ref)
    row("bearing-sweep finite film, `bs.coefficients(...).to_ross()`", lambda: bs.coefficients(dict(brg, model="finite"), speeds=speeds, load=[0.0, -weight], backend="cpu").to_ross(n=0), finite_ref)
    grids = [(8, 16), (16, 32)] if quick else [(8, 16), (16, 32), (32, 64)]
    for nz, nt in grids:
        row(
            f"ROSS `BearingFluidFlow` (finite differences, nz={nz}, ntheta={nt})",
            lambda nz=nz, nt=nt: rs.BearingFluidFlow(0, nz, nt, brg["length"], speeds, 0.0, 0.0, brg["radius"] - brg["clearance"], brg["radius"], brg["viscosity"], 860.0, load=weight),
            finite_ref,
        )
    print()


def _at(rs, b, n):
    """A copy of bearing `b` at node `n`."""
    import copy

    c = copy.deepcopy(b)
    c.n = n
    return c


if __name__ == "__main__":
    ap = argparse.ArgumentParser()
    ap.add_argument("--quick", action="store_true")
    ap.add_argument("--only", choices=["overhead", "ross"])
    a = ap.parse_args()
    print(f"bearing_sweep {bs.__version__}, Python {sys.version.split()[0]}, numpy {np.__version__}\n")
    if a.only in (None, "overhead"):
        overhead(a.quick)
    if a.only in (None, "ross"):
        ross_times(a.quick)
