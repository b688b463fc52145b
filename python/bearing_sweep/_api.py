"""The local API: film loads, coefficients, sweeps and stability on the linked Rust core."""

from __future__ import annotations

import inspect
import json
import math
import os
import tempfile
from pathlib import Path
from typing import Any, Iterable, Iterator, Mapping, Optional, Sequence, Tuple, Union

import numpy as np
import pandas as pd

from . import _core
from ._errors import InputError

#: Columns of a journal state, in the order of a state row (SI: m, m/s, rad/s).
STATE_FIELDS: Tuple[str, ...] = tuple(_core.columns()[0])
#: Load arrays returned by :func:`eval` (SI: N, N·m, m, W); NaN where undefined.
LOAD_FIELDS: Tuple[str, ...] = tuple(_core.columns()[1])
#: The ROSS columns of :func:`coefficients` (the x-y force block of K and C).
ROSS_COLUMNS: Tuple[str, ...] = ("kxx", "kxy", "kyx", "kyy", "cxx", "cxy", "cyx", "cyy")

PathLike = Union[str, "os.PathLike[str]"]


# ---------------------------------------------------------------------------- JSON in


def _plain(value: Any, path: str) -> Any:
    """``value`` as plain JSON data (numpy scalars and arrays included), refusing
    non-finite numbers with the JSON path of the first one."""
    if isinstance(value, Mapping):
        out = {}
        for k, v in value.items():
            if not isinstance(k, str):
                raise InputError(path, f"object keys must be strings (got {k!r})")
            out[k] = _plain(v, f"{path}.{k}" if path != "$" else k)
        return out
    if isinstance(value, np.ndarray):
        value = value.tolist()
    if isinstance(value, (list, tuple)):
        return [_plain(v, f"{path}[{i}]") for i, v in enumerate(value)]
    if isinstance(value, (bool, np.bool_)):
        return bool(value)
    if isinstance(value, (int, np.integer)):
        return int(value)
    if isinstance(value, (float, np.floating)):
        x = float(value)
        if not math.isfinite(x):
            raise InputError(path, f"must be a finite number (got {x})")
        return x
    if value is None or isinstance(value, str):
        return value
    if isinstance(value, Path):
        return str(value)
    raise InputError(path, f"cannot be sent as JSON ({type(value).__name__})")


def _dumps(value: Any, path: str = "$") -> str:
    return json.dumps(_plain(value, path))


def _document(doc: Union[Mapping[str, Any], PathLike], default_name: str) -> Tuple[str, str]:
    """(file name, JSON text) of a document given as a dict or a file path."""
    if isinstance(doc, Mapping):
        return default_name, _dumps(doc)
    p = Path(doc)
    try:
        return str(p), p.read_text()
    except OSError as e:
        raise InputError("$", f"{p}: {e.strerror or e}") from None


# --------------------------------------------------------------------------- eval


class EvalResult(dict):
    """Film loads of :func:`eval`: a dict of numpy arrays, one entry per state.

    Keys: ``wx, wy`` (N, film force on the journal), ``mx, my`` (N·m, about the bore
    centre of the face z = 0), ``mz`` (N·m, friction torque), ``friction_coefficient``,
    ``sommerfeld`` (NaN where undefined), ``h_min`` (m), ``power_loss`` (W), ``status``
    (``"ok"`` or the fault code of a state without loads, whose numbers are NaN); for a
    film model other than ``short`` also ``film_model`` (the model used per state) and
    ``finite_error_estimate`` (NaN where none). Attributes: ``info`` (backend, accuracy,
    rule: the header ``eval`` writes), ``notices`` and ``errors`` (messages of the states
    without loads, each naming ``states[k]``).
    """

    info: dict
    notices: list
    errors: list

    def to_frame(self) -> pd.DataFrame:
        """The loads as a DataFrame, one row per state."""
        return pd.DataFrame({k: v for k, v in self.items()})


