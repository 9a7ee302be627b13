"""The tilt-rotor's jackscrews with thread friction (not in the paper): each nut is a thread of
lead 10 mm at 25 mm radius (tan α = 0.064) with μ = 0.1 — self-locking, as jackscrews that must
hold a blade's centrifugal load are — and the retraction drive pays the screw's efficiency.

    python examples/vdtr/thread_friction.py [--t-end 4] [--mu 0.1] [--out DIR]

Runs the conversion's first seconds without and with the friction and prints the jackscrew's
force along the screw (what its drive supplies): retracting pulls the nut inward against the
centrifugal load P, so it costs P tan(α + φ)/tan α (φ = atan μ) instead of P.
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
    spec = importlib.util.spec_from_file_location("vdtr_build", HERE / "build.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


vdtr = _load_build().vdtr


def run(mu: float, t_end: float, out: Path | None = None):
    """The first `t_end` seconds without and with thread friction μ."""
    kw = {"t_end": t_end}
    plain = fd.simulate(vdtr(**kw), out=out / "vdtr.nc" if out else None)
    rubbing = fd.simulate(vdtr(thread_friction=mu, **kw), out=out / "vdtr_thread.nc" if out else None)
    return plain, rubbing


def report(plain, rubbing, mu: float, lead: float = 0.01, radius: float = 0.025) -> str:
    t = rubbing["time"].values
    late = t > 0.5 * t[-1]  # past the start's transient
    load = np.abs(plain["jackscrew_force"].values[late]).mean()
    with_friction = np.abs(rubbing["jackscrew_force"].values[late]).mean()
    tan_alpha = lead / (2 * np.pi * radius)
    factor = np.tan(np.arctan(tan_alpha) + np.arctan(mu)) / tan_alpha
    ratio = with_friction / load
    dissipated = rubbing["energy.friction_dissipation"].values[-1]
    window = f"{t[-1] / 2:.1f}–{t[-1]:.1f} s"
    lines = [
        f"jackscrew thread: lead {lead * 1e3:.0f} mm, radius {radius * 1e3:.0f} mm, tan α = {tan_alpha:.4f}, μ = {mu}",
        f"  jackscrew force (mean over {window}): {load:.0f} N without friction",
        f"  with it: {with_friction:.0f} N, ×{ratio:.3f} (tan(α + φ)/tan α = {factor:.3f})",
        f"  energy the threads dissipated: {dissipated:.1f} J",
    ]
    return "\n".join(lines)


def main():
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--mu", type=float, default=0.1)
    p.add_argument("--t-end", type=float, default=4.0)
    p.add_argument("--out", type=Path)
    a = p.parse_args()
    if a.out:
        a.out.mkdir(parents=True, exist_ok=True)
    plain, rubbing = run(a.mu, a.t_end, a.out)
    print(report(plain, rubbing, a.mu))


if __name__ == "__main__":
    main()
