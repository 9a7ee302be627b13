"""The `flexdyn` command: run a model (dynamic or static) or a sweep of it, see the motion (3-D
view, ParaView export, video), plot and compare results, describe or check a model, expand its
patterns, list its natural frequencies (about the equilibrium or along a run), or print the
model-file schema. `--set PATH=VALUE` changes a model's value without editing the file."""

from __future__ import annotations

import argparse
import os
import sys
from pathlib import Path

from . import _core

#: Exit statuses: a bad model or command line; a run that could not complete.
EXIT_USAGE, EXIT_RUN = 2, 3


def _model(args):
    """The model file's path, or the model with `--set` overrides applied (validated)."""
    if not getattr(args, "set", None):
        return args.model
    from .builder import load
    from .overrides import parse_assignment

    return load(args.model).with_(dict(parse_assignment(a) for a in args.set))


def _modes_along(args) -> int:
    """`flexdyn modes --along N`: frequencies at N instants of the model's run."""
    from .trajectory_modes import frequencies_along

    ds = frequencies_along(
        _model(args), samples=args.along, count=args.count, method=args.method, out=args.output
    )
    etas = [n for n in ds.data_vars if n.startswith("eta.")]
    heads = [f"{n:>14}" for n in etas] + [f"{'f' + str(k) + ' [Hz]':>14}" for k in ds["mode"].values]
    print(f"{'t [s]':>10}" + "".join(heads))
    for i, t in enumerate(ds["time"].values):
        row = [ds[n].values[i] for n in etas] + list(ds["frequency"].values[i])
        print(f"{t:>10.4g}" + "".join(f"{v:>14.6g}" for v in row))
    if args.plot:
        from .plots import plot_frequencies

        against = "eta" if len(etas) == 1 else "time"
        print(f"wrote {plot_frequencies(ds, args.plot, against=against)}")
    if args.output:
        print(f"wrote {args.output}")
    return 0


def _campbell(args) -> int:
    """`flexdyn campbell model.yaml --speed [PATH=]START:STOP:COUNT`."""
    import numpy as np

    from .campbell import campbell, plot_campbell

    path, _, span = args.speed.rpartition("=")
    try:
        start, stop, count = span.split(":")
        speeds = np.linspace(float(start), float(stop), int(count))
    except ValueError:
        raise _core.ModelError(
            f"--speed `{args.speed}`: write [PATH=]START:STOP:COUNT, e.g. 0:40:21"
        ) from None
    ds = campbell(_model(args), speeds, speed=path or None, count=args.count)
    print(f"{'speed [rad/s]':>14}" + "".join(f"{'f' + str(k) + ' [Hz]':>12}" for k in ds["mode"].values))
    for i, w in enumerate(ds["speed"].values):
        print(f"{w:>14.6g}" + "".join(f"{f:>12.6g}" for f in ds["frequency"].values[i]))
    return _saved(ds, args, plot_campbell)


def _loaded(args):
    """The model as a `Model`, with its overrides."""
    from .builder import load

    model = _model(args)
    return load(model) if isinstance(model, (str, Path)) else model


def _run(args) -> int:
    from .results import Interrupted, simulate

    model = _model(args)
    try:
        res = simulate(
            model,
            t_end=args.t_end,
            dt=args.dt,
            scheme=args.scheme,
            output_dt=args.output_dt,
            step_control="fixed" if args.fixed_step else ("adaptive" if args.tolerance is not None else None),
            tolerance=args.tolerance,
            fields=args.fields,
            timings=True if args.timings else None,
            out=args.output,
            progress=False if args.quiet else None,
        )
    except (_core.SolverError, Interrupted) as e:
        _error(e)
        if args.output and getattr(e, "results", None) is not None:
            n = e.results.sizes.get("time", e.results.sizes.get("load_factor", 0))
            print(f"partial results: {n} samples in {args.output}", file=sys.stderr)
        if isinstance(e, Interrupted):
            return 128 + int(e.signal)
        return EXIT_RUN
    for w in res.flexdyn.warnings:
        print(f"warning: {w}", file=sys.stderr)
    s = res.flexdyn.stats
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
        spin = s.get("steps_set_by_spin", 0)
        if not static and spin > s["steps"] / 2:
            print(
                f"note: a spin set the size of {spin} of {s['steps']} steps — both schemes' "
                "rotation parameters read a spin ω as ω(1 + (ωh)²/12), so steps keep (ωh)²/12 "
                "within the tolerance; a looser `tolerance` takes longer steps at the cost of "
                "the spin's rate and phase"
            )
    if args.timings:
        print(res.flexdyn.timing_report())
    if not args.quiet and args.output:
        n = res.sizes["load_factor" if static else "time"]
        fields = " and the full-field motion" if "node_position" in res else ""
        print(f"wrote {n} samples of {len(_channel_names(res))} channels{fields} to {args.output}")
    return 0


