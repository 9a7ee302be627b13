"""Building models in Python. A Model is the same data as a YAML model file: the builder
produces it, Rust validates it (errors name the offending item), and `to_yaml` writes it out.

    m = Model("pendulum", gravity=[0, 0, -9.81])
    m.node("bob", position=[1, 0, 0])
    m.body("ball", node="bob", mass=2.0, inertia=[0.01, 0.01, 0.01])
    m.revolute("pin", "ground", "bob", axis=[0, 1, 0], position=[0, 0, 0])
    m.sensor("joint_coordinate", "angle", joint="pin")

Names are the file format's: a method per item, named by its `type:` (joints, loads) or the
singular of its list (`nodes` → `node`, `bodies` → `body`, `beams` → `beam`,
`initial_spins` → `initial_spin`), `sensor(type, ...)` for sensors and `simulation(...)` for
the `simulation:` settings; every keyword argument is the item's YAML key
(tests/test_builder_names.py holds the builder to the schema).
"""

from __future__ import annotations

import copy
import difflib
import functools
import inspect
import json
import warnings
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any, Literal, Self, Union

import yaml

from . import _core

GROUND = "ground"

#: A vector of three numbers, m (or m/s, rad/s, … as the key says), inertial frame.
Vec3 = Sequence[float]
#: A function of time: a number, an expression of `t` in a string, a table
#: {"t": [...], "value": [...]}, or a `drive(...)`.
Function = Union[float, str, Mapping[str, Sequence[float]], "Drive"]
#: A spring and damper on a coordinate: {"stiffness", "damping", "rest"} or {"table": ...}.
Spring = Mapping[str, Any]
#: `{"static": μs, "kinetic": μk, "viscous": N·s/m, "preload": N, "radius": m,
#: "thread_angle": rad}` (see the file format's `friction:`).
Friction = Mapping[str, Any]
#: Where a joint's position and axes are given: the inertial frame or a node's triad.
Frame = Literal["inertial", "node1", "node2"]


