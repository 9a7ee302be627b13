"""`flexdyn view` (issue 20): a self-contained HTML page with a 3-D animation of the motion,
checked in a real headless Chromium — it loads without console errors and without fetching
anything, its canvas is drawn, and its controls (frames, play, scale, colouring) work."""

import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import flexdyn as fd
from flexdyn.viewer import scene, scene_data, write_html

from browser import open_page
from test_fields import swinging_sleeve

ROOT = Path(__file__).resolve().parent.parent


@pytest.fixture(scope="module")
def results(tmp_path_factory):
    out = tmp_path_factory.mktemp("view") / "sleeve.nc"
    fd.simulate(swinging_sleeve(), out=out)
    return out


def plot_area(img: np.ndarray) -> np.ndarray:
    """The 3-D scene's pixels: above the control bar, clear of the legend and colour bar."""
    h, w, _ = img.shape
    return img[60 : h - 80, 180 : w - 120]


def changed(a: np.ndarray, b: np.ndarray) -> float:
    """Share of pixels that differ between two screenshots."""
    return float((np.abs(a.astype(int) - b.astype(int)).sum(axis=2) > 30).mean())


def test_the_page_renders_offline_without_errors(results, tmp_path):
    page_file = write_html(results, tmp_path / "sleeve.html", color="M2", scale=5.0)
    text = page_file.read_text()
    assert "cdn" not in text.lower().split("flexdyn-data")[0][-2000:]  # the page's own tags
    with open_page(page_file) as page:
        page.page.wait_for_function("window.flexdynView && window.flexdynView.ready", timeout=30000)
        frames = page.page.evaluate("window.flexdynView.frames")
        page.page.evaluate(f"window.flexdynView.show({frames - 1})")
        page.page.wait_for_timeout(300)
        img = plot_area(page.screenshot(tmp_path / "last.png"))
        # The same view with every trace hidden: axes and grid only.
        page.page.evaluate("Plotly.restyle('flexdyn-plot', {visible: false})")
        page.page.wait_for_timeout(300)
        empty = plot_area(page.screenshot(tmp_path / "empty.png"))
        assert page.errors() == []
        assert page.requests == []  # nothing fetched: works offline
    assert frames == 31  # every sample of the 0.6 s run at 0.02 s
    # Not blank: the strip, its ribbon coloured by M2, the bodies and the markers cover 3 % of
    # the scene here (a thin strip seen from afar), against nothing drawn without them.
    assert changed(img, empty) > 0.01
    # The bodies' shaded orange is there (R high, B low), and absent from the empty scene.
    orange = lambda im: ((im[..., 0] > 150) & (im[..., 2] < 110) & (im[..., 1] > 90)).sum()
    assert orange(img) > 500 and orange(empty) == 0


def test_the_controls_move_the_scene(results, tmp_path):
    page_file = write_html(results, tmp_path / "sleeve.html")
    with open_page(page_file) as page:
        p = page.page
        p.wait_for_function("window.flexdynView.ready", timeout=30000)
        first = plot_area(page.screenshot(tmp_path / "a.png"))
        p.fill("#flexdyn-scale", "50")
        p.dispatch_event("#flexdyn-scale", "change")
        p.select_option("#flexdyn-color", "M2")
        p.click("#flexdyn-play")
        p.wait_for_function("window.flexdynView.state.frame > 5", timeout=30000)
        p.click("#flexdyn-play")  # pause
        state = p.evaluate("window.flexdynView.state")
        moved = plot_area(page.screenshot(tmp_path / "b.png"))
        assert page.errors() == []
    assert state["scale"] == 50 and state["color"] == "M2" and not state["playing"]
    assert changed(moved, first) > 0.005


def test_pages_can_share_plotly_beside_them(results, tmp_path):
    a = write_html(results, tmp_path / "docs" / "a.html", plotly_js="beside")
    write_html(results, tmp_path / "docs" / "b.html", plotly_js="beside", color="F1")
    assert (tmp_path / "docs" / "plotly.min.js").is_file()
    assert a.stat().st_size < 0.2 * (tmp_path / "docs" / "plotly.min.js").stat().st_size
    with open_page(a) as page:
        page.page.wait_for_function("window.flexdynView && window.flexdynView.ready", timeout=30000)
        assert page.errors() == [] and page.requests == []


