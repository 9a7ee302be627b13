"""The `flexdyn` command: run a model, validate it, or print the model-file schema."""

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
    if not args.quiet:
        print(
            f"{res.attrs['scheme'].upper()}: {s['steps']} steps, {s['halvings']} halvings, "
            f"{s['newton_iterations']} Newton iterations, {s['factorizations']} factorizations, "
            f"wall {s['wall_time_s']:.2f} s; max |C| {s['max_constraint_violation']:.2e}, "
            f"max energy-identity defect {s['max_energy_defect']:.2e} J"
        )
        if args.output:
            print(f"wrote {len(res.time)} samples of {len(res.data_vars)} channels to {args.output}")
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
    r.add_argument("-q", "--quiet", action="store_true")
    r.set_defaults(func=_run)
    v = sub.add_parser("validate", help="check a model file")
    v.add_argument("model")
    v.set_defaults(func=_validate)
    s = sub.add_parser("schema", help="print the JSON Schema of model files")
    s.set_defaults(func=lambda a: print(_core.schema()) or 0)
    args = p.parse_args(argv)
    return args.func(args)


if __name__ == "__main__":
    sys.exit(main())
