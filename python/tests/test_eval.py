"""bs.eval against the CLI's `eval`: the same numbers bit for bit (short and finite film,
a state without loads), and input errors that carry the JSON path."""

from __future__ import annotations

import json

import numpy as np
import pytest

import bearing_sweep as bs
from conftest import cli_json, run_cli

BEARING = {"radius": 0.02, "length": 0.02, "clearance": 0.0003, "viscosity": 0.0242}


def random_states(n: int, clearance: float, seed: int) -> np.ndarray:
    """States with end eccentricity ratios up to 0.9, random velocities and spins."""
    rng = np.random.default_rng(seed)
    ends = []
    for _ in range(2):
        r = 0.9 * clearance * np.sqrt(rng.random(n))
        a = rng.random(n) * 2 * np.pi
        ends.append((r * np.cos(a), r * np.sin(a)))
    v = rng.normal(scale=0.02, size=(n, 4))
    omega = rng.uniform(10, 2000, size=n)
    return np.column_stack([ends[0][0], ends[0][1], ends[1][0], ends[1][1], v, omega])


def cli_eval(cli, bearing, states: np.ndarray, *args: str) -> dict:
    doc = {"bearing": bearing, "states": [dict(zip(bs.STATE_FIELDS, map(float, s))) for s in states]}
    return cli_json(cli, "eval", "-", *args, stdin=json.dumps(doc))


def assert_bitwise(name: str, actual: np.ndarray, expected: np.ndarray) -> None:
    a = np.asarray(actual, dtype=np.float64)
    e = np.asarray(expected, dtype=np.float64)
    same = (a.view(np.uint64) == e.view(np.uint64)) | (np.isnan(a) & np.isnan(e))
    if not same.all():
        k = int(np.flatnonzero(~same)[0])
        pytest.fail(f"{name}[{k}]: python {a[k]!r} vs CLI {e[k]!r} (tolerance: bit for bit)")


def column(loads: list, key: str) -> np.ndarray:
    return np.array([np.nan if l.get(key) is None else l[key] for l in loads], dtype=np.float64)


@pytest.mark.parametrize("accuracy", ["1e-6", "1e-12"])
def test_short_film_equals_cli_bit_for_bit(cli, accuracy):
    states = random_states(300, BEARING["clearance"], seed=1)
    # One state through the wall: no loads, the same status both ways.
    states[7, 0] = 2 * BEARING["clearance"]
    out = bs.eval(BEARING, states, backend="cpu", accuracy=float(accuracy))
    ref = cli_eval(cli, BEARING, states, "--backend", "cpu", "--accuracy", accuracy)
    loads = ref["loads"]
    assert len(loads) == len(states)
    for f in bs.LOAD_FIELDS:
        assert_bitwise(f, out[f], column(loads, f))
    assert list(out["status"]) == [l["status"] for l in loads]
    assert out["status"][7] == "through_wall" and np.isnan(out["wx"][7])
    assert out.errors and out.errors[0].startswith("states[7]")
    assert out.info["backend"] == ref["backend"]
    assert out.info["accuracy"] == ref["accuracy"]


def test_finite_film_equals_cli_bit_for_bit(cli):
    bearing = dict(BEARING, model="finite")
    states = random_states(12, bearing["clearance"], seed=2)
    out = bs.eval(bearing, states, backend="cpu")
    ref = cli_eval(cli, bearing, states, "--backend", "cpu")
    loads = ref["loads"]
    for f in bs.LOAD_FIELDS + ("finite_error_estimate",):
        assert_bitwise(f, out[f], column(loads, f))
    assert list(out["film_model"]) == [l["film_model"] for l in loads]


def test_input_forms_agree():
    states = random_states(5, BEARING["clearance"], seed=3)
    a = bs.eval(BEARING, states, backend="cpu")
    as_dicts = [dict(zip(bs.STATE_FIELDS, s)) for s in states]
    b = bs.eval(BEARING, as_dicts, backend="cpu")
    c = bs.eval(BEARING, a.to_frame().assign(**{f: states[:, j] for j, f in enumerate(bs.STATE_FIELDS)}), backend="cpu")
    for f in bs.LOAD_FIELDS:
        assert_bitwise(f, b[f], a[f])
        assert_bitwise(f, c[f], a[f])


def test_errors_carry_the_json_path(cli):
    states = random_states(3, BEARING["clearance"], seed=4)
    bad = dict(BEARING, clearance=-1e-4)
    with pytest.raises(bs.InputError) as e:
        bs.eval(bad, states)
    assert e.value.path == "bearing.clearance", str(e.value)
    # The CLI names the same path for the same document.
    doc = {"bearing": bad, "states": [dict(zip(bs.STATE_FIELDS, map(float, s))) for s in states]}
    r = run_cli(cli, "eval", "-", stdin=json.dumps(doc))
    assert r.returncode != 0 and "bearing.clearance" in r.stderr, r.stderr
    states[1, 8] = np.nan
    with pytest.raises(bs.InputError) as e:
        bs.eval(BEARING, states)
    assert e.value.path == "states[1].omega", str(e.value)
    with pytest.raises(bs.InputError) as e:
        bs.eval(BEARING, [{"xi": 0, "yi": 0, "xj": 0, "yj": 0, "vxi": 0, "vyi": 0, "vxj": 0, "vyj": 0, "omega": 1, "spin": 2}])
    assert e.value.path == "states[0].spin"
    with pytest.raises(bs.InputError) as e:
        bs.eval(dict(BEARING, viscosity=float("inf")), states)
    assert e.value.path == "bearing.viscosity"
    with pytest.raises(bs.InputError) as e:
        bs.eval(dict(BEARING, radius="big"), states[:1])
    assert e.value.path.startswith("bearing.radius"), str(e.value)
    with pytest.raises(bs.InputError) as e:
        bs.eval(BEARING, np.zeros((2, 8)))
    assert e.value.path == "states"
    with pytest.raises(bs.InputError) as e:
        bs.eval(BEARING, states[:1], backend="tpu")
    assert e.value.path == "backend"
    # An InputError is a ValueError, printed as `path: reason`.
    assert isinstance(e.value, ValueError) and str(e.value).startswith("backend: ")
