"""How cost grows with model size: a pinned beam pendulum of N cubic elements (N = 12 … 2000,
up to 72 000 unknowns under ED), fixed steps, default Newton settings.

python benches/scaling.py [N ...]

Prints per N: unknowns, set-up time (model compilation, initial velocities, the pre-load that
starts the beam bent by its fall), CPU per step,
per step and unknown, and the growth factor per doubling of N (1.0× per unknown: linear).
"""

import sys
import time

from simulate import beam_pendulum

import flexdyn as fd

# Steps per timed run: enough that the steps' CPU stands out of the set-up's run-to-run spread
# (the set-up includes the beam's pre-load, ~1 s at 2000 elements; a step ~10 ms).
STEPS = 100


def pendulum(elements, scheme):
    m = beam_pendulum(elements)
    m.simulation(scheme=scheme, step_control="fixed", dt=1e-3, t_end=STEPS * 1e-3)
    return m


def cpu_of_run(elements, scheme, steps):
    model = pendulum(elements, scheme)
    t0 = time.process_time()
    res = fd.simulate(model, t_end=steps * 1e-3)
    return time.process_time() - t0, res.flexdyn.stats["unknowns"]


def measure(elements, scheme):
    """(unknowns, set-up CPU, CPU per step): from runs of 1 and STEPS steps."""
    one, _ = cpu_of_run(elements, scheme, 1)
    many, unknowns = cpu_of_run(elements, scheme, STEPS)
    per_step = (many - one) / (STEPS - 1)
    return unknowns, one - per_step, per_step


def main():
    sizes = [int(a) for a in sys.argv[1:]] or [12, 125, 250, 500, 1000, 2000]
    cpu_of_run(12, "ep", 1)  # untimed: the first results a process builds pay xarray's imports
    print(
        f"{'N':>5} {'sch':>3} {'unknowns':>9} {'set-up s':>9} {'ms/step':>8} {'µs/step/unknown':>16} {'×/doubling':>11}"
    )
    for scheme in ("ep", "ed"):
        previous = None
        for n in sizes:
            unknowns, setup, per_step = measure(n, scheme)
            per_unknown = 1e6 * per_step / unknowns
            growth = ""
            if previous and n == 2 * previous[0]:
                growth = f"{per_step / previous[1]:11.2f}"
            print(
                f"{n:5d} {scheme:>3} {unknowns:9d} {setup:9.2f} {1e3 * per_step:8.2f} {per_unknown:16.2f} {growth:>11}"
            )
            previous = (n, per_step)


if __name__ == "__main__":
    main()
