"""`flexdyn export --vtk` and `flexdyn animate` (issue 20): a VTU/PVD time series that meshio
reads back with the right points, steps, frames and channels; videos with one frame per
requested frame."""

import subprocess
import sys
import xml.etree.ElementTree as ET

import meshio
import numpy as np
import pytest

import flexdyn as fd
from flexdyn.animate import animate
from flexdyn.export import export_vtk
from flexdyn.fields import motion

from test_fields import swinging_sleeve


@pytest.fixture(scope="module")
def results(tmp_path_factory):
    out = tmp_path_factory.mktemp("export") / "sleeve.nc"
    fd.simulate(swinging_sleeve(), out=out)
    return out


def test_the_vtu_series_reads_back_with_every_step_point_and_frame(results, tmp_path):
    pvd = export_vtk(results, tmp_path / "vtk")
    mo = motion(results)
    steps = ET.parse(pvd).getroot().findall("./Collection/DataSet")
    assert len(steps) == len(mo.times) == 31
    np.testing.assert_allclose([float(s.get("timestep")) for s in steps], mo.times, rtol=0, atol=0)
    k = 17
    mesh = meshio.read(tmp_path / "vtk" / steps[k].get("file"))
    # Points: the 14 nodes, then the one contact point.
    assert len(mesh.points) == 14 + 1
    np.testing.assert_allclose(mesh.points[:14], mo.positions[k], atol=1e-14)
    np.testing.assert_allclose(mesh.points[14], mo.contact_position[k, 0], atol=1e-14)
    # Cells: the strip's 12 segments, vertices for the sleeve node and the contact point.
    blocks = {c.type: c.data for c in mesh.cells}
    assert len(blocks["line"]) == 12 and len(blocks["vertex"]) == 2
    # Section frames and loads of the strip's nodes, as `motion` gives them.
    beam = mo.beam("strip")
    strip_nodes = [mo.nodes.index(n) for n in ["hub"] + [f"strip.{j}" for j in range(1, 13)]]
    for a in range(3):
        got = mesh.point_data[f"section_axis_{a + 1}"][strip_nodes]
        np.testing.assert_allclose(got, beam["frames"][k, :, :, a], atol=1e-12)
    np.testing.assert_allclose(mesh.point_data["section_moment"][strip_nodes], beam["moment"][k], atol=1e-9)
    np.testing.assert_allclose(
        mesh.point_data["displacement"][:14], mo.positions[k] - mo.positions[0], atol=1e-14
    )
    assert mesh.point_data["contact_eta"][14] == pytest.approx(mo.contact_eta[k, 0], abs=1e-15)
    # Channels as the grid's field data.
    with fd.open_results(results) as ds:
        assert mesh.field_data["tip.z"][0] == pytest.approx(float(ds["tip.z"][k]), abs=1e-15)


def test_export_command(results, tmp_path):
    done = subprocess.run(
        [sys.executable, "-m", "flexdyn", "export", str(results), "--vtk", str(tmp_path / "out")],
        check=False,
        capture_output=True,
        text=True,
    )
    assert done.returncode == 0, done.stderr
    assert (tmp_path / "out" / "sleeve.pvd").is_file() and len(list((tmp_path / "out").glob("*.vtu"))) == 31


@pytest.mark.parametrize("suffix", [".gif", ".mp4"])
def test_animations_have_the_frames_asked_for(results, tmp_path, suffix):
    out = animate(results, tmp_path / f"motion{suffix}", max_frames=12, fps=10, color="M2", scale=3.0)
    if suffix == ".gif":
        from PIL import Image

        with Image.open(out) as im:
            assert im.n_frames == 12
            im.seek(11)
            frame = np.asarray(im.convert("RGB"))
        assert len(np.unique(frame.reshape(-1, 3), axis=0)) > 20  # drawn, not blank
    else:
        import imageio_ffmpeg

        frames, _ = imageio_ffmpeg.count_frames_and_secs(str(out))
        assert frames == 12


def test_animate_refuses_an_unknown_format(results, tmp_path):
    with pytest.raises(ValueError, match=r"\.mp4 or \.gif"):
        animate(results, tmp_path / "motion.avi")


def test_a_model_without_beams_animates_and_refuses_a_colour(tmp_path):
    """A regression: matplotlib cannot add an empty 3-D line collection (a rigid four-bar has
    no beams), which stopped `flexdyn animate` with a numpy error."""
    from pathlib import Path

    four_bar = Path(__file__).resolve().parent.parent / "examples" / "four_bar.yaml"
    res = fd.simulate(four_bar, t_end=0.1, output_dt=0.01)
    out = animate(res, tmp_path / "four_bar.gif", max_frames=5)
    assert out.is_file()
    with pytest.raises(ValueError, match="no beams to colour"):
        animate(res, tmp_path / "x.gif", color="M2")
    with pytest.raises(ValueError, match="no beams to colour"):
        fd.view(res, tmp_path / "x.html", color="M2")
