"""The paper's beam sliders (Bauchau & Bottasso 2001, sections 7.1 and 7.2), built in Python.

    python examples/beam_slider/build.py            # writes the four YAML models next to this file
    flexdyn run examples/beam_slider/case1.yaml -o case1.nc

A flexible beam R→tip (2.4 m, 12 cubic elements, 40 kg tip body) pinned at R by a spherical
joint is pushed by a flexible driver (1.6 m, 3 cubic elements) hinged at A about i3:
- case 1: the driver's top slides along the beam (sliding joint; η prescribed);
- case 2: the driver's top is held at the beam's *material* point s = 0.6 m through a prismatic
  joint (Δ prescribed) followed by a revolute joint about i3;
- twisted: the beam is pre-twisted (k1 = 0.4363 rad/m); case 1 uses a sliding screw joint,
  case 2 a screw joint of pitch 1/k1 followed by a universal joint.

Values the paper does not give are assumptions (also in docs/paper_examples.md):
- A = (0.6, −1.6, 0): the driver vertical from A up to the beam point at η = 0.25 (s = 0.6 m),
  where both drives start (η(0) = 0.25, Δ(0) = 0).
- The beam's section axis 2 is i2 (its soft bending, EI33 = 23 kN·m², is in the plane of the
  mechanism); the driver's axis 2 is i1 (its stiff bending, EI33 = 300 kN·m², in the plane).
- The mass moments per span "1.0 and 11.0 mg.m" are read as g·m: I22 = 1e-3, I33 = 11e-3 kg·m.
- No gravity; the mechanism starts at rest (the drives' rates are zero at t = 0).
- ED scheme with adaptive steps at tolerance 1e-2 (the paper: "automated time-step selection");
  case 1's peaks are then within 2 % of a converged run (docs/paper_examples.md; 3e-3: 0.5 %).
"""

from pathlib import Path

import flexdyn as fd

HERE = Path(__file__).resolve().parent

# Section 7.1: the beam, and the driver with its bending and shear stiffnesses swapped.
BEAM = {
    "ea": 44.0e6,  # N
    "ga2": 2.8e6,  # N (GK22)
    "ga3": 14.0e6,  # N (GK33)
    "gj": 28.0e3,  # N·m²
    "ei2": 300.0e3,  # N·m²
    "ei3": 23.0e3,  # N·m²
    "m": 1.6,  # kg/m
    "i22": 1.0e-3,  # kg·m (assumed: "mg.m" read as g·m)
    "i33": 11.0e-3,  # kg·m
}
DRIVER = {**BEAM, "ei2": 23.0e3, "ei3": 300.0e3, "ga2": 14.0e6, "ga3": 2.8e6}
TWIST = 0.4363  # rad/m, section 7.2
ETA = "0.5 - 0.25*cos(2*pi*t)"  # case 1: contact point along the beam
DELTA = "0.6*(1 - cos(2*pi*t))"  # case 2: slide of the driver's top from s = 0.6 m, m


def beam_slider(
    case: int,
    twisted: bool = False,
    elements: int = 12,
    t_end: float | None = None,
    friction: dict | None = None,
):
    """The beam slider of section 7.1 (or 7.2 when `twisted`), case 1 or 2; `friction` (e.g.
    `{"static": 0.2}`) on the slide (not in the paper: see friction.py)."""
    title = f"{'twisted ' if twisted else ''}beam slider, case {case}"
    m = fd.Model(title)
    m.node("tip", [2.4, 0, 0]).body("tip_body", "tip", mass=40.0, inertia=[0.45, 0.225, 0.225])
    twist = {"twist_rate": TWIST} if twisted else {}
    m.beam("beam", [0, 0, 0], end_node="tip", elements=elements, order=3, section=BEAM, e2=[0, 1, 0], **twist)
    m.beam("driver", [0.6, -1.6, 0], [0.6, 0, 0], elements=3, order=3, section=DRIVER, e2=[1, 0, 0])
    m.spherical("R", "ground", "beam.0", position=[0, 0, 0])
    m.revolute("A", "ground", "driver.0", axis=[0, 0, 1], position=[0.6, -1.6, 0])
    top = "driver.9"
    if case == 1:
        slide = m.sliding_screw if twisted else m.sliding
        slide("slide", "beam", top, eta=fd.drive(ETA), friction=friction)
        m.sensor("joint_coordinate", "eta", joint="slide", component="eta")
        m.sensor("drive_force", "drive_force", joint="slide", component="force")  # N along the beam
        m.sensor("drive_force", "drive_force_eta", joint="slide", component="force_eta")  # N per unit η
    else:
        # The sliding piece: a massless node between the beam's material point B and the driver.
        b = f"beam.{elements * 3 // 4}"  # s = 0.6 m (a quarter of the beam: a node of the mesh)
        m.node("sleeve", [0.6, 0, 0])
        if twisted:
            m.screw(
                "slide", b, "sleeve", axis=[1, 0, 0], pitch=1 / TWIST, drive_delta=DELTA, friction=friction
            )
            # Cross axes i2 (sleeve) and i3 (driver): the rotation about the beam axis i1 is
            # transmitted, "the sole relative rotation of the screw joint".
            m.universal("link", "sleeve", top, axis1=[0, 1, 0], axis2=[0, 0, 1])
        else:
            m.prismatic("slide", b, "sleeve", axis=[1, 0, 0], drive=DELTA, friction=friction)
            m.revolute("link", "sleeve", top, axis=[0, 0, 1])
        m.sensor("joint_coordinate", "delta", joint="slide", component="delta")
        m.sensor("drive_force", "drive_force", joint="slide", component="force")  # N along the beam
    if friction is not None:
        m.sensor("friction", "friction", joint="slide")
    for comp, name in (("uy", "u2"), ("uz", "u3"), ("phi1", "phi1"), ("phi3", "phi3")):
        m.sensor("beam_section", f"beam_tip_{name}", beam="beam", eta=1.0, component=comp)
    for comp in ("F1", "F3", "M1", "M3"):
        m.sensor("beam_section", f"beam_mid_{comp}", beam="beam", eta=0.5, component=comp)
    # The root section's rotation about the beam axis: the tip's minus it is the elastic twist.
    m.sensor("beam_section", "beam_root_phi1", beam="beam", eta=0.0, component="phi1")
    m.sensor("beam_section", "driver_mid_F1", beam="driver", eta=0.5, component="F1")
    m.sensor("energy", "energy")
    m.simulation(
        scheme="ed",
        t_end=t_end or (3.0 if twisted else 2.0),
        dt=1e-3,
        output_dt=0.002,
        tolerance=1e-2,
        modified_newton=True,  # factors reused while h is unchanged: ~2× faster
    )
    return m


MODELS = {
    "case1": {"case": 1},
    "case2": {"case": 2},
    "twisted_case1": {"case": 1, "twisted": True},
    "twisted_case2": {"case": 2, "twisted": True},
}


if __name__ == "__main__":
    for stem, kw in MODELS.items():
        path = HERE / f"{stem}.yaml"
        assumptions = __doc__.split("Values the paper does not give are assumptions")[1].split("\n", 1)[1]
        header = (
            "# Generated by examples/beam_slider/build.py. Assumptions (values the paper does not give):\n"
        )
        header += "".join(f"# {line}\n" if line else "#\n" for line in assumptions.strip().splitlines())
        path.write_text(header + beam_slider(**kw).to_yaml())
        print(f"wrote {path}")
