"""Work-precision of adaptive against fixed steps, EP and ED (issues 6 and 15).

    python benches/step_control.py                 # all problems, both schemes (~15 min)
    python benches/step_control.py beam_pendulum   # one problem
    python benches/step_control.py --repeats 5

For each problem a converged reference is computed with a tiny fixed step; then runs with fixed
steps and with adaptive steps at several tolerances record a watched quantity at the requested
output times. The table gives, per run:

- `error`: the largest error of the watched quantity at the output times (a position in m,
  or the beam slider's mid-span axial force in N), and `rel`: that error over the quantity's
  range in the reference — a global relative error, to hold against the tolerance
  (`rel/tol`);
- `ends/samples`: the error at the steps' ends over the error at the samples (dense output
  makes samples as accurate as step ends: ≈ 1);
- steps, rejected steps, Newton iterations, and the process CPU time (median of interleaved
  repeats: every configuration is run once per round, so machine load spreads evenly);
- `cost ratio`: for an adaptive run, its CPU time over the time fixed steps need for the same
  error (interpolated log-log along the fixed-step runs, whose error goes as dt²).
"""

import argparse
import resource
import sys
from pathlib import Path

import numpy as np

import flexdyn as fd

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(Path(__file__).resolve().parent))
from simulate import beam_pendulum as _beam_pendulum


def _load(path, **settings):
    m = fd.load(ROOT / "examples" / path)
    m.simulation(**{**m.data["simulation"], **settings})
    return m


POSITION = ["watch.x", "watch.y", "watch.z"]
ALL_TOLERANCES = [1e-2, 1e-3, 1e-4, 1e-5]


def pendulum():
    m = _load("pendulum.yaml", t_end=5.0)
    m.sensor("node_position", "watch", node="bob")
    return m, POSITION, 0.05, [4e-2, 2e-2, 1e-2, 5e-3], 1e-4, ALL_TOLERANCES


def heavy_top():
    m = _load("heavy_top.yaml", t_end=0.5)
    m.sensor("node_position", "watch", node="top")
    return m, POSITION, 0.01, [2e-3, 1e-3, 5e-4, 2.5e-4], 1e-5, ALL_TOLERANCES


def beam_pendulum():
    m = _beam_pendulum()
    m.sensor("node_position", "watch", node="tip")
    m.simulation(t_end=2.0)
    return m, POSITION, 0.01, [1.6e-2, 8e-3, 4e-3, 2e-3, 1e-3], 1e-4, ALL_TOLERANCES


def beam_slider():
    # Case 1 of the paper's beam slider (section 7.1), 2 s: the beam's tip.
    m = _load("beam_slider/case1.yaml", modified_newton=False)
    m.sensor("node_position", "watch", node="tip")
    return m, POSITION, 0.01, [1.6e-2, 8e-3, 4e-3, 2e-3], 1e-4, ALL_TOLERANCES[:3]


def beam_slider_load():
    # The same, watching the paper's load: the beam's mid-span axial force (N). It converges
    # at first order (the contact crosses the C0 path's element boundaries; its ring carries
    # the force), so its reference needs a finer step.
    m = _load("beam_slider/case1.yaml", modified_newton=False)
    return m, ["beam_mid_F1"], 0.01, [8e-3, 4e-3, 2e-3, 1e-3], 1e-4, ALL_TOLERANCES[:3]


PROBLEMS = {f.__name__: f for f in (pendulum, heavy_top, beam_pendulum, beam_slider, beam_slider_load)}


def cpu():
    r = resource.getrusage(resource.RUSAGE_SELF)
    return r.ru_utime + r.ru_stime


def watched(res, channels):
    return np.stack([res[c].values for c in channels], axis=1)


def error_at(ref_t, ref_x, t, x):
    """Largest distance from the reference (interpolated to t) at the times t, leaving out
    the first and last 10 ms (multiplier channels are extrapolated there)."""
    xi = np.stack([np.interp(t, ref_t, ref_x[:, k]) for k in range(ref_x.shape[1])], axis=1)
    inside = (t > ref_t[0] + 0.01) & (t < ref_t[-1] - 0.01)
    return np.linalg.norm(x - xi, axis=1)[inside].max()


