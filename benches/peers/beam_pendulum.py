"""Work–precision of flexdyn against Exudyn on the beam pendulum (examples/beam_pendulum.yaml).

    python benches/peers/beam_pendulum.py [--repeats 3] [--quick]

Sets up Exudyn in its own environment (benches/peers/.venv, from requirements.txt) on first
use. Every run is a fresh process timed by its own process CPU time around the solve; the
runs of both codes are interleaved, repeated, and the median taken. Accuracy is the largest
tip-position error over the samples every 0.01 s of the 2 s swing, against each code's own
converged solution of its own mesh (flexdyn: 12 cubic elements; Exudyn: 36 linear
geometrically exact elements, the same 37 nodes), computed once and cached in
benches/peers/.cache. The two references' own difference (mesh and mass model) is printed too.
Prints the work–precision tables and the CPU-time ratios at equal accuracy (1e-3 m, 1e-4 m),
interpolated log-log along each curve.
"""

import argparse
import itertools
import json
import math
import statistics
import subprocess
import sys
import venv
from pathlib import Path

HERE = Path(__file__).resolve().parent
VENV = HERE / ".venv"
CACHE = HERE / ".cache"
PEER_PYTHON = VENV / "bin" / "python"
TARGETS = (1e-3, 1e-4)

FIXED_DT = (0.02, 0.01, 0.005, 0.0025, 0.001, 5e-4)
TOLERANCES = (3e-3, 1e-3, 3e-4, 1e-4, 3e-5)
# References: second-order schemes at steps 10–40× below the finest measured.
FLEXDYN_REFERENCE = ("ep", "fixed", 2.5e-5)
EXUDYN_REFERENCE = 2.5e-5


def ensure_peer_env():
    if not PEER_PYTHON.exists():
        print(f"setting up Exudyn in {VENV} ...", flush=True)
        venv.create(VENV, with_pip=True)
        pip = [str(PEER_PYTHON), "-m", "pip", "install", "-q", "-r", str(HERE / "requirements.txt")]
        subprocess.run(pip, check=True)


def flexdyn_run(scheme, control, value):
    cmd = [sys.executable, str(HERE / "flexdyn_beam_pendulum.py"), scheme, control, repr(value)]
    return json.loads(subprocess.run(cmd, check=True, capture_output=True, text=True).stdout)


def exudyn_run(dt, linear_solver="sparse"):
    cmd = [str(PEER_PYTHON), "-W", "ignore", str(HERE / "exudyn_beam_pendulum.py"), repr(dt), linear_solver]
    out = json.loads(subprocess.run(cmd, check=True, capture_output=True, text=True).stdout)
    if not out["ok"]:
        raise RuntimeError(f"Exudyn did not finish at dt = {dt}")
    return out


def cached(name, compute):
    CACHE.mkdir(exist_ok=True)
    path = CACHE / f"{name}.json"
    if path.exists():
        return json.loads(path.read_text())
    print(f"computing reference {name} (once) ...", flush=True)
    data = compute()
    path.write_text(json.dumps(data))
    return data


def tip_error(run, reference):
    """Largest distance between the tips at the sample times both runs have (a run with
    steps longer than 0.01 s has only those on its own step grid)."""
    ref = {round(t / 0.01): p for t, p in zip(reference["times"], reference["tip"])}
    return max(
        math.dist(p, ref[round(t / 0.01)]) for t, p in zip(run["times"], run["tip"]) if round(t / 0.01) in ref
    )


def configurations(quick):
    dts = FIXED_DT[1:4] if quick else FIXED_DT
    tols = TOLERANCES[:4] if quick else TOLERANCES
    configs = []
    for scheme in ("ep", "ed"):
        configs += [("flexdyn", f"{scheme.upper()} fixed", (scheme, "fixed", dt)) for dt in dts]
        configs += [("flexdyn", f"{scheme.upper()} adaptive", (scheme, "adaptive", t)) for t in tols]
    configs += [("exudyn", "Exudyn gen-α, sparse LU", ("sparse", dt)) for dt in dts]
    configs += [("exudyn", "Exudyn gen-α (defaults)", ("dense", dt)) for dt in dts]
    return configs


