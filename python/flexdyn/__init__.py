"""flexdyn: flexible multibody dynamics with energy-preserving (EP) and energy-decaying (ED)
time integration (Bauchau & Bottasso 2001).

    import flexdyn as fd
    model = fd.load("examples/pendulum.yaml")          # or fd.Model(...) built in Python
    res = fd.simulate(model, t_end=2.0, scheme="ed", out="pendulum.nc")
    res["pin.phi"].plot()
"""

from ._core import FlexdynError, ModelError, SolverError
from ._core import schema as _schema
from .builder import Model, drive, load
from .modes import modes
from .results import Interrupted, open_results, simulate, solve_static
from .storage import OutputError

__all__ = [
    "FlexdynError",
    "Interrupted",
    "Model",
    "ModelError",
    "OutputError",
    "SolverError",
    "drive",
    "load",
    "modes",
    "open_results",
    "schema",
    "simulate",
    "solve_static",
]


def schema() -> str:
    """The JSON Schema of flexdyn model files."""
    return _schema()