def run(model, scheme, kw):
    c0 = cpu()
    res = fd.simulate(model, scheme=scheme, **kw)
    return res, cpu() - c0


def equal_accuracy_time(fixed, error):
    """CPU time fixed steps need for `error`: log-log interpolation along the fixed-step runs
    (extrapolated from the nearest two outside their range)."""
    pts = sorted(fixed)
    e = np.log([p[0] for p in pts])
    c = np.log([p[1] for p in pts])
    x = np.log(error)
    i = int(np.clip(np.searchsorted(e, x) - 1, 0, len(e) - 2))
    slope = (c[i + 1] - c[i]) / (e[i + 1] - e[i])
    return float(np.exp(c[i] + slope * (x - e[i])))


def study(name, scheme, repeats):
    model, channels, out, dts, dt_ref, tolerances = PROBLEMS[name]()
    ref, _ = run(model, scheme, {"step_control": "fixed", "dt": dt_ref, "output_dt": dt_ref})
    ref_t, ref_x = ref["time"].values, watched(ref, channels)
    span = np.ptp(ref_x, axis=0).max()
    configs = [("fixed", f"dt {dt:g}", {"step_control": "fixed", "dt": dt}) for dt in dts]
    configs += [
        ("adaptive", f"tol {tol:g}", {"step_control": "adaptive", "tolerance": tol}) for tol in tolerances
    ]
    times = {label: [] for _, label, _ in configs}
    rows = {}
    for _ in range(repeats):
        for kind, label, kw in configs:
            try:
                res, t = run(model, scheme, {**kw, "output_dt": out})
            except fd.SolverError as e:
                rows[label] = (kind, None, str(e).splitlines()[0][:90])
                continue
            times[label].append(t)
            if label not in rows:
                ends = fd.simulate(model, scheme=scheme, **kw)  # every step recorded
                err = error_at(ref_t, ref_x, res["time"].values, watched(res, channels))
                err_ends = error_at(ref_t, ref_x, ends["time"].values, watched(ends, channels))
                rows[label] = (kind, (err, err_ends, res.flexdyn.stats), kw)
    fixed = [(rows[lb][1][0], np.median(times[lb])) for k, lb, _ in configs if k == "fixed" and rows[lb][1]]
    unit = ref[channels[0]].attrs.get("units", "")
    print(f"\n{name}, {scheme.upper()} (range of {', '.join(channels)}: {span:.3g} {unit})\n")
    print(
        "| steps by | error | rel | rel/tol | ends/samples | steps | rejected | Newton its | CPU s | cost ratio |"
    )
    print("| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |")
    for kind, label, kw in configs:
        kind, data, extra = rows[label]
        if data is None:
            print(f"| {label} | failed: {extra} | | | | | | | | |")
            continue
        err, err_ends, s = data
        t = np.median(times[label])
        rel = err / span
        per_tol = f"{rel / kw['tolerance']:.2f}" if kind == "adaptive" else ""
        ratio = f"{t / equal_accuracy_time(fixed, err):.2f}" if kind == "adaptive" else ""
        print(
            f"| {label} | {err:.2e} | {rel:.1e} | {per_tol} | {err_ends / err:.2f} | {s['steps']} | "
            f"{s['rejected']} | {s['newton_iterations']} | {t:.3f} | {ratio} |",
            flush=True,
        )


def main():
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("problems", nargs="*", help=f"of {', '.join(PROBLEMS)} (default: all)")
    p.add_argument("--schemes", nargs="*", default=["ed", "ep"])
    p.add_argument("--repeats", type=int, default=3)
    a = p.parse_args()
    unknown = [n for n in a.problems if n not in PROBLEMS]
    if unknown:
        p.error(f"unknown problem(s) {', '.join(unknown)}; choose from {', '.join(PROBLEMS)}")
    for name in a.problems or PROBLEMS:
        for scheme in a.schemes:
            study(name, scheme, a.repeats)


if __name__ == "__main__":
    main()
