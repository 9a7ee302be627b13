"""Building models in Python. A Model is the same data as a YAML model file: the builder
produces it, Rust validates it (errors name the offending item), and `to_yaml` writes it out.

    m = Model("pendulum", gravity=[0, 0, -9.81])
    m.node("bob", position=[1, 0, 0])
    m.rigid_body("ball", node="bob", mass=2.0, inertia=[0.01, 0.01, 0.01])
    m.revolute("pin", "ground", "bob", axis=[0, 1, 0], position=[0, 0, 0])
    m.sensor("joint_coordinate", "angle", joint="pin")
"""

from __future__ import annotations

import copy
import json
from pathlib import Path
from typing import Any

import yaml

from . import _core

GROUND = "ground"


def _plain(v, path: str = ""):
    """`v` as plain JSON data: numpy scalars and arrays become numbers and lists, Drives
    their functions; a non-finite number or an object that is not data is a ModelError
    naming `path`. Types are not coerced (2.7 elements stays 2.7, so Rust rejects it by name)."""
    import math

    import numpy as np

    if isinstance(v, Drive):
        return _plain(v.function, path)
    if isinstance(v, np.ndarray):
        v = v.tolist()
    elif isinstance(v, np.generic):
        v = v.item()
    if isinstance(v, dict):
        return {str(k): _plain(x, f"{path}.{k}" if path else str(k)) for k, x in v.items()}
    if isinstance(v, (list, tuple)):
        return [_plain(x, f"{path}[{i}]") for i, x in enumerate(v)]
    if isinstance(v, float) and not math.isfinite(v):
        raise _core.ModelError(f"{path}: must be a finite number (got {v})")
    if v is None or isinstance(v, (bool, int, float, str)):
        return v
    raise _core.ModelError(
        f"{path}: {type(v).__name__} {v!r} is not model data (give numbers, strings, lists)"
    )


def _vec(v):
    """A copy of what was given (a later change to the caller's list or array must not change
    the model); `to_dict` makes it plain data and names the item if it is not."""
    return list(v) if isinstance(v, (tuple, range)) else copy.deepcopy(v)


def _drop_none(d: dict) -> dict:
    return {k: v for k, v in d.items() if v is not None}


class Drive:
    """A prescribed motion of a joint coordinate (see `drive`)."""

    def __init__(self, function):
        if isinstance(function, Drive):
            function = function.function
        self.function = function

    def __repr__(self) -> str:
        return f"drive({self.function!r})"


def drive(function) -> Drive:
    """A prescribed motion: a number, an expression of `t` ("0.5 - 0.25*cos(2*pi*t)"), or a
    table {"t": [...], "value": [...]}. Pass it where a coordinate is expected, e.g.
    `sliding_joint(..., eta=drive("0.5 - 0.25*cos(2*pi*t)"))`."""
    return Drive(function)


_SLIDING_TYPES = {"point": "sliding", "screw": "sliding_screw", "clamp": "sliding_clamp"}


