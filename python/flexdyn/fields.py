"""Full-field output: where every node is and how it is turned at each output time, the beams'
section loads at their nodes, the sliding joints' contact points, and the model's topology.

A run records them when `simulation.fields` is true, or by default when their estimated size
(`flexdyn info`) is at most 100 MB. In a results dataset they are the variables

==================  =============================  ======  =========================================
variable            dimensions                     units   meaning
==================  =============================  ======  =========================================
node_position       time, node, xyz                m       node position, inertial frame
node_orientation    time, node, quaternion         1       unit quaternion (w, x, y, z) of the
                                                           node's triad, inertial frame
section_force       time, beam_point, section_axis N       F1 F2 F3 in the section triad
section_moment      time, beam_point, section_axis N*m     M1 M2 M3 in the section triad
contact_eta         time, contact                  1       a sliding joint's η = s/L
contact_position    time, contact, xyz             m       its contact point on the beam
==================  =============================  ======  =========================================

with `beam_point_node` (the node of each beam point: every beam's nodes in order along it)
and the attribute `flexdyn_topology` (JSON: beams, bodies, joints, contacts). `motion(ds)`
reads them back as arrays, with the beams' section frames.
"""

from __future__ import annotations

import json
from dataclasses import dataclass

import numpy as np
import xarray as xr

from .storage import ArrayVariable

#: Record variables in column order: name, dimensions after time, units, description.
_RECORD = [
    ("node_position", ("node", "xyz"), "m", "node position, inertial frame"),
    ("node_orientation", ("node", "quaternion"), "1", "unit quaternion (w, x, y, z) of the node triad"),
    ("section_force", ("beam_point", "section_axis"), "N", "section force F1 F2 F3, section triad"),
    ("section_moment", ("beam_point", "section_axis"), "N*m", "section moment M1 M2 M3, section triad"),
    ("contact_eta", ("contact",), "1", "sliding joint contact point eta = s/L"),
    ("contact_position", ("contact", "xyz"), "m", "sliding joint contact point, inertial frame"),
]

_FIELD_NAMES = {name for name, *_ in _RECORD} | {"beam_point_node"}


def is_field_variable(name: str) -> bool:
    """Whether a results variable is part of the field output (not a sensor channel)."""
    return name in _FIELD_NAMES


@dataclass
class FieldLayout:
    """The field columns of a run's samples (after its channels), from `Simulation.field_layout`."""

    topology: dict

    @classmethod
    def from_core(cls, layout: dict | None) -> FieldLayout | None:
        """The layout the compiled core describes (`Simulation.field_layout`), None if the
        run records no fields."""
        return None if layout is None else cls(json.loads(layout["topology"]))

    @property
    def sizes(self) -> dict:
        t = self.topology
        points = sum(len(b["nodes"]) for b in t["beams"])
        return {
            "node": len(t["nodes"]),
            "xyz": 3,
            "quaternion": 4,
            "beam_point": points,
            "section_axis": 3,
            "contact": len(t["contacts"]),
        }

    def labels(self) -> dict:
        """Coordinate labels of each dimension."""
        t = self.topology
        return {
            "node": list(t["nodes"]),
            "xyz": ["x", "y", "z"],
            "quaternion": ["w", "x", "y", "z"],
            "beam_point": [f"{b['name']}[{k}]" for b in t["beams"] for k in range(len(b["nodes"]))],
            "section_axis": ["1", "2", "3"],
            "contact": [c["name"] for c in t["contacts"]],
        }

    def point_nodes(self) -> np.ndarray:
        """The node index of each beam point, beam after beam (int32)."""
        return np.array([n for b in self.topology["beams"] for n in b["nodes"]], dtype=np.int32)

    def width(self) -> int:
        """Columns the fields add to every sample (after the channels)."""
        sizes = self.sizes
        return sum(int(np.prod([sizes[d] for d in dims])) for _, dims, _, _ in _RECORD)

    def split(self, values: np.ndarray) -> dict:
        """The record arrays of field columns `values[n, width]`: name → array (n, *dims)."""
        sizes, out, col = self.sizes, {}, 0
        for name, dims, _, _ in _RECORD:
            shape = [sizes[d] for d in dims]
            k = int(np.prod(shape))
            out[name] = values[:, col : col + k].reshape(len(values), *shape)
            col += k
        return out

    def netcdf(self, dim: str) -> tuple[list[ArrayVariable], dict]:
        """The variables and dimensions the results file needs: string coordinates, the beam
        points' nodes, and the record arrays (record dimension `dim`)."""
        # A dimension of size 0 would read as a second unlimited one: what has none is left out.
        sizes = {d: n for d, n in self.sizes.items() if n > 0}
        labels = {d: v for d, v in self.labels().items() if d in sizes}
        dims = dict(sizes)
        arrays = []
        for d, names in labels.items():
            width = max([len(n.encode("utf-8")) for n in names] + [1])
            dims[f"{d}_strlen"] = width
            arrays.append(ArrayVariable(d, (d, f"{d}_strlen"), {"_Encoding": "utf-8"}, data=names))
        if "beam_point" in sizes:
            arrays.append(ArrayVariable("beam_point_node", ("beam_point",), {}, data=self.point_nodes()))
        for name, rdims, units, what in _RECORD:
            if all(d in sizes for d in rdims):
                arrays.append(ArrayVariable(name, (dim, *rdims), {"units": units, "long_name": what}))
        return arrays, dims

    def add_to(self, ds: xr.Dataset, values: np.ndarray, dim: str) -> xr.Dataset:
        """`ds` with the field variables of columns `values` (in-memory results)."""
        labels = {d: v for d, v in self.labels().items() if v}
        for (name, rdims, units, what), arr in zip(_RECORD, self.split(values).values()):
            if all(d in labels for d in rdims):
                ds[name] = ((dim, *rdims), arr, {"units": units, "long_name": what})
        ds = ds.assign_coords({d: (d, np.array(v, dtype=object)) for d, v in labels.items()})
        if "beam_point" in labels:
            ds["beam_point_node"] = ("beam_point", self.point_nodes())
        return ds