def _channel_names(ds) -> list[str]:
    """The sensors' channels of a results dataset (not the field arrays)."""
    from .fields import is_field_variable

    return [n for n in ds.data_vars if not is_field_variable(n)]


def _modes(args) -> int:
    if args.along:
        return _modes_along(args)
    from .modes import modes

    md = modes(_model(args), args.count, preload=not args.no_preload, method=args.method)
    print(f"{'mode':>4}  {'omega [rad/s]':>14}  {'f [Hz]':>12}")
    for k, w, f in zip(md.mode.values, md.omega.values, md.frequency.values):
        print(f"{k:>4}  {w:>14.6g}  {f:>12.6g}")
    from .plots import plot_modes

    return _saved(md, args, lambda ds, path: plot_modes(ds, path, count=min(args.count, 9)))


def _saved(ds, args, draw) -> int:
    """Draws `ds` to `--plot` with `draw(ds, path)` and writes it to `-o` (NetCDF), if asked."""
    if args.plot:
        print(f"wrote {draw(ds, args.plot)}")
    if args.output:
        ds.to_netcdf(args.output)
        print(f"wrote {args.output}")
    return 0


def _compiled(args):
    """The model file loaded (with its overrides) and compiled (every check a run makes
    before its first step), or None after printing why it cannot be."""
    import json

    try:
        m = _loaded(args)
        return m, _core.Simulation(json.dumps(m.to_dict()))
    except _core.FlexdynError as e:
        _error(e)
        return None


def _validate(args) -> int:
    if (compiled := _compiled(args)) is None:
        return 2
    m, sim = compiled
    for w in sim.warnings:
        print(f"warning: {w}", file=sys.stderr)
    print(f"ok: {m!r}")
    return 0


def _info(args) -> int:
    if (compiled := _compiled(args)) is None:
        return 2
    m, sim = compiled
    d, n = m.data, sim.size
    joints: dict[str, int] = {}
    for j in d.get("joints", []):
        joints[j["type"]] = joints.get(j["type"], 0) + 1
    print(f"model `{d.get('name', '')}`")
    print(f"  bodies      {len(d.get('bodies', []))}")
    beams = ", ".join(
        f"{b['name']} ({b.get('elements', 1)}×p{b.get('order', 3)})" for b in d.get("beams", [])
    )
    print(f"  beams       {len(d.get('beams', []))}: {beams or '-'}; {n['beam_elements']} elements")
    print(
        f"  joints      {len(d.get('joints', []))}: "
        + (", ".join(f"{k} {v}" for k, v in joints.items()) or "-")
    )
    print(f"  nodes       {n['nodes']} (6 unknowns each), joint coordinates {n['coordinates']}")
    print(f"  constraints {n['constraints']} equations (drives included)")
    print(f"  DOFs        {6 * n['nodes'] + n['coordinates'] - n['constraints']} free")
    print(f"  unknowns    {n['unknowns']} in the Newton system ({sim.scheme.upper()} layout)")
    print(f"  sensors     {len(d.get('sensors', []))} giving {len(sim.channel_names)} channels")
    control = sim.step_control
    steps = f"tolerance {sim.tolerance:g}" if control == "adaptive" else f"dt {sim.dt:g} s"
    print(f"  run         {sim.scheme.upper()}, t_end {sim.t_end:g} s, {control} steps ({steps})")
    print(f"  fields      {_field_estimate(sim, d.get('simulation', {}))}")
    return 0


