"""The `flexdyn` command: run a model (dynamic or static), list its natural frequencies,
validate it, or print the model-file schema."""

from __future__ import annotations

import argparse
import sys

from . import _core


def _run(args) -> int:
    from .results import simulate

    try:
        res = simulate(
            args.model,
            t_end=args.t_end,
            dt=args.dt,
            scheme=args.scheme,
            output_dt=args.output_dt,
            step_control="fixed" if args.fixed_step else ("adaptive" if args.tolerance is not None else None),
            tolerance=args.tolerance,
            out=args.output,
            progress=not args.quiet and sys.stderr.isatty(),
        )
    except _core.ModelError as e:
        print(f"error: {e}", file=sys.stderr)
        return 2
    except _core.SolverError as e:
        print(f"error: {e}", file=sys.stderr)
        if args.output:
            print(f"partial results written to {args.output}", file=sys.stderr)
        return 3
    except KeyboardInterrupt as e:
        print(f"\n{e}", file=sys.stderr)
        return 130
    for w in res.attrs.get("warnings_list", []):
        print(f"warning: {w}", file=sys.stderr)
    s = res.attrs["stats"]
    static = res.attrs.get("analysis") == "static"
    if not args.quiet:
        if static:
            print(
                f"STATIC: {s['steps']} load steps, {s['halvings']} halvings, "
                f"{s['newton_iterations']} Newton iterations, wall {s['wall_time_s']:.2f} s; "
                f"max |C| {s['max_constraint_violation']:.2e}"
            )
        else:
            print(
                f"{res.attrs['scheme'].upper()}: {s['steps']} steps "
                f"({s['dt_smallest']:.2e} to {s['dt_largest']:.2e} s, {s['rejected']} rejected), "
                f"{s['newton_iterations']} Newton iterations, {s['factorizations']} factorizations, "
                f"wall {s['wall_time_s']:.2f} s; max |C| {s['max_constraint_violation']:.2e}, "
                f"max energy-identity defect {s['max_energy_defect']:.2e} J"
            )
        if args.output:
            n = res.sizes["load_factor" if static else "time"]
            print(f"wrote {n} samples of {len(res.data_vars)} channels to {args.output}")
    return 0


def _modes(args) -> int:
    from .modes import modes

    try:
        md = modes(args.model, args.count, preload=not args.no_preload)
    except (_core.ModelError, _core.SolverError) as e:
        print(f"error: {e}", file=sys.stderr)
        return 2
    print(f"{'mode':>4}  {'omega [rad/s]':>14}  {'f [Hz]':>12}")
    for k, w, f in zip(md.mode.values, md.omega.values, md.frequency.values):
        print(f"{k:>4}  {w:>14.6g}  {f:>12.6g}")
    return 0


def _validate(args) -> int:
    from .builder import load

    try:
        m = load(args.model)
    except _core.ModelError as e:
        print(f"error: {e}", file=sys.stderr)
        return 2
    print(f"ok: {m!r}")
    return 0


def main(argv=None) -> int:
    p = argparse.ArgumentParser(prog="flexdyn", description=__doc__)
    sub = p.add_subparsers(dest="command", required=True)
    r = sub.add_parser("run", help="run a model file and write its sensors to NetCDF")
    r.add_argument("model")
    r.add_argument("-o", "--output", help="results file (.nc)")
    r.add_argument("--scheme", choices=["ep", "ed"])
    r.add_argument("--t-end", type=float)
    r.add_argument("--dt", type=float)
    r.add_argument("--output-dt", type=float)
    r.add_argument("--tolerance", type=float, help="adaptive steps with this local error tolerance")
    r.add_argument("--fixed-step", action="store_true", help="fixed steps of dt instead of adaptive steps")
    r.add_argument("-q", "--quiet", action="store_true")
    r.set_defaults(func=_run)
    md = sub.add_parser("modes", help="natural frequencies about the static equilibrium")
    md.add_argument("model")
    md.add_argument("-n", "--count", type=int, default=10, help="number of modes (default 10)")
    md.add_argument("--no-preload", action="store_true", help="linearize about the initial configuration")
    md.set_defaults(func=_modes)
    v = sub.add_parser("validate", help="check a model file")
    v.add_argument("model")
    v.set_defaults(func=_validate)
    s = sub.add_parser("schema", help="print the JSON Schema of model files")
    s.set_defaults(func=lambda a: print(_core.schema()) or 0)
    args = p.parse_args(argv)
    return args.func(args)


if __name__ == "__main__":
    sys.exit(main())
