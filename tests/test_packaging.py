"""What a user sees of the package itself: its version (the Python package's and the compiled
core's must agree, or a stale build is running), `flexdyn --version`, and type information
(`py.typed`, stubs of the compiled module that list exactly what it exports)."""

import ast
import tomllib
from pathlib import Path

import pytest

import flexdyn
from flexdyn import _core
from flexdyn.cli import main

ROOT = Path(__file__).resolve().parent.parent
PACKAGE = Path(flexdyn.__file__).resolve().parent


def test_versions_agree_with_the_project_files():
    pyproject = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]["version"]
    cargo = tomllib.loads((ROOT / "Cargo.toml").read_text())["package"]["version"]
    assert flexdyn.__version__ == pyproject == cargo == _core.__version__


def test_cli_prints_its_version(capsys):
    with pytest.raises(SystemExit) as exit_:
        main(["--version"])
    assert exit_.value.code == 0
    assert capsys.readouterr().out.strip() == f"flexdyn {flexdyn.__version__} (core {_core.__version__})"


def _stub_names(tree: ast.Module | ast.ClassDef) -> set[str]:
    names = set()
    for node in tree.body:
        if isinstance(node, ast.FunctionDef | ast.ClassDef):
            names.add(node.name)
        elif isinstance(node, ast.AnnAssign) and isinstance(node.target, ast.Name):
            names.add(node.target.id)
    return names


def test_package_is_typed_and_the_core_stub_matches_the_compiled_module():
    assert (PACKAGE / "py.typed").is_file()
    tree = ast.parse((PACKAGE / "_core.pyi").read_text())
    stub = _stub_names(tree) - {"_Sparse"}
    exported = {n for n in dir(_core) if not n.startswith("__") or n == "__version__"}
    assert stub == exported, f"stub only: {stub - exported}; module only: {exported - stub}"
    cls = next(n for n in tree.body if isinstance(n, ast.ClassDef) and n.name == "Simulation")
    members = _stub_names(cls) - {"__init__"}
    compiled = {n for n in dir(_core.Simulation) if not n.startswith("__")}
    assert members == compiled, f"stub only: {members - compiled}; module only: {compiled - members}"


def test_the_compiled_module_documents_everything_it_exports():
    undocumented = [
        n for n in ("parse_json", "parse_yaml", "schema", "Simulation") if not getattr(_core, n).__doc__
    ]
    if not (_core.__doc__ or "").strip():
        undocumented.append("_core")
    for name in dir(_core.Simulation):
        member = getattr(_core.Simulation, name)
        if not name.startswith("_") and not (member.__doc__ or "").strip():
            undocumented.append(f"Simulation.{name}")
    assert not undocumented, f"no docstring: {undocumented}"
