"""Reproduces the paper's sections 7.1–7.2: runs the four beam-slider models in full, draws
figures 9–21 (case 1 solid, case 2 dashed) and checks the paper's statements.

    python examples/beam_slider/paper.py [--out DIR] [--figures DIR] [--views DIR]

Results go to DIR (default `paper_results/`), figures to `docs/figures/`, the 3-D views of
the sliding cases (`flexdyn view`: the slider travelling along the beam) to `docs/views/`,
and the table of the
paper's statements against flexdyn's numbers is printed (Markdown) and written to
`docs/figures/claims.md`. `--study` adds the step and mesh convergence study of case 1's peaks.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))

from build import MODELS, beam_slider

import flexdyn as fd
from flexdyn.plots import plot

L = 2.4  # beam length, m: Δ = L·(η − 0.25), so case 2's force per unit η is L·F

# (figure, stem pair, channel, caption) — the paper's figures 9–21.
FIGURES = [
    (9, "", "beam_tip_u2", "beam tip vertical displacement u2"),
    (10, "", "beam_tip_phi3", "beam tip rotation Φ3"),
    (11, "", "beam_mid_F1", "beam mid-span axial force F1"),
    (12, "", "beam_mid_M3", "beam mid-span bending moment M3"),
    (13, "", "driver_mid_F1", "driver mid-span axial force F1"),
    (14, "", "drive_force", "driving force"),
    (15, "twisted_", "beam_tip_u3", "beam tip out-of-plane displacement u3"),
    (16, "twisted_", "beam_tip_phi1", "beam tip twist φ1"),
    (17, "twisted_", "beam_mid_F1", "beam mid-span axial force F1"),
    (18, "twisted_", "beam_mid_F3", "beam mid-span out-of-plane shearing force F3"),
    (19, "twisted_", "beam_mid_M1", "beam mid-span torque M1"),
    (20, "twisted_", "driver_mid_F1", "driver mid-span axial force F1"),
    (21, "twisted_", "drive_force", "driving force"),
]


def run_all(out: Path) -> dict:
    out.mkdir(parents=True, exist_ok=True)
    results = {}
    for stem, kw in MODELS.items():
        t0 = time.perf_counter()
        res = fd.simulate(beam_slider(**kw), out=out / f"{stem}.nc")
        s = res.flexdyn.stats
        wall = time.perf_counter() - t0
        print(
            f"{stem}: {res['time'].values[-1]:.1f} s simulated in {wall:.2f} s wall; {s['steps']} steps "
            f"({s['rejected']} rejected), {s['newton_iterations']} Newton iterations, "
            f"{s['factorizations']} factorizations; energy balance {np.abs(res['energy.balance']).max():.1e} J",
            flush=True,
        )
        results[stem] = res
    return results


def peak(x):
    return float(np.abs(x).max())


def peak_times(t, x, count=3, separation=0.3):
    """Times of the largest |x| peaks, at least `separation` apart."""
    order = np.argsort(-np.abs(x))
    times = []
    for i in order:
        if all(abs(t[i] - s) > separation for s in times):
            times.append(float(t[i]))
        if len(times) == count:
            break
    return sorted(times)


def high_frequency_rms(t, x, window=0.05):
    """RMS of what a moving average over `window` s removes."""
    n = max(round(window / np.median(np.diff(t))), 1)
    smooth = np.convolve(x, np.ones(n) / n, mode="same")
    return float(np.sqrt(np.mean((x - smooth)[n:-n] ** 2)))


def claims(r: dict) -> str:
    c1, c2, t1, t2 = r["case1"], r["case2"], r["twisted_case1"], r["twisted_case2"]
    t = c1["time"].values
    tt = t1["time"].values

    def elastic(res):
        return res["beam_tip_phi1"].values - res["beam_root_phi1"].values

    def ratio(a, b, ch):
        return peak(a[ch].values) / peak(b[ch].values)

    rows = [
        (
            "7.1, fig. 9: case 1 tip displacement has very significant high-frequency content",
            (
                "RMS content above 20 Hz (50 ms moving average removed): case 1 "
                f"{high_frequency_rms(t, c1['beam_tip_u2'].values) * 1e3:.2f} mm, case 2 "
                f"{high_frequency_rms(c2['time'].values, c2['beam_tip_u2'].values) * 1e3:.2f} mm"
            ),
        ),
        (
            "7.1, fig. 11: mid-span axial force about 20× larger in case 1",
            f"peak ratio {ratio(c1, c2, 'beam_mid_F1'):.1f}×",
        ),
        (
            "7.1, fig. 11: case 1 axial force peaks at t = 0.5 and 1.5 s",
            "largest peaks at t = "
            + ", ".join(f"{x:.2f}" for x in peak_times(t, c1["beam_mid_F1"].values, 2))
            + " s",
        ),
        (
            "7.1, fig. 12: mid-span bending moment peak about 30 % higher in case 1",
            f"{100 * (ratio(c1, c2, 'beam_mid_M3') - 1):+.0f} %",
        ),
        (
            "7.1, fig. 13: driver axial force peak about 4× larger in case 1",
            f"{ratio(c1, c2, 'driver_mid_F1'):.1f}×",
        ),
        (
            "7.1, fig. 14: driving force peak about 6× larger in case 1",
            (
                f"{ratio(c1, c2, 'drive_force'):.1f}× as force along the beam (N); "
                f"{peak(c1['drive_force_eta'].values) / (L * peak(c2['drive_force'].values)):.1f}× as force per unit η"
            ),
        ),
        (
            "7.2, figs. 15–16: case 1 displacements and rotations much larger, tip twist up to 2.5×",
            (
                f"tip rotation about the beam axis {ratio(t1, t2, 'beam_tip_phi1'):.1f}× (both ≈ −k1Δ: the "
                f"beam turns on its spherical joint to follow the pre-twist); elastic tip twist "
                f"(tip − root) {peak(elastic(t1)) / peak(elastic(t2)):.1f}× "
                f"({peak(elastic(t1)) * 1e3:.1f} vs {peak(elastic(t2)) * 1e3:.1f} mrad); out-of-plane tip "
                f"displacement {ratio(t1, t2, 'beam_tip_u3'):.1f}×"
            ),
        ),
        (
            "7.2, fig. 17: mid-span axial forces differ in amplitude and frequency",
            f"peak ratio {ratio(t1, t2, 'beam_mid_F1'):.1f}×",
        ),
        (
            "7.2, fig. 18: a large out-of-plane shearing force develops",
            f"peak ratio {ratio(t1, t2, 'beam_mid_F3'):.1f}×",
        ),
        (
            "7.2, fig. 19: case 1 mid-span torque large at t = 0.5, 1.5, 2.5 s; case 2 very small",
            "case 1 largest peaks at t = "
            + ", ".join(f"{x:.2f}" for x in peak_times(tt, t1["beam_mid_M1"].values, 4))
            + f" s (the contact point passes mid-span at t = 0.25, 0.75, …); peak ratio "
            f"{ratio(t1, t2, 'beam_mid_M1'):.1f}×",
        ),
        (
            "7.2, fig. 20: driver axial forces differ sharply",
            f"peak ratio {ratio(t1, t2, 'driver_mid_F1'):.1f}×",
        ),
        (
            "7.2, fig. 21: driving force peak about 5× larger in case 1",
            (
                f"{ratio(t1, t2, 'drive_force'):.1f}× as force along the beam; "
                f"{peak(t1['drive_force_eta'].values) / (L * peak(t2['drive_force'].values)):.1f}× per unit η"
            ),
        ),
    ]
    lines = ["| the paper says | flexdyn computes |", "| --- | --- |"]
    lines += [f"| {a} | {b} |" for a, b in rows]
    return "\n".join(lines) + "\n"


def figures(out: Path, figdir: Path):
    figdir.mkdir(parents=True, exist_ok=True)
    for number, prefix, channel, caption in FIGURES:
        files = [out / f"{prefix}case1.nc", out / f"{prefix}case2.nc"]
        plot(
            files,
            [channel],
            figdir / f"fig{number:02d}_{prefix}{channel}.png",
            labels=["case 1 (sliding)", "case 2 (prismatic)" if not prefix else "case 2 (screw)"],
            title=f"Fig. {number}: {caption}",
        )


#: (page, results stem, colour, deformation scale, title) of the docs' 3-D views.
VIEWS = [
    ("beam_slider", "case1", "M3", 1.0, "Beam slider, case 1 (sliding joint): section 7.1"),
    (
        "twisted_beam_slider",
        "twisted_case1",
        "M1",
        1.0,
        "Twisted beam slider, case 1 (sliding screw joint): 7.2",
    ),
]


def views(out: Path, viewdir: Path):
    """The sliding cases' motion as HTML pages sharing one plotly.min.js (works offline)."""
    for page, stem, color, scale, title in VIEWS:
        fd.view(
            out / f"{stem}.nc",
            viewdir / f"{page}.html",
            color=color,
            scale=scale,
            title=title,
            plotly_js="beside",
        )


