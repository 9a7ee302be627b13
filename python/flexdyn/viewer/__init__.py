"""`flexdyn view`: a results file's full-field motion as one self-contained HTML page — a 3-D
animation drawn by plotly.js (inlined: it works offline, nothing is fetched) with a time
slider, play/pause, a deformation scale factor and colouring of the beams by a section load.

Beams are drawn as their reference line and a ribbon along section axis 2 (so twist shows),
bodies as the uniform box of their principal inertias, joints and contact points as markers.
"""

from __future__ import annotations

import base64
import html
import json
from importlib import resources
from pathlib import Path

import numpy as np

from ..fields import Motion, motion
from . import scene

LOAD_UNITS = {"F1": "N", "F2": "N", "F3": "N", "M1": "N*m", "M2": "N*m", "M3": "N*m"}


def _b64(a: np.ndarray) -> str:
    return base64.b64encode(np.ascontiguousarray(a, dtype="<f4").tobytes()).decode("ascii")


def _extent(mo: Motion) -> float:
    x = mo.positions.reshape(-1, 3)
    return float(np.linalg.norm(x.max(axis=0) - x.min(axis=0))) or 1.0


def _ribbon_width(mo: Motion, extent: float, given: float | None) -> float:
    """Given, else 3 % of the model's extent and at most a tenth of its median beam's length
    (a ribbon wider than a typical beam is long would hide it)."""
    if given is not None:
        return float(given)
    lengths = [b["length"] for b in mo.topology["beams"]]
    if not lengths:
        return 0.03 * extent
    return min(0.03 * extent, 0.1 * float(np.median(lengths)))


def _loads(mo: Motion, frames: np.ndarray) -> tuple[dict, dict]:
    """Section-load components per frame and beam point, and each one's colour range
    (symmetric about zero, over the whole run: a colour means the same load in every frame)."""
    loads, ranges = {}, {}
    if mo.section_force.shape[1] == 0:
        return loads, ranges
    both = np.concatenate([mo.section_force, mo.section_moment], axis=2)[frames]
    for k, name in enumerate(scene.COMPONENTS):
        v = both[:, :, k]
        top = float(np.abs(v).max()) or 1.0
        loads[name], ranges[name] = _b64(v), [-top, top]
    return loads, ranges


def scene_data(mo: Motion, *, color=None, scale=1.0, max_frames=400, ribbon_width=None, title=""):
    """The page's data (JSON-ready): frames, node positions and elastic displacements, beams,
    ribbons, loads, bodies, joints, contacts."""
    frames = scene.frame_indices(mo.times, max_frames)
    extent = _extent(mo)
    d = scene.elastic_displacements(mo)
    corners, body_nodes = scene.body_boxes(mo, frames, extent)
    jrel, joint_nodes, joint_labels = scene.joint_points(mo, frames)
    arms, arm_nodes = scene.joint_arms(mo, frames)
    loads, ranges = _loads(mo, frames)
    first, beams = 0, []
    for b in mo.topology["beams"]:
        beams.append({"name": b["name"], "nodes": b["nodes"], "first": first})
        first += len(b["nodes"])
    dim = "load factor" if mo.dim == "load_factor" else "t"
    return {
        "title": title,
        "dim": dim,
        "unit": "" if mo.dim == "load_factor" else "s",
        "times": mo.times[frames].tolist(),
        "nodes": len(mo.nodes),
        "points": first,
        "x": _b64(mo.positions[frames]),
        "d": _b64(d[frames]),
        "beams": beams,
        "e2": _b64(scene.section_axis2(mo, frames)),
        "ribbon": _ribbon_width(mo, extent, ribbon_width),
        "loads": loads,
        "load_range": ranges,
        "load_units": LOAD_UNITS,
        "bodies": {"nodes": body_nodes, "corners": _b64(corners)},
        "joints": {"nodes": joint_nodes, "labels": joint_labels, "rel": _b64(jrel)},
        "arms": {"nodes": arm_nodes, "rel": _b64(arms)},
        "ground": [[*p, label] for p, label in scene.ground_points(mo)],
        "contacts": {
            "labels": [c["name"] for c in mo.topology["contacts"]],
            "x": _b64(mo.contact_position[frames]),
            "d": _b64(scene.contact_displacements(mo, d, frames)),
        },
        "color": color,
        "scale": scale,
    }


