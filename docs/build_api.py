"""Builds flexdyn's API reference (HTML, with pdoc): `python docs/build_api.py [OUT]`
(default `docs/api/`; open its `index.html`). The test suite builds it too, with warnings as
errors, and checks that every public item has a docstring."""

from __future__ import annotations

import sys
from pathlib import Path

#: The documented modules: the package (its top-level API; pdoc adds the submodules its
#: `__all__` names: animate, campbell, modes, sweep) and each other public module, the
#: compiled core included.
MODULES = [
    "flexdyn",
    "flexdyn.builder",
    "flexdyn.results",
    "flexdyn.accessor",
    "flexdyn.channels",
    "flexdyn.progress",
    "flexdyn.plots",
    "flexdyn.fields",
    "flexdyn.trajectory_modes",
    "flexdyn.overrides",
    "flexdyn.export",
    "flexdyn.storage",
    "flexdyn.cli",
    "flexdyn._core",
]


def build(out: str | Path) -> Path:
    """Writes the reference to folder `out` and returns it."""
    import pdoc
    import pdoc.render

    pdoc.render.configure(docformat="markdown", footer_text="flexdyn API reference")
    out = Path(out)
    pdoc.pdoc(*MODULES, output_directory=out)
    return out


def undocumented() -> list[str]:
    """Public functions, classes, methods and properties without a docstring."""
    import pdoc.doc

    missing = []

    def visit(obj):
        for member in obj.members.values():
            if member.name.startswith("_") or member.taken_from[0] != obj.taken_from[0]:
                continue  # private, or imported from elsewhere (documented there)
            if isinstance(member, (pdoc.doc.Function, pdoc.doc.Class)) and not member.docstring.strip():
                missing.append(member.fullname)
            if isinstance(member, pdoc.doc.Class):
                visit(member)

    for name in [*MODULES, "flexdyn.animate", "flexdyn.campbell", "flexdyn.modes", "flexdyn.sweep"]:
        visit(pdoc.doc.Module.from_name(name))
    return missing


if __name__ == "__main__":
    print(
        f"wrote {build(sys.argv[1] if len(sys.argv) > 1 else Path(__file__).parent / 'api') / 'index.html'}"
    )