def _size(n: float) -> str:
    for unit in ("B", "kB", "MB", "GB"):
        if n < 1000 or unit == "GB":
            return f"{n:.3g} {unit}"
        n /= 1000
    return ""


def _field_estimate(sim, settings: dict) -> str:
    """The full-field output's estimated size and whether the run records it, and why."""
    per_sample, samples, on = sim.field_estimate
    if settings.get("output_dt"):
        every = "output_dt"
    elif sim.step_control == "fixed" or sim.is_static:
        every = "step"
    else:
        every = "dt; adaptive steps usually grow past it, set output_dt to know"
    size = f"{_size(per_sample)} per sample × ~{samples:.0f} samples (one per {every}) ≈ {_size(per_sample * samples)}"
    if "fields" in settings:
        why = "as simulation.fields says"
    else:
        why = "by default: at most 100 MB" if on else "over 100 MB: set simulation.fields: true"
    return f"{size}; {'recorded' if on else 'not recorded'} ({why})"


def _writing(results: list, make, message: str = "wrote {}") -> int:
    """Checks that the results files exist, calls `make()` (which writes a file and returns
    its path) and says so; its KeyError or ValueError (an unknown channel, a bad option, no
    field output) is a usage error in one line."""
    for f in results:
        if not Path(f).is_file():
            raise _core.ModelError(f"{f}: no such results file")
    try:
        out = make()
    except (KeyError, ValueError) as e:
        print(f"error: {str(e).strip(chr(39))}", file=sys.stderr)
        return EXIT_USAGE
    print(message.format(out))
    return 0


def _plot(args) -> int:
    from .plots import plot

    def make():
        return plot(
            args.results,
            args.sensors,
            args.output,
            labels=args.labels,
            title=args.title,
            overlay=args.overlay,
        )

    return _writing(args.results, make)


def _view(args) -> int:
    from .viewer import write_html

    options = {"color": args.color, "scale": args.scale, "max_frames": args.max_frames}
    options |= {"ribbon_width": args.ribbon_width, "plotly_js": args.plotly_js}
    out = args.output or str(Path(args.results).with_suffix(".html"))
    return _writing([args.results], lambda: write_html(args.results, out, **options))


def _export(args) -> int:
    from .export import export_vtk

    make = lambda: export_vtk(args.results, args.vtk, name=args.name)
    return _writing([args.results], make, "wrote {} (open it in ParaView)")


def _camera(text: str) -> tuple[float, float]:
    try:
        elevation, azimuth = (float(v) for v in text.split(","))
    except ValueError:
        raise ValueError(f"--view: give elevation,azimuth in degrees, e.g. 25,-60 (got `{text}`)") from None
    return elevation, azimuth


def _animate(args) -> int:
    from .animate import animate

    options = {"fps": args.fps, "max_frames": args.max_frames, "scale": args.scale, "color": args.color}
    make = lambda: animate(args.results, args.output, view=_camera(args.view), **options)
    return _writing([args.results], make)


def _split_values(text: str) -> list[str]:
    """`v1,v2,…` split at the commas outside brackets, braces and parentheses (so that
    `[0, 0, 1],[0, 1, 0]` and `sin(t),cos(t)` are two values each)."""
    parts, depth, current = [], 0, ""
    for ch in text:
        depth += (ch in "([{") - (ch in ")]}")
        if ch == "," and depth == 0:
            parts.append(current)
            current = ""
        else:
            current += ch
    return [p.strip() for p in parts + [current] if p.strip()]