def _states_array(states: Any) -> np.ndarray:
    """States as an (n, 9) float64 array in STATE_FIELDS order."""
    if isinstance(states, pd.DataFrame) or (
        isinstance(states, Mapping) and all(f in states for f in STATE_FIELDS)
    ):
        missing = [f for f in STATE_FIELDS if f not in states]
        if missing:
            raise InputError("states", f"missing column `{missing[0]}` (needs {', '.join(STATE_FIELDS)})")
        cols = []
        for f in STATE_FIELDS:
            try:
                cols.append(np.asarray(states[f], dtype=np.float64).reshape(-1))
            except (TypeError, ValueError) as e:
                raise InputError(f"states.{f}", f"not numbers: {e}") from None
        if len({len(c) for c in cols}) != 1:
            raise InputError("states", "columns of different lengths")
        return np.ascontiguousarray(np.stack(cols, axis=1))
    if isinstance(states, Mapping):
        states = [states]
    if isinstance(states, (list, tuple)) and states and isinstance(states[0], Mapping):
        arr = np.empty((len(states), 9), dtype=np.float64)
        for k, s in enumerate(states):
            if not isinstance(s, Mapping):
                raise InputError(f"states[{k}]", "expected an object like states[0]")
            for key in s:
                if key not in STATE_FIELDS:
                    raise InputError(f"states[{k}].{key}", f"unknown field (expected {', '.join(STATE_FIELDS)})")
            for j, f in enumerate(STATE_FIELDS):
                if f not in s:
                    raise InputError(f"states[{k}]", f"missing field `{f}`")
                try:
                    arr[k, j] = float(s[f])
                except (TypeError, ValueError):
                    raise InputError(f"states[{k}].{f}", f"expected a number, got {s[f]!r}") from None
        return arr
    try:
        arr = np.asarray(states, dtype=np.float64)
    except (TypeError, ValueError) as e:
        raise InputError("states", f"expected an array of shape (n, 9), a DataFrame or a list of state objects: {e}") from None
    if arr.ndim == 1 and arr.size == 9:
        arr = arr.reshape(1, 9)
    if arr.ndim != 2 or arr.shape[1] != 9:
        raise InputError("states", f"expected shape (n, 9) with columns {', '.join(STATE_FIELDS)}; got {arr.shape}")
    return np.ascontiguousarray(arr)


def eval(  # noqa: A001 - the CLI's command name
    bearing: Mapping[str, Any],
    states: Any,
    *,
    backend: str = "auto",
    accuracy: float = 1e-6,
) -> EvalResult:
    """Film loads of many journal states of one bearing in one batched call, as
    ``bearing-sweep eval`` computes them (same evaluator, bit for bit the same numbers).

    Parameters
    ----------
    bearing : dict
        The bearing object as ``eval`` reads it (``radius``, ``length``, ``clearance``,
        ``viscosity``, ... in SI units).
    states : array (n, 9) | DataFrame | list of dicts | dict
        Journal states: columns ``xi, yi, xj, yj`` (m, the journal centre at the end
        faces), ``vxi, vyi, vxj, vyj`` (m/s) and ``omega`` (rad/s), in that order for an
        array.
    backend : {"auto", "cpu", "gpu"}
        As ``eval --backend`` (``auto``: a hardware GPU for 64 states or more, else the
        CPU).
    accuracy : float
        Relative accuracy of the load vector (as ``eval --accuracy``, default 1e-6).

    Returns
    -------
    EvalResult
        A dict of numpy arrays (``wx``, ``wy``, ... ``status``).

    Raises
    ------
    InputError
        With the JSON path of the bad field (``bearing.clearance``, ``states[3].omega``).
    """
    arr = _states_array(states)
    n = arr.shape[0]
    header, loads, faults, finite = _core.eval_states(
        _dumps(bearing, "bearing"), arr.astype("<f8", copy=False).tobytes(), n, backend, float(accuracy)
    )
    table = np.frombuffer(loads, dtype="<f8").reshape(n, 9)
    out = EvalResult()
    for j, f in enumerate(LOAD_FIELDS):
        out[f] = table[:, j].copy()
    status = np.full(n, "ok", dtype=object)
    errors = []
    for k, code, message in faults:
        status[k] = code
        errors.append(message)
    out["status"] = status
    if finite is not None:
        codes, est = finite
        out["film_model"] = np.where(np.frombuffer(codes, dtype=np.uint8) == 1, "finite", "short").astype(object)
        out["finite_error_estimate"] = np.frombuffer(est, dtype="<f8").copy()
    info = json.loads(header)
    out.notices = info.pop("notices", [])
    out.info = info
    out.errors = errors
    return out


# -------------------------------------------------------------------- coefficients


def _ross_bearing_class():
    try:
        import ross  # noqa: F401
    except ImportError as e:  # pragma: no cover - depends on the environment
        raise ImportError(
            "to_ross() needs ROSS: pip install ross-rotordynamics (on Python < 3.13: "
            "ross-rotordynamics 2.x with 'plotly<6')"
        ) from e
    import ross

    return ross.BearingElement


