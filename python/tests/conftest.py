"""Shared fixtures: the `bearing-sweep` binary the pytest suite compares against, and
scratch folders."""

from __future__ import annotations

import json
import os
import subprocess
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[2]


def binary() -> Path:
    """The CLI built from this repository (BEARING_SWEEP_BIN, else the release build in
    CARGO_TARGET_DIR or target/)."""
    env = os.environ.get("BEARING_SWEEP_BIN")
    if env:
        return Path(env)
    target = Path(os.environ.get("CARGO_TARGET_DIR", REPO / "target"))
    return target / "release" / "bearing-sweep"


@pytest.fixture(scope="session")
def cli() -> Path:
    b = binary()
    if not b.exists():
        pytest.fail(f"{b} missing: build it with `cargo build --release` (or set BEARING_SWEEP_BIN)")
    return b


def run_cli(cli: Path, *args: str, stdin: str | None = None, cwd: Path | None = None) -> subprocess.CompletedProcess:
    return subprocess.run([str(cli), *args], input=stdin, capture_output=True, text=True, cwd=cwd, timeout=600)


def cli_json(cli: Path, *args: str, stdin: str | None = None) -> dict:
    r = run_cli(cli, *args, stdin=stdin)
    assert r.returncode == 0, f"bearing-sweep {' '.join(args)} failed: {r.stderr}"
    return json.loads(r.stdout)


def required(name: str) -> bool:
    """Whether BEARING_SWEEP_REQUIRE_<NAME> turns a missing tool into a failure."""
    return os.environ.get(f"BEARING_SWEEP_REQUIRE_{name}", "") not in ("", "0")


def skip_or_fail(name: str, why: str) -> None:
    if required(name):
        pytest.fail(f"{why} (BEARING_SWEEP_REQUIRE_{name} is set)")
    pytest.skip(f"notice: {why}; skipped (set BEARING_SWEEP_REQUIRE_{name}=1 to fail instead)")
