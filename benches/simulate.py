"""Times whole simulations and prints steps, Newton iterations, factorizations and wall time.

python benches/simulate.py            # the examples and a chain of pendulums, EP and ED; the VDTR
"""

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
    # The tilt-rotor's first 2 s (the whole 20 s: examples/vdtr/paper.py prints its cost).
    run("VDTR 2 s of 20", fd.load(ROOT / "examples" / "vdtr" / "vdtr.yaml"), t_end=2.0)


if __name__ == "__main__":
    main()