def ross_speed_keyword(bearing_class: Any = None) -> str:
    """The ``BearingElement`` argument that holds the rotor speeds: ``speed`` in ROSS
    3.x (where ``frequency`` is the whirl frequency), ``frequency`` in ROSS 2.x."""
    cls = bearing_class or _ross_bearing_class()
    return "speed" if "speed" in inspect.signature(cls.__init__).parameters else "frequency"


class CoefficientFrame(pd.DataFrame):
    """Linearised bearing coefficients, one row per speed (a pandas DataFrame).

    Columns: ``speed`` (rad/s), the force block ``kxx, kxy, kyx, kyy`` (N/m) and
    ``cxx, cxy, cyx, cyy`` (N·s/m) in the bearing frame (x, y across the bore, spin from
    +x toward +y; ``K = -dW/dq``), ``load_x, load_y`` (N, the static load on the
    journal), ``eccentricity_ratio``, ``attitude_angle_rad``, ``attitude_angle_deg``,
    ``x, y`` (m, journal centre at the mid-plane), ``h_min`` (m), ``sommerfeld``,
    ``friction_coefficient``, ``power_loss`` (W). The full output of ``coefficients``
    (4×4 K and C with the tilt blocks, error estimates, backend) is in ``.raw``;
    ``.stiffness`` and ``.damping`` give the 4×4 matrices as (n, 4, 4) arrays.
    """

    _metadata = ["raw"]

    @property
    def _constructor(self):
        return CoefficientFrame

    @property
    def points(self) -> list:
        raw = getattr(self, "raw", None) or {}
        return raw.get("points", [raw])

    @property
    def stiffness(self) -> np.ndarray:
        """4×4 stiffness per speed, order (x, y, tilt_x, tilt_y); (n, 4, 4)."""
        return np.array([p["stiffness"] for p in self.points], dtype=np.float64)

    @property
    def damping(self) -> np.ndarray:
        """4×4 damping per speed, order (x, y, tilt_x, tilt_y); (n, 4, 4)."""
        return np.array([p["damping"] for p in self.points], dtype=np.float64)

    def to_ross(self, n: int = 0, *, tag: Optional[str] = None, n_link: Optional[int] = None, **kwargs: Any):
        """A speed-dependent ``ross.BearingElement`` at node ``n``.

        The rotor speeds go to the constructor's rotor-speed argument (``speed`` in ROSS
        3.x, ``frequency`` in ROSS 2.x: see :func:`ross_speed_keyword`). ROSS 2.x fits a
        smoothing spline (``UnivariateSpline`` with ``s`` = number of speeds) through 4 or
        more speeds, which does not pass through the given values; the element returned
        here interpolates them exactly (a cubic spline through the speeds; linear or
        quadratic through 2 or 3). With one speed the coefficients are constant.

        ROSS's BearingElement holds the x-y force block only: the tilt blocks of
        ``.stiffness`` and ``.damping`` (film moments against tilt) are not part of it.
        """
        cls = _ross_bearing_class()
        key = ross_speed_keyword(cls)
        args: dict = dict(n=n, tag=tag, n_link=n_link)
        if len(self) == 1:
            for c in ROSS_COLUMNS:
                args[c] = float(self[c].iloc[0])
        else:
            args[key] = self["speed"].to_numpy(dtype=np.float64)
            for c in ROSS_COLUMNS:
                args[c] = self[c].to_numpy(dtype=np.float64)
        args.update(kwargs)
        brg = cls(**args)
        if key == "frequency" and len(self) > 3:
            _exact_interpolation(brg, self["speed"].to_numpy(dtype=np.float64), {c: self[c].to_numpy(dtype=np.float64) for c in ROSS_COLUMNS})
        return brg

    def to_ross_toml(self, path: Optional[PathLike] = None, *, version: Optional[int] = None) -> str:
        """The TOML text that ``ross.BearingElement.load`` reads (as ``coefficients
        --format ross-toml``, or ``ross3-toml`` with ``version=3``); written to ``path``
        when given. ``version`` defaults to the installed ROSS's major version (2 when
        ROSS is not installed)."""
        if version is None:
            try:
                version = 3 if ross_speed_keyword() == "speed" else 2
            except ImportError:
                version = 2
        text = _core.ross_toml_text(json.dumps(self.raw), int(version))
        if path is not None:
            Path(path).write_text(text)
        return text


