"""A Campbell diagram: a three-bladed rotor (2 m blades, hub on a shaft held by its drive)
spun from 0 to 60 rad/s; its lowest frequencies in the turning frame, with the gyroscopic
terms, against the spin rate and the excitation lines 1P … 4P — to
docs/figures/campbell_rotor.png.

    python examples/studies/campbell_rotor.py [--figure PATH]

The same from the command line: `flexdyn campbell rotor.yaml --speed 0:60:13 -n 6 --plot c.png`
(the speed is the rate of the model's initial spin, `initial_spins.0.rate`).
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

import flexdyn as fd
from flexdyn.campbell import plot_campbell

HERE = Path(__file__).resolve().parent
# A 2 m blade: soft lag (ei2, in the rotor plane) and stiffer flap (ei3), 8 kg/m.
BLADE = {
    "ea": 2e8,
    "ga2": 5e7,
    "ga3": 5e7,
    "gj": 2e4,
    "ei2": 5e4,
    "ei3": 5e5,
    "m": 8.0,
    "i22": 0.01,
    "i33": 0.1,
}


def rotor() -> fd.Model:
    m = fd.Model("three-bladed rotor")
    m.node("hub", [0, 0, 0]).body("hub_body", "hub", mass=20.0, inertia=[1, 1, 2])
    m.revolute("shaft", "ground", "hub", axis=[0, 0, 1], position=[0, 0, 0], drive="0")
    with m.pattern("rotor", count=3, axis=[0, 0, 1]) as p:
        p.beam("blade{i}", start_node="hub", end=[2.0, 0, 0], elements=4, section=BLADE, e2=[0, 0, 1])
    m.initial_spin(["hub", "blade1", "blade2", "blade3"], axis=[0, 0, 1], rate=0.0)
    return m


def main():
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument(
        "--figure", type=Path, default=HERE.parent.parent / "docs" / "figures" / "campbell_rotor.png"
    )
    args = p.parse_args()
    ds = fd.campbell(rotor(), np.linspace(0.0, 60.0, 13), count=6)
    args.figure.parent.mkdir(parents=True, exist_ok=True)
    plot_campbell(ds, args.figure)
    f0, f1 = ds["frequency"].values[0], ds["frequency"].values[-1]
    print("at rest [Hz]:", np.round(f0, 3), "\nat 60 rad/s [Hz]:", np.round(f1, 3), f"\nwrote {args.figure}")


if __name__ == "__main__":
    main()
