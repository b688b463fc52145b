"""Exceptions of bearing_sweep: every input error names the JSON path of the bad field."""

from __future__ import annotations


class BearingSweepError(Exception):
    """Base class of the package's errors."""


class InputError(BearingSweepError, ValueError):
    """Input that cannot be used: ``path`` is the JSON path inside the document (as the
    CLI prints it, e.g. ``bearing.clearance`` or ``states[3].omega``), ``reason`` why."""

    def __init__(self, path: str, reason: str) -> None:
        super().__init__(path, reason)
        self.path = path
        self.reason = reason

    def __str__(self) -> str:
        return f"{self.path}: {self.reason}"


class ServiceError(InputError):
    """An error answer of the service: HTTP ``status``, and the ``path`` and ``reason``
    of its JSON error body (``$`` for the whole request, ``?name`` for a query
    parameter)."""

    def __init__(self, status: int, path: str, reason: str) -> None:
        super().__init__(path, reason)
        self.status = status
        self.args = (status, path, reason)

    def __str__(self) -> str:
        return f"HTTP {self.status}: {self.path}: {self.reason}"
