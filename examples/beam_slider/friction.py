"""The beam slider of case 1 with friction on the slide (not in the paper): the driver's top
rubs along the flexible beam with μ = 0.2, and the drive pays for it.

    python examples/beam_slider/friction.py [--mu 0.2] [--out DIR] [--figures DIR]

Runs case 1 without and with friction (same settings as the paper's run) and prints what the
friction changes: the driving force along the beam, less the frictionless one, against the
friction force μ N (N: the contact force normal to the beam, which the driver's bending sets);
the energy friction dissipates, which the drive supplies; the beam's mid-span loads. Writes
docs/figures/beam_slider_friction.png.
"""

from __future__ import annotations

import argparse
import importlib.util
from pathlib import Path

import numpy as np

import flexdyn as fd

HERE = Path(__file__).resolve().parent


def _load_build():
    """This folder's build.py, by path (another example's `build` may be imported already)."""
    spec = importlib.util.spec_from_file_location("beam_slider_build", HERE / "build.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


beam_slider = _load_build().beam_slider


def run(mu: float, out: Path, t_end: float = 2.0):
    """Case 1 without friction and with `{"static": mu}` on the slide."""
    out.mkdir(parents=True, exist_ok=True)
    plain = fd.simulate(beam_slider(1, t_end=t_end), out=out / "case1.nc")
    rubbing = fd.simulate(beam_slider(1, t_end=t_end, friction={"static": mu}), out=out / "case1_friction.nc")
    return plain, rubbing


def report(plain, rubbing, mu: float) -> str:
    """The numbers friction changes, as lines of text."""
    t = rubbing["time"].values
    extra = rubbing["drive_force"].values - np.interp(t, plain["time"].values, plain["drive_force"].values)
    friction = rubbing["friction.force"].values
    normal = rubbing["friction.normal"].values
    dissipated = rubbing["friction.dissipation"].values[-1]
    drive_work = rubbing["energy.drive_work"].values[-1] - plain["energy.drive_work"].values[-1]
    peak = lambda res, ch: np.abs(res[ch].values).max()
    rms = np.sqrt(np.mean((extra - friction) ** 2))
    lines = [
        f"friction μ = {mu} on the slide of case 1, {t[-1]:.1f} s:",
        f"  normal force (contact force normal to the beam): peak {np.abs(normal).max():.0f} N",
        f"  friction force μN: peak {np.abs(friction).max():.0f} N",
        f"  peak driving force along the beam: {peak(plain, 'drive_force'):.0f} N without friction",
        f"                                      {peak(rubbing, 'drive_force'):.0f} N with it",
        f"  extra driving force: peak {np.abs(extra).max():.0f} N, rms {rms:.1f} N from μN",
        f"  energy dissipated by friction {dissipated:.1f} J; extra drive work {drive_work:.1f} J",
        f"  beam mid-span M3 peak: {peak(plain, 'beam_mid_M3'):.0f} N·m without friction",
        f"                         {peak(rubbing, 'beam_mid_M3'):.0f} N·m with it",
    ]
    return "\n".join(lines)


def figure(plain, rubbing, path: Path):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(2, 1, figsize=(7, 5.5), sharex=True)
    ax[0].plot(plain["time"], plain["drive_force"], label="no friction")
    ax[0].plot(rubbing["time"], rubbing["drive_force"], label="μ = 0.2")
    ax[0].set_ylabel("driving force along the beam (N)")
    ax[0].legend()
    ax[1].plot(rubbing["time"], rubbing["friction.force"], label="friction force μN")
    ax[1].plot(rubbing["time"], rubbing["friction.normal"], label="normal force N", alpha=0.7)
    ax[1].set_ylabel("N")
    ax[1].set_xlabel("time (s)")
    ax[1].legend()
    fig.suptitle("Beam slider, case 1, with friction on the slide")
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=100)
    plt.close(fig)


def main():
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--mu", type=float, default=0.2)
    p.add_argument("--t-end", type=float, default=2.0)
    p.add_argument("--out", type=Path, default=Path("paper_results"))
    p.add_argument("--figures", type=Path, default=HERE.parent.parent / "docs" / "figures")
    a = p.parse_args()
    plain, rubbing = run(a.mu, a.out, a.t_end)
    print(report(plain, rubbing, a.mu))
    figure(plain, rubbing, a.figures / "beam_slider_friction.png")
    print(f"wrote {a.figures / 'beam_slider_friction.png'}")


if __name__ == "__main__":
    main()
