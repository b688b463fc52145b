"""bs.coefficients against the CLI's `coefficients` (JSON and the ROSS TOML export)."""

from __future__ import annotations

import json

import numpy as np
import pytest

import bearing_sweep as bs
from conftest import cli_json, run_cli

FRISWELL = {"radius": 0.05, "length": 0.03, "clearance": 1e-4, "viscosity": 0.1}
SPEEDS = [100.0, 157.1, 300.0]
LOAD = [0.0, -525.0]


def test_frame_equals_cli_output(cli):
    k = bs.coefficients(FRISWELL, speeds=SPEEDS, load=LOAD, backend="cpu")
    ref = cli_json(cli, "coefficients", "-", "--backend", "cpu", stdin=json.dumps({"bearing": FRISWELL, "speeds": SPEEDS, "load": LOAD}))
    assert list(k["speed"]) == SPEEDS
    for i, p in enumerate(ref["points"]):
        assert np.array_equal(k.stiffness[i], np.array(p["stiffness"])), f"K at speeds[{i}]"
        assert np.array_equal(k.damping[i], np.array(p["damping"])), f"C at speeds[{i}]"
        row = ref["ross"][i]
        for j, c in enumerate(("speed",) + bs.ROSS_COLUMNS):
            assert k[c].iloc[i] == row[j], f"{c}[{i}]: {k[c].iloc[i]} vs CLI {row[j]} (exact)"
        assert k["eccentricity_ratio"].iloc[i] == p["equilibrium"]["eccentricity_ratio"]
        assert k["attitude_angle_rad"].iloc[i] == p["equilibrium"]["attitude_angle_rad"]
        assert [k["load_x"].iloc[i], k["load_y"].iloc[i]] == LOAD
    # A pandas operation keeps the frame's type and its raw output.
    sub = k[k["speed"] > 120]
    assert isinstance(sub, bs.CoefficientFrame) and sub.raw is k.raw


def test_ross_toml_matches_cli_and_holds_everything(cli):
    toml = pytest.importorskip("toml")
    doc = json.dumps({"bearing": FRISWELL, "speeds": SPEEDS, "load": LOAD})
    r = run_cli(cli, "coefficients", "--format", "ross-toml", "--backend", "cpu", "-", stdin=doc)
    assert r.returncode == 0, r.stderr
    assert "tilt blocks" in r.stderr, "the export must say what ROSS cannot hold"
    k = bs.coefficients(FRISWELL, speeds=SPEEDS, load=LOAD, backend="cpu")
    assert k.to_ross_toml(version=2) == r.stdout
    data = toml.loads(r.stdout)
    first = list(data.values())[0]  # what ROSS's Element.load reads
    assert first["frequency"] == SPEEDS
    for c in bs.ROSS_COLUMNS:
        assert first[c] == list(k[c]), c
    meta = first["bearing_sweep"]
    assert meta["load_N"] == [LOAD] * 3
    assert meta["eccentricity_ratio"] == list(k["eccentricity_ratio"])
    assert meta["attitude_angle_deg"] == list(k["attitude_angle_deg"])
    assert meta["bearing"]["radius"] == FRISWELL["radius"]
    assert np.array_equal(np.array(meta["stiffness"]), k.stiffness)
    # ROSS 3 layout: the speeds under `speed`.
    r3 = run_cli(cli, "coefficients", "--format", "ross3-toml", "--backend", "cpu", "-", stdin=doc)
    assert list(toml.loads(r3.stdout).values())[0]["speed"] == SPEEDS


def test_errors_carry_the_json_path():
    with pytest.raises(bs.InputError) as e:
        bs.coefficients(FRISWELL, speeds=[100.0, float("nan")], load=LOAD)
    assert e.value.path == "speeds[1]"
    with pytest.raises(bs.InputError) as e:
        bs.coefficients(FRISWELL, speed=100.0, load=[0.0])
    assert e.value.path == "load"
    with pytest.raises(bs.InputError) as e:
        bs.coefficients(dict(FRISWELL, length=0.0), speed=100.0, load=LOAD)
    assert e.value.path == "bearing.length"
    with pytest.raises(bs.InputError) as e:
        bs.coefficients(FRISWELL, load=LOAD)
    assert e.value.path == "speed"
