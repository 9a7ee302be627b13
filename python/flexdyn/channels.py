"""What each results channel is: the attributes that make a results file explain itself.

Every channel `<sensor>.<component>` gets CF-style variable attributes (CF conventions,
https://cfconventions.org): `long_name` and `units`, plus flexdyn's own `sensor`,
`sensor_type`, `component` and — for every vector component — `frame`, the frame its
components are taken in (`inertial`; `joint`, the joint frame of docs/sensors.md; `section`,
the beam's deformed section frame; `reference section`, its reference one; `node <name>`, a
node's triad). Scalars (energies, coordinates, a friction's slip) have no frame.
"""

from __future__ import annotations

import datetime as _dt
import hashlib
import json

#: Component → (quantity, frame) shared by most sensors.
_VECTOR = {
    "x": ("position along x", "inertial"),
    "y": ("position along y", "inertial"),
    "z": ("position along z", "inertial"),
    "ux": ("displacement along x", "inertial"),
    "uy": ("displacement along y", "inertial"),
    "uz": ("displacement along z", "inertial"),
    "rx": ("rotation vector, x component", "inertial"),
    "ry": ("rotation vector, y component", "inertial"),
    "rz": ("rotation vector, z component", "inertial"),
    "vx": ("velocity along x", "inertial"),
    "vy": ("velocity along y", "inertial"),
    "vz": ("velocity along z", "inertial"),
    "wx": ("angular velocity about x", "inertial"),
    "wy": ("angular velocity about y", "inertial"),
    "wz": ("angular velocity about z", "inertial"),
    "Fx": ("force along x", "inertial"),
    "Fy": ("force along y", "inertial"),
    "Fz": ("force along z", "inertial"),
    "Mx": ("moment about x", "inertial"),
    "My": ("moment about y", "inertial"),
    "Mz": ("moment about z", "inertial"),
    "px": ("linear momentum along x", "inertial"),
    "py": ("linear momentum along y", "inertial"),
    "pz": ("linear momentum along z", "inertial"),
    "Hx": ("angular momentum about the origin, x component", "inertial"),
    "Hy": ("angular momentum about the origin, y component", "inertial"),
    "Hz": ("angular momentum about the origin, z component", "inertial"),
}

#: Per sensor type: component → (quantity, frame or None for a scalar). Checked first.
_BY_TYPE = {
    # Spellings before 0.2, kept as aliases until 0.3.
    "node_displacement": {a: (f"displacement along {a} (old name of u{a})", "inertial") for a in "xyz"},
    "node_rotation": {
        **{
            f"R{i}{j}": (f"triad matrix entry ({i},{j}), node axis {j}", "inertial")
            for i in "123"
            for j in "123"
        },
        **{a: (f"rotation vector, {a} component (old name of r{a})", "inertial") for a in "xyz"},
    },
    "relative_position": {
        **{f"x{i}": (f"position along the reference's axis {i}", "node") for i in "123"},
        **{f"r{i}": (f"distance from the reference's axis {i}", "node") for i in "123"},
    },
    "joint_reaction": {
        **{f"F{i}": (f"reaction force along joint axis {i}", "joint") for i in "123"},
        **{f"M{i}": (f"reaction moment about joint axis {i}", "joint") for i in "123"},
        **{
            f"{q}{a}": (f"reaction {w} {p} {a}", "inertial")
            for q, w, p in (("F", "force", "along"), ("M", "moment", "about"))
            for a in "xyz"
        },
        "violation": ("largest constraint violation (m for points, 1 for directions)", None),
    },
    "beam_section": {
        "F1": ("axial force (tension positive)", "section"),
        "F2": ("shear force along section axis 2", "section"),
        "F3": ("shear force along section axis 3", "section"),
        "M1": ("torque", "section"),
        "M2": ("bending moment about section axis 2", "section"),
        "M3": ("bending moment about section axis 3", "section"),
        "e1": ("axial strain", "section"),
        "g2": ("shear strain along section axis 2", "section"),
        "g3": ("shear strain along section axis 3", "section"),
        "k1": ("twist curvature", "section"),
        "k2": ("bending curvature about section axis 2", "section"),
        "k3": ("bending curvature about section axis 3", "section"),
        "phi1": ("section twist about the beam axis", "reference section"),
        "phi2": ("section bending rotation about axis 2", "reference section"),
        "phi3": ("section bending rotation about axis 3", "reference section"),
    },
    "joint_coordinate": {
        "eta": ("contact point along the beam, fraction of its length", None),
        "eta_rate": ("rate of the contact point's length fraction", None),
        "s": ("contact point's arc length along the beam", None),
    },
    "drive_force": {
        "force": ("driving force", None),
        "torque": ("driving torque", None),
        "force_eta": ("generalized driving force on the contact point's length fraction", None),
        "work": ("work done by the drive", None),
    },
    "friction": {
        "force": ("friction force on the slip (step mean)", None),
        "normal": ("normal force (step mean)", None),
        "slip": ("slip", None),
        "slip_rate": ("slip rate", None),
        "stick": ("stuck (1) or sliding (0)", None),
        "dissipation": ("energy dissipated by friction", None),
    },
    "energy": {
        "kinetic": ("kinetic energy", None),
        "potential": ("potential energy (strain, springs, gravity)", None),
        "total": ("total energy", None),
        "drive_work": ("work done by drives", None),
        "external_work": ("work done by applied loads", None),
        "damper_work": ("work done by dampers", None),
        "friction_dissipation": ("energy dissipated by friction", None),
        "numerical_dissipation": ("energy dissipated by the time scheme", None),
        "balance": ("energy balance residual", None),
    },
    "beam_energy": {
        "kinetic": ("kinetic energy of the beam", None),
        "strain": ("strain energy of the beam", None),
    },
}

