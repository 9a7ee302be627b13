"""Where a run's time goes (`simulation.timings`, integrator/timings.rs): the phases a run
reports, their sum, the report a user reads, and the clear error when none were recorded.
No assertion here is about speed (speed is measured in benchmarks): only about the
bookkeeping of the time measured."""

from pathlib import Path

import pytest

import flexdyn as fd
from flexdyn.cli import main

EXAMPLES = Path(__file__).resolve().parent.parent / "examples"
PHASES = {
    "predictor",
    "residuals",
    "tangents",
    "factorizations",
    "solves",
    "contact_borders",
    "step_ends",
    "patterns",
    "outputs",
}


def collar(**timings):
    m = fd.load(EXAMPLES / "free_collar.yaml")
    m.simulation(t_end=0.2, **timings)
    return m


def test_a_timed_run_reports_every_phase_and_they_add_up_to_the_core_time():
    ds = fd.simulate(collar(timings=True))
    t = ds.flexdyn.timings
    assert set(t) == PHASES | {"other", "core"}
    assert all(v >= 0.0 for v in t.values())
    # `other` is the core's time outside every phase (the phases' sum never exceeds it).
    phases = sum(v for k, v in t.items() if k in PHASES)
    assert phases + t["other"] == pytest.approx(t["core"], rel=1e-9)
    # A sliding collar on a beam: its steps assemble, solve and refresh the contact's rows.
    for k in ("residuals", "solves", "contact_borders", "outputs"):
        assert t[k] > 0.0, k
    # The model asked nothing else of the run: same steps as untimed.
    plain = fd.simulate(collar())
    assert plain.flexdyn.stats["newton_iterations"] == ds.flexdyn.stats["newton_iterations"]

    report = ds.flexdyn.timing_report().splitlines()
    assert report[0].startswith("time in the solver core:")
    rows = [line.split() for line in report[1:]]
    assert len(rows) == len(PHASES) + 1
    seconds = [float(r[-4]) for r in rows]
    assert seconds == sorted(seconds, reverse=True)  # the largest phase first
    assert {" ".join(r[:-4]) for r in rows} == {k.replace("_", " ") for k in PHASES | {"other"}}


def test_an_untimed_run_has_no_timings_and_says_how_to_get_them():
    ds = fd.simulate(collar())
    assert ds.flexdyn.timings == {}
    assert not any(k.startswith("time_") for k in ds.flexdyn.stats)
    with pytest.raises(KeyError, match="timings=True"):
        ds.flexdyn.timing_report()


def test_the_run_command_prints_the_timings_when_asked(tmp_path, capsys):
    model = str(EXAMPLES / "free_collar.yaml")
    assert main(["run", model, "--t-end", "0.05", "--timings", "-q"]) == 0
    out = capsys.readouterr().out
    assert out.startswith("time in the solver core:"), out
    assert "factorizations" in out and "contact borders" in out
    assert main(["run", model, "--t-end", "0.05", "-q"]) == 0
    assert "time in the solver core" not in capsys.readouterr().out


def test_timings_are_a_setting_of_the_model_file_and_the_builder(tmp_path):
    m = collar()
    m.simulation(timings=True)
    assert "timings: true" in m.to_yaml()
    # Read back from a model file, it is the same setting (the schema knows it).
    path = tmp_path / "timed.yaml"
    m.to_yaml(path)
    assert fd.load(path).data["simulation"]["timings"] is True
    assert '"timings"' in fd.schema()
    assert "time_core_s" in fd.simulate(fd.load(path)).flexdyn.stats