def _exact_interpolation(brg: Any, speeds: np.ndarray, values: Mapping[str, np.ndarray]) -> None:
    """Replaces ROSS 2.x's smoothing splines of ``brg`` by interpolating cubic splines."""
    from scipy.interpolate import CubicSpline

    order = np.argsort(speeds)
    for c, v in values.items():
        setattr(brg, f"{c}_interpolated", CubicSpline(speeds[order], v[order], extrapolate=True))


def _frame_from_output(out: dict) -> CoefficientFrame:
    points = out.get("points", [out])
    rows = []
    for p in points:
        eq = p.get("equilibrium", {})
        load = p.get("load") or [math.nan, math.nan]
        k, c = p["stiffness"], p["damping"]
        rows.append(
            {
                "speed": p["speed"],
                "kxx": k[0][0], "kxy": k[0][1], "kyx": k[1][0], "kyy": k[1][1],
                "cxx": c[0][0], "cxy": c[0][1], "cyx": c[1][0], "cyy": c[1][1],
                "load_x": load[0], "load_y": load[1],
                "eccentricity_ratio": eq.get("eccentricity_ratio", math.nan),
                "attitude_angle_rad": eq.get("attitude_angle_rad", math.nan),
                "attitude_angle_deg": eq.get("attitude_angle_deg", math.nan),
                "x": eq.get("x", math.nan), "y": eq.get("y", math.nan),
                "h_min": p["loads"]["h_min"],
                "sommerfeld": p.get("sommerfeld") if p.get("sommerfeld") is not None else math.nan,
                "friction_coefficient": p.get("friction_coefficient") if p.get("friction_coefficient") is not None else math.nan,
                "power_loss": p.get("power_loss", math.nan),
            }
        )
    frame = CoefficientFrame(rows)
    frame.raw = out
    return frame


def coefficients(
    bearing: Mapping[str, Any],
    *,
    speed: Optional[float] = None,
    speeds: Optional[Iterable[float]] = None,
    load: Optional[Sequence[float]] = None,
    state: Optional[Mapping[str, Any]] = None,
    backend: str = "auto",
    accuracy: float = 1e-12,
) -> CoefficientFrame:
    """Linearised 4×4 stiffness and damping of a bearing at its static equilibrium under
    ``load`` (``[W_x, W_y]``, N, the static load on the journal: a weight is
    ``[0, -m g]``) at ``speed`` or each of ``speeds`` (rad/s); or at a given journal
    ``state`` (as :func:`eval` reads one). Same computation as ``bearing-sweep
    coefficients`` (central differences with Richardson extrapolation, accuracy 1e-12).

    Returns a :class:`CoefficientFrame` (a DataFrame, one row per speed) whose
    ``.to_ross()`` gives a speed-dependent ``ross.BearingElement``.

    Raises :class:`InputError` naming the JSON path (``speeds[2]``, ``load[1]``,
    ``bearing.viscosity``).
    """
    doc: dict = {"bearing": bearing}
    if state is not None:
        doc["state"] = state
    if speed is not None:
        doc["speed"] = speed
    if speeds is not None:
        doc["speeds"] = list(speeds)
    if load is not None:
        doc["load"] = list(load)
    text, notices = _core.coefficients(_dumps(doc), backend, float(accuracy))
    out = json.loads(text)
    out["notices"] = notices
    return _frame_from_output(out)


# ----------------------------------------------------------------------------- run


class RunResult:
    """A sweep's outcome: ``result`` (the ``result.json`` document as a dict),
    ``variants`` (one row per variant: ``id``, ``status``, the axis values and the
    reductions, nested fields joined with ``.``), ``path`` (the result file),
    ``lines`` and ``notices`` (what the CLI prints). Unpacks as
    ``result, variants = bs.run(spec)``."""

    def __init__(self, path: Path, lines: list, notices: list) -> None:
        self.path = Path(path)
        self.lines = lines
        self.notices = notices
        self.result = json.loads(self.path.read_text())
        self.variants = variants_frame(self.result.get("variants", []))

    def __iter__(self) -> Iterator[Any]:
        return iter((self.result, self.variants))

    def __repr__(self) -> str:
        return f"RunResult({self.path}, {len(self.variants)} variants)"