def _sweep(args) -> int:
    from .overrides import parse_value
    from .sweep import sweep

    parameters = {}
    for g in args.grid:
        path, sep, values = g.partition("=")
        if not sep or not _split_values(values):
            raise _core.ModelError(
                f"--grid `{g}`: write PATH=V1,V2,…, e.g. --grid joints.pin.spring.stiffness=1e3,1e4"
            )
        parameters[path.strip()] = [parse_value(v) for v in _split_values(values)]
    executor = None
    if args.scheduler:
        try:
            from distributed import Client
        except ImportError:
            raise _core.ModelError(
                "--scheduler needs Dask's distributed: pip install 'flexdyn[cluster]'"
            ) from None
        executor = Client(args.scheduler)
    settings = {
        k: v
        for k, v in (("t_end", args.t_end), ("scheme", args.scheme), ("output_dt", args.output_dt))
        if v is not None
    }
    result = sweep(
        _model(args),
        parameters,
        args.output,
        executor=executor,
        workers=args.workers,
        summary=args.summary or (),
        progress=False if args.quiet else None,
        **settings,
    )
    failed = result.failed()
    print(
        f"{len(result.cases) - len(failed)} of {len(result.cases)} cases done; manifest {result.folder / 'manifest.json'}"
    )
    for c in failed:
        print(f"case {c['index']} {c['parameters']} failed: {c['error']}", file=sys.stderr)
    return EXIT_RUN if failed else 0


def _with(args, **fields):
    for k, v in fields.items():
        setattr(args, k, v)
    return args


def _expand(args) -> int:
    text = _loaded(args).expanded().to_yaml(args.output)
    if not args.output:
        print(text, end="")
    return 0


def _plot_split(args) -> int:
    """`flexdyn plot A.nc [B.nc …] CHANNEL …`: the leading arguments ending in .nc are files."""
    files = [a for a in args.results if a.endswith(".nc")]
    channels = [a for a in args.results if not a.endswith(".nc")] + (args.sensors or [])
    models = [
        a for a in channels if Path(a).suffix.lower() in (".yaml", ".yml", ".json") and Path(a).is_file()
    ]
    if models:
        print(
            f"error: {models[0]} is a model file: run it first (flexdyn run {models[0]} -o results.nc), then plot the results",
            file=sys.stderr,
        )
        return 2
    if not files or not channels:
        print("error: give one or more results files (.nc) and then channels or sensors", file=sys.stderr)
        return 2
    return _plot(_with(args, results=files, sensors=channels))


def _model_argument(parser):
    """The model file, and `--set PATH=VALUE` overrides of its values."""
    parser.add_argument("model")
    parser.add_argument(
        "--set",
        action="append",
        metavar="PATH=VALUE",
        help="change a value of the model without editing it, e.g. --set joints.slider.spring.stiffness=2e4 "
        "(a key, an item's name, keys inside it; repeatable; checked like the file)",
    )


def _version_line() -> str:
    """`flexdyn X (core Y)`: the package and its compiled core, which a stale build sets apart."""
    from . import __version__

    return f"flexdyn {__version__} (core {_core.__version__})"


