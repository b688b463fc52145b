"""A client of the bearing-sweep service (``bearing-sweep serve``): submit a sweep, wait
for it with progress, read its result and variants. Standard library only (urllib)."""

from __future__ import annotations

import json
import sys
import time
import urllib.error
import urllib.parse
import urllib.request
from typing import Any, Callable, Mapping, Optional, Union

import pandas as pd

from ._api import _document, _dumps, variants_frame, PathLike
from ._errors import ServiceError

#: Largest page of variant records the service returns.
_PAGE = 10_000


class Client:
    """The service at ``url`` (e.g. ``http://127.0.0.1:8080``), with a bearer ``token``
    when the service requires one (``serve --token``).

    >>> c = Client("http://127.0.0.1:8080", token="s3cret")      # doctest: +SKIP
    >>> sid = c.submit(spec)                                      # doctest: +SKIP
    >>> info = c.wait(sid)            # prints done/total on stderr  # doctest: +SKIP
    >>> df = c.variants(sid)                                      # doctest: +SKIP

    Error answers raise :class:`ServiceError` with the HTTP status and the JSON path the
    service names (``axes[0].values``, ``?accuracy``, ``Authorization``).
    """

    def __init__(self, url: str, token: Optional[str] = None, *, timeout: float = 60.0) -> None:
        self.url = url.rstrip("/")
        self.token = token
        self.timeout = timeout

    # ------------------------------------------------------------------ plumbing

    def _request(self, method: str, path: str, body: Optional[bytes] = None, query: Optional[Mapping[str, Any]] = None) -> bytes:
        url = self.url + path
        if query:
            url += "?" + urllib.parse.urlencode({k: v for k, v in query.items() if v is not None})
        req = urllib.request.Request(url, data=body, method=method)
        if body is not None:
            req.add_header("Content-Type", "application/json")
        if self.token:
            req.add_header("Authorization", f"Bearer {self.token}")
        try:
            with urllib.request.urlopen(req, timeout=self.timeout) as r:
                return r.read()
        except urllib.error.HTTPError as e:
            text = e.read().decode("utf-8", "replace")
            try:
                err = json.loads(text)["error"]
                path, reason = str(err.get("path", "$")), str(err.get("message", text))
            except (ValueError, KeyError, TypeError, AttributeError):
                path, reason = "$", text or str(e)
            raise ServiceError(e.code, path, reason) from None

    def _json(self, method: str, path: str, body: Optional[bytes] = None, query: Optional[Mapping[str, Any]] = None) -> Any:
        return json.loads(self._request(method, path, body, query))

    # ------------------------------------------------------------------ sweeps

    def submit(
        self,
        spec: Union[Mapping[str, Any], PathLike],
        *,
        backend: Optional[str] = None,
        accuracy: Optional[float] = None,
        full_model: Optional[bool] = None,
    ) -> str:
        """Queues a sweep spec (a dict or a JSON file); returns its id."""
        _, text = _document(spec, "sweep.json")
        query = {
            "backend": backend,
            "accuracy": repr(float(accuracy)) if accuracy is not None else None,
            "full_model": ("true" if full_model else "false") if full_model is not None else None,
        }
        return self._json("POST", "/api/sweeps", text.encode(), query)["id"]

    def status(self, sweep_id: str) -> dict:
        """The sweep's record: ``status``, ``progress`` (``done``, ``failed``,
        ``total``, ``eta_s``), timings, ``message``."""
        return self._json("GET", f"/api/sweeps/{urllib.parse.quote(sweep_id)}")

    def wait(
        self,
        sweep_id: str,
        *,
        progress: Union[bool, Callable[[dict], None]] = True,
        poll_s: float = 0.5,
        timeout_s: Optional[float] = None,
    ) -> dict:
        """Polls until the sweep is final (done, failed or cancelled) and returns its
        record. ``progress``: True prints ``done/total`` on stderr, a callable gets each
        record. Raises :class:`ServiceError` if the sweep failed or was cancelled,
        ``TimeoutError`` after ``timeout_s``."""
        start = time.monotonic()
        while True:
            info = self.status(sweep_id)
            p = info.get("progress") or {}
            if callable(progress):
                progress(info)
            elif progress:
                print(f"\r{sweep_id}: {info.get('status')} {p.get('done', 0)}/{p.get('total', '?')} variants", end="", file=sys.stderr, flush=True)
            if info.get("status") in ("done", "failed", "cancelled"):
                if progress is True:
                    print(file=sys.stderr)
                if info["status"] != "done":
                    raise ServiceError(409, "$", f"sweep {sweep_id} is {info['status']}: {info.get('message')}")
                return info
            if timeout_s is not None and time.monotonic() - start > timeout_s:
                raise TimeoutError(f"sweep {sweep_id} not done after {timeout_s} s (status {info.get('status')})")
            time.sleep(poll_s)

    def result(self, sweep_id: str) -> dict:
        """The finished sweep's result document (as ``run``'s ``result.json``)."""
        return self._json("GET", f"/api/sweeps/{urllib.parse.quote(sweep_id)}/result")

    def variant_records(self, sweep_id: str) -> list:
        """Every variant record (paged over ``/variants``)."""
        out: list = []
        while True:
            page = self._json("GET", f"/api/sweeps/{urllib.parse.quote(sweep_id)}/variants", query={"offset": len(out), "limit": _PAGE})
            got = page.get("variants", [])
            out.extend(got)
            if len(got) < _PAGE or len(out) >= page.get("total", 0):
                return out

    def variants(self, sweep_id: str) -> pd.DataFrame:
        """The variants as a DataFrame (as :func:`bearing_sweep.run`'s ``variants``)."""
        return variants_frame(self.variant_records(sweep_id))

    def cancel(self, sweep_id: str) -> dict:
        """Cancels a queued or running sweep."""
        return self._json("POST", f"/api/sweeps/{urllib.parse.quote(sweep_id)}/cancel")

    def delete(self, sweep_id: str) -> None:
        """Deletes a sweep and everything stored for it."""
        self._request("DELETE", f"/api/sweeps/{urllib.parse.quote(sweep_id)}")

    def list(self) -> list:
        """The sweeps the service knows."""
        doc = self._json("GET", "/api/sweeps")
        return doc.get("sweeps", doc) if isinstance(doc, dict) else doc

    # ------------------------------------------------------------- evaluation

    def eval(self, bearing: Mapping[str, Any], states: list, *, backend: Optional[str] = None, accuracy: Optional[float] = None) -> dict:
        """``/api/eval``: film loads of ``states`` (a list of state objects) as a dict
        (the service's JSON answer)."""
        body = _dumps({"bearing": bearing, "states": states}).encode()
        return self._json("POST", "/api/eval", body, {"backend": backend, "accuracy": accuracy})
