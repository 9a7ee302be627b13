"""`flexdyn export --vtk`: a results file's full-field motion as a VTU time series (one
unstructured grid per output time, written by meshio) and a PVD collection that ParaView
opens as one animated dataset.

Each grid's points are the model's nodes and then the sliding joints' contact points; its
cells are the beams' segments between consecutive nodes (`line`) and one `vertex` per node
not on a beam and per contact point. Point data: `displacement` (m, from t = 0),
`section_axis_1/2/3` (the section triad on beam nodes, the node triad elsewhere),
`section_force` (N) and `section_moment` (N·m) in the section triad (zero off beams),
`orientation` (quaternion w x y z), `contact_eta` (contact points; NaN elsewhere). Cell data:
`item` (the beam's index, or −1). Field data: the sensors' channels at that time.
"""

from __future__ import annotations

from pathlib import Path
from xml.sax.saxutils import quoteattr

import numpy as np
import xarray as xr

from .fields import Motion, _multiply, frames, is_field_variable, motion


def _section_quaternions(mo: Motion) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Per node and time: the section triad's quaternion (the node's own off beams), and the
    section force and moment (zero off beams). A node on two beams takes the first."""
    q = mo.orientations.copy()
    force = np.zeros(mo.positions.shape)
    moment = np.zeros(mo.positions.shape)
    seen = set()
    for b in mo.topology["beams"]:
        idx = np.array(b["nodes"])
        sl = mo.beam_points[b["name"]]
        fresh = np.array([n not in seen for n in idx])
        sec = _multiply(mo.orientations[:, idx], np.array(b["section_offsets"])[None])
        q[:, idx[fresh]] = sec[:, fresh]
        force[:, idx[fresh]] = mo.section_force[:, sl][:, fresh]
        moment[:, idx[fresh]] = mo.section_moment[:, sl][:, fresh]
        seen.update(int(n) for n in idx)
    return q, force, moment


def _cells(mo: Motion):
    """meshio cell blocks and their `item` cell data."""
    lines, items, on_beam = [], [], set()
    for k, b in enumerate(mo.topology["beams"]):
        n = b["nodes"]
        lines += [[n[a], n[a + 1]] for a in range(len(n) - 1)]
        items += [k] * (len(n) - 1)
        on_beam.update(n)
    n_nodes, n_contacts = len(mo.nodes), mo.contact_position.shape[1]
    vertices = [[i] for i in range(n_nodes) if i not in on_beam]
    vertices += [[n_nodes + c] for c in range(n_contacts)]
    cells, data = [], []
    if lines:
        cells.append(("line", np.array(lines, dtype=np.int64)))
        data.append(np.array(items, dtype=np.int32))
    if vertices:
        cells.append(("vertex", np.array(vertices, dtype=np.int64)))
        data.append(np.full(len(vertices), -1, dtype=np.int32))
    return cells, {"item": data}


def export_vtk(results, folder: str | Path, *, name: str | None = None) -> Path:
    """Writes `folder/<name>_<k>.vtu` for every output time and `folder/<name>.pvd` listing
    them with their times (load factors for static results); `name` defaults to the results
    file's stem (or `results`). Returns the PVD file's path."""
    import meshio

    ds = results if isinstance(results, xr.Dataset) else xr.open_dataset(results)
    try:
        mo = motion(ds)
        channels = {n: ds[n].values for n in ds.data_vars if not is_field_variable(n) and ds[n].ndim == 1}
    finally:
        if ds is not results:
            ds.close()
    name = name or (Path(results).stem if not isinstance(results, xr.Dataset) else "results")
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    q, force, moment = _section_quaternions(mo)
    axes = frames(q)
    cells, cell_data = _cells(mo)
    n_contacts = mo.contact_position.shape[1]
    pad = lambda a: np.concatenate([a, np.zeros((n_contacts,) + a.shape[1:])])
    entries = []
    for k, t in enumerate(mo.times):
        points = np.concatenate([mo.positions[k], mo.contact_position[k]])
        eta = np.concatenate([np.full(len(mo.nodes), np.nan), mo.contact_eta[k]])
        point_data = {
            "displacement": pad(mo.positions[k] - mo.positions[0]),
            "orientation": pad(q[k]),
            "section_force": pad(force[k]),
            "section_moment": pad(moment[k]),
            "contact_eta": eta,
        }
        for a in range(3):
            point_data[f"section_axis_{a + 1}"] = pad(axes[k, :, :, a])
        mesh = meshio.Mesh(points, cells, point_data=point_data, cell_data=cell_data)
        file = f"{name}_{k:05d}.vtu"
        meshio.write(folder / file, mesh, file_format="vtu")
        _add_field_data(folder / file, {n: v[k] for n, v in channels.items()})
        entries.append((float(t), file))
    return _write_pvd(folder / f"{name}.pvd", entries)


def _add_field_data(path: Path, values: dict):
    """Adds the channels as the grid's FieldData (one value each; meshio's VTU writer leaves
    field data out), in ASCII so they are readable in the file too."""
    if not values:
        return
    arrays = "".join(
        f'<DataArray type="Float64" Name={quoteattr(n)} NumberOfTuples="1" format="ascii">{float(v)!r}</DataArray>'
        for n, v in values.items()
    )
    text = path.read_text(encoding="utf-8")
    i = text.index(">", text.index("<UnstructuredGrid")) + 1
    path.write_text(f"{text[:i]}\n<FieldData>{arrays}</FieldData>{text[i:]}", encoding="utf-8")


def _write_pvd(path: Path, entries) -> Path:
    rows = "\n".join(
        f'    <DataSet timestep="{t!r}" part="0" file={quoteattr(file)}/>' for t, file in entries
    )
    path.write_text(
        '<?xml version="1.0"?>\n'
        '<VTKFile type="Collection" version="0.1" byte_order="LittleEndian">\n'
        f"  <Collection>\n{rows}\n  </Collection>\n</VTKFile>\n",
        encoding="utf-8",
    )
    return path