def main(argv=None) -> int:
    """The `flexdyn` command: parses `argv` (default: the command line) and runs the
    subcommand; returns its exit code (0 success, 2 a usage or model error, 3 a failed run)."""
    p = argparse.ArgumentParser(prog="flexdyn", description=__doc__)
    p.add_argument("--version", action="version", version=_version_line())
    sub = p.add_subparsers(dest="command", required=True)
    r = sub.add_parser("run", help="run a model file and write its sensors to NetCDF")
    _model_argument(r)
    r.add_argument("-o", "--output", help="results file (.nc)")
    r.add_argument("--scheme", choices=["ep", "ed"])
    r.add_argument("--t-end", type=float)
    r.add_argument("--dt", type=float)
    r.add_argument("--output-dt", type=float)
    r.add_argument("--tolerance", type=float, help="adaptive steps with this local error tolerance")
    r.add_argument("--fixed-step", action="store_true", help="fixed steps of dt instead of adaptive steps")
    r.add_argument(
        "--fields",
        action=argparse.BooleanOptionalAction,
        default=None,
        help="record the full-field motion for view/animate/export (default: when its estimate, "
        "shown by `flexdyn info`, is at most 100 MB)",
    )
    r.add_argument(
        "--timings",
        action="store_true",
        help="print where the run's time went, phase by phase (residuals, factorizations, solves, …)",
    )
    r.add_argument("-q", "--quiet", action="store_true")
    r.set_defaults(func=_run)
    md = sub.add_parser(
        "modes", help="natural frequencies about the static equilibrium, or along a run (--along)"
    )
    _model_argument(md)
    md.add_argument("-n", "--count", type=int, default=10, help="number of modes (default 10)")
    md.add_argument("--no-preload", action="store_true", help="linearize about the initial configuration")
    md.add_argument(
        "--method",
        choices=["auto", "dense", "sparse"],
        default="auto",
        help="eigen-solver: dense (every mode, memory ∝ n²), sparse (shift-invert Arnoldi), "
        "auto (dense up to 1500 unknowns; the default)",
    )
    md.add_argument(
        "--plot",
        metavar="FIGURE",
        help="also draw the mode shapes (up to 9; with --along, the frequencies) to this .png/.svg/.pdf",
    )
    md.add_argument(
        "--along",
        type=int,
        metavar="N",
        help="frequencies at N instants along the model's run (linearized about each state reached)",
    )
    md.add_argument(
        "-o", "--output", help="write the modes (with --along: the frequencies as channels) to this .nc"
    )
    md.set_defaults(func=_modes)
    for name in ("check", "validate"):
        v = sub.add_parser(name, help="check a model file (everything a run checks before its first step)")
        _model_argument(v)
        v.set_defaults(func=_validate)
    i = sub.add_parser("info", help="describe a model: bodies, beams, joints, DOFs, constraints")
    _model_argument(i)
    i.set_defaults(func=_info)
    pl = sub.add_parser("plot", help="plot channels of one or more results files against time")
    pl.add_argument("results", nargs="+", help="results files (.nc), then the channels or sensors")
    pl.add_argument(
        "-o", "--output", default="plot.png", help="figure file: .png, .svg or .pdf (default plot.png)"
    )
    pl.add_argument("--labels", nargs="+")
    pl.add_argument("--title")
    pl.add_argument("--overlay", action="store_true", help="all channels in one panel, with a legend")
    pl.add_argument(
        "--sensors", nargs="+", help="channels or sensors (as well as, or instead of, after the files)"
    )
    pl.set_defaults(func=_plot_split)
    cp = sub.add_parser("compare", help="overlay results files (first solid, second dashed)")
    cp.add_argument("results", nargs="+", help="results files (.nc)")
    cp.add_argument("--sensors", nargs="+", required=True, help="channels or sensors to compare")
    cp.add_argument("-o", "--output", default="compare.png", help="figure file: .png, .svg or .pdf")
    cp.add_argument("--labels", nargs="+")
    cp.add_argument("--title")
    cp.add_argument("--overlay", action="store_true", help="all channels in one panel, with a legend")
    cp.set_defaults(func=lambda a: _plot(_with(a, sensors=a.sensors)))
    vw = sub.add_parser("view", help="a 3-D animation of a results file's motion, as one HTML page")
    vw.add_argument("results", help="results file (.nc) with field output")
    vw.add_argument("-o", "--output", help="page to write (default: the results file's name, .html)")
    vw.add_argument(
        "--color", choices=["F1", "F2", "F3", "M1", "M2", "M3"], help="colour beams by a section load"
    )
    vw.add_argument("--scale", type=float, default=1.0, help="deformation scale factor (default 1)")
    vw.add_argument("--max-frames", type=int, default=400, help="frames at most, evenly spread (default 400)")
    vw.add_argument(
        "--ribbon-width",
        type=float,
        help="ribbon width, m (default 3 %% of the model's extent, at most a tenth of the median beam length)",
    )
    vw.add_argument(
        "--plotly-js",
        choices=["inline", "beside"],
        default="inline",
        help="plotly.js in the page (default) or once as plotly.min.js beside it",
    )
    vw.set_defaults(func=_view)
    an = sub.add_parser("animate", help="a results file's motion as a video (.mp4) or animated GIF")
    an.add_argument("results", help="results file (.nc) with field output")
    an.add_argument("-o", "--output", required=True, help="video file: .mp4 or .gif")
    an.add_argument("--fps", type=int, default=25, help="frames per second (default 25)")
    an.add_argument("--max-frames", type=int, default=200, help="frames at most, evenly spread (default 200)")
    an.add_argument("--scale", type=float, default=1.0, help="deformation scale factor (default 1)")
    an.add_argument(
        "--color", choices=["F1", "F2", "F3", "M1", "M2", "M3"], help="colour beams by a section load"
    )
    an.add_argument("--view", default="25,-60", help="camera elevation,azimuth in degrees (default 25,-60)")
    an.set_defaults(func=_animate)
    cb = sub.add_parser("campbell", help="frequencies over a range of spin rates, with Coriolis terms")
    _model_argument(cb)
    cb.add_argument(
        "--speed",
        required=True,
        metavar="[PATH=]START:STOP:COUNT",
        help="spin rates, rad/s: PATH an override path (initial_spins.1.rate) or the rotor's joint (the "
        "initial spin about its axis); default the model's only initial spin",
    )
    cb.add_argument("-n", "--count", type=int, default=6, help="number of modes (default 6)")
    cb.add_argument("--plot", metavar="FIGURE", help="draw the Campbell diagram to this .png/.svg/.pdf")
    cb.add_argument("-o", "--output", help="write the frequencies to this .nc")
    cb.set_defaults(func=_campbell)
    sw = sub.add_parser("sweep", help="run a model for every combination of parameter values")
    _model_argument(sw)
    sw.add_argument(
        "--grid",
        action="append",
        required=True,
        metavar="PATH=V1,V2,…",
        help="a parameter and its values (repeatable: every combination)",
    )
    sw.add_argument(
        "-o",
        "--output",
        required=True,
        metavar="FOLDER",
        help="folder for the cases' results and manifest.json",
    )
    sw.add_argument("--workers", type=int, help="local processes (default: the CPU count)")
    sw.add_argument(
        "--scheduler", metavar="ADDRESS", help="run on a Dask distributed cluster (e.g. tcp://host:8786)"
    )
    sw.add_argument(
        "--summary", nargs="+", metavar="CHANNEL", help="channels summarized in the manifest (max |x|, final)"
    )
    sw.add_argument("--t-end", type=float)
    sw.add_argument("--scheme", choices=["ep", "ed"])
    sw.add_argument("--output-dt", type=float)
    sw.add_argument("-q", "--quiet", action="store_true")
    sw.set_defaults(func=_sweep)
    ex = sub.add_parser("export", help="export a results file's motion (VTU/PVD time series for ParaView)")
    ex.add_argument("results", help="results file (.nc) with field output")
    ex.add_argument("--vtk", required=True, metavar="FOLDER", help="folder for the .vtu files and the .pvd")
    ex.add_argument("--name", help="file name stem (default: the results file's)")
    ex.set_defaults(func=_export)
    e = sub.add_parser(
        "expand", help="print a model file with its patterns expanded and frames placed (YAML)"
    )
    _model_argument(e)
    e.add_argument("-o", "--output", help="write the expanded model to this file instead")
    e.set_defaults(func=_expand)
    s = sub.add_parser("schema", help="print the JSON Schema of model files")
    s.set_defaults(func=lambda a: print(_core.schema()) or 0)
    args = p.parse_args(argv)
    return _guarded(args)


def _error(e: BaseException):
    """One line (or the error's own lines) on stderr, never a traceback."""
    print(f"error: {e}", file=sys.stderr)


def _guarded(args) -> int:
    """Runs a command; every failure becomes a message and an exit status (2: the model or
    the command line, 3: the run). FLEXDYN_DEBUG=1 shows the traceback of an unexpected one."""
    from .storage import OutputError

    try:
        return args.func(args)
    except (_core.ModelError, OutputError) as e:  # an unusable results path is a usage error
        _error(e)
        return EXIT_USAGE
    except _core.FlexdynError as e:
        _error(e)
        return EXIT_RUN
    except KeyboardInterrupt:
        print("\ninterrupted", file=sys.stderr)
        return 130
    except OSError as e:
        _error(f"{e.filename or ''}: {e.strerror}" if e.strerror else e)
        return EXIT_USAGE
    except Exception as e:  # the promise: no traceback reaches a user
        if os.environ.get("FLEXDYN_DEBUG"):
            raise
        _error(
            f"internal error ({type(e).__name__}: {e}); this is a bug in flexdyn, please report it "
            "with the model file (FLEXDYN_DEBUG=1 shows where)"
        )
        return EXIT_RUN


if __name__ == "__main__":
    sys.exit(main())
