"""bs.run and bs.merge against the CLI's `run`: the variants DataFrame equals
result.json, the result equals the CLI's, errors carry the spec's JSON path."""

from __future__ import annotations

import copy
import json
import math

import pandas as pd
import pytest

import bearing_sweep as bs
from conftest import run_cli
from specs import ROTOR_SWEEP, STABILITY_SWEEP


def deterministic(doc: dict) -> dict:
    """A result without its `run` section (timings, machine)."""
    d = copy.deepcopy(doc)
    d.pop("run", None)
    return d


def lookup(record: dict, column: str):
    """The value at a flattened column name (`a.b.c`, keys may hold dots in brackets)."""
    node = record
    parts = []
    buf = ""
    depth = 0
    for ch in column:
        if ch == "[":
            depth += 1
        elif ch == "]":
            depth -= 1
        if ch == "." and depth == 0:
            parts.append(buf)
            buf = ""
        else:
            buf += ch
    parts.append(buf)
    # A key may itself contain dots (axis paths): match greedily against the dict.
    i = 0
    while i < len(parts):
        for j in range(len(parts), i, -1):
            key = ".".join(parts[i:j])
            if isinstance(node, dict) and key in node:
                node = node[key]
                i = j
                break
        else:
            raise KeyError(column)
    return node


def same(a, b) -> bool:
    if isinstance(a, float) and isinstance(b, float) and math.isnan(a) and math.isnan(b):
        return True
    if a is None and isinstance(b, float) and math.isnan(b):
        return True
    return a == b


@pytest.mark.parametrize("spec", [STABILITY_SWEEP, ROTOR_SWEEP], ids=["stability", "rotor"])
def test_variants_frame_equals_result_json_and_the_cli(cli, tmp_path, spec):
    res = bs.run(spec, out=tmp_path / "py", backend="cpu")
    result, variants = res
    on_disk = json.loads(res.path.read_text())
    assert result == on_disk
    assert len(variants) == len(on_disk["variants"]) > 0
    for i, record in enumerate(on_disk["variants"]):
        for col in variants.columns:
            v = variants[col].iloc[i]
            try:
                want = lookup(record, col)
            except KeyError:
                # A column another variant has (e.g. an error field): absent here.
                assert v is None or (isinstance(v, float) and math.isnan(v)), f"row {i} {col}: {v!r}, absent in result.json"
                continue
            assert same(want, v), f"row {i} column {col}: DataFrame {v!r} vs result.json {want!r}"
    # The CLI's run of the same spec gives the same result (its `run` timings aside).
    spec_file = tmp_path / "sweep.json"
    spec_file.write_text(json.dumps(spec))
    r = run_cli(cli, "run", str(spec_file), "--out", str(tmp_path / "cli"), "--backend", "cpu", "--quiet")
    assert r.returncode == 0, r.stderr
    cli_result = json.loads((tmp_path / "cli" / "sweep" / "result.json").read_text())
    assert deterministic(cli_result) == deterministic(result)


def test_shards_merge_to_the_whole_run(tmp_path):
    whole = bs.run(STABILITY_SWEEP, out=tmp_path, backend="cpu")
    parts = [bs.run(STABILITY_SWEEP, out=tmp_path, shard=(k, 3), backend="cpu") for k in range(3)]
    merged = bs.merge(tmp_path / "merged.json", [p.path for p in parts])
    assert deterministic(merged.result) == deterministic(whole.result)
    pd.testing.assert_frame_equal(merged.variants, whole.variants)


def test_spec_errors_carry_the_json_path(tmp_path):
    bad = copy.deepcopy(STABILITY_SWEEP)
    bad["axes"][1]["values"] = []
    with pytest.raises(bs.InputError) as e:
        bs.run(bad, out=tmp_path)
    assert e.value.path.startswith("axes[1]"), str(e.value)
    bad = copy.deepcopy(STABILITY_SWEEP)
    bad["base"]["rotor"]["mass"] = -1.0
    with pytest.raises(bs.InputError) as e:
        bs.run(bad, out=tmp_path)
    assert "rotor.mass" in e.value.path, str(e.value)
    with pytest.raises(bs.InputError) as e:
        bs.run(STABILITY_SWEEP, out=tmp_path, shard=(3, 3))
    assert e.value.path == "shard"