def _deprecated(old: str, new: str) -> None:
    warnings.warn(
        f"Model.{old} is deprecated: use Model.{new} (the model file's name)",
        DeprecationWarning,
        stacklevel=3,
    )


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
        self,
        name: str,
        position: Vec3,
        *,
        velocity: Vec3 | None = None,
        angular_velocity: Vec3 | None = None,
        rotation_vector: Vec3 | None = None,
        matrix: Sequence[Vec3] | None = None,
        frame: str | None = None,
    ) -> Model:
        """A node (point with a triad) at `position`, m. Velocities (m/s, rad/s) in the
        inertial frame; its `orientation:` as a `rotation_vector` (rad) or a `matrix` whose
        columns are the triad's unit vectors. With `frame="hub"` all of these are given in
        node `hub`'s initial frame (position relative to it, vectors in its triad)."""
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
                    "frame": frame,
                }
            )
        )
        return self

    def body(
        self,
        name: str,
        node: str,
        mass: float,
        inertia: Vec3 | Sequence[Vec3],
        cm_offset: Vec3 | None = None,
    ) -> Model:
        """A rigid body on `node` (an item of `bodies:`): `mass` in kg; `inertia` about the
        centre of mass in the node's triad, kg·m²: [I11, I22, I33] or a full 3×3 matrix;
        `cm_offset` from the node, m, node triad."""
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

    def rigid_body(self, name, node, mass, inertia, cm_offset=None) -> Model:
        """Deprecated spelling of `body` (the file's list is `bodies:`)."""
        _deprecated("rigid_body", "body")
        return self.body(name, node, mass, inertia, cm_offset)

    def beam(
        self,
        name: str,
        start: Vec3 | None = None,
        end: Vec3 | None = None,
        *,
        elements: int,
        section: Mapping[str, Any] | None = None,
        sections: Sequence[Mapping[str, Any]] | None = None,
        order: int = 3,
        e2: Vec3 | None = None,
        twist_rate: float = 0.0,
        twist: Mapping[str, Sequence[float]] | None = None,
        arc: Mapping[str, Any] | None = None,
        via: Sequence[Vec3] | None = None,
        start_node: str | None = None,
        end_node: str | None = None,
        velocity: Vec3 | None = None,
        angular_velocity: Vec3 | None = None,
        damping: Mapping[str, Any] | None = None,
        frame: str | None = None,
    ) -> Model:
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
        - `damping`: structural damping, e.g. `{"ratio": 0.01, "frequency": 12.0}` (1 % at
          12 Hz, stiffness-proportional), `{"stiffness_proportional": μ}` (s), a sectional
          `{"matrix": 6×6}` (N·s), and/or `{"mass_proportional": α}` (1/s; damps rigid motion
          too). See docs/damping.md.
        - `frame`: a node in whose initial frame the geometry is given (points relative to it,
          directions in its triad; the default `e2` follows the default rule in that frame).
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
                    "damping": num(damping) if damping is not None else None,
                    "frame": frame,
                }
            )
        )
        return self

    def _joint(self, kind: str, name: str, node1: str, node2: str, **fields) -> Model:
        """Joints: `position` and axes are inertial, or with frame="node1"/"node2" given in
        that node's initial triad (position relative to the node)."""
        fields = {k: _vec(v) if isinstance(v, (tuple, list)) else v for k, v in fields.items()}
        fields = {k: dict(v) if isinstance(v, Mapping) else v for k, v in fields.items()}
        self.data["joints"].append(
            _drop_none({"type": kind, "name": name, "node1": node1, "node2": node2, **copy.deepcopy(fields)})
        )
        return self

    def spherical(
        self, name: str, node1: str, node2: str, position: Vec3 | None = None, frame: Frame | None = None
    ) -> Model:
        """Spherical joint: the nodes share a point (`position`, m, default node2's; in node
        `frame`'s initial frame if given)."""
        return self._joint("spherical", name, node1, node2, position=position, frame=frame)

    def revolute(
        self,
        name: str,
        node1: str,
        node2: str,
        axis: Vec3,
        position: Vec3 | None = None,
        drive: Function | None = None,
        spring: Spring | None = None,
        frame: Frame | None = None,
    ) -> Model:
        """Revolute joint about `axis`; `drive` prescribes φ(t) (number, expression of t, or
        {"t": [...], "value": [...]}); `spring` = {"stiffness", "damping", "rest"}."""
        return self._joint(
            "revolute",
            name,
            node1,
            node2,
            axis=axis,
            position=position,
            drive=drive,
            spring=spring,
            frame=frame,
        )

    def prismatic(
        self,
        name: str,
        node1: str,
        node2: str,
        axis: Vec3,
        position: Vec3 | None = None,
        drive: Function | None = None,
        spring: Spring | None = None,
        frame: Frame | None = None,
        friction: Friction | None = None,
    ) -> Model:
        """Prismatic joint: identical orientations, node2 slides by Δ along `axis`; `drive`
        prescribes Δ(t) (m), `spring` acts on Δ (N/m, N·s/m), `friction` opposes the slide
        (`{"static": μs, "kinetic": μk}`; the normal force is the joint's force normal to the
        axis)."""
        return self._joint(
            "prismatic",
            name,
            node1,
            node2,
            axis=axis,
            position=position,
            drive=drive,
            spring=spring,
            frame=frame,
            friction=friction,
        )

    def cylindrical(
        self,
        name: str,
        node1: str,
        node2: str,
        axis: Vec3,
        position: Vec3 | None = None,
        drive_delta: Function | None = None,
        spring_delta: Spring | None = None,
        drive_phi: Function | None = None,
        spring_phi: Spring | None = None,
        frame: Frame | None = None,
        friction: Friction | None = None,
    ) -> Model:
        """Cylindrical joint: slides by Δ along and turns by φ about `axis`; drives and
        springs on either; `friction` opposes the slide along the axis."""
        return self._joint(
            "cylindrical",
            name,
            node1,
            node2,
            axis=axis,
            position=position,
            drive_delta=drive_delta,
            spring_delta=spring_delta,
            drive_phi=drive_phi,
            spring_phi=spring_phi,
            frame=frame,
            friction=friction,
        )

    def screw(
        self,
        name: str,
        node1: str,
        node2: str,
        axis: Vec3,
        pitch: float,
        position: Vec3 | None = None,
        drive_delta: Function | None = None,
        spring_delta: Spring | None = None,
        drive_phi: Function | None = None,
        spring_phi: Spring | None = None,
        frame: Frame | None = None,
        friction: Friction | None = None,
    ) -> Model:
        """Screw joint: a cylindrical joint with Δ = pitch·φ (`pitch` in m/rad); drive one of
        Δ and φ. `friction` is thread friction at the mean thread `radius` (m, required):
        `{"static": μs, "kinetic": μk, "radius": r, "thread_angle": β}`; the thread holds its
        load without torque when μs ≥ tan α·cos β, tan α = pitch/radius."""
        return self._joint(
            "screw",
            name,
            node1,
            node2,
            axis=axis,
            pitch=pitch,
            position=position,
            drive_delta=drive_delta,
            spring_delta=spring_delta,
            drive_phi=drive_phi,
            spring_phi=spring_phi,
            frame=frame,
            friction=friction,
        )

    def universal(
        self,
        name: str,
        node1: str,
        node2: str,
        axis1: Vec3,
        axis2: Vec3,
        position: Vec3 | None = None,
        frame: Frame | None = None,
        spring1: Spring | None = None,
        spring2: Spring | None = None,
        drive1: Function | None = None,
        drive2: Function | None = None,
    ) -> Model:
        """A universal joint (a gimbal): `axis1` fixed to node1, `axis2` to node2. Its rotations
        φ1 (the cross about axis1) and φ2 (node2 about axis2) take springs/dampers
        (`spring1={"stiffness": k, "damping": c}`) and drives like a revolute's φ."""
        return self._joint(
            "universal",
            name,
            node1,
            node2,
            axis1=axis1,
            axis2=axis2,
            position=position,
            frame=frame,
            spring1=spring1,
            spring2=spring2,
            drive1=drive1,
            drive2=drive2,
        )

    def clamp(self, name: str, node1: str, node2: str) -> Model:
        """Clamp: the two nodes move as one body, as placed initially."""
        return self._joint("clamp", name, node1, node2)

    def sliding(
        self,
        name: str,
        beam: str,
        follower: str,
        eta: float | Drive | None = None,
        drive: Function | None = None,
        spring: Spring | None = None,
        end_stops: Mapping[str, float] | None = None,
        friction: Friction | None = None,
    ) -> Model:
        """Sliding joint: the `follower` node stays in contact with `beam` at a moving point
        η = s/L, turning freely.

        - `eta`: the initial η (default: the beam point closest to the follower); or
          `drive` (or `eta=drive(...)`) prescribes η(t) — its multiplier is the driving force
          along the beam, and a number given as `eta` too must be its value at t = 0.
          Without a drive the contact point slides freely (unless `friction` is given).
        - `spring`: {"stiffness": N/m, "damping": N·s/m, "rest": η} along the beam.
        - `follower` may be "ground": a fixed guide the beam slides through.
        - `end_stops`: {"stiffness": N/m}: elastic stops at the beam's ends (else a free contact
          point reaching an end stops the run with a message).
        - `friction`: {"static": μs, "kinetic": μk, "viscous": N·s/m, "preload": N}: Coulomb
          friction along the beam, the normal force being the contact force normal to it.
        """
        return self._sliding("sliding", name, beam, follower, eta, drive, spring, end_stops, friction)

    def sliding_screw(
        self,
        name: str,
        beam: str,
        follower: str,
        eta: float | Drive | None = None,
        drive: Function | None = None,
        spring: Spring | None = None,
        end_stops: Mapping[str, float] | None = None,
        friction: Friction | None = None,
    ) -> Model:
        """Sliding screw joint: a sliding joint whose follower also turns with the beam's
        section about its axis (pre-twist and elastic twist). Arguments as `sliding`."""
        return self._sliding("sliding_screw", name, beam, follower, eta, drive, spring, end_stops, friction)

    def sliding_clamp(
        self,
        name: str,
        beam: str,
        follower: str,
        eta: float | Drive | None = None,
        drive: Function | None = None,
        spring: Spring | None = None,
        end_stops: Mapping[str, float] | None = None,
        friction: Friction | None = None,
    ) -> Model:
        """Sliding clamp (a sleeve): the follower keeps its orientation relative to the
        section as it slides. Arguments as `sliding`."""
        return self._sliding("sliding_clamp", name, beam, follower, eta, drive, spring, end_stops, friction)

    def _sliding(self, kind, name, beam, follower, eta, drive, spring, end_stops, friction=None) -> Model:
        if isinstance(eta, Drive):
            if drive is not None:
                raise ValueError(
                    f"sliding joint `{name}`: give the drive once (`drive=` or `eta=drive(...)`)"
                )
            eta, drive = None, eta
        fields = {"type": kind, "name": name, "beam": beam, "follower": follower, "eta": eta}
        fields["drive"] = drive.function if isinstance(drive, Drive) else drive
        fields["spring"] = dict(spring) if spring is not None else None
        fields["end_stops"] = dict(end_stops) if end_stops is not None else None
        fields["friction"] = dict(friction) if friction is not None else None
        self.data["joints"].append(_drop_none(copy.deepcopy(fields)))
        return self

    def sliding_joint(
        self, name, beam, follower, eta=None, spring=None, kind="point", end_stops=None
    ) -> Model:
        """Deprecated: use `sliding`, `sliding_screw` or `sliding_clamp` (the file's `type:`)."""
        if kind not in _SLIDING_TYPES:
            raise ValueError(
                f"sliding joint `{name}`: kind must be one of {sorted(_SLIDING_TYPES)} (got {kind!r})"
            )
        _deprecated("sliding_joint(kind=...)", _SLIDING_TYPES[kind])
        return self._sliding(_SLIDING_TYPES[kind], name, beam, follower, eta, None, spring, end_stops)

    def initial_spin(
        self, items: Sequence[str], axis: Vec3, rate: float, center: Vec3 = (0.0, 0.0, 0.0)
    ) -> Model:
        """An item of `initial_spins:`: start the listed nodes and beams (all their nodes)
        turning together at `rate` rad/s about the unit `axis` through `center`:
        v = ω × (x − center), angular velocity ω."""
        self.data.setdefault("initial_spins", []).append(
            {"axis": _vec(axis), "rate": rate, "center": _vec(center), "items": list(items)}
        )
        return self

    def pattern(
        self,
        name: str,
        count: int,
        axis: Vec3,
        center: Vec3 = (0.0, 0.0, 0.0),
        step: float | None = None,
    ) -> Pattern:
        """An item of `patterns:`: the items added to the returned pattern are copied `count`
        times, copy i (1 … count) turned by (i − 1)·`step` rad (default 2π/count) about the
        `axis` through `center`. Write `{i}` in every name (and wherever the copy's number
        belongs: references, expressions). Use it as a context manager or keep the object:

            with m.pattern("rotor", count=3, axis=[0, 0, 1]) as blade:
                blade.beam("blade{i}", [0.5, 0, 0], [5, 0, 0], elements=4, section=s)
                blade.clamp("root{i}", "hub", "blade{i}.start")
        """
        entry = _drop_none(
            {
                "name": name,
                "count": count,
                "axis": _vec(axis),
                "center": _vec(center),
                "step": step,
            }
        )
        self.data.setdefault("patterns", []).append(entry)
        return Pattern(entry)

    def force(
        self, name: str, node: str, value: Vec3, scale: Function | None = None, follower: bool = False
    ) -> Model:
        """Point force, N, times an optional function of time: dead (inertial frame) or, with
        follower=True, given in the node's triad and turning with it."""
        return self._load("force", name, node=node, value=value, scale=scale, follower=follower)

    def moment(
        self, name: str, node: str, value: Vec3, scale: Function | None = None, follower: bool = False
    ) -> Model:
        """Point moment, N·m: dead (inertial frame) or follower (node's triad)."""
        return self._load("moment", name, node=node, value=value, scale=scale, follower=follower)

    def distributed_force(
        self, name: str, beam: str, value: Vec3, scale: Function | None = None, follower: bool = False
    ) -> Model:
        """Force per unit length along a whole beam, N/m: dead (inertial frame) or follower
        (section frame, axis 1 along the beam), lumped consistently to the beam's nodes."""
        return self._load("distributed_force", name, beam=beam, value=value, scale=scale, follower=follower)

    def distributed_moment(
        self, name: str, beam: str, value: Vec3, scale: Function | None = None, follower: bool = False
    ) -> Model:
        """Moment per unit length along a whole beam, N·m/m (dead or follower)."""
        return self._load("distributed_moment", name, beam=beam, value=value, scale=scale, follower=follower)

    def _load(self, kind, name, *, value, scale, follower, **target) -> Model:
        item = {"type": kind, "name": name, **target, "value": _vec(value), "scale": scale}
        if follower:
            item["follower"] = True
        self.data["loads"].append(_drop_none(item))
        return self

    def sensor(self, type: str | None = None, name: str | None = None, **fields) -> Model:
        """A sensor of `type` (its `type:` in the file), its other keys as keyword arguments:
        node_position, node_displacement, node_rotation, node_velocity (node=...);
        relative_position (node=..., reference=...); joint_coordinate, joint_reaction,
        drive_force (joint=..., coordinate=...); friction (joint=...: force, normal force, slip,
        slip rate, stick, dissipation); beam_section (beam=..., eta=... or s=...),
        beam_energy (beam=...); energy; momentum. `component=` keeps one channel."""
        if "kind" in fields:
            _deprecated("sensor(kind=...)", "sensor(type=...)")
            type = fields.pop("kind")
        self.data["sensors"].append({"type": type, "name": name, **copy.deepcopy(fields)})
        return self

    def simulation(
        self,
        *,
        analysis: Literal["dynamic", "static"] | None = None,
        scheme: Literal["ep", "ed"] | None = None,
        t_end: float | None = None,
        dt: float | None = None,
        output_dt: float | None = None,
        fields: bool | None = None,
        step_control: Literal["adaptive", "fixed"] | None = None,
        tolerance: float | None = None,
        dt_min: float | None = None,
        dt_max: float | None = None,
        max_growth: float | None = None,
        max_shrink: float | None = None,
        max_step_halvings: int | None = None,
        newton_tol: float | None = None,
        newton_increment_tol: float | None = None,
        max_newton_iterations: int | None = None,
        modified_newton: bool | None = None,
        load_steps: int | None = None,
        preload: bool | None = None,
        inertial_preload: bool | None = None,
        timings: bool | None = None,
    ) -> Model:
        """The `simulation:` settings (those given; the rest keep their defaults): analysis,
        scheme ("ed", the default, or "ep"), t_end and dt (s), output_dt (s); fields (record
        the full-field motion for `flexdyn view`/`export`; default: when ≤ 100 MB); step_control
        ("adaptive", the default, or "fixed") with tolerance (relative), dt_min, dt_max (s), max_growth,
        max_shrink, max_step_halvings; Newton's newton_tol, newton_increment_tol,
        max_newton_iterations, modified_newton; load_steps (static); preload (True: start a dynamic
        run from the static equilibrium at t = 0; False: start the beams unstrained, as given;
        unset: a model at rest under gravity, loads or joint springs off their rest starts with
        its beams in equilibrium with them — a structure in its static equilibrium, a mechanism
        that moves by itself bent by the loads of the motion it starts —, anything else as
        given); inertial_preload (default True: beams that
        drives moving at t = 0 carry along, or given a motion of their own, start strained by
        that motion's inertial loads);
        timings (record where the run's wall time goes, phase by phase, in the statistics:
        `ds.flexdyn.timing_report()`)."""
        given = {k: v for k, v in locals().items() if k != "self" and v is not None}
        self.data["simulation"].update(copy.deepcopy(given))
        return self

    def settings(self, **fields) -> Model:
        """Deprecated spelling of `simulation` (the file's key is `simulation:`)."""
        _deprecated("settings", "simulation")
        return self.simulation(**fields)

    # --- conversion ------------------------------------------------------------------
    def to_dict(self) -> dict:
        """The model as plain data (numpy values converted; non-finite numbers rejected)."""
        return _plain(self.data)

    def to_json(self) -> str:
        """The model as JSON text (the model file's content; `_core.parse_json` reads it)."""
        return json.dumps(self.to_dict(), allow_nan=False)

    def validate(self) -> Model:
        """Raises ModelError naming every offending item."""
        _core.parse_json(self.to_json())
        return self

    def with_(self, overrides: Mapping[str, Any]) -> Model:
        """A new model with values changed by path, validated: `m.with_({"joints.slider.spring.
        stiffness": 2e4, "simulation.t_end": 5})`. A path is a top-level key, an item's name
        (or index) in a list, then keys inside it (created if missing); see
        `flexdyn.overrides`. This model is left as it is."""
        from .overrides import apply

        changed = Model.from_dict(apply(self.to_dict(), overrides))
        try:
            return changed.validate()
        except _core.ModelError as e:
            paths = ", ".join(overrides)
            raise _core.ModelError(f"{e}\n(the model with {paths} changed)") from None

    def expanded(self) -> Model:
        """The model as the solver sees it: patterns expanded into their copies (`{i}`
        replaced), nodes and beams given in a node's frame placed in the inertial frame, and
        the default section axis of every copied beam written out."""
        return Model.from_dict(json.loads(_core.expand_json(self.to_json())))

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
        """A model from plain data as in a model file (`to_dict`'s inverse; copied, not
        validated: `validate()` checks it)."""
        m = cls()
        m.data = copy.deepcopy(data)
        for key in ("nodes", "bodies", "beams", "joints", "loads", "sensors"):
            m.data.setdefault(key, [])
        m.data.setdefault("simulation", {})
        return m

    def __repr__(self) -> str:
        """A summary like `flexdyn info`'s, from the model as given (nothing compiled)."""
        d = self.data

        def listed(items, describe=lambda i: i.get("name", "?"), most=6):
            names = [describe(i) for i in items]
            shown = ", ".join(names[:most]) + (f", … ({len(names) - most} more)" if len(names) > most else "")
            return f"{len(names)}" + (f": {shown}" if names else "")

        kinds: dict[str, int] = {}
        for j in d.get("joints", []):
            kinds[j.get("type", "?")] = kinds.get(j.get("type", "?"), 0) + 1
        beam = lambda b: f"{b.get('name', '?')} ({b.get('elements', 1)}×p{b.get('order', 3)})"
        sensor = lambda x: f"{x.get('name', '?')} ({x.get('type', '?')})"
        sim = d.get("simulation", {})
        units = {"t_end": " s", "dt": " s"}
        keys = ("analysis", "scheme", "t_end", "dt", "step_control")
        run = ", ".join(f"{k} {sim[k]}{units.get(k, '')}" for k in keys if k in sim)
        g = d.get("gravity", [0, 0, 0])
        lines = [
            f"flexdyn.Model `{d.get('name', '')}` (gravity {list(g)} m/s²)",
            f"  nodes    {listed(d.get('nodes', []))}",
            f"  bodies   {listed(d.get('bodies', []))}",
            f"  beams    {listed(d.get('beams', []), beam)}",
            f"  joints   {len(d.get('joints', []))}"
            + (": " + ", ".join(f"{k} {v}" for k, v in kinds.items()) if kinds else ""),
            f"  loads    {listed(d.get('loads', []))}",
            f"  sensors  {listed(d.get('sensors', []), sensor)}",
            f"  run      {run or 'defaults'}",
        ]
        if d.get("patterns"):
            lines.insert(7, f"  patterns {listed(d['patterns'])} (expanded when run)")
        return "\n".join(lines)


