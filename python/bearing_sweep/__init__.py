"""bearing-sweep from Python: rigid rotors in hydrodynamic journal bearings, on the same
Rust core as the ``bearing-sweep`` command (linked in with PyO3, not a subprocess).

>>> import bearing_sweep as bs
>>> brg = {"radius": 0.05, "length": 0.03, "clearance": 1e-4, "viscosity": 0.1}
>>> loads = bs.eval(brg, [[0, -3e-5, 0, -3e-5, 0, 0, 0, 0, 300.0]])   # numpy arrays
>>> k = bs.coefficients(brg, speeds=[100, 200, 300], load=[0, -525])    # DataFrame
>>> round(float(k["eccentricity_ratio"].iloc[0]), 3) > 0
True

Functions: :func:`eval`, :func:`coefficients` (``.to_ross()``), :func:`run`,
:func:`merge`, :func:`stability`; :class:`Client` for the HTTP service. Errors raise
:class:`InputError` carrying the JSON path of the bad field. See docs/python.md.
"""

from ._errors import BearingSweepError, InputError, ServiceError
from ._api import (
    LOAD_FIELDS,
    ROSS_COLUMNS,
    STATE_FIELDS,
    CoefficientFrame,
    EvalResult,
    RunResult,
    StabilityResult,
    coefficients,
    eval,
    merge,
    ross_speed_keyword,
    run,
    stability,
    variants_frame,
)
from .client import Client
from . import _core

__version__ = _core.VERSION

__all__ = [
    "BearingSweepError",
    "InputError",
    "ServiceError",
    "LOAD_FIELDS",
    "ROSS_COLUMNS",
    "STATE_FIELDS",
    "CoefficientFrame",
    "EvalResult",
    "RunResult",
    "StabilityResult",
    "Client",
    "coefficients",
    "eval",
    "merge",
    "ross_speed_keyword",
    "run",
    "stability",
    "variants_frame",
]
