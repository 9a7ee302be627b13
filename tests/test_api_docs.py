"""The API reference (issue 23): pdoc builds it without a warning, every public function,
class and method has a docstring, and a Model says what it holds."""

import importlib.util
import json
import warnings
from pathlib import Path

from test_sliding import free_collar

import flexdyn as fd

ROOT = Path(__file__).resolve().parents[1]


def build_api():
    spec = importlib.util.spec_from_file_location("build_api", ROOT / "docs" / "build_api.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_the_api_reference_builds_without_warnings(tmp_path):
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        out = build_api().build(tmp_path / "api")
    assert (out / "index.html").is_file()
    builder = (out / "flexdyn" / "builder.html").read_text()
    assert "sliding_clamp" in builder and "kg·m²" in builder
    # The compiled core is documented from its docstrings and stubs.
    assert "linearize" in (out / "flexdyn" / "_core.html").read_text()


def test_every_public_function_class_and_method_has_a_docstring():
    assert build_api().undocumented() == []


def test_the_sensor_method_documents_every_sensor_type():
    defs = json.loads(fd.schema())["$defs"]
    kinds = {v["properties"]["type"]["const"] for v in defs["Sensor"]["oneOf"]}
    assert kinds and all(k in fd.Model.sensor.__doc__ for k in kinds)


def test_a_model_repr_summarizes_it_like_flexdyn_info():
    text = repr(free_collar("ed"))
    assert text.splitlines()[0] == "flexdyn.Model `free collar` (gravity [0.0, 0.0, 0.0] m/s²)"
    assert "beams    1: beam (12×p3)" in text
    assert "joints   1: sliding 1" in text
    assert "sensors  4: E (energy)" in text
    assert "t_end 2.0 s" in text
