"""ED's cost per step against EP's at equal fixed step size (issue 17, item 2).

    python benches/ed_vs_ep.py [--repeats 3] [--dt 1e-3] [--t-end 1.0] [--models a,b] [--phases]

Runs each example with both schemes at the same fixed step and default Newton (modified
Newton, kept factors), interleaved, and prints the median process CPU per step, the Newton
iterations, factorizations and back-substitutions per step, and the ED/EP ratio. With
`--phases`, one more run per scheme with `timings` on (not among the timed ones: its clock
reads cost up to 3 %) shows where ED's extra cost per step sits, phase by phase.
"""

import argparse
import statistics
import time
from pathlib import Path

import flexdyn as fd

EXAMPLES = Path(__file__).resolve().parent.parent / "examples"
# The beam pendulum, the collar sliding freely on a tumbling beam, a linkage, and the paper's
# beam sliders (a collar driven along the beam: its window crosses elements and comes back).
MODELS = (
    "beam_pendulum",
    "free_collar",
    "four_bar",
    "beam_slider/case1",
    "beam_slider/twisted_case1",
)


def run(model: str, scheme: str, dt: float, t_end: float, timings: bool = False) -> tuple[float, dict]:
    m = fd.load(EXAMPLES / f"{model}.yaml")
    m.simulation(scheme=scheme, step_control="fixed", dt=dt, t_end=t_end, timings=timings)
    start = time.process_time()
    res = fd.simulate(m)
    return time.process_time() - start, res.flexdyn.stats


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--dt", type=float, default=1e-3)
    ap.add_argument("--t-end", type=float, default=1.0)
    ap.add_argument("--models", default=",".join(MODELS), help="examples, comma-separated")
    ap.add_argument("--phases", action="store_true", help="also ED's and EP's µs per step by phase")
    args = ap.parse_args()
    models = args.models.split(",")
    # Untimed: the process's first results pay xarray's one-time imports (0.2–0.5 s with dask
    # installed), which the first timed run (EP on the beam pendulum) would otherwise carry.
    run(models[0], "ep", args.dt, args.dt)
    print(f"fixed h = {args.dt} s, {args.t_end} s simulated, median of {args.repeats}")
    print("| model | scheme | µs per step | iterations | factorizations | solves | ED/EP |")
    print("| --- | --- | --- | --- | --- | --- | --- |")
    for model in models:
        times: dict[str, list[float]] = {"ep": [], "ed": []}
        stats: dict[str, dict] = {}
        for _ in range(args.repeats):
            for scheme in ("ep", "ed"):
                cpu, stats[scheme] = run(model, scheme, args.dt, args.t_end)
                times[scheme].append(cpu)
        per_step = {s: statistics.median(times[s]) / stats[s]["steps"] for s in times}
        for scheme in ("ep", "ed"):
            st, n = stats[scheme], stats[scheme]["steps"]
            ratio = f"{per_step['ed'] / per_step['ep']:.2f}" if scheme == "ed" else ""
            print(
                f"| {model} | {scheme.upper()} | {1e6 * per_step[scheme]:.0f} "
                f"| {st['newton_iterations'] / n:.2f} | {st['factorizations'] / n:.2f} "
                f"| {st['linear_solves'] / n:.2f} | {ratio} |"
            )
    if args.phases:
        for model in models:
            print_phases(model, args.dt, args.t_end)


def print_phases(model: str, dt: float, t_end: float) -> None:
    """µs per step by phase (`simulation.timings`) under each scheme, and ED's excess."""
    per_step = {}
    for scheme in ("ep", "ed"):
        _, st = run(model, scheme, dt, t_end, timings=True)
        per_step[scheme] = {
            k[len("time_") : -len("_s")]: 1e6 * v / st["steps"]
            for k, v in st.items()
            if k.startswith("time_") and k.endswith("_s")
        }
    print(f"\n{model}, h = {dt} s: µs per step by phase")
    print("| phase | EP | ED | ED − EP |")
    print("| --- | --- | --- | --- |")
    ep, ed = per_step["ep"], per_step["ed"]
    phases = sorted((k for k in ep if k != "core"), key=lambda k: ep[k] - ed[k])
    for k in [*phases, "core"]:
        print(f"| {k.replace('_', ' ')} | {ep[k]:.1f} | {ed[k]:.1f} | {ed[k] - ep[k]:+.1f} |")


if __name__ == "__main__":
    main()
