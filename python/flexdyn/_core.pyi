"""Type stubs of flexdyn's compiled core (`src/python.rs`). Units are SI; vectors inertial."""

# pdoc evaluates the stubs at runtime, where `Simulation` is used before its definition ends.
from __future__ import annotations  # noqa: PYI044

from typing import Any, TypeAlias

import numpy as np
import numpy.typing as npt

__version__: str

class FlexdynError(Exception):
    """Base class of flexdyn's errors."""

class ModelError(FlexdynError):
    """The model is invalid; the message names the offending item."""

class SolverError(FlexdynError):
    """A step could not be completed; the message says where and why."""

def parse_yaml(text: str) -> str:
    """Parses and validates YAML model text; returns the canonical JSON of the model."""

def parse_json(text: str) -> str:
    """Validates JSON model text (what the builder produces); returns its canonical JSON."""

def expand_json(text: str) -> str:
    """Validates JSON model text; returns the canonical JSON of the model with its patterns
    expanded and every node and beam given in the inertial frame."""

def schema() -> str:
    """The JSON Schema of model files."""

def _panic_for_test() -> None: ...

_Sparse: TypeAlias = tuple[npt.NDArray[np.uintp], npt.NDArray[np.uintp], npt.NDArray[np.float64]]

class Simulation:
    """A compiled model and its integrator; advances in time or solves statics."""

    def __init__(self, model_json: str, scheme: str | None = None) -> None:
        """Builds a simulation from JSON model text; `scheme` ("ep"/"ed") overrides the model's."""
    def advance_to(self, t: float, wall_s: float | None = None) -> None:
        """Advances to time `t` (s, clamped to t_end), returning early after `wall_s` seconds of
        wall time if given; raises SolverError if a step cannot be completed."""
    def solve_static(self) -> None:
        """Solves the load steps to load factor 1 (static analysis)."""
    def linearize(self) -> tuple[int, _Sparse, _Sparse, _Sparse, list[str]]:
        """`(n, (k_indptr, k_indices, k_data), (m_rows, m_cols, m_data), (c_rows, c_cols, c_data), labels)`."""
    def linearize_about(self, run: Simulation) -> tuple[int, _Sparse, _Sparse, _Sparse, list[str]]:
        """As `linearize`, about the current state of `run` (a simulation of the same model)."""
    def gyroscopic(self) -> _Sparse:
        """The gyroscopic matrix `(rows, cols, values)` about the current state (spinning frame)."""
    def flush(self) -> None:
        """Completes samples still waiting for the next step."""
    def take_samples(self) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.float64]]:
        """Samples recorded since the last call: (times[n], values[n, channels])."""
    @property
    def is_static(self) -> bool: ...
    @property
    def load_factor(self) -> float: ...
    @property
    def channel_names(self) -> list[str]: ...
    @property
    def channel_units(self) -> list[str]: ...
    @property
    def t(self) -> float: ...
    @property
    def size(self) -> dict[str, int]: ...
    @property
    def last_dt(self) -> float: ...
    @property
    def t_end(self) -> float: ...
    @property
    def dt(self) -> float: ...
    @property
    def tolerance(self) -> float: ...
    @property
    def step_control(self) -> str: ...
    @property
    def scheme(self) -> str: ...
    @property
    def done(self) -> bool: ...
    @property
    def field_layout(self) -> dict[str, Any] | None: ...
    @property
    def field_estimate(self) -> tuple[int, float, bool]: ...
    @property
    def warnings(self) -> list[str]: ...
    @property
    def energy(self) -> float: ...
    @property
    def stats(self) -> dict[str, Any]: ...
    @property
    def last_residuals(self) -> list[float]: ...
