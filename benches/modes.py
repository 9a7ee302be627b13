"""Times modal analysis of long cantilevers (process CPU and peak memory of this process).

python benches/modes.py [ELEMENTS ...]     default 100 300 1000 2000 cubic elements

Each: a 10 m cantilever of cubic elements (the beam-slider section), 10 lowest modes about its
static equilibrium under gravity, by the sparse path; the dense path too up to 300 elements,
and the largest difference of their frequencies.
"""

import resource
import sys
import time

import numpy as np
from beam_section import BEAM_SECTION

import flexdyn as fd


def cantilever(elements):
    m = fd.Model(f"cantilever {elements}", gravity=[0, 0, -9.81])
    m.beam("b", [0, 0, 0], [10.0, 0, 0], elements=elements, order=3, section=BEAM_SECTION)
    m.clamp("root", "ground", "b.0")
    return m


def timed(elements, method):
    t0 = time.process_time()
    md = fd.modes(cantilever(elements), 10, method=method)
    return time.process_time() - t0, md.frequency.values


def main():
    sizes = [int(a) for a in sys.argv[1:]] or [100, 300, 1000, 2000]
    print(
        f"{'elements':>8} {'unknowns':>9} {'sparse s':>9} {'dense s':>8} {'max rel diff':>13} {'peak MB':>8}"
    )
    for n in sizes:
        cpu_s, f_s = timed(n, "sparse")
        dense, diff = "", ""
        if n <= 300:
            cpu_d, f_d = timed(n, "dense")
            dense, diff = f"{cpu_d:8.2f}", f"{np.max(np.abs(f_s / f_d - 1)):13.1e}"
        peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
        print(f"{n:8d} {6 * (3 * n + 1):9d} {cpu_s:9.2f} {dense:>8} {diff:>13} {peak:8.0f}")
        print(f"         lowest frequencies (Hz): {np.round(f_s[:4], 4)}")


if __name__ == "__main__":
    main()
