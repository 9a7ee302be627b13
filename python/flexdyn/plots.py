"""Time-history figures from results files: one panel per channel, one line per file (the first
solid, the next dashed, as in the paper's case-1/case-2 figures)."""

from __future__ import annotations

from pathlib import Path

import xarray as xr

STYLES = ["-", "--", ":", "-."]


def _channels(ds: xr.Dataset, wanted: list[str]) -> list[str]:
    """The channels asked for: exact names, or a sensor name standing for all its channels."""
    found = []
    for w in wanted:
        if w in ds.data_vars:
            found.append(w)
            continue
        parts = [n for n in ds.data_vars if n.startswith(w + ".")]
        if not parts:
            known = ", ".join(sorted({n.split(".")[0] for n in ds.data_vars}))
            raise KeyError(f"no channel or sensor `{w}` in the results; they have: {known}")
        found.extend(parts)
    return found


def plot(
    files: list[str | Path],
    channels: list[str],
    out: str | Path,
    labels: list[str] | None = None,
    title: str | None = None,
) -> Path:
    """Writes a figure (PNG, SVG or PDF by the extension of `out`) of `channels` against time,
    overlaying the files. Returns the path written."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    sets = [xr.open_dataset(f) for f in files]
    names = _channels(sets[0], channels)
    for f, ds in zip(files[1:], sets[1:]):
        missing = [n for n in names if n not in ds.data_vars]
        if missing:
            raise KeyError(f"{f} has no channel {', '.join(missing)}")
    labels = labels or [ds.attrs.get("model") or Path(f).stem for f, ds in zip(files, sets)]
    fig, axes = plt.subplots(len(names), 1, sharex=True, figsize=(7, 1.2 + 2.0 * len(names)), squeeze=False)
    for ax, name in zip(axes[:, 0], names):
        for k, (ds, label) in enumerate(zip(sets, labels)):
            ax.plot(
                ds["time"].values, ds[name].values, STYLES[k % len(STYLES)], color="k", lw=1.0, label=label
            )
        units = sets[0][name].attrs.get("units", "")
        ax.set_ylabel(f"{name} [{units}]" if units else name)
        ax.grid(alpha=0.3)
    axes[-1, 0].set_xlabel("time [s]")
    if len(sets) > 1:
        axes[0, 0].legend(loc="best", fontsize="small")
    if title:
        axes[0, 0].set_title(title)
    fig.tight_layout()
    out = Path(out)
    fig.savefig(out)
    plt.close(fig)
    for ds in sets:
        ds.close()
    return out
