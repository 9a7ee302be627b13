"""Cost for a given accuracy, fixed against adaptive steps, EP and ED (issue 6).

python benches/step_control.py

Each problem is run with a tiny fixed step as reference, then with fixed steps and with adaptive
steps at several tolerances; the table gives the largest error of a watched channel (relative
to its range), steps, rejected steps, Newton iterations and wall time.
"""

import time
from pathlib import Path

import numpy as np
from simulate import beam_pendulum

import flexdyn as fd

ROOT = Path(__file__).resolve().parent.parent


def heavy_top():
    m = fd.load(ROOT / "examples" / "heavy_top.yaml")
    m.settings(**{**m.data["simulation"], "t_end": 0.5, "output_dt": 0.01})
    return m, "cm.y", [2e-3, 1e-3, 5e-4], 2.5e-5


def pendulum():
    m = fd.load(ROOT / "examples" / "pendulum.yaml")
    m.settings(**{**m.data["simulation"], "t_end": 5.0, "output_dt": 0.05})
    return m, "angle.phi", [4e-2, 2e-2, 1e-2], 2e-4


def flexible_pendulum():
    m = beam_pendulum()
    m.sensor("node_displacement", "tip_u", node="tip")
    m.settings(t_end=1.0, output_dt=0.01, newton_tol=1e-10)
    return m, "tip_u.y", [4e-3, 2e-3, 1e-3], 1e-4


def main():
    tolerances = [1e-3, 1e-4, 1e-5]
    print("| problem | scheme | steps chosen by | error | steps | rejected | Newton its | wall s |")
    print("| --- | --- | --- | --- | --- | --- | --- | --- |")
    for build in (heavy_top, pendulum, flexible_pendulum):
        model, channel, dts, dt_ref = build()
        for scheme in ("ep", "ed"):
            ref = fd.simulate(model, scheme=scheme, step_control="fixed", dt=dt_ref)[channel].values
            span = np.ptp(ref)
            runs = [("fixed", f"dt {dt:g}", {"step_control": "fixed", "dt": dt}) for dt in dts]
            runs += [
                ("adaptive", f"tol {tol:g}", {"step_control": "adaptive", "tolerance": tol})
                for tol in tolerances
            ]
            for _, label, kw in runs:
                t0 = time.perf_counter()
                try:
                    res = fd.simulate(model, scheme=scheme, **kw)
                except fd.SolverError as e:
                    print(f"| {build.__name__} | {scheme} | {label} | failed: {str(e)[:80]} | | | | |")
                    continue
                wall = time.perf_counter() - t0
                s = res.attrs["stats"]
                err = np.abs(res[channel].values - ref).max() / span
                print(
                    f"| {build.__name__} | {scheme.upper()} | {label} | {err:.1e} | {s['steps']} | {s['rejected']} "
                    f"| {s['newton_iterations']} | {wall:.2f} |",
                    flush=True,
                )


if __name__ == "__main__":
    main()
