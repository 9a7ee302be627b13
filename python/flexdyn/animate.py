"""`flexdyn animate`: a results file's motion as a video (.mp4, through the ffmpeg that
imageio-ffmpeg ships) or an animated GIF, drawn with matplotlib — for reports and slides.
Beams are lines (coloured by a section load if asked), bodies squares, joints diamonds, the
sliding joints' contact points red dots; the deformation scale factor acts as in `view`."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from .fields import Motion, motion
from .viewer import scene

WRITERS = {".gif": "pillow", ".mp4": "ffmpeg"}


def _display(mo: Motion, frames: np.ndarray, scale: float):
    """Displayed node and contact positions per frame (elastic part magnified)."""
    d = scene.elastic_displacements(mo)
    nodes = mo.positions[frames] + (scale - 1.0) * d[frames]
    contacts = mo.contact_position[frames] + (scale - 1.0) * scene.contact_displacements(mo, d, frames)
    return nodes, contacts


def _limits(ax, nodes: np.ndarray, contacts: np.ndarray):
    pts = np.concatenate([nodes.reshape(-1, 3), contacts.reshape(-1, 3)])
    lo, hi = pts.min(axis=0), pts.max(axis=0)
    centre, half = 0.5 * (lo + hi), 0.55 * max((hi - lo).max(), 1e-9)
    for setter, c in zip((ax.set_xlim, ax.set_ylim, ax.set_zlim), centre):
        setter(c - half, c + half)
    ax.set_box_aspect((1, 1, 1))
    ax.set(xlabel="x [m]", ylabel="y [m]", zlabel="z [m]")


def _segments(mo: Motion, p: np.ndarray) -> np.ndarray:
    segs = [
        [p[b["nodes"][a]], p[b["nodes"][a + 1]]]
        for b in mo.topology["beams"]
        for a in range(len(b["nodes"]) - 1)
    ]
    return np.array(segs).reshape(-1, 2, 3)


def _segment_loads(mo: Motion, k: int, component: str) -> np.ndarray:
    """A section load per beam segment (the mean of its two nodes')."""
    c = scene.COMPONENTS.index(component)
    values = (mo.section_force if c < 3 else mo.section_moment)[k, :, c % 3]
    out = []
    for b in mo.topology["beams"]:
        v = values[mo.beam_points[b["name"]]]
        out.extend(0.5 * (v[:-1] + v[1:]))
    return np.array(out)


def animate(
    results,
    out: str | Path,
    *,
    fps: int = 25,
    max_frames: int = 200,
    scale: float = 1.0,
    color: str | None = None,
    view: tuple[float, float] = (25.0, -60.0),
    dpi: int = 100,
) -> Path:
    """Writes the motion to `out` (.mp4 or .gif): at most `max_frames` frames evenly spread
    over the run, played at `fps`; `scale` magnifies the beams' elastic displacement; `color`
    a section load (F1 … M3) to colour the beams by; `view` the camera's (elevation, azimuth)
    in degrees. Returns the path written."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib import animation
    from mpl_toolkits.mplot3d.art3d import Line3DCollection

    out = Path(out)
    writer_name = WRITERS.get(out.suffix.lower())
    if writer_name is None:
        raise ValueError(f"{out}: the file must end in .mp4 or .gif")
    if color is not None and color not in scene.COMPONENTS:
        raise ValueError(f"color: `{color}` is not a section load; use one of {', '.join(scene.COMPONENTS)}")
    mo = motion(results)
    if color is not None and not mo.topology["beams"]:
        raise ValueError(f"color: the model has no beams to colour by {color}")
    frames = scene.frame_indices(mo.times, max_frames)
    nodes, contacts = _display(mo, frames, scale)
    fig = plt.figure(figsize=(6.4, 5.4))
    ax = fig.add_subplot(projection="3d")
    ax.view_init(*view)
    _limits(ax, nodes, contacts)
    # A dark centre line always (a load near zero is a pale colour), the coloured band on it.
    line = Line3DCollection(_segments(mo, nodes[0]), colors="0.2", linewidths=1.2 if color else 2.5)
    beams = Line3DCollection(_segments(mo, nodes[0]), linewidths=5.0 if color else 0.0)
    if color:
        top = max(float(np.abs(_segment_loads(mo, k, color)).max()) for k in frames) or 1.0
        beams.set(cmap="RdBu_r", norm=plt.Normalize(-top, top))
        beams.set_array(_segment_loads(mo, frames[0], color))
        unit = "N" if color.startswith("F") else "N·m"
        fig.colorbar(beams, ax=ax, shrink=0.6, label=f"{color} [{unit}]")
    if mo.topology["beams"]:  # matplotlib cannot add an empty 3-D collection
        ax.add_collection3d(beams)
        ax.add_collection3d(line)
    body_nodes = [b["node"] for b in mo.topology["bodies"] if b["node"] is not None]
    _, joint_nodes, _ = scene.joint_points(mo, frames[:1])
    bodies = ax.plot([], [], [], "s", color="#d9a441", ms=9, mec="k", label="bodies")[0]
    joints = ax.plot([], [], [], "D", color="#2b7a3d", ms=5, label="joints")[0]
    dots = ax.plot([], [], [], "o", color="#c0392b", ms=7, label="contact points")[0]
    label = "load factor" if mo.dim == "load_factor" else "t"
    title = ax.set_title("")
    ax.legend(loc="upper left", fontsize="small")

    def draw(f):
        p = nodes[f]
        beams.set_segments(_segments(mo, p))
        line.set_segments(_segments(mo, p))
        if color:
            beams.set_array(_segment_loads(mo, frames[f], color))
        for artist, idx in ((bodies, body_nodes), (joints, joint_nodes)):
            artist.set_data_3d(*(p[idx].T if idx else ([], [], [])))
        dots.set_data_3d(*contacts[f].T)
        title.set_text(f"{label} = {mo.times[frames[f]]:.4f}" + (" s" if label == "t" else ""))
        return beams, line, bodies, joints, dots, title

    anim = animation.FuncAnimation(fig, draw, frames=len(frames), blit=False)
    anim.save(out, writer=_writer(writer_name, fps), dpi=dpi)
    plt.close(fig)
    return out


def _writer(name: str, fps: int):
    from matplotlib import animation

    if name == "pillow":
        return animation.PillowWriter(fps=fps)
    import imageio_ffmpeg
    import matplotlib

    matplotlib.rcParams["animation.ffmpeg_path"] = imageio_ffmpeg.get_ffmpeg_exe()
    return animation.FFMpegWriter(fps=fps, codec="libx264", extra_args=["-pix_fmt", "yuv420p"])
