"""bs.Client against a real `bearing-sweep serve` on 127.0.0.1 (ephemeral port, token):
submit, wait with progress, the variants DataFrame equal to a local bs.run; errors
carry the status and the JSON path."""

from __future__ import annotations

import copy
import re
import subprocess
import time

import pandas as pd
import pytest

import bearing_sweep as bs
from specs import STABILITY_SWEEP

TOKEN = "pytest-token"


@pytest.fixture(scope="module")
def service(cli, tmp_path_factory):
    d = tmp_path_factory.mktemp("serve")
    log = open(d / "serve.log", "w+")
    p = subprocess.Popen([str(cli), "serve", "--bind", "127.0.0.1:0", "--data", str(d / "data"), "--token", TOKEN], stdout=log, stderr=subprocess.STDOUT)
    url = None
    for _ in range(200):
        m = re.search(r"listening on (http://\S+)", (d / "serve.log").read_text())
        if m:
            url = m.group(1)
            break
        time.sleep(0.05)
    if url is None:
        p.kill()
        pytest.fail(f"serve did not start: {(d / 'serve.log').read_text()}")
    yield url
    p.terminate()
    p.wait(timeout=30)


def test_submit_wait_variants_equal_local_run(service, tmp_path):
    c = bs.Client(service, TOKEN)
    sid = c.submit(STABILITY_SWEEP, backend="cpu")
    seen = []
    info = c.wait(sid, progress=seen.append, poll_s=0.1, timeout_s=300)
    assert info["status"] == "done"
    assert seen and seen[-1]["progress"]["done"] == seen[-1]["progress"]["total"] == 6
    remote = c.variants(sid)
    local = bs.run(STABILITY_SWEEP, out=tmp_path, backend="cpu").variants
    pd.testing.assert_frame_equal(remote.reset_index(drop=True), local.reset_index(drop=True), check_exact=True)
    result = c.result(sid)
    assert len(result["variants"]) == 6


def test_service_errors_carry_status_and_path(service):
    with pytest.raises(bs.ServiceError) as e:
        bs.Client(service, "wrong").submit(STABILITY_SWEEP)
    assert e.value.status == 401 and e.value.path == "Authorization"
    bad = copy.deepcopy(STABILITY_SWEEP)
    bad["axes"][0]["values"] = []
    with pytest.raises(bs.ServiceError) as e:
        bs.Client(service, TOKEN).submit(bad)
    assert e.value.status == 422 and e.value.path.startswith("axes[0]"), str(e.value)
    with pytest.raises(bs.ServiceError) as e:
        bs.Client(service, TOKEN).submit(STABILITY_SWEEP, accuracy=0.0)
    assert e.value.status == 422 and e.value.path == "?accuracy", str(e.value)
    # A ServiceError is an InputError (path, reason).
    assert isinstance(e.value, bs.InputError)
