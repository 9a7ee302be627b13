"""The variable-diameter tilt-rotor conversion (Bauchau & Bottasso 2001, section 7.3): a
three-bladed gimballed rotor whose blades telescope inward (jackscrew and nut) while the
nacelle tilts from helicopter to aeroplane mode. Built from sliding and sliding screw joints.

    python examples/vdtr/build.py                 # writes vdtr.yaml next to this file
    flexdyn run examples/vdtr/vdtr.yaml -o vdtr.nc

`vdtr(**parameters)` builds the model in Python; every dimension and property below is a
parameter. Values the paper does not give are assumptions (docs/paper_examples.md):
- Rotor at Ω = 20 rad/s from t = 0 (initial spin), hub 1 m above the tilt axis; three blades.
- Each blade: lag hinge (spring, no damper) at 0.15 m, flap hinge (spring) at 0.25 m, pitch
  bearing at 0.30 m, then a torque tube (0.30 → 3.20 m) with a jackscrew inside it (0.30 →
  2.90 m); the nut rides the jackscrew (sliding screw joint, η prescribed linearly) and carries
  the outboard blade (2.50 → 5.00 m in hover), which is held on the torque tube by two sliding
  screw contacts so its twist follows the tube. Retraction 1.7 m: tip radius 5.0 → 3.3 m (66 %).
- Blade 8 kg/m; flap / lag / torsion stiffness 1.0e5 / 1.0e6 / 1.0e5 N·m², EA 1e8 N: the order
  of a composite blade of this size (an XV-15-class blade, ~3.8 m radius, has flap EI ~ 1e5).
- Gimbal: universal joint between shaft and hub with springs 2e4 N·m/rad and dampers
  500 N·m·s/rad on both rotations.
- Swashplate: a rigid body on the shaft (sliding screw joint at a fixed η, and a sliding joint
  with a free η through a second node rigidly attached to it); pitch links are short stiff
  beams with spherical joints from swashplate arms to pitch horns.
- No aerodynamics, no gravity (the paper's run is in vacuum).
- Starts in steady spin (`preload`: the blades already stretched by their centrifugal loads).
- ED with adaptive steps, tolerance 1e-3: the 20 s run takes ~2 min on one core. (At 1e-2 it
  is no faster — at ~17 ms steps the rotor turns 20° per step, and modified Newton needs ~9
  iterations a step — and the drive torque carries more of the midpoint rule's O((Ωh)²)
  rotation-rate error as the step changes.)
"""

from __future__ import annotations

from math import cos, pi, sin
from pathlib import Path

import flexdyn as fd

HERE = Path(__file__).resolve().parent


def section(m, ei_flap, ei_lag, gj, ea=1e8, ga=5e7, radius_of_gyration=0.05):
    """A beam section (axis 2 in the rotor plane's normal direction for blades: flap bending
    is about axis 2)."""
    i = m * radius_of_gyration**2
    return {
        "ea": ea,
        "ga2": ga,
        "ga3": ga,
        "gj": gj,
        "ei2": ei_flap,
        "ei3": ei_lag,
        "m": m,
        "i22": i / 2,
        "i33": i / 2,
    }


