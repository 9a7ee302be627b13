"""flexdyn: flexible multibody dynamics with energy-preserving (EP) and energy-decaying (ED)
time integration (Bauchau & Bottasso 2001).

    import flexdyn as fd
    model = fd.load("examples/pendulum.yaml")          # or fd.Model(...) built in Python
    res = fd.simulate(model, t_end=2.0, scheme="ed", out="pendulum.nc")
    res["pin.phi"].plot()
"""

from importlib import metadata as _metadata

from ._core import FlexdynError, ModelError, SolverError
from ._core import __version__ as _core_version
from ._core import schema as _schema
from .animate import animate
from .builder import Model, drive, load
from .campbell import campbell
from .export import export_vtk
from .fields import motion
from .modes import modes
from .results import Interrupted, open_results, simulate, solve_static
from .storage import OutputError
from .sweep import Sweep, sweep
from .trajectory_modes import frequencies_along
from .viewer import write_html as view

try:
    __version__: str = _metadata.version("flexdyn")
except _metadata.PackageNotFoundError:  # run from a source tree without installing it
    __version__ = _core_version

__all__ = [
    "FlexdynError",
    "Interrupted",
    "Model",
    "ModelError",
    "OutputError",
    "SolverError",
    "Sweep",
    "__version__",
    "animate",
    "campbell",
    "drive",
    "export_vtk",
    "frequencies_along",
    "load",
    "modes",
    "motion",
    "open_results",
    "schema",
    "simulate",
    "solve_static",
    "sweep",
    "view",
]


def schema() -> str:
    """The JSON Schema of flexdyn model files."""
    return _schema()
