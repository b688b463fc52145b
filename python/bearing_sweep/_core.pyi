"""Type stubs of the native module ``bearing_sweep._core`` (PyO3). Use the wrappers in
``bearing_sweep`` instead: they take numpy arrays and dicts and return DataFrames."""

from typing import List, Optional, Tuple

EVAL_CHUNK: int
VERSION: str

def columns() -> Tuple[List[str], List[str]]:
    """(state columns, load columns) in packed order."""

def eval_states(
    bearing: str, states: bytes, n: int, backend: str = "auto", accuracy: float = 1e-6
) -> Tuple[str, bytes, List[Tuple[int, str, str]], Optional[Tuple[bytes, bytes]]]:
    """Loads of n states (n*9 little-endian f64) of the bearing (JSON text):
    (header JSON, n*9 f64 loads, faults (index, status, message), finite-film codes and
    error estimates or None)."""

def coefficients(input: str, backend: str = "auto", accuracy: float = 1e-12) -> Tuple[str, List[str]]:
    """`coefficients` on a JSON document: (output JSON, notices)."""

def ross_toml_text(output: str, version: int) -> str:
    """A `coefficients` output (JSON) as ROSS TOML text (version 2 or 3)."""

def run_sweep(
    spec_file: str,
    text: str,
    out: str,
    shard: Optional[Tuple[int, int]] = None,
    backend: str = "auto",
    accuracy: float = 1e-6,
    progress: bool = False,
    full_model: bool = False,
) -> Tuple[List[str], List[str]]:
    """`run` of a sweep spec into `out`: (lines, notices)."""

def merge(out: str, shards: List[str]) -> List[str]:
    """`merge OUT SHARD...`: the lines `merge` prints."""

def stability(
    path: str,
    text: str,
    speeds: List[float] = ...,
    out: Optional[str] = None,
    backend: str = "auto",
    accuracy: float = 1e-12,
) -> Tuple[str, List[str], List[str]]:
    """`stability` of a scene: (output JSON, files written, notices)."""
