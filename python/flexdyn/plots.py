"""Figures from results files: channels against time (or against the load factor of static
results) — one panel per channel laid out in a grid, or all of them `overlay`ed in one panel
with a legend; several files drawn over one another (colours and line styles tell them
apart, the first solid, as in the paper's case-1/case-2 figures) — and mode shapes from
`modes`."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import xarray as xr

from .fields import is_field_variable

STYLES = ["-", "--", ":", "-."]


def _channels(ds: xr.Dataset, wanted: list[str]) -> list[str]:
    """The channels asked for: exact names, or a sensor name standing for all its channels
    (its former spellings, kept as aliases, left out)."""
    names = [n for n in ds.data_vars if not is_field_variable(n)]
    aliases = _aliases(names)
    found = []
    for w in wanted:
        if w in names:
            found.append(w)
            continue
        parts = [n for n in names if n.startswith(w + ".") and n not in aliases]
        if not parts:
            known = ", ".join(sorted({n.split(".")[0] for n in names}))
            raise KeyError(f"no channel or sensor `{w}` in the results; they have: {known}")
        found.extend(parts)
    return found


def _aliases(names: list[str]) -> set[str]:
    """The former spellings `.x .y .z` that node_displacement (beside `.ux`) and node_rotation
    (beside `.rx` and `.R11`) still carry: the same data twice in a whole-sensor plot."""
    have, out = set(names), set()
    for n in names:
        sensor, _, comp = n.rpartition(".")
        displacement = comp == "ux" and f"{sensor}.phi1" not in have
        rotation = comp == "rx" and f"{sensor}.R11" in have
        if displacement or rotation:
            out |= {f"{sensor}.{c}" for c in "xyz"}
    return out


def _axis(ds: xr.Dataset, name: str) -> tuple[str, str]:
    """The variable channel `name` runs along — time, or the load factor of static results —
    and its axis label (the coordinate's long name and units)."""
    dims = ds[name].dims
    if len(dims) != 1:
        raise ValueError(f"`{name}` is not a channel over time or load factor (it spans {', '.join(dims)})")
    coord = ds[dims[0]]
    what = coord.attrs.get("long_name") or dims[0].replace("_", " ")
    units = coord.attrs.get("units", "")
    return dims[0], f"{what} [{units}]" if units and units != "1" else what


def _common_axis(files, sets, names) -> tuple[str, str]:
    """The one axis every file's channels share; a one-line error when files differ (a static
    result runs along the load factor, a dynamic one along time)."""
    axes = [_axis(ds, names[0]) for ds in sets]
    for f, (dim, _) in zip(files, axes):
        if dim != axes[0][0]:
            kind = lambda d: {
                "load_factor": "a static result (along the load factor)",
                "time": "a dynamic result (along time)",
            }.get(d, f"along {d}")
            raise ValueError(f"{files[0]} is {kind(axes[0][0])} and {f} {kind(dim)}: plot them separately")
    return axes[0]


def _open(path) -> xr.Dataset:
    """A results file, or a one-line error saying what it is instead."""
    p = Path(path)
    if p.suffix.lower() in (".yaml", ".yml", ".json"):
        raise ValueError(
            f"{p} is a model file: run it first (flexdyn run {p} -o results.nc), then plot the results"
        )
    try:
        return xr.open_dataset(p)
    except OSError as e:
        raise ValueError(f"{p}: cannot read it ({e.strerror or e})") from None
    except ValueError:
        raise ValueError(f"{p} is not a results file: it is not NetCDF") from None


def _grid(n: int) -> tuple[int, int]:
    """Rows and columns for n panels: one column up to 4, then about 3 rows per 2 columns."""
    if n <= 4:
        return n, 1
    cols = min(4, math.ceil(math.sqrt(n / 1.5)))
    return math.ceil(n / cols), cols


def _label(ds: xr.Dataset, name: str) -> str:
    units = ds[name].attrs.get("units", "")
    return f"{name} [{units}]" if units else name


def plot(
    files: list[str | Path],
    channels: list[str],
    out: str | Path,
    labels: list[str] | None = None,
    title: str | None = None,
    overlay: bool = False,
) -> Path:
    """Writes a figure (PNG, SVG or PDF by the extension of `out`) of `channels` (or whole
    sensors) against time or load factor, overlaying the files; `overlay` puts every channel
    in one panel with a legend. Returns the path written."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    sets = []
    try:
        sets.extend(_open(f) for f in files)
        names = _channels(sets[0], channels)
        for f, ds in zip(files[1:], sets[1:]):
            missing = [n for n in names if n not in ds.data_vars]
            if missing:
                raise KeyError(f"{f} has no channel {', '.join(missing)}")
        labels = labels or [ds.attrs.get("model") or Path(f).stem for f, ds in zip(files, sets)]
        if len(labels) != len(sets):
            raise ValueError(f"--labels: {len(labels)} labels for {len(sets)} results files")
        axis = _common_axis(files, sets, names)
        fig = (_overlaid if overlay else _panels)(plt, sets, names, labels, axis)
        if title:
            fig.suptitle(title)
        fig.tight_layout()
        out = Path(out)
        fig.savefig(out)
        plt.close(fig)
    finally:
        for ds in sets:
            ds.close()
    return out


def _panels(plt, sets, names, labels, axis):
    rows, cols = _grid(len(names))
    fig, axes = plt.subplots(
        rows, cols, sharex=True, figsize=(4.2 * cols + 1.5, 1.2 + 2.0 * rows), squeeze=False
    )
    dim, xlabel = axis
    for ax, name in zip(axes.flat, names):
        for k, (ds, label) in enumerate(zip(sets, labels)):
            style = STYLES[k % len(STYLES)]
            ax.plot(ds[dim].values, ds[name].values, style, color=f"C{k}", lw=1.2, label=label)
        ax.set_title(_label(sets[0], name), fontsize="medium")
        ax.grid(alpha=0.3)
    for ax in axes.flat[len(names) :]:
        ax.set_visible(False)
    for ax in axes[-1]:
        ax.set_xlabel(xlabel)
    for c in range(cols):  # the bottom visible panel of each column carries the x label
        visible = [r for r in range(rows) if axes[r, c].get_visible()]
        if visible:
            axes[visible[-1], c].set_xlabel(xlabel)
            axes[visible[-1], c].xaxis.set_tick_params(labelbottom=True)
    if len(sets) > 1:
        axes[0, 0].legend(loc="best", fontsize="small")
    return fig


def _overlaid(plt, sets, names, labels, axis):
    fig, ax = plt.subplots(figsize=(8, 4.8))
    dim, xlabel = axis
    for j, name in enumerate(names):
        for k, (ds, label) in enumerate(zip(sets, labels)):
            tag = _label(ds, name) + (f" — {label}" if len(sets) > 1 else "")
            ax.plot(
                ds[dim].values,
                ds[name].values,
                STYLES[k % len(STYLES)],
                color=f"C{j % 10}",
                lw=1.2,
                label=tag,
            )
    units = {sets[0][n].attrs.get("units", "") for n in names}
    if len(units) == 1 and "" not in units:
        ax.set_ylabel(f"[{units.pop()}]")
    ax.set_xlabel(xlabel)
    ax.grid(alpha=0.3)
    ax.legend(loc="best", fontsize="small", ncol=1 + len(names) // 8)
    return fig


def plot_modes(md: xr.Dataset, out: str | Path, count: int = 6, amplitude: float = 0.1) -> Path:
    """Writes the first `count` mode shapes of a `modes` result to a figure: each beam's
    reference line at the equilibrium (grey) and displaced along the mode (scaled so the
    largest displacement is `amplitude` of the model's extent), titled with the frequency."""
    import json

    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    if "node_position" not in md:
        raise KeyError("these modes carry no geometry (computed by an older flexdyn); compute them again")
    topo = json.loads(md.attrs["flexdyn_topology"])
    x0 = md["node_position"].values
    shown = min(count, md.sizes["mode"])
    rows, cols = math.ceil(shown / 3), min(3, shown)
    fig = plt.figure(figsize=(4.2 * cols, 3.8 * rows))
    extent = float(np.linalg.norm(x0.max(axis=0) - x0.min(axis=0))) or 1.0
    for m in range(shown):
        u = _mode_displacements(md, m, len(x0))
        scale = amplitude * extent / max(float(np.abs(u).max()), 1e-300)
        ax = fig.add_subplot(rows, cols, m + 1, projection="3d")
        _draw_lines(ax, topo, x0, color="0.7", lw=1.0)
        _draw_lines(ax, topo, x0 + scale * u, color="C0", lw=2.0)
        f, z = float(md["frequency"][m]), float(md["damping_ratio"][m])
        ax.set_title(f"mode {m + 1}: {f:.4g} Hz" + (f", ζ = {z:.3g}" if z else ""), fontsize="medium")
        _equal_axes(ax, np.concatenate([x0, x0 + scale * u]))
    fig.tight_layout()
    out = Path(out)
    fig.savefig(out)
    plt.close(fig)
    return out


def _mode_displacements(md: xr.Dataset, m: int, n_nodes: int) -> np.ndarray:
    """Mode m's nodal translations `[node, 3]` (nodes without them stay put)."""
    u = np.zeros((n_nodes, 3))
    nodes = {str(name): k for k, name in enumerate(md["node"].values)}
    for label, value in zip(md["dof"].values, md["shape"].values[m]):
        node, _, comp = str(label).rpartition(".")
        if comp in ("x", "y", "z") and node in nodes:
            u[nodes[node], "xyz".index(comp)] = value
    return u


def _draw_lines(ax, topo, x, **style):
    for b in topo["beams"]:
        p = x[b["nodes"]]
        ax.plot(p[:, 0], p[:, 1], p[:, 2], **style)
    bodies = [b["node"] for b in topo["bodies"] if b["node"] is not None]
    if bodies:
        ax.plot(*x[bodies].T, "s", color=style["color"], ms=5)


def _equal_axes(ax, pts):
    lo, hi = pts.min(axis=0), pts.max(axis=0)
    centre, half = 0.5 * (lo + hi), 0.55 * max((hi - lo).max(), 1e-9)
    ax.set(xlim=(centre[0] - half, centre[0] + half), ylim=(centre[1] - half, centre[1] + half))
    ax.set(zlim=(centre[2] - half, centre[2] + half), xlabel="x", ylabel="y", zlabel="z")
    ax.set_box_aspect((1, 1, 1))


def plot_frequencies(ds: xr.Dataset, out: str | Path, against: str = "time") -> Path:
    """Writes the natural frequencies along a trajectory (`frequencies_along`) against time or
    against a sliding joint's η (`against="eta.<joint>"`, or `"eta"` for the only one)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    etas = [n for n in ds.data_vars if n.startswith("eta.")]
    if against == "eta":
        if len(etas) != 1:
            raise ValueError(f"against: name the sliding joint, one of {', '.join(etas) or 'none'}")
        against = etas[0]
    if against != "time" and against not in ds:
        raise ValueError(f"against: `{against}` is neither time nor one of {', '.join(etas) or 'no η'}")
    x = ds[against].values
    fig, ax = plt.subplots(figsize=(7, 4.5))
    for k in ds["mode"].values:
        ax.plot(x, ds["frequency"].sel(mode=k).values, "o-", ms=3, lw=1.2, label=f"mode {k}")
    ax.set_xlabel("time [s]" if against == "time" else f"{against} [1]")
    ax.set_ylabel("frequency [Hz]")
    ax.grid(alpha=0.3)
    ax.legend(fontsize="small")
    fig.tight_layout()
    out = Path(out)
    fig.savefig(out)
    plt.close(fig)
    return out