def _rotate(q: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Vectors `v[..., 3]` turned by unit quaternions `q[..., 4]` (w, x, y, z)."""
    w, u = q[..., :1], q[..., 1:]
    t = 2.0 * np.cross(u, v)
    return v + w * t + np.cross(u, t)


def _multiply(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Quaternion products a b (w, x, y, z)."""
    aw, av = a[..., :1], a[..., 1:]
    bw, bv = b[..., :1], b[..., 1:]
    w = aw * bw - np.sum(av * bv, axis=-1, keepdims=True)
    v = aw * bv + bw * av + np.cross(av, bv)
    return np.concatenate([w, v], axis=-1)


def frames(q: np.ndarray) -> np.ndarray:
    """Rotation matrices `[..., 3, 3]` of unit quaternions `q[..., 4]`; column k is axis k+1."""
    eye = np.eye(3)
    cols = [_rotate(q, np.broadcast_to(eye[k], q.shape[:-1] + (3,))) for k in range(3)]
    return np.stack(cols, axis=-1)


class Motion:
    """The full-field motion of a results dataset (see the module's description).

    `times` [T]; `positions` [T, N, 3] m and `orientations` [T, N, 4] of the nodes named
    `nodes`; `topology` the model's topology (dict). `beam(name)` gives a beam's reference
    line, section frames and section loads at its nodes."""

    def __init__(self, ds: xr.Dataset):
        if "node_position" not in ds:
            raise KeyError(
                "these results have no field output; run the model with `simulation: {fields: true}` "
                "(or `flexdyn run --fields`), or a coarser output_dt so the default records it"
            )
        self.dim = "load_factor" if "load_factor" in ds.dims else "time"
        self.times = ds[self.dim].values
        self.nodes = [str(n) for n in ds["node"].values]
        self.positions = ds["node_position"].values
        self.orientations = ds["node_orientation"].values
        self.topology = json.loads(ds.attrs["flexdyn_topology"])
        n = len(self.times)
        empty = {"section_force": (n, 0, 3), "section_moment": (n, 0, 3)}
        empty |= {"contact_eta": (n, 0), "contact_position": (n, 0, 3)}
        for name, shape in empty.items():
            setattr(self, name, ds[name].values if name in ds else np.zeros(shape))
        first, self.beam_points = 0, {}
        for b in self.topology["beams"]:
            self.beam_points[b["name"]] = slice(first, first + len(b["nodes"]))
            first += len(b["nodes"])

    def beam(self, name: str) -> dict:
        """A beam's nodes along it: `s` [P] arc length (m), `x` [T, P, 3] positions,
        `frames` [T, P, 3, 3] section triads (column k = axis k+1, inertial components),
        `force` and `moment` [T, P, 3] section loads (section triad)."""
        b = next((b for b in self.topology["beams"] if b["name"] == name), None)
        if b is None:
            have = ", ".join(x["name"] for x in self.topology["beams"]) or "none"
            raise KeyError(f"no beam `{name}` in the results; they have: {have}")
        idx = np.array(b["nodes"])
        offsets = np.array(b["section_offsets"])
        q = _multiply(self.orientations[:, idx], offsets[None])
        sl = self.beam_points[name]
        return {
            "s": np.array(b["s"]),
            "x": self.positions[:, idx],
            "frames": frames(q),
            "force": self.section_force[:, sl],
            "moment": self.section_moment[:, sl],
        }


def motion(results) -> Motion:
    """The full-field motion of a results dataset or file (`simulate(...)`'s return or a path)."""
    if isinstance(results, xr.Dataset):
        return Motion(results)
    with xr.open_dataset(results) as ds:
        return Motion(ds.load())
