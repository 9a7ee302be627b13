"""The progress bar (issue 23): tqdm's, on a terminal and in Jupyter, on by default for runs
longer than DELAY_S, silent under CI and when stderr is not a terminal."""

import io
import sys
import types

import pytest
from test_plots import strip_alone

import flexdyn as fd
from flexdyn import progress


class Terminal(io.StringIO):
    def isatty(self):
        return True


def test_default_is_on_for_a_terminal_or_a_notebook_and_off_under_ci_or_a_pipe(monkeypatch):
    monkeypatch.delenv("CI", raising=False)
    monkeypatch.setattr(sys, "stderr", Terminal())
    assert progress.wanted(None)
    monkeypatch.setenv("CI", "true")
    assert not progress.wanted(None)
    assert progress.wanted(True) and not progress.wanted(False)  # asked for, either way
    monkeypatch.delenv("CI")
    monkeypatch.setattr(sys, "stderr", io.StringIO())  # piped to a file
    assert not progress.wanted(None)
    # A Jupyter kernel: stderr is no terminal, yet the bar shows.
    kernel = type("ZMQInteractiveShell", (), {})()
    monkeypatch.setitem(sys.modules, "IPython", types.SimpleNamespace(get_ipython=lambda: kernel))
    assert progress.in_notebook() and progress.wanted(None)


@pytest.mark.parametrize("static", [False, True])
def test_a_run_asked_for_progress_draws_a_bar_to_its_end(capsys, static):
    m = strip_alone()
    if static:
        fd.solve_static(m, load_steps=3)  # no bar by default here: stderr is captured
        assert capsys.readouterr().err == ""
        m.data["simulation"]["analysis"] = "static"
    fd.simulate(m, t_end=0.05, progress=True)
    err = capsys.readouterr().err
    assert "100%" in err
    assert ("1/1" if static else "0.05/0.05 s") in err and "it/step" in err


def test_a_quick_run_stays_quiet_even_on_a_terminal(monkeypatch):
    monkeypatch.delenv("CI", raising=False)
    term = Terminal()
    monkeypatch.setattr(sys, "stderr", term)
    fd.simulate(strip_alone(), t_end=0.01)  # far under DELAY_S
    assert term.getvalue() == ""


def test_a_sweep_counts_its_cases_and_its_runs_draw_no_bars_of_their_own(tmp_path, capfd):
    from concurrent.futures import ThreadPoolExecutor

    from test_sweep import FOUR_BAR

    with ThreadPoolExecutor(2) as pool:
        fd.sweep(
            FOUR_BAR,
            {"bodies.coupler_bar.mass": [0.6, 1.2, 2.4]},
            tmp_path,
            executor=pool,
            t_end=0.05,
            progress=True,
        )
    err = capfd.readouterr().err
    assert "3/3" in err and "0 failed" in err
    assert " s [" not in err  # no run's bar (simulated seconds) among the cases'