def measure(configs, repeats, references):
    cpu = {i: [] for i in range(len(configs))}
    results = {}
    # Interleaved: each repeat runs every configuration once, flexdyn and Exudyn alternating.
    order = sorted(range(len(configs)), key=lambda i: (i % 2, i))
    for r in range(repeats):
        for i in order:
            code, _, args = configs[i]
            try:
                out = flexdyn_run(*args) if code == "flexdyn" else exudyn_run(args[1], args[0])
            except (RuntimeError, subprocess.CalledProcessError):
                out = {"cpu": math.nan, "failed": True}
            cpu[i].append(out["cpu"])
            results[i] = out
        print(f"repeat {r + 1}/{repeats} done", flush=True)
    rows = []
    for i, (code, curve, args) in enumerate(configs):
        if results[i].get("failed"):
            print(f"{curve} at {args[-1]:.1e} did not finish; left out", flush=True)
            continue
        err = tip_error(results[i], references[code])
        rows.append(
            {
                "curve": curve,
                "setting": args[-1],
                "cpu": statistics.median(cpu[i]),
                "error": err,
                "steps": results[i]["steps"],
                "factorizations": results[i].get("factorizations"),
            }
        )
    return rows


def cost_at(rows, target):
    """CPU time at tip error `target`, log-log interpolated between the two runs around it."""
    pts = sorted((r["error"], r["cpu"]) for r in rows)
    for (e0, c0), (e1, c1) in itertools.pairwise(pts):
        if e0 <= target <= e1 and e1 > e0:
            w = math.log(target / e0) / math.log(e1 / e0)
            return math.exp(math.log(c0) + w * math.log(c1 / c0))
    return None


def report(rows, reference_gap):
    print(f"\nreference solutions differ by {reference_gap:.2e} m (mesh and mass model, not time step)\n")
    print(f"{'curve':24} {'dt / tol':>9} {'CPU s':>8} {'tip error m':>12} {'steps':>6} {'LU':>6}")
    for r in rows:
        lu = "" if r["factorizations"] is None else r["factorizations"]
        print(
            f"{r['curve']:24} {r['setting']:9.1e} {r['cpu']:8.3f} {r['error']:12.2e} {r['steps']:6d} {lu!s:>6}"
        )
    curves = {}
    for r in rows:
        curves.setdefault(r["curve"], []).append(r)
    peers = {name: curves.pop(name) for name in list(curves) if name.startswith("Exudyn")}
    for peer_name, peer in peers.items():
        print(f"\n{peer_name}: its CPU / flexdyn's CPU at equal tip error (— : a curve does not reach it)")
        print(f"{'curve':22} " + " ".join(f"{t:>9.0e}" for t in TARGETS))
        for name, pts in curves.items():
            cells = []
            for t in TARGETS:
                a, b = cost_at(peer, t), cost_at(pts, t)
                cells.append(f"{a / b:9.2f}" if a and b else f"{'—':>9}")
            print(f"{name:22} " + " ".join(cells))


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--quick", action="store_true", help="fewer step sizes and tolerances")
    args = ap.parse_args()
    ensure_peer_env()
    references = {
        "flexdyn": cached("flexdyn_reference", lambda: flexdyn_run(*FLEXDYN_REFERENCE)),
        "exudyn": cached("exudyn_reference", lambda: exudyn_run(EXUDYN_REFERENCE)),
    }
    rows = measure(configurations(args.quick), args.repeats, references)
    (CACHE / "last_run.json").write_text(json.dumps(rows, indent=1))
    report(rows, tip_error(references["flexdyn"], references["exudyn"]))


if __name__ == "__main__":
    main()