def study():
    """Step and mesh convergence of case 1's peaks, against a fine fixed-step run."""
    channels = ["beam_tip_u2", "beam_mid_F1", "beam_mid_M3", "driver_mid_F1", "drive_force"]
    ref = fd.simulate(beam_slider(1), step_control="fixed", dt=2.5e-4)
    base = {c: peak(ref[c].values) for c in channels}
    print("| run | wall s | steps | " + " | ".join(f"{c} peak" for c in channels) + " |")
    print("| --- | --- | --- | " + " | ".join("---" for _ in channels) + " |")
    print("| fixed 2.5e-4 s (reference) | | 8000 | " + " | ".join(f"{base[c]:.4g}" for c in channels) + " |")
    runs = [(f"tolerance {tol:g}", {}, {"tolerance": tol}) for tol in (1e-2, 3e-3, 1e-3)]
    runs += [("fixed 1e-3 s", {}, {"step_control": "fixed", "dt": 1e-3})]
    runs += [("24 elements, tolerance 1e-3", {"elements": 24}, {"tolerance": 1e-3})]
    for label, model_kw, kw in runs:
        t0 = time.perf_counter()
        res = fd.simulate(beam_slider(1, **model_kw), **kw)
        wall = time.perf_counter() - t0
        cells = [
            f"{peak(res[c].values):.4g} ({100 * (peak(res[c].values) / base[c] - 1):+.1f} %)"
            for c in channels
        ]
        print(
            f"| {label} | {wall:.1f} | {res.attrs['stats']['steps']} | " + " | ".join(cells) + " |",
            flush=True,
        )


def main():
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--out", type=Path, default=Path("paper_results"))
    p.add_argument("--figures", type=Path, default=HERE.parent.parent / "docs" / "figures")
    p.add_argument("--views", type=Path, default=HERE.parent.parent / "docs" / "views")
    p.add_argument("--study", action="store_true", help="also run the convergence study of case 1")
    args = p.parse_args()
    results = run_all(args.out)
    figures(args.out, args.figures)
    views(args.out, args.views)
    table = claims(results)
    (args.figures / "claims.md").write_text(table)
    print(table)
    if args.study:
        study()


if __name__ == "__main__":
    main()
