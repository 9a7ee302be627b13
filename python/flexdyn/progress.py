"""The progress bar of a run: tqdm's, on a terminal and in Jupyter (its widget when ipywidgets
is installed, else text), shown once a run has taken DELAY_S, and silent under CI or when
nothing would see it (output piped to a file)."""

from __future__ import annotations

import os
import sys

#: A run shows its bar only after this much wall time (s): quick runs stay quiet.
DELAY_S = 2.0


def in_notebook() -> bool:
    """Whether this is a Jupyter kernel (where stderr is not a terminal, yet a bar shows)."""
    shell = sys.modules.get("IPython") and sys.modules["IPython"].get_ipython()
    return type(shell).__name__ == "ZMQInteractiveShell" if shell else False


def wanted(progress: bool | None) -> bool:
    """`progress` as asked; None (the default): on a terminal or in a notebook, not under CI."""
    if progress is not None:
        return bool(progress)
    if os.environ.get("CI"):
        return False
    return in_notebook() or (hasattr(sys.stderr, "isatty") and sys.stderr.isatty())


class Bar:
    """Simulated time (or load factor) against its end, with the step size and Newton
    iterations per step as a postfix."""

    def __init__(self, end: float, static: bool, delay: float = DELAY_S):
        unit = "" if static else " s"  # a load factor has none
        self.bar = _tqdm_class()(
            total=end,
            delay=delay,
            bar_format="{l_bar}{bar}| {n:.4g}/{total:.4g}" + unit + " [{elapsed}<{remaining}{postfix}]",
            file=sys.stderr,
            dynamic_ncols=True,
        )

    def update(self, position: float, stats: dict, last_dt: float):
        """Moves the bar to `position` (s or load factor)."""
        per_step = stats.get("newton_iterations", 0) / max(stats.get("steps", 0), 1)
        self.bar.set_postfix_str(f"dt {last_dt:.2e} s, {per_step:.1f} it/step", refresh=False)
        self.bar.update(max(0.0, min(position, self.bar.total) - self.bar.n))

    def close(self):
        """Ends the bar (left on screen)."""
        self.bar.close()


def cases(total: int, done: int, delay: float = DELAY_S):
    """A bar counting a sweep's cases (`done` of `total` finished before it starts)."""
    return _tqdm_class()(
        total=total, initial=done, delay=delay, unit="case", file=sys.stderr, dynamic_ncols=True
    )


def _tqdm_class():
    if in_notebook():
        try:
            import ipywidgets  # noqa: F401
            from tqdm.notebook import tqdm

            return tqdm
        except ImportError:
            pass
    from tqdm import tqdm

    return tqdm