class Model:
    """A flexdyn model, built item by item (every method returns the model, so calls chain)."""

    def __init__(self, name: str = "", gravity=(0.0, 0.0, 0.0)):
        self.data: dict[str, Any] = {
            "name": name,
            "gravity": _vec(gravity),
            "nodes": [],
            "bodies": [],
            "beams": [],
            "joints": [],
            "loads": [],
            "sensors": [],
            "simulation": {},
        }

    # --- items -------------------------------------------------------------------------
    def node(
        self, name, position, *, velocity=None, angular_velocity=None, rotation_vector=None, matrix=None
    ):
        """A node (point with a triad). Velocities and orientation in the inertial frame."""
        orientation = _drop_none(
            {
                "rotation_vector": _vec(rotation_vector) if rotation_vector is not None else None,
                "matrix": [_vec(r) for r in matrix] if matrix is not None else None,
            }
        )
        self.data["nodes"].append(
            _drop_none(
                {
                    "name": name,
                    "position": _vec(position),
                    "orientation": orientation or None,
                    "velocity": _vec(velocity) if velocity is not None else None,
                    "angular_velocity": _vec(angular_velocity) if angular_velocity is not None else None,
                }
            )
        )
        return self

    def rigid_body(self, name, node, mass, inertia, cm_offset=None):
        """Rigid body on `node`; inertia about the centre of mass in the node's triad:
        [I11, I22, I33] or a full 3x3 matrix."""
        inertia = [_vec(r) for r in inertia] if hasattr(inertia[0], "__len__") else _vec(inertia)
        self.data["bodies"].append(
            _drop_none(
                {
                    "name": name,
                    "node": node,
                    "mass": mass,
                    "inertia": inertia,
                    "cm_offset": _vec(cm_offset) if cm_offset is not None else None,
                }
            )
        )
        return self

    def beam(
        self,
        name,
        start=None,
        end=None,
        *,
        elements,
        section=None,
        sections=None,
        order=3,
        e2=None,
        twist_rate=0.0,
        twist=None,
        arc=None,
        via=None,
        start_node=None,
        end_node=None,
        velocity=None,
        angular_velocity=None,
    ):
        """A geometrically exact beam from `start` to `end` (or shared `start_node` /
        `end_node`), meshed with `elements` elements of `order` 1, 2 or 3; its nodes are named
        `<name>.0` ... `<name>.N`.

        - `section`: a dict of ea, ga2, ga3, gj, ei2, ei3, m, i22, i33 (optional i23,
          tension_center, shear_center), or {"stiffness": 6×6, "mass": 6×6}; or `sections`,
          a list of {"eta": η, "section": ...} interpolated linearly along the span.
        - Shape: straight by default; `arc={"center": c, "axis": a, "angle": rad}` (the end
          follows from the start), or `via=[p1, p2, ...]` corner points of a polyline.
        - Pre-twist: `twist_rate` (rad/m) or `twist={"eta": [...], "angle": [...]}` (rad).
        - `e2`: the section's axis 2 at the start (projected normal to the beam).
        """

        num = _vec

        self.data["beams"].append(
            _drop_none(
                {
                    "name": name,
                    "start": _vec(start) if start is not None else None,
                    "end": _vec(end) if end is not None else None,
                    "start_node": start_node,
                    "end_node": end_node,
                    "elements": elements,
                    "order": order,
                    "section": num(section) if section is not None else None,
                    "sections": [{"eta": st["eta"], "section": num(st["section"])} for st in sections]
                    if sections is not None
                    else None,
                    "e2": _vec(e2) if e2 is not None else None,
                    "twist_rate": twist_rate,
                    "twist": num(twist) if twist is not None else None,
                    "arc": num(arc) if arc is not None else None,
                    "via": [_vec(p) for p in via] if via is not None else None,
                    "velocity": _vec(velocity) if velocity is not None else None,
                    "angular_velocity": _vec(angular_velocity) if angular_velocity is not None else None,
                }
            )
        )
        return self

    def _joint(self, kind, name, node1, node2, **fields):
        """Joints: `position` and axes are inertial, or with frame="node1"/"node2" given in
        that node's initial triad (position relative to the node)."""
        self.data["joints"].append(
            _drop_none({"type": kind, "name": name, "node1": node1, "node2": node2, **copy.deepcopy(fields)})
        )
        return self

    def spherical(self, name, node1, node2, position=None, frame=None):
        return self._joint(
            "spherical",
            name,
            node1,
            node2,
            position=_vec(position) if position is not None else None,
            frame=frame,
        )

    def revolute(self, name, node1, node2, axis, position=None, drive=None, spring=None, frame=None):
        """Revolute joint about `axis`; `drive` prescribes φ(t) (number, expression of t, or
        {"t": [...], "value": [...]}); `spring` = {"stiffness", "damping", "rest"}."""
        return self._joint(
            "revolute",
            name,
            node1,
            node2,
            axis=_vec(axis),
            position=_vec(position) if position is not None else None,
            drive=drive,
            spring=dict(spring) if spring is not None else None,
            frame=frame,
        )

    def prismatic(self, name, node1, node2, axis, position=None, drive=None, spring=None, frame=None):
        """Prismatic joint: identical orientations, node2 slides by Δ along `axis`; `drive`
        prescribes Δ(t) (m), `spring` acts on Δ (N/m, N·s/m)."""
        return self._joint(
            "prismatic",
            name,
            node1,
            node2,
            axis=_vec(axis),
            position=_vec(position) if position is not None else None,
            drive=drive,
            spring=dict(spring) if spring is not None else None,
            frame=frame,
        )

    def cylindrical(
        self,
        name,
        node1,
        node2,
        axis,
        position=None,
        drive_delta=None,
        spring_delta=None,
        drive_phi=None,
        spring_phi=None,
        frame=None,
    ):
        """Cylindrical joint: slides by Δ along and turns by φ about `axis`; drives and
        springs on either."""
        return self._joint(
            "cylindrical",
            name,
            node1,
            node2,
            axis=_vec(axis),
            position=_vec(position) if position is not None else None,
            drive_delta=drive_delta,
            spring_delta=dict(spring_delta) if spring_delta is not None else None,
            drive_phi=drive_phi,
            spring_phi=dict(spring_phi) if spring_phi is not None else None,
            frame=frame,
        )

    def screw(
        self,
        name,
        node1,
        node2,
        axis,
        pitch,
        position=None,
        drive_delta=None,
        spring_delta=None,
        drive_phi=None,
        spring_phi=None,
        frame=None,
    ):
        """Screw joint: a cylindrical joint with Δ = pitch·φ (`pitch` in m/rad); drive one of
        Δ and φ."""
        return self._joint(
            "screw",
            name,
            node1,
            node2,
            axis=_vec(axis),
            pitch=pitch,
            position=_vec(position) if position is not None else None,
            drive_delta=drive_delta,
            spring_delta=dict(spring_delta) if spring_delta is not None else None,
            drive_phi=drive_phi,
            spring_phi=dict(spring_phi) if spring_phi is not None else None,
            frame=frame,
        )

    def universal(
        self,
        name,
        node1,
        node2,
        axis1,
        axis2,
        position=None,
        frame=None,
        spring1=None,
        spring2=None,
        drive1=None,
        drive2=None,
    ):
        """A universal joint (a gimbal): `axis1` fixed to node1, `axis2` to node2. Its rotations
        φ1 (the cross about axis1) and φ2 (node2 about axis2) take springs/dampers
        (`spring1={"stiffness": k, "damping": c}`) and drives like a revolute's φ."""
        return self._joint(
            "universal",
            name,
            node1,
            node2,
            axis1=_vec(axis1),
            axis2=_vec(axis2),
            position=_vec(position) if position is not None else None,
            frame=frame,
            spring1=spring1,
            spring2=spring2,
            drive1=drive1,
            drive2=drive2,
        )

    def clamp(self, name, node1, node2):
        return self._joint("clamp", name, node1, node2)

    def sliding_joint(self, name, beam, follower, eta=None, spring=None, kind="point", end_stops=None):
        """The follower node stays in contact with `beam` at a moving point η = s/L.

        - `eta`: the initial η (a number; default: the beam point closest to the follower),
          or `drive(...)` to prescribe η(t) — its multiplier is the driving force along the
          beam. Without a drive the contact point slides freely (no friction).
        - `spring`: {"stiffness": N/m, "damping": N·s/m, "rest": η} along the beam.
        - `kind`: "point" (sliding joint: the point stays on the beam, the follower turns
          freely), "screw" (sliding screw joint: the follower also turns with the beam's section
          about its axis — pre-twist and elastic twist), or "clamp" (a sleeve: the follower
          keeps its orientation relative to the section).
        - `follower` may be "ground": a fixed guide the beam slides through.
        - `end_stops`: {"stiffness": N/m}: elastic stops at the beam's ends (else a free contact
          point reaching an end stops the run with a message).
        """
        if kind not in _SLIDING_TYPES:
            raise ValueError(
                f"sliding joint `{name}`: kind must be one of {sorted(_SLIDING_TYPES)} (got {kind!r})"
            )
        fields = {"type": _SLIDING_TYPES[kind], "name": name, "beam": beam, "follower": follower}
        if isinstance(eta, Drive):
            fields["drive"] = eta.function
        elif eta is not None:
            fields["eta"] = eta
        if spring is not None:
            fields["spring"] = dict(spring)
        if end_stops is not None:
            fields["end_stops"] = dict(end_stops)
        self.data["joints"].append(fields)
        return self

    def initial_spin(self, items, axis, rate, center=(0.0, 0.0, 0.0)):
        """Start the listed nodes and beams (all their nodes) turning together at `rate` rad/s
        about `axis` through `center`: v = ω × (x − center), angular velocity ω."""
        self.data.setdefault("initial_spins", []).append(
            {"axis": _vec(axis), "rate": rate, "center": _vec(center), "items": list(items)}
        )
        return self

    def force(self, name, node, value, scale=None, follower=False):
        """Point force, N, times an optional function of time: dead (inertial frame) or, with
        follower=True, given in the node's triad and turning with it."""
        return self._load("force", name, node=node, value=value, scale=scale, follower=follower)

    def moment(self, name, node, value, scale=None, follower=False):
        """Point moment, N·m: dead (inertial frame) or follower (node's triad)."""
        return self._load("moment", name, node=node, value=value, scale=scale, follower=follower)

    def distributed_force(self, name, beam, value, scale=None, follower=False):
        """Force per unit length along a whole beam, N/m: dead (inertial frame) or follower
        (section frame, axis 1 along the beam), lumped consistently to the beam's nodes."""
        return self._load("distributed_force", name, beam=beam, value=value, scale=scale, follower=follower)

    def distributed_moment(self, name, beam, value, scale=None, follower=False):
        """Moment per unit length along a whole beam, N·m/m (dead or follower)."""
        return self._load("distributed_moment", name, beam=beam, value=value, scale=scale, follower=follower)

    def _load(self, kind, name, *, value, scale, follower, **target):
        item = {"type": kind, "name": name, **target, "value": _vec(value), "scale": scale}
        if follower:
            item["follower"] = True
        self.data["loads"].append(_drop_none(item))
        return self

    def sensor(self, kind, name, **fields):
        """A sensor: node_position, node_displacement, node_rotation, node_velocity (node=...),
        joint_coordinate, joint_reaction, drive_force (joint=...), energy."""
        self.data["sensors"].append({"type": kind, "name": name, **copy.deepcopy(fields)})
        return self

    def settings(self, **fields):
        """Simulation settings: analysis ("dynamic"/"static"), load_steps, scheme ("ep"/"ed"),
        t_end, dt, output_dt, newton_tol, newton_increment_tol, max_newton_iterations,
        max_step_halvings; step_control ("adaptive", the default, or "fixed"), tolerance, dt_min, dt_max, max_growth, max_shrink;
        preload (start a dynamic run from the static equilibrium at t = 0), modified_newton."""
        self.data["simulation"].update(copy.deepcopy(fields))
        return self

    # --- conversion ------------------------------------------------------------------
    def to_dict(self) -> dict:
        """The model as plain data (numpy values converted; non-finite numbers rejected)."""
        return _plain(self.data)

    def to_json(self) -> str:
        return json.dumps(self.to_dict(), allow_nan=False)

    def validate(self) -> Model:
        """Raises ModelError naming every offending item."""
        _core.parse_json(self.to_json())
        return self

    def to_yaml(self, path: str | Path | None = None) -> str:
        """The model as a YAML model file (validated first; what was given, defaults left
        out; short lists on one line)."""
        self.validate()
        text = yaml.safe_dump(
            self.to_dict(), sort_keys=False, default_flow_style=None, allow_unicode=True, width=100
        )
        if path is not None:
            Path(path).write_text(text)
        return text

    @classmethod
    def from_dict(cls, data: dict) -> Model:
        m = cls()
        m.data = copy.deepcopy(data)
        for key in ("nodes", "bodies", "beams", "joints", "loads", "sensors"):
            m.data.setdefault(key, [])
        m.data.setdefault("simulation", {})
        return m

    def __repr__(self) -> str:
        d = self.data
        return (
            f"Model({d.get('name')!r}: {len(d['nodes'])} nodes, {len(d['bodies'])} bodies, "
            f"{len(d.get('beams', []))} beams, "
            f"{len(d['joints'])} joints, {len(d['sensors'])} sensors)"
        )