#: What each sensor type's channels are of, for the long name.
_SUBJECT = {
    "node_position": "node",
    "node_displacement": "node",
    "node_rotation": "node",
    "node_velocity": "node",
    "relative_position": "node",
    "joint_coordinate": "joint",
    "joint_reaction": "joint",
    "drive_force": "joint",
    "friction": "joint",
    "beam_section": "beam",
    "beam_energy": "beam",
}


def describe(component: str, sensor: dict) -> tuple[str, str | None]:
    """The quantity a sensor's `component` is and its frame (None for scalars)."""
    kind = sensor.get("type", "")
    found = _BY_TYPE.get(kind, {}).get(component) or _VECTOR.get(component)
    if found is None and kind == "joint_coordinate":
        base = component.removesuffix("_rate")
        what = "angle" if base.startswith("phi") else "displacement"
        found = (f"joint {what} `{base}`" + (" rate" if component != base else ""), None)
    if found is None:
        return component, None
    quantity, frame = found
    if frame == "node":
        frame = f"node {sensor.get('reference', '')}".strip()
    if kind == "joint_coordinate" and component in ("x", "y", "z"):
        quantity = "contact point " + quantity
    return quantity, frame


def channel_attrs(names, units, sensors) -> list[dict]:
    """Each channel's attributes: long_name, units, sensor, sensor_type, component, frame."""
    by_name = {s.get("name", ""): s for s in sensors}
    out = []
    for name, unit in zip(names, units):
        sensor_name = max((n for n in by_name if name == n or name.startswith(n + ".")), key=len, default="")
        sensor = by_name.get(sensor_name, {})
        component = name[len(sensor_name) + 1 :] if name != sensor_name else sensor.get("component", "")
        quantity, frame = describe(component, sensor)
        kind = sensor.get("type", "")
        key = _SUBJECT.get(kind)
        subject = f" of {key} `{sensor[key]}`" if key and sensor.get(key) else ""
        attrs = {"long_name": f"{quantity}{subject}", "units": unit}
        attrs.update({"sensor": sensor_name, "sensor_type": kind, "component": component})
        if frame:
            attrs["frame"] = frame
        out.append(attrs)
    return out


def model_hash(data: dict) -> str:
    """A model's fingerprint: sha256 of its canonical JSON (keys sorted), as `sha256:<hex>`."""
    canonical = json.dumps(data, sort_keys=True, separators=(",", ":"))
    return "sha256:" + hashlib.sha256(canonical.encode()).hexdigest()


def global_attrs(data: dict, analysis: str, scheme: str, version: str) -> dict:
    """CF global attributes (Conventions, title, source, history, date_created) and flexdyn's
    own: its version, the model's hash and its simulation settings (JSON)."""
    now = _dt.datetime.now(_dt.UTC).replace(microsecond=0).isoformat().replace("+00:00", "Z")
    name = data.get("name") or "unnamed model"
    return {
        "Conventions": "CF-1.11",
        "title": f"{name}: flexdyn {analysis} results",
        "source": f"flexdyn {version}",
        "history": f"{now} flexdyn {version}: {analysis} analysis ({scheme}) of `{name}`",
        "date_created": now,
        "flexdyn_version": version,
        "model_hash": model_hash(data),
        "settings": json.dumps(data.get("simulation", {}), sort_keys=True),
    }
