"""Never crash, never lose a completed step: killed and interrupted runs, a full disk, bad
files and paths, numpy input, and a regression test for every crash found (issue 16)."""

import contextlib
import os
import resource
import signal
import struct
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
import xarray as xr

import flexdyn as fd

EXAMPLES = Path(__file__).resolve().parent.parent / "examples"
PENDULUM = EXAMPLES / "pendulum.yaml"
#: A run long enough to be stopped while it works: 1e7 steps of a pendulum (minutes).
LONG_RUN = ["--fixed-step", "--dt", "1e-5", "--t-end", "100", "--output-dt", "1e-3", "-q"]


def flexdyn(*args, **kw):
    return subprocess.run(
        [sys.executable, "-m", "flexdyn", *map(str, args)], check=False, capture_output=True, text=True, **kw
    )


def records_on_disk(path: Path) -> int:
    """`numrecs` from the header of a NetCDF classic file (0 before the header exists)."""
    try:
        with open(path, "rb") as f:
            head = f.read(8)
    except FileNotFoundError:
        return 0
    return struct.unpack(">i", head[4:8])[0] if len(head) == 8 else 0


def start_long_run(out: Path, min_records=200):
    """A CLI run in the background, returned once at least `min_records` samples are on disk
    (several flushes at FLUSH_WALL_S)."""
    proc = subprocess.Popen(
        [sys.executable, "-m", "flexdyn", "run", str(PENDULUM), "-o", str(out), *LONG_RUN],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    deadline = time.monotonic() + 120
    while records_on_disk(out) < min_records:
        assert proc.poll() is None, proc.stderr.read()
        assert time.monotonic() < deadline, "the run wrote nothing for two minutes"
        time.sleep(0.05)
    return proc


def assert_samples_match_a_fresh_run(path: Path):
    """Every sample in a stopped run's file equals the same samples of an uninterrupted run
    of the same steps (the computation is deterministic, so to round-off)."""
    with xr.open_dataset(path) as ds:
        assert ds.attrs["completed"] == 0
        t = ds.time.values
        assert len(t) >= 200 and np.all(np.diff(t) > 0)
        angle = ds["angle.phi"].values
        ref = fd.simulate(PENDULUM, step_control="fixed", dt=1e-5, t_end=float(t[-1]), output_dt=1e-3)
        np.testing.assert_allclose(t, ref.time.values[: len(t)], rtol=0, atol=1e-12)
        np.testing.assert_allclose(angle, ref["angle.phi"].values[: len(t)], rtol=1e-12, atol=1e-14)


def test_a_killed_run_leaves_a_file_with_every_flushed_sample(tmp_path):
    out = tmp_path / "killed.nc"
    proc = start_long_run(out)
    flushed = records_on_disk(out)
    proc.kill()  # SIGKILL: no handler runs
    proc.wait()
    with xr.open_dataset(out) as ds:
        assert ds.sizes["time"] >= flushed
    assert_samples_match_a_fresh_run(out)


@pytest.mark.parametrize("sig, status", [(signal.SIGTERM, 143), (signal.SIGINT, 130)])
def test_sigterm_and_ctrl_c_stop_within_a_second_and_close_the_file(tmp_path, sig, status):
    out = tmp_path / "stopped.nc"
    proc = start_long_run(out)
    sent = time.monotonic()
    proc.send_signal(sig)
    _, err = proc.communicate(timeout=30)
    waited = time.monotonic() - sent
    # FLUSH_WALL_S = 1 s between chances to stop; 3 s leaves room for a loaded CI machine.
    assert waited < 3.0, f"took {waited:.1f} s to stop"
    assert proc.returncode == status
    assert "Traceback" not in err
    assert f"interrupted ({signal.Signals(sig).name})" in err and "partial results" in err
    assert_samples_match_a_fresh_run(out)


@contextlib.contextmanager
def small_filesystem(tmp_path, size="200k"):
    """A real tmpfs of `size` (needs root); otherwise None (the caller limits the file size)."""
    mount = tmp_path / "small"
    mount.mkdir()
    ok = subprocess.run(
        ["mount", "-t", "tmpfs", "-o", f"size={size}", "tmpfs", str(mount)], check=False, capture_output=True
    )
    try:
        yield mount if ok.returncode == 0 else None
    finally:
        if ok.returncode == 0:
            subprocess.run(["umount", "-l", str(mount)], check=False)


def _limit_file_size():
    resource.setrlimit(resource.RLIMIT_FSIZE, (300_000, 300_000))
    signal.signal(signal.SIGXFSZ, signal.SIG_IGN)  # writes fail with EFBIG instead of killing


def test_a_full_disk_stops_the_run_with_a_message_and_a_readable_file(tmp_path):
    with small_filesystem(tmp_path) as fs:
        out = (fs or tmp_path) / "full.nc"
        args = ["run", PENDULUM, "-o", out, "--fixed-step", "--dt", "1e-4", "--output-dt", "1e-4", "-q"]
        r = subprocess.run(
            [sys.executable, "-m", "flexdyn", *map(str, args)],
            check=False,
            capture_output=True,
            text=True,
            preexec_fn=None if fs else _limit_file_size,
        )
        assert r.returncode == 3, r.stderr
        assert "Traceback" not in r.stderr
        assert ("No space left on device" if fs else "File too large") in r.stderr
        assert "holds the" in r.stderr
        with xr.open_dataset(out) as ds:
            assert ds.attrs["completed"] == 0
            n = ds.sizes["time"]
            assert n > 100 and np.all(np.isfinite(ds["angle.phi"].values))
            np.testing.assert_allclose(np.diff(ds.time.values), 1e-4, rtol=1e-9)


def test_an_exception_in_a_callback_leaves_an_incomplete_file(tmp_nc):
    def boom(t, v):
        raise RuntimeError("user code failed")

    with pytest.raises(RuntimeError, match="user code failed"):
        fd.simulate(PENDULUM, t_end=1.0, out=tmp_nc, on_chunk=boom)
    with xr.open_dataset(tmp_nc) as ds:
        assert ds.attrs["completed"] == 0
        assert ds.sizes["time"] >= 1


def test_completed_only_when_the_run_reached_its_end(tmp_nc):
    fd.simulate(PENDULUM, t_end=0.2, out=tmp_nc)
    with xr.open_dataset(tmp_nc) as ds:
        assert ds.attrs["completed"] == 1
        assert ds.time.values[-1] == pytest.approx(0.2)


BAD_FILES = {
    "missing": (lambda d: d / "nope.yaml", "no such model file"),
    "folder": (lambda d: d, "is a folder"),
    "binary": (lambda d: write(d / "b.yaml", bytes(range(256)) * 4), "not a text model file"),
    "nul": (lambda d: write(d / "n.yaml", b"name: x\x00\n"), "NUL"),
    "empty": (lambda d: write(d / "e.yaml", b""), "the model is empty"),
}


def write(path: Path, data: bytes) -> Path:
    path.write_bytes(data)
    return path


@pytest.mark.parametrize("case", BAD_FILES)
def test_bad_model_files_give_one_line_and_status_2(tmp_path, case):
    make, message = BAD_FILES[case]
    for command in ("run", "check", "info", "modes"):
        r = flexdyn(command, make(tmp_path))
        assert r.returncode == 2, (command, r.stderr)
        assert r.stderr.startswith("error: ") and message in r.stderr, r.stderr
        assert "Traceback" not in r.stderr


def test_a_utf16_model_file_is_read(tmp_path):
    path = tmp_path / "utf16.yaml"
    path.write_text(PENDULUM.read_text(), encoding="utf-16")
    assert fd.load(path).data["name"] == "pendulum"


@pytest.mark.parametrize(
    "out, message",
    [
        ("{d}/missing/r.nc", "No such file or directory"),
        ("{d}", "is a folder"),
        ("/sys/r.nc", "Permission denied"),
        (str(PENDULUM), "is the model file itself"),
    ],
)
def test_unusable_output_paths_give_one_line_and_status_2(tmp_path, out, message):
    before = PENDULUM.read_text()
    r = flexdyn("run", PENDULUM, "-o", out.format(d=tmp_path), "--t-end", "0.01")
    assert r.returncode == 2 and message in r.stderr and "Traceback" not in r.stderr, r.stderr
    assert PENDULUM.read_text() == before


@pytest.mark.parametrize("flag", ["--t-end", "--dt", "--tolerance", "--output-dt"])
@pytest.mark.parametrize("value", ["nan", "inf", "-1"])
def test_non_finite_or_negative_cli_numbers_are_usage_errors(flag, value):
    r = flexdyn("run", PENDULUM, flag, value)
    assert r.returncode == 2 and r.stderr.startswith("error: simulation."), r.stderr


def test_missing_results_file_to_plot_is_one_line(tmp_path):
    r = flexdyn("plot", tmp_path / "none.nc", "angle")
    assert r.returncode == 2 and "no such results file" in r.stderr


def test_no_panic_reaches_python_as_panic_exception():
    with pytest.raises(fd.FlexdynError, match="internal error in a test: deliberate panic"):
        fd._core._panic_for_test()


def test_numpy_numbers_and_arrays_are_model_data():
    m = fd.Model("np")
    m.node("a", position=np.array([1.0, 0.0, 0.0]))
    m.body("b", "a", mass=np.float32(2.0), inertia=np.full(3, 0.01))
    m.revolute("pin", "ground", "a", axis=np.array([0, 1, 0]), position=np.zeros(3))
    m.simulation(t_end=np.float64(0.05), dt=np.float32(0.01))
    res = fd.simulate(m, t_end=np.float64(0.05), dt=np.array(0.01))
    assert res.time.values[-1] == pytest.approx(0.05)
    m.beam("rod", start=[0, 0, 0], end=[1, 0, 0], elements=np.int64(2), section=SECTION)
    assert m.to_dict()["beams"][0]["elements"] == 2


@pytest.mark.parametrize(
    "edit, path",
    [
        (lambda m: m.node("x", position=[float("nan"), 0, 0]), "nodes"),
        (
            lambda m: m.beam("r", start=[0, 0, 0], end=[1, 0, 0], elements=2.7, section=SECTION),
            "beams[0].elements",
        ),
        (lambda m: m.node("y", position=[object(), 0, 0]), "is not model data"),
    ],
)
def test_builder_values_that_are_not_model_data_name_the_item(edit, path):
    m = fd.Model("bad")
    with pytest.raises(fd.ModelError, match=path.replace("[", r"\[").replace("]", r"\]")):
        edit(m)
        m.validate()


SECTION = {
    "ea": 1e6,
    "ga2": 1e5,
    "ga3": 1e5,
    "gj": 1e3,
    "ei2": 1e3,
    "ei3": 1e3,
    "m": 1.0,
    "i22": 1e-3,
    "i33": 1e-3,
}


def pendulum_with(**joint_fields) -> fd.Model:
    m = fd.load(PENDULUM)
    m.data["joints"][0].update(joint_fields)
    return m


@pytest.mark.parametrize(
    "drive",
    [
        " + ".join(["t"] * 90),
        " + ".join(f"{1 / k:.4f}*sin({k}*2*pi*t + 0.3)" for k in range(1, 91)),
        "*".join(["(1 + 0.001*t)"] * 46),
        "sin(" * 46 + "t" + ")" * 46,
        "1e-3*t",
    ],
    ids=["sum90", "fourier90", "product46", "sin46", "scientific"],
)
def test_drive_expressions_that_crashed_the_interpreter_now_run(drive):
    """Regression: exmex's symbolic differentiation overflowed the stack (a segfault)."""
    res = fd.simulate(pendulum_with(drive=drive), t_end=0.02, step_control="fixed", dt=0.01)
    assert np.all(np.isfinite(res["angle.phi"].values))


def test_a_piecewise_drive_has_exact_rates_in_each_piece():
    drive = "t < 0.1 ? 2*t^2 : 0.02 + 0.4*(t - 0.1)"
    res = fd.simulate(pendulum_with(drive=drive), t_end=0.2, step_control="fixed", dt=0.01)
    t = res.time.values
    rate = np.where(t < 0.1, 4 * t, 0.4)
    np.testing.assert_allclose(res["angle.phi_rate"].values, rate, atol=1e-9)


def test_table_drive_with_a_non_finite_t_end_is_a_model_error():
    """Regression: a Rust panic (index out of bounds in the table lookup)."""
    for t_end in (".nan", ".inf"):
        text = PENDULUM.read_text().replace("t_end: 10.0", f"t_end: {t_end}")
        text = text.replace("damping: 0.2}", "damping: 0.2}\n    drive: {t: [0, 1], value: [0, 1]}")
        with pytest.raises(fd.ModelError, match="simulation.t_end"):
            fd._core.parse_yaml(text)


@pytest.mark.parametrize(
    "old, new, message",
    [
        ("name: angle", "name: e/b", "sensors[0].name: `e/b` is not a valid name"),
        ("name: angle", "name: pin_load.Fx", "is not a valid name"),
        (
            "{type: energy, name: energy}",
            "{type: energy, name: energy, compnent: total}",
            "unknown field `compnent`",
        ),
        (
            "damping: 0.2}",
            "damping: 0.2}\n    drive: {t: [0, 1], value: [0, 1], vlaue: [1, 2]}",
            "with no other keys",
        ),
        ("dt: 0.005}", "dt: 0.005, newton_increment_tol: -1}", "simulation.newton_increment_tol"),
        ("dt: 0.005}", "dt: 0.005, output_dt: 1e-9}", "simulation.output_dt: 1.000e10 output samples"),
        ("damping: 0.2}", "damping: 0.2}\n    drive: 'sin t'", "is a function"),
    ],
)
def test_silently_accepted_inputs_are_now_model_errors(old, new, message):
    text = PENDULUM.read_text()
    assert old in text
    with pytest.raises(
        fd.ModelError, match=message.replace("[", r"\[").replace("]", r"\]").replace(".", r"\.")
    ):
        fd._core.parse_yaml(text.replace(old, new))


def test_resource_limits_are_checked_before_allocating():
    m = fd.Model("huge")
    m.beam("rod", start=[0, 0, 0], end=[1, 0, 0], elements=10**7, section=SECTION)
    start = time.process_time()
    with pytest.raises(fd.ModelError, match=r"beams\[0\]\.elements: .*limit is 100000"):
        m.validate()
    with pytest.raises(fd.ModelError, match="limit is 20000"):
        pendulum_with(drive="t+" * 500_000 + "t").validate()
    # Both refused by counting, not by building (a 1e7-element mesh took gigabytes).
    assert time.process_time() - start < 5.0
    with pytest.raises(fd.ModelError, match="GiB in memory; give `out=`"):
        fd.simulate(PENDULUM, output_dt=1e-6, t_end=90.0)


def test_overwriting_results_while_a_previous_result_is_open(tmp_nc):
    first = fd.simulate(PENDULUM, t_end=0.05, out=tmp_nc)
    second = fd.simulate(PENDULUM, t_end=0.1, out=tmp_nc)
    assert second.time.values[-1] == pytest.approx(0.1)
    first.close()
    second.close()


@pytest.fixture
def cwd_tmp(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    return tmp_path


def test_cli_unexpected_errors_print_no_traceback(cwd_tmp):
    (cwd_tmp / "r.nc").write_text("not netcdf")
    r = flexdyn("plot", "r.nc", "angle")
    assert r.returncode in (2, 3) and r.stderr.startswith("error: ") and "Traceback" not in r.stderr
    assert os.path.exists("r.nc")


def test_the_builder_keeps_copies_of_what_it_was_given():
    """Regression: storing numpy-friendly values as given aliased a shared section dict, so
    editing one model's section changed every later model built from the same dict."""
    section = dict(SECTION)
    position = np.array([1.0, 0.0, 0.0])
    m = fd.Model("copies")
    m.node("a", position=position)
    m.beam("rod", start=[0, 0, 0], end_node="a", elements=2, section=section)
    m.data["beams"][0]["section"]["ei3"] = -1.0
    position[0] = 5.0
    assert section["ei3"] == SECTION["ei3"]
    assert m.to_dict()["nodes"][0]["position"] == [1.0, 0.0, 0.0]
