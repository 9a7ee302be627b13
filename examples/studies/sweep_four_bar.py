"""A parameter sweep: the four-bar's crank torque as its coupler gets heavier and its crank
bearing more damped — 4 × 2 cases on local processes, gathered with the parameters as
dimensions, drawn to docs/figures/sweep_four_bar.png.

    python examples/studies/sweep_four_bar.py [--out DIR] [--figure PATH]

The same from the command line:

    flexdyn sweep examples/four_bar.yaml -o sweep/ --t-end 1 --output-dt 0.005 \\
        --grid bodies.coupler_bar.mass=0.6,1.2,2.4,4.8 --grid joints.crank_pin.spring.damping=0,2 \\
        --summary crank_drive.torque
"""

from __future__ import annotations

import argparse
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt

import flexdyn as fd

HERE = Path(__file__).resolve().parent
GRID = {"bodies.coupler_bar.mass": [0.6, 1.2, 2.4, 4.8], "joints.crank_pin.spring.damping": [0.0, 2.0]}


def main():
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--out", type=Path, default=Path("sweep_four_bar"))
    p.add_argument(
        "--figure", type=Path, default=HERE.parent.parent / "docs" / "figures" / "sweep_four_bar.png"
    )
    args = p.parse_args()
    study = fd.sweep(
        HERE.parent / "four_bar.yaml",
        GRID,
        args.out,
        summary=["crank_drive.torque"],
        t_end=1.0,
        output_dt=0.005,
    )
    torque = study.dataset(["crank_drive.torque"])["crank_drive.torque"]
    fig, (left, right) = plt.subplots(1, 2, figsize=(11, 4.2))
    for mass in GRID["bodies.coupler_bar.mass"]:
        line = torque.sel({"bodies.coupler_bar.mass": mass, "joints.crank_pin.spring.damping": 0.0})
        left.plot(line["time"], line, label=f"coupler {mass:g} kg")
    left.set(xlabel="time [s]", ylabel="crank drive torque [N·m]", title="undamped crank bearing")
    for damping in GRID["joints.crank_pin.spring.damping"]:
        peak = abs(torque.sel({"joints.crank_pin.spring.damping": damping})).max("time")
        right.plot(
            peak["bodies.coupler_bar.mass"], peak, "o-", label=f"bearing damping {damping:g} N·m·s/rad"
        )
    right.set(xlabel="coupler mass [kg]", ylabel="peak |torque| [N·m]", title="peak torque over the sweep")
    for ax in (left, right):
        ax.grid(alpha=0.3)
        ax.legend(fontsize="small")
    fig.tight_layout()
    args.figure.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(args.figure, dpi=110)
    print(f"{len(study.cases)} cases, {len(study.failed())} failed; wrote {args.figure}")


if __name__ == "__main__":
    main()
