"""Natural frequencies along a trajectory: a 5 kg sleeve slides along a 1 m cantilever from
η = 0.3 to 0.9; the run is linearized about 25 of its states and the first frequency drawn
against η with the closed form √(3EI/(M s³))/2π of a cantilever carrying a point mass at s —
to docs/figures/frequencies_along.png.

    python examples/studies/sliding_mass_frequencies.py [--figure PATH]

The same from the command line, for any model: `flexdyn modes model.yaml --along 25 --plot f.png`.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np

import flexdyn as fd
from flexdyn.trajectory_modes import frequencies_along

HERE = Path(__file__).resolve().parent
EI, MASS, L = 2.0e3, 5.0, 1.0


def sliding_mass() -> fd.Model:
    section = {"ea": 1e9, "ga2": 1e9, "ga3": 1e9, "gj": 1e3, "ei2": EI, "ei3": EI, "m": 5e-4}
    m = fd.Model("sliding mass")
    m.beam("bar", [0, 0, 0], [L, 0, 0], elements=8, section=section | {"i22": 1e-9, "i33": 1e-9})
    m.clamp("root", "ground", "bar.0")
    m.node("sleeve", [0.3, 0, 0]).body("mass", "sleeve", mass=MASS, inertia=[1e-9, 1e-9, 1e-9])
    m.sliding_clamp("ride", "bar", "sleeve", drive="0.3 + 0.6*(3*(t/2)^2 - 2*(t/2)^3)")
    return m.simulation(t_end=2.0)


def main():
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument(
        "--figure", type=Path, default=HERE.parent.parent / "docs" / "figures" / "frequencies_along.png"
    )
    args = p.parse_args()
    ds = frequencies_along(sliding_mass(), samples=25, count=1)
    s = ds["eta.ride"].values * L
    exact = np.sqrt(3 * EI / (MASS * s**3)) / (2 * np.pi)
    error = np.abs(ds["frequency"].values[:, 0] / exact - 1).max()
    fine = np.linspace(s.min(), s.max(), 200)
    fig, ax = plt.subplots(figsize=(6.5, 4.2))
    ax.plot(
        fine,
        np.sqrt(3 * EI / (MASS * fine**3)) / (2 * np.pi),
        "-",
        color="0.6",
        label="closed form √(3EI/Ms³)/2π",
    )
    ax.plot(s, ds["frequency"].values[:, 0], "o", ms=4, label="flexdyn, linearized along the run")
    ax.set(
        xlabel="sleeve position s [m]", ylabel="first frequency [Hz]", title=f"largest difference {error:.1e}"
    )
    ax.grid(alpha=0.3)
    ax.legend()
    fig.tight_layout()
    args.figure.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(args.figure, dpi=110)
    print(f"largest relative difference from the closed form {error:.2e}; wrote {args.figure}")


if __name__ == "__main__":
    main()