def variants_frame(variants: Sequence[Mapping[str, Any]]) -> pd.DataFrame:
    """Variant records (``result.json``'s ``variants``, or the service's) as a
    DataFrame: nested objects flattened with ``.`` in the column names (``params`` keeps
    each axis path as one column, e.g. ``params.bearings[*].clearance``); lists (one
    value per bearing) stay as lists in their cell."""
    rows = []
    for v in variants:
        row: dict = {}
        _flatten(v, "", row)
        rows.append(row)
    return pd.DataFrame(rows)


def _flatten(value: Any, prefix: str, row: dict) -> None:
    if isinstance(value, Mapping) and value:
        for k, v in value.items():
            _flatten(v, f"{prefix}.{k}" if prefix else k, row)
    else:
        row[prefix] = value


def run(
    spec: Union[Mapping[str, Any], PathLike],
    *,
    out: Optional[PathLike] = None,
    shard: Optional[Tuple[int, int]] = None,
    backend: str = "auto",
    accuracy: float = 1e-6,
    progress: bool = False,
    full_model: bool = False,
) -> RunResult:
    """Runs a sweep spec (a dict or a JSON file) as ``bearing-sweep run`` does, in this
    process (resumable: the same ``out`` resumes an interrupted run).

    Results go to ``out/<spec stem>/result.json`` (``sweep`` for a dict; a fresh
    temporary folder when ``out`` is None); ``shard=(k, n)`` runs shard k of n
    (``.../shard-k-of-n/``). Returns a :class:`RunResult` (``result`` dict and
    ``variants`` DataFrame). Raises :class:`InputError` with the spec's JSON path.
    """
    name, text = _document(spec, "sweep.json")
    if out is None:
        out = tempfile.mkdtemp(prefix="bearing-sweep-")
    lines, notices = _core.run_sweep(
        name, text, str(out), tuple(shard) if shard is not None else None, backend, float(accuracy), bool(progress), bool(full_model)
    )
    stem = Path(name).stem or "sweep"
    folder = Path(out) / stem
    if shard is not None:
        folder = folder / f"shard-{shard[0]}-of-{shard[1]}"
    return RunResult(folder / "result.json", lines, notices)


def merge(out: PathLike, shards: Sequence[PathLike]) -> RunResult:
    """Merges shard results (their ``result.json`` files) into ``out`` as
    ``bearing-sweep merge`` does."""
    lines = _core.merge(str(out), [str(s) for s in shards])
    return RunResult(Path(out), lines, [])


# ------------------------------------------------------------------------ stability


class StabilityResult(dict):
    """The ``stability`` output document (a dict) with DataFrame views: ``modes`` (at
    the scene's speed, least damped first), ``campbell`` (one row per speed and mode) and
    ``threshold_speed`` (rad/s, None where the scan found none); ``files`` written,
    ``notices``."""

    files: list
    notices: list

    @property
    def scene(self) -> dict:
        return self["scenes"][0] if "scenes" in self else self

    @property
    def threshold_speed(self) -> Optional[float]:
        return self.scene.get("threshold_speed_rad_s")

    @property
    def modes(self) -> pd.DataFrame:
        rows = []
        for m in self.scene.get("modes", []):
            rows.append({k: v for k, v in m.items() if k not in ("eigenvalue", "shape")})
        return pd.DataFrame(rows)

    @property
    def campbell(self) -> pd.DataFrame:
        rows = []
        for entry in self.scene.get("campbell", []):
            for k, m in enumerate(entry.get("modes", [])):
                rows.append({"speed_rad_s": entry["speed_rad_s"], "mode": k, **m})
        return pd.DataFrame(rows)


def stability(
    scene: Union[Mapping[str, Any], PathLike],
    *,
    speeds: Optional[Iterable[float]] = None,
    out: Optional[PathLike] = None,
    backend: str = "auto",
    accuracy: float = 1e-12,
) -> StabilityResult:
    """Linear stability of a scene (a dict or a scene file, as ``bearing-sweep
    stability`` reads it): modes at the scene's speed, the threshold speed of oil whirl
    and a Campbell scan over ``speeds`` (rad/s; default 41 speeds from 0.1× to 10× the
    scene's spin). Figures are written under ``out/<stem>/`` when ``out`` is given.
    Raises :class:`InputError` with the scene's JSON path."""
    name, text = _document(scene, "scene.json")
    sp = [float(w) for w in speeds] if speeds is not None else []
    doc, files, notices = _core.stability(name, text, sp, str(out) if out is not None else None, backend, float(accuracy))
    res = StabilityResult(json.loads(doc))
    res.files = files
    res.notices = notices
    return res
