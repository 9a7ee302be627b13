"""Times whole simulations and prints steps, Newton iterations, factorizations and wall time.

python benches/simulate.py            # the examples, a chain of pendulums, a rotor, EP and ED; the VDTR
"""

import math
import time
from pathlib import Path

from beam_section import BEAM_SECTION

import flexdyn as fd

ROOT = Path(__file__).resolve().parent.parent


def chain(n, length=0.5):
    """n rigid links hanging from the ground by revolute joints (a planar chain in 3-D)."""
    m = fd.Model(f"chain_{n}", gravity=[0, 0, -9.81])
    for i in range(n):
        m.node(f"n{i}", [length * (i + 0.5), 0, 0])
        m.body(f"link{i}", f"n{i}", mass=1.0, inertia=[1e-3, length**2 / 12, length**2 / 12])
        m.revolute(
            f"pin{i}",
            "ground" if i == 0 else f"n{i - 1}",
            f"n{i}",
            axis=[0, 1, 0],
            position=[length * i, 0, 0],
        )
    m.sensor("energy", "energy")
    return m


def beam_pendulum(elements=12):
    """Issue 3's benchmark: 2.4 m beam of `elements` cubic elements (12) (the paper's beam section), pinned at
    the root, 40 kg tip mass, released horizontally under gravity, 2 s."""
    m = fd.Model("beam pendulum", gravity=[0, -9.81, 0])
    m.node("root", [0, 0, 0]).node("tip", [2.4, 0, 0])
    m.body("tip_body", "tip", mass=40.0, inertia=[0.45, 0.225, 0.225])
    m.beam(
        "beam",
        start_node="root",
        end_node="tip",
        elements=elements,
        order=3,
        section=BEAM_SECTION,
        e2=[0, 1, 0],
    )
    m.spherical("pin", "ground", "root", position=[0, 0, 0])
    m.sensor("energy", "energy")
    return m


def rotor(omega=40.0, blades=3):
    """A hub on a driven shaft with `blades` clamped 2.7 m beams (4 cubic elements each),
    spinning at `omega` rad/s from t = 0: what co-rotated kept factors are for (issue 17)."""
    m = fd.Model("rotor", gravity=[0, 0, -9.81])
    m.node("hub", [0, 0, 0]).body("hub_mass", "hub", mass=20.0, inertia=[2, 2, 4])
    m.revolute("shaft", "ground", "hub", axis=[0, 0, 1], position=[0, 0, 0], drive=f"{omega}*t")
    section = {"ea": 2.0e8, "ga2": 5e7, "ga3": 5e7, "gj": 2e4, "ei2": 4e4, "ei3": 8e5}
    section |= {"m": 8.0, "i22": 2e-3, "i33": 2e-2}
    for k in range(blades):
        a = 2 * math.pi * k / blades
        direction = [math.cos(a), math.sin(a), 0.0]
        root, tip = [0.3 * c for c in direction], [3.0 * c for c in direction]
        m.beam(f"blade{k}", root, tip, elements=4, section=section)
        m.clamp(f"hub_blade{k}", "hub", f"blade{k}.start")
    m.initial_spin(["hub"] + [f"blade{k}" for k in range(blades)], axis=[0, 0, 1], rate=omega)
    return m


def run(label, model, **kw):
    t0 = time.perf_counter()
    res = fd.simulate(model, **kw)
    wall = time.perf_counter() - t0
    s = res.flexdyn.stats
    print(
        f"{label:<28} {res.attrs['scheme']:>3} {s['unknowns']:>6} {s['steps']:>7} "
        f"{s['newton_iterations'] / max(s['steps'], 1):>6.2f} {s['factorizations']:>7} "
        f"{wall:>8.3f} {1e6 * wall / max(s['steps'], 1):>9.1f}"
    )


def main():
    print(
        f"{'case':<28} {'sch':>3} {'unkn':>6} {'steps':>7} {'it/st':>6} {'factor':>7} {'wall s':>8} {'us/step':>9}"
    )
    for path in sorted((ROOT / "examples").glob("*.yaml")):
        for scheme in ("ep", "ed"):
            run(path.stem, fd.load(path), scheme=scheme)
    for scheme in ("ep", "ed"):
        run("beam pendulum (12 cubic)", beam_pendulum(), scheme=scheme, dt=1e-3, t_end=2.0)
    for n in (4, 16, 64):
        for scheme in ("ep", "ed"):
            run(f"chain of {n}", chain(n), scheme=scheme, dt=1e-3, t_end=1.0)
    for scheme in ("ep", "ed"):
        run("rotor 40 rad/s, defaults", rotor(), scheme=scheme, t_end=1.0)
        fixed = {"dt": 1e-3, "t_end": 0.5, "step_control": "fixed"}
        run("rotor 40 rad/s, 1 ms fixed", rotor(), scheme=scheme, **fixed)
    # The tilt-rotor's first 2 s (the whole 20 s: examples/vdtr/paper.py prints its cost).
    run("VDTR 2 s of 20", fd.load(ROOT / "examples" / "vdtr" / "vdtr.yaml"), t_end=2.0)


if __name__ == "__main__":
    main()