class Pattern(Model):
    """The items of one pattern (see `Model.pattern`): built with the model's item methods
    (node, body, beam, joints, loads, sensors, initial_spin)."""

    def __init__(self, entry: dict):
        for key in ("nodes", "bodies", "beams", "joints", "loads", "sensors"):
            entry.setdefault(key, [])
        self.data = entry

    def __enter__(self) -> Self:
        return self

    def __exit__(self, *exc) -> None:
        return None

    def _whole_model_only(self, what: str):
        raise TypeError(f"{what} belongs to the model, not to pattern `{self.data['name']}`")

    def simulation(self, **fields) -> Model:
        self._whole_model_only("simulation()")

    def pattern(self, *args, **kwargs) -> Pattern:
        self._whole_model_only("pattern() (patterns do not nest)")

    def __repr__(self) -> str:
        d = self.data
        return f"Pattern({d['name']!r}: {d['count']} copies of {len(d['nodes'])} nodes, {len(d['beams'])} beams, {len(d['joints'])} joints)"


def _suggesting_keywords(method):
    """`method`, whose misspelt keyword argument is told the accepted one it was likely meant
    as (as a model file's misspelt key is): `Model.revolute() got an unexpected keyword
    argument 'axsi'; did you mean 'axis'?`."""
    parameters = inspect.signature(method).parameters.values()
    kinds = (inspect.Parameter.POSITIONAL_OR_KEYWORD, inspect.Parameter.KEYWORD_ONLY)
    accepted = [p.name for p in parameters if p.kind in kinds and p.name != "self"]

    @functools.wraps(method)
    def checked(*args, **kwargs):
        for given in kwargs:
            if given not in accepted:
                near = difflib.get_close_matches(given, accepted, n=1, cutoff=0.75)
                hint = f"; did you mean {near[0]!r}?" if near else ""
                raise TypeError(f"{method.__qualname__}() got an unexpected keyword argument {given!r}{hint}")
        return method(*args, **kwargs)

    return checked


def _suggest_keywords(cls: type) -> None:
    """Every public method of `cls` with a fixed set of keywords tells a misspelt one."""
    for name, member in list(vars(cls).items()):
        if name.startswith("_") or not inspect.isfunction(member):
            continue
        kinds = {p.kind for p in inspect.signature(member).parameters.values()}
        if inspect.Parameter.VAR_KEYWORD not in kinds:
            setattr(cls, name, _suggesting_keywords(member))


_suggest_keywords(Model)


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