def test_the_scene_magnifies_only_elastic_displacement(results):
    """The scale factor acts on each beam's displacement from its root section's rigid
    motion: at t = 0 that is zero, and a rigid hub node has none at any time."""
    data = scene_data(fd.fields.motion(results))
    decode = lambda s: np.frombuffer(__import__("base64").b64decode(s), dtype="<f4")
    d = decode(data["d"]).reshape(len(data["times"]), data["nodes"], 3)
    assert np.abs(d[0]).max() == 0.0
    hub = fd.fields.motion(results).nodes.index("hub")
    assert np.abs(d[:, hub]).max() == 0.0
    assert np.abs(d[-1]).max() > 1e-4  # the strip does bend under gravity


def test_view_command_and_its_errors(results, tmp_path):
    run = lambda *a: subprocess.run(
        [sys.executable, "-m", "flexdyn", *a], check=False, capture_output=True, text=True
    )
    ok = run("view", str(results), "-o", str(tmp_path / "v.html"), "--color", "F3", "--scale", "10")
    assert ok.returncode == 0 and (tmp_path / "v.html").stat().st_size > 1e6, ok.stderr
    missing = run("view", str(tmp_path / "none.nc"))
    assert missing.returncode == 2 and "no such results file" in missing.stderr
    plain = tmp_path / "plain.nc"
    fd.simulate(swinging_sleeve(), t_end=0.04, fields=False, out=plain)
    nofields = run("view", str(plain))
    assert nofields.returncode == 2 and "no field output" in nofields.stderr
    assert "Traceback" not in missing.stderr + nofields.stderr


def test_rigid_links_show_as_boxes_along_them_and_arms_that_meet(tmp_path):
    """A rigid four-bar (no beams): each body's box lies along its principal axes (a bar's
    inertia given about tilted axes), arms from the nodes reach the joints, both sides of a
    joint meet there, and the page renders without errors."""
    res = fd.simulate(fd.load(ROOT / "examples" / "four_bar.yaml"), t_end=0.3, output_dt=0.01)
    mo = fd.fields.motion(res)
    frames = np.arange(len(mo.times))
    arms, arm_nodes = scene.joint_arms(mo, frames)
    ends = mo.positions[:, arm_nodes] + arms
    # The coupler's two joints each join it to a neighbour: every arm end has a partner.
    for k in range(ends.shape[1]):
        gaps = np.linalg.norm(ends - ends[:, k : k + 1], axis=2).max(axis=0)
        gaps[k] = np.inf
        ground = [j for j in mo.topology["joints"] if any(s["node"] is None for s in j["sides"])]
        assert gaps.min() < 1e-9 or ground  # a joint to the ground has one arm only
    corners, _ = scene.body_boxes(mo, frames[:1], 10.0)
    for b, body in enumerate(mo.topology["bodies"]):
        _, v = np.linalg.eigh(np.asarray(body["inertia"]))
        rel = corners[0, b] - corners[0, b].mean(axis=0)
        # In the principal frame the box is axis-aligned: corner coordinates take two values.
        principal = rel @ v
        assert all(len(np.unique(np.round(principal[:, a], 9))) == 2 for a in range(3))
        # The longest side lies along the smallest principal inertia (the bar's axis).
        assert np.ptp(principal[:, 0]) == pytest.approx(np.ptp(principal, axis=0).max())
    page_file = write_html(res, tmp_path / "four_bar.html")
    with open_page(page_file) as page:
        page.page.wait_for_function("window.flexdynView && window.flexdynView.ready", timeout=30000)
        assert page.errors() == [] and page.requests == []


@pytest.mark.parametrize("name", ["beam_slider", "twisted_beam_slider", "vdtr"])
def test_the_docs_views_open_offline_without_errors(name):
    """The pages the paper scripts wrote into docs/views (sharing plotly.min.js) work."""
    page_file = ROOT / "docs" / "views" / f"{name}.html"
    with open_page(page_file) as page:
        page.page.wait_for_function("window.flexdynView && window.flexdynView.ready", timeout=60000)
        frames = page.page.evaluate("window.flexdynView.frames")
        page.page.evaluate(f"window.flexdynView.show({frames // 2})")
        page.page.wait_for_timeout(200)
        assert page.errors() == [] and page.requests == []
    assert frames > 100
