import numpy as np
import pytest

import flexdyn as fd


def angular_momentum(res, bodies):
    """Total spatial angular momentum about the origin from sensors `<b>_rot` and `<b>_vel`,
    `<b>_pos` for bodies given as {name: (mass, inertia 3x3)} (node at the centre of mass)."""
    h = 0.0
    for name, (m, j) in bodies.items():
        rot = np.stack([res[f"{name}_rot.R{i}{k}"].values for i in (1, 2, 3) for k in (1, 2, 3)], axis=-1)
        rot = rot.reshape(-1, 3, 3)
        w = np.stack([res[f"{name}_vel.w{c}"].values for c in "xyz"], axis=-1)
        v = np.stack([res[f"{name}_vel.v{c}"].values for c in "xyz"], axis=-1)
        x = np.stack([res[f"{name}_pos.{c}"].values for c in "xyz"], axis=-1)
        jw = np.einsum("nij,jk,nlk,nl->ni", rot, np.asarray(j), rot, w)
        h = h + jw + m * np.cross(x, v)
    return h


def track(model: fd.Model, *names):
    for n in names:
        model.sensor("node_rotation", f"{n}_rot", node=n)
        model.sensor("node_velocity", f"{n}_vel", node=n)
        model.sensor("node_position", f"{n}_pos", node=n)
    return model


@pytest.fixture
def tmp_nc(tmp_path):
    return tmp_path / "out.nc"


def example_module(folder: str, name: str = "build"):
    """An example's Python script imported as a module under a name of its own (the
    examples' scripts share the name `build.py`)."""
    import importlib.util
    from pathlib import Path

    path = Path(__file__).resolve().parent.parent / "examples" / folder / f"{name}.py"
    spec = importlib.util.spec_from_file_location(f"example_{folder}_{name}", path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module