def write_html(
    results,
    out: str | Path,
    *,
    color: str | None = None,
    scale: float = 1.0,
    max_frames: int = 400,
    ribbon_width: float | None = None,
    title: str | None = None,
    plotly_js: str = "inline",
) -> Path:
    """Writes the 3-D view of `results` (a dataset or a results file with field output) to
    `out` (.html): `color` a section load to colour the beams by (F1 F2 F3 N, M1 M2 M3 N·m;
    changeable in the page), `scale` the initial deformation scale factor, at most
    `max_frames` frames evenly spread over the run, `ribbon_width` in m (default 3 % of the
    model's extent); `plotly_js="inline"` puts plotly.js in the page (one file that works
    anywhere), `"beside"` writes it once as plotly.min.js next to the page, which loads it
    from there (several pages share it: still offline). Returns the path written."""
    if plotly_js not in ("inline", "beside"):
        raise ValueError(f"plotly_js: `{plotly_js}` is neither `inline` nor `beside`")
    if color is not None and color not in scene.COMPONENTS:
        raise ValueError(f"color: `{color}` is not a section load; use one of {', '.join(scene.COMPONENTS)}")
    if not scale >= 0:
        raise ValueError(f"scale: must be a number ≥ 0 (got {scale})")
    mo = motion(results)
    if color is not None and not mo.topology["beams"]:
        raise ValueError(f"color: the model has no beams to colour by {color}")
    name = title or _model_name(results) or "flexdyn results"
    data = scene_data(
        mo, color=color, scale=scale, max_frames=max_frames, ribbon_width=ribbon_width, title=name
    )
    out = Path(out)
    out.parent.mkdir(parents=True, exist_ok=True)
    if plotly_js == "beside":
        _write_plotly_beside(out.parent)
    out.write_text(_page(data, name, plotly_js), encoding="utf-8")
    return out


def _write_plotly_beside(folder: Path):
    from plotly.offline import get_plotlyjs

    js = folder / "plotly.min.js"
    text = get_plotlyjs()
    if not js.is_file() or js.read_text(encoding="utf-8") != text:
        js.write_text(text, encoding="utf-8")


def _model_name(results) -> str:
    import xarray as xr

    if isinstance(results, xr.Dataset):
        return results.attrs.get("model", "")
    with xr.open_dataset(results) as ds:
        return ds.attrs.get("model", "")


def _page(data: dict, title: str, plotly_js: str = "inline") -> str:
    import re

    from plotly.offline import get_plotlyjs, get_plotlyjs_version

    here = resources.files(__package__)
    template = (here / "page.html").read_text(encoding="utf-8")
    # `<` escaped so that no string in the data can close the script element.
    payload = json.dumps(data, allow_nan=False).replace("<", "\\u003c")
    footer = f"flexdyn view · drawn with plotly.js {get_plotlyjs_version()} (inlined: works offline)"
    parts = {
        "TITLE": html.escape(title),
        "FOOTER": html.escape(footer),
        "DATA": payload,
        "VIEWER": (here / "viewer.js").read_text(encoding="utf-8"),
        "PLOTLY": get_plotlyjs() if plotly_js == "inline" else "",
    }
    # One pass over the template: nothing substituted is searched again.
    if plotly_js == "beside":
        template = template.replace("<script>{{PLOTLY}}</script>", '<script src="plotly.min.js"></script>')
    return re.sub(r"\{\{(\w+)\}\}", lambda m: parts[m.group(1)], template)