def vdtr(
    blades: int = 3,
    omega: float = 20.0,
    hover_radius: float = 5.0,
    retraction: float = 1.7,
    t_end: float = 20.0,
    conversion_time: float = 20.0,
    blade_section: dict | None = None,
    gimbal_stiffness: float = 2e4,
    gimbal_damping: float = 500.0,
    flap_stiffness: float = 5e4,
    lag_stiffness: float = 1e5,
    hub_height: float = 1.0,
    tolerance: float = 1e-3,
    tilt: bool = True,
    mesh: int = 1,
    thread_friction: float | None = None,
    thread_lead: float = 0.01,
    thread_radius: float = 0.025,
):
    """The VDTR model; `t_end` can be shortened (the conversion still takes `conversion_time`);
    `mesh` multiplies every beam's element count (a mesh-convergence check). With
    `thread_friction` (μ), each nut's sliding screw joint is a thread of `thread_lead` (m per
    turn) at `thread_radius` (m) with that friction: the jackscrew's drive then pays the
    screw's efficiency (not in the paper; see thread_friction.py)."""
    blade = blade_section or section(8.0, 1.0e5, 1.0e6, 1.0e5)
    tube = section(3.0, 2.0e5, 2.0e5, 2.0e5, ea=2e8)
    screw = section(2.0, 5.0e4, 5.0e4, 5.0e4)
    stiff = section(10.0, 1e7, 1e7, 1e7, ea=1e9, ga=5e8)
    link = section(1.0, 1e5, 1e5, 1e5, ea=1e8)
    m = fd.Model("variable-diameter tilt-rotor")
    z = hub_height
    # Nacelle tilted about the wing (i2) by φ = 0.25π(1 − sin(2π(t/40 + 0.25))): 0 → 90° in 20 s.
    period = 2 * conversion_time
    m.node("nacelle", [0, 0, 0]).body("nacelle_body", "nacelle", mass=200.0, inertia=[20, 20, 20])
    m.revolute(
        "tilt",
        "ground",
        "nacelle",
        axis=[0, 1, 0],
        position=[0, 0, 0],
        drive=f"0.25*pi*(1 - sin(2*pi*(t/{period} + 0.25)))" if tilt else "0",
    )
    # Shaft (a beam along i3), spun at Ω relative to the nacelle.
    m.beam("shaft", [0, 0, 0], [0, 0, z], elements=4 * mesh, section=stiff, e2=[1, 0, 0])
    m.revolute("spin", "nacelle", "shaft.0", axis=[0, 0, 1], position=[0, 0, 0], drive=f"{omega}*t")
    # Gimbal and hub.
    m.node("hub", [0, 0, z]).body("hub_body", "hub", mass=50.0, inertia=[5, 5, 8])
    spring = {"stiffness": gimbal_stiffness, "damping": gimbal_damping}
    m.universal("gimbal", "shaft.12", "hub", axis1=[1, 0, 0], axis2=[0, 1, 0], spring1=spring, spring2=spring)
    # Swashplate: held on the shaft at a fixed η (sliding screw: it turns with the shaft), and
    # by a second point with a free η.
    m.node("swash", [0, 0, 0.6 * z]).body("swash_body", "swash", mass=20.0, inertia=[1, 1, 2])
    # (0.45, not 0.5: a contact point resting on an element boundary of the shaft would
    # rebuild the Newton pattern at every tiny oscillation across it.)
    m.node("swash_lower", [0, 0, 0.45 * z])
    m.clamp("swash_rigid", "swash", "swash_lower")
    m.sliding_screw("swash_screw", "shaft", "swash", eta=fd.drive("0.6"))
    m.sliding("swash_slide", "shaft", "swash_lower")
    rotor = ["shaft", "hub", "swash", "swash_lower"]
    r_lag, r_flap, r_root, r_tube, r_screw, r_nut = 0.15, 0.25, 0.30, 3.20, 2.90, hover_radius - 2.5
    screw_len = r_screw - r_root
    for b in range(1, blades + 1):
        psi = 2 * pi * (b - 1) / blades
        u = [cos(psi), sin(psi), 0.0]  # radial
        t = [-sin(psi), cos(psi), 0.0]  # lead-lag direction (rotation sense)

        def at(r, up=0.0, ahead=0.0, u=u, t=t):
            return [r * u[0] + ahead * t[0], r * u[1] + ahead * t[1], z + up]

        n = f"b{b}"
        m.node(f"{n}_lag", at(r_lag)).body(f"{n}_lag_body", f"{n}_lag", mass=0.5, inertia=[1e-3] * 3)
        m.node(f"{n}_flap", at(r_flap)).body(f"{n}_flap_body", f"{n}_flap", mass=0.5, inertia=[1e-3] * 3)
        m.revolute(
            f"{n}_lag_hinge",
            "hub",
            f"{n}_lag",
            axis=[0, 0, 1],
            position=at(r_lag),
            spring={"stiffness": lag_stiffness},
        )
        m.revolute(
            f"{n}_flap_hinge",
            f"{n}_lag",
            f"{n}_flap",
            axis=t,
            position=at(r_flap),
            spring={"stiffness": flap_stiffness},
        )
        # Torque tube from the pitch bearing; jackscrew inside it from the same root node.
        m.node(f"{n}_root", at(r_root))
        m.beam(f"{n}_tube", start_node=f"{n}_root", end=at(r_tube), elements=6 * mesh, section=tube, e2=t)
        m.revolute(f"{n}_pitch", f"{n}_flap", f"{n}_root", axis=u, position=at(r_root))
        m.beam(
            f"{n}_jackscrew", start_node=f"{n}_root", end=at(r_screw), elements=4 * mesh, section=screw, e2=t
        )
        # Outboard blade from the nut; two sliding screw contacts on the torque tube.
        m.beam(f"{n}_blade", at(r_nut), at(hover_radius), elements=5 * mesh, section=blade, e2=t)
        eta0 = (r_nut - r_root) / screw_len
        eta1 = eta0 - retraction / screw_len
        ramp = {"t": [0.0, conversion_time], "value": [eta0, eta1]}  # linear, then held
        thread = None
        if thread_friction is not None:
            thread = {"static": thread_friction, "lead": thread_lead, "radius": thread_radius}
        m.sliding_screw(f"{n}_nut", f"{n}_jackscrew", f"{n}_blade.0", eta=fd.drive(ramp), friction=thread)
        m.sliding_screw(f"{n}_contact1", f"{n}_tube", f"{n}_blade.{2 * mesh}")
        m.sliding_screw(f"{n}_contact2", f"{n}_tube", f"{n}_blade.{4 * mesh}")
        # Pitch horn (on the tube root, ahead of the pitch axis) and pitch link from the
        # swashplate arm below it.
        m.node(f"{n}_horn", at(r_root, ahead=0.15))
        m.clamp(f"{n}_horn_rigid", f"{n}_root", f"{n}_horn")
        m.node(f"{n}_arm", at(r_root, up=-0.4 * z, ahead=0.15))
        m.clamp(f"{n}_arm_rigid", "swash", f"{n}_arm")
        m.beam(
            f"{n}_link",
            start_node=f"{n}_arm",
            end=at(r_root, up=-0.05, ahead=0.15),
            elements=mesh,
            section=link,
            e2=u,
        )
        m.spherical(
            f"{n}_link_top", f"{n}_link.{3 * mesh}", f"{n}_horn", position=at(r_root, up=-0.05, ahead=0.15)
        )
        rotor += [
            f"{n}_lag",
            f"{n}_flap",
            f"{n}_root",
            f"{n}_tube",
            f"{n}_jackscrew",
            f"{n}_blade",
            f"{n}_horn",
            f"{n}_arm",
            f"{n}_link",
        ]
    m.initial_spin(rotor, axis=[0, 0, 1], rate=omega)
    # Sensors (fixed names).
    tip = f"b1_blade.{15 * mesh}"
    for c, comp in (("x", "x"), ("y", "y"), ("z", "z")):
        m.sensor("node_position", f"blade1_tip_{c}", node=tip, component=comp)
    m.sensor("joint_coordinate", "gimbal_rot1", joint="gimbal", component="phi1")
    m.sensor("joint_coordinate", "gimbal_rot2", joint="gimbal", component="phi2")
    m.sensor("joint_coordinate", "pitch_rot", joint="b1_pitch", component="phi")
    m.sensor("joint_coordinate", "lag_rot", joint="b1_lag_hinge", component="phi")
    m.sensor("joint_coordinate", "flap_rot", joint="b1_flap_hinge", component="phi")
    # The blade tip's distance from the hub's spin axis (its axis 3).
    m.sensor("relative_position", "rotor_radius", node=tip, reference="hub", component="r3")
    m.sensor("drive_force", "jackscrew_force", joint="b1_nut", component="force")
    m.sensor("joint_coordinate", "nut_s", joint="b1_nut", component="s")
    # Axial forces: the outboard blade between the nut and its first contact, the torque tube.
    m.sensor("beam_section", "blade1_axial_force", beam="b1_blade", eta=0.1, component="F1")
    m.sensor("beam_section", "tube1_axial_force", beam="b1_tube", eta=0.5, component="F1")
    m.sensor("drive_force", "spin_torque", joint="spin", component="torque")
    m.sensor("drive_force", "tilt_torque", joint="tilt", component="torque")
    m.sensor("energy", "energy")
    # Starts in steady spin: the static pre-load solves the rotor's equilibrium under its
    # centrifugal loads (blades stretched), so the drive holds the spin without a start-up ring.
    m.simulation(
        scheme="ed",
        t_end=t_end,
        dt=1e-3,
        output_dt=0.01,
        tolerance=tolerance,
        modified_newton=True,
        preload=True,
    )
    return m


if __name__ == "__main__":
    path = HERE / "vdtr.yaml"
    path.write_text(
        "# Generated by examples/vdtr/build.py (parameters and assumptions there).\n" + vdtr().to_yaml()
    )
    print(f"wrote {path}")