#: Largest model file read, bytes (a model is text; anything larger is a mistake).
MAX_MODEL_FILE_BYTES = 64 * 2**20


def read_model_text(path: str | Path) -> str:
    """The text of a model file (UTF-8, or UTF-16/32 with a byte-order mark); a missing file,
    a folder, a binary or oversized file is a ModelError naming the path."""
    p = Path(path)
    try:
        size = p.stat().st_size
        if p.is_dir():
            raise _core.ModelError(f"{p}: is a folder, not a model file")
        if size > MAX_MODEL_FILE_BYTES:
            raise _core.ModelError(
                f"{p}: {size} bytes is too large for a model file (at most {MAX_MODEL_FILE_BYTES})"
            )
        raw = p.read_bytes()
    except FileNotFoundError:
        raise _core.ModelError(f"{p}: no such model file") from None
    except OSError as e:
        raise _core.ModelError(f"{p}: cannot read the model file: {e.strerror}") from None
    for bom, codec in (
        (b"\xef\xbb\xbf", "utf-8-sig"),
        (b"\xff\xfe\0\0", "utf-32"),
        (b"\0\0\xfe\xff", "utf-32"),
        (b"\xff\xfe", "utf-16"),
        (b"\xfe\xff", "utf-16"),
    ):
        if raw.startswith(bom):
            try:
                return raw.decode(codec)
            except UnicodeDecodeError:
                break
    try:
        text = raw.decode("utf-8")
    except UnicodeDecodeError as e:
        raise _core.ModelError(
            f"{p}: not a text model file (byte {e.start} is not UTF-8); save it as UTF-8 YAML"
        ) from None
    if "\0" in text:
        raise _core.ModelError(f"{p}: not a text model file (it contains NUL bytes)")
    return text


def load(path: str | Path) -> Model:
    """Loads and validates a YAML model file (errors name the item, e.g. `joints[3].axis`)."""
    text = read_model_text(path)
    try:
        canonical = _core.parse_yaml(text)
    except _core.ModelError as e:
        raise _core.ModelError(f"{path}: {e}") from None
    return Model.from_dict(json.loads(canonical))
