"""deploy/slurm-sweep.sh on a real single-node Slurm (Debian's slurm-wlm and munge,
controller and node on this machine, started here by deploy/slurm-local-cluster.sh): an
array job over shards, then the merge as a dependent job, equal to `bearing-sweep run`.
Skips with a notice where Slurm is not installed, unless BEARING_SWEEP_REQUIRE_SLURM."""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import time
from pathlib import Path

import pytest

from conftest import REPO, run_cli, skip_or_fail
from specs import ROTOR_SWEEP, STABILITY_SWEEP
from test_run import deterministic

SHARDS = 3


@pytest.fixture(scope="module")
def slurm(tmp_path_factory):
    missing = [b for b in ("munged", "slurmctld", "slurmd", "sbatch", "squeue", "sinfo") if not (shutil.which(b) or Path("/usr/sbin", b).exists())]
    if missing:
        skip_or_fail("SLURM", f"Slurm is not installed (missing {', '.join(missing)}: apt-get install slurm-wlm munge)")
    if os.geteuid() != 0:
        skip_or_fail("SLURM", "the local Slurm cluster needs root (slurmd runs jobs as their owner)")
    d = tmp_path_factory.mktemp("slurm")
    script = REPO / "deploy" / "slurm-local-cluster.sh"
    r = subprocess.run(["bash", str(script), "start", str(d)], capture_output=True, text=True, timeout=120)
    if r.returncode != 0:
        pytest.fail(f"the local Slurm cluster did not start: {r.stderr}")
    env = dict(os.environ, SLURM_CONF=str(d / "slurm.conf"), PATH=os.environ.get("PATH", "") + ":/usr/sbin")
    yield env
    subprocess.run(["bash", str(script), "stop", str(d)], capture_output=True, timeout=60)


def wait_for(job: str, env: dict, timeout_s: float = 300) -> None:
    start = time.monotonic()
    while time.monotonic() - start < timeout_s:
        q = subprocess.run(["squeue", "-h", "-j", job, "-o", "%i %T"], capture_output=True, text=True, env=env)
        if not q.stdout.strip():
            return
        time.sleep(0.5)
    raise AssertionError(f"job {job} still queued or running after {timeout_s} s")


@pytest.mark.parametrize("spec", [STABILITY_SWEEP, ROTOR_SWEEP], ids=["stability", "rotor"])
def test_array_job_then_merge_equals_run(slurm, cli, tmp_path, spec):
    spec_file = tmp_path / "grid.json"
    spec_file.write_text(json.dumps(spec))
    env = dict(slurm, BEARING_SWEEP_BIN=str(cli), OUT=str(tmp_path / "sweep-out"), SBATCH_EXTRA="--cpus-per-task=1 --mem=200M --time=00:10:00")
    r = subprocess.run(["bash", str(REPO / "deploy" / "slurm-submit.sh"), str(spec_file), str(SHARDS)], capture_output=True, text=True, env=env, cwd=tmp_path, timeout=60)
    assert r.returncode == 0, r.stderr
    array_id, merge_id = r.stdout.split()
    wait_for(array_id, env)
    wait_for(merge_id, env)
    logs = "\n".join(p.read_text() for p in sorted((tmp_path / "sweep-out").glob("slurm-*.log")))
    # Every shard ran as its own array task.
    shards = sorted((tmp_path / "sweep-out" / "grid").glob("shard-*-of-*/result.json"))
    assert [p.parent.name for p in shards] == [f"shard-{k}-of-{SHARDS}" for k in range(SHARDS)], logs
    merged = tmp_path / "sweep-out" / "grid" / "result.json"
    assert merged.exists(), f"no merged result; job logs:\n{logs}"
    # The same spec run in one process.
    r = run_cli(cli, "run", str(spec_file), "--out", str(tmp_path / "whole"), "--backend", "cpu", "--quiet")
    assert r.returncode == 0, r.stderr
    whole = json.loads((tmp_path / "whole" / "grid" / "result.json").read_text())
    got = json.loads(merged.read_text())
    assert len(got["variants"]) == len(whole["variants"]) > SHARDS
    assert deterministic(got) == deterministic(whole)
