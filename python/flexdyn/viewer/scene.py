"""What the 3-D view draws, per frame: the nodes' displayed positions (with the beams' elastic
displacement kept apart, so that the page can magnify it), the beams' section axis 2 (for the
ribbons that show twist), the section loads (for colouring), the bodies' boxes, the joints'
points and the sliding joints' contact points. Arrays are float32, frame-major."""

from __future__ import annotations

import numpy as np

from ..fields import Motion, _multiply, _rotate

#: Section-load components a view can be coloured by.
COMPONENTS = ("F1", "F2", "F3", "M1", "M2", "M3")


def frame_indices(times: np.ndarray, max_frames: int) -> np.ndarray:
    """At most `max_frames` samples, evenly spread, first and last included."""
    n = len(times)
    if n <= max_frames:
        return np.arange(n)
    return np.unique(np.round(np.linspace(0, n - 1, max_frames)).astype(int))


def elastic_displacements(mo: Motion) -> np.ndarray:
    """`[T, N, 3]`: each beam node's displacement from where its beam's first section would
    carry it rigidly (root frame); zero for nodes on no beam. What the scale factor magnifies."""
    x, q = mo.positions, mo.orientations
    d = np.zeros_like(x)
    done = np.zeros(x.shape[1], dtype=bool)
    for b in mo.topology["beams"]:
        idx = np.array(b["nodes"])
        root = idx[0]
        q_rel = _multiply(q[:, root], _conjugate(q[0, root]))  # R0(t) R0(0)ᵀ
        arm = x[0, idx] - x[0, root]
        rigid = x[:, root, None] + _rotate(q_rel[:, None], np.broadcast_to(arm, x[:, idx].shape))
        fresh = ~done[idx]
        d[:, idx[fresh]] = (x[:, idx] - rigid)[:, fresh]
        done[idx] = True
    return d


def _conjugate(q: np.ndarray) -> np.ndarray:
    return q * np.array([1.0, -1.0, -1.0, -1.0])


def _box_corners(mass: float, inertia, scale: float) -> np.ndarray:
    """`[8, 3]` corners (node triad) of the uniform box with the body's principal inertias,
    along its principal axes (its size and lie show its mass distribution); a cube of side
    `scale` when they give none."""
    j, axes = np.linalg.eigh(np.asarray(inertia, dtype=float))
    sq = np.array([j[1] + j[2] - j[0], j[0] + j[2] - j[1], j[0] + j[1] - j[2]]) * 6.0 / max(mass, 1e-300)
    half = 0.5 * np.sqrt(np.clip(sq, 0.0, None))
    if not np.all(np.isfinite(half)) or half.max() <= 0:
        half = np.full(3, 0.5 * scale)
    half = np.clip(half, 0.05 * half.max(), None)  # a flat body still shows
    signs = np.array([[(k >> a) & 1 for a in range(3)] for k in range(8)]) * 2.0 - 1.0
    return (signs * half) @ axes.T


def body_boxes(mo: Motion, frames: np.ndarray, extent: float) -> tuple[np.ndarray, list[int]]:
    """`[F, B, 8, 3]` box corners of each body relative to its node (inertial frame), and the
    bodies' nodes. Boxes of absurd size (a point mass far from its node) are capped."""
    rel, nodes = [], []
    for b in mo.topology["bodies"]:
        if b["node"] is None:
            continue
        corners = _box_corners(b["mass"], b["inertia"], 0.02 * extent)
        # A box of absurd size (a point mass carried far from its node) shrinks, keeping shape.
        corners *= min(1.0, 0.25 * extent / max(np.abs(corners).max(), 1e-300))
        corners = corners + np.asarray(b["cm_offset"])
        q = mo.orientations[frames, b["node"]][:, None]
        rel.append(_rotate(q, np.broadcast_to(corners, (len(frames), 8, 3))))
        nodes.append(b["node"])
    if not rel:
        return np.zeros((len(frames), 0, 8, 3)), nodes
    return np.stack(rel, axis=1), nodes


def joint_points(mo: Motion, frames: np.ndarray) -> tuple[np.ndarray, list[int], list[str]]:
    """`[F, J, 3]` each joint's point relative to the node it is drawn at (its first side on a
    node), that node, and a label per joint."""
    rel, nodes, labels = [], [], []
    for j in mo.topology["joints"]:
        side = next((s for s in j["sides"] if s["node"] is not None), None)
        if side is None:
            continue
        q = mo.orientations[frames, side["node"]]
        rel.append(_rotate(q, np.broadcast_to(side["offset"], (len(frames), 3))))
        nodes.append(side["node"])
        labels.append(f"{j['name']} ({j['type']})")
    if not rel:
        return np.zeros((len(frames), 0, 3)), nodes, labels
    return np.stack(rel, axis=1), nodes, labels


def joint_arms(mo: Motion, frames: np.ndarray) -> tuple[np.ndarray, list[int]]:
    """`[F, K, 3]` the attachment point of every joint side on a node relative to that node,
    for sides whose point is off the node (≥ 1e-9 of the model's size): drawn as thin arms
    from a body's node to its joints, so a rigid link shows as a bar between its joints."""
    rel, nodes = [], []
    for j in mo.topology["joints"]:
        for side in j["sides"]:
            offset = np.asarray(side.get("offset", (0.0, 0.0, 0.0)))
            if side["node"] is None or np.linalg.norm(offset) <= 1e-9 * mo.topology["length_ref"]:
                continue
            q = mo.orientations[frames, side["node"]]
            rel.append(_rotate(q, np.broadcast_to(offset, (len(frames), 3))))
            nodes.append(side["node"])
    if not rel:
        return np.zeros((len(frames), 0, 3)), nodes
    return np.stack(rel, axis=1), nodes


def ground_points(mo: Motion) -> list[tuple[list[float], str]]:
    """Where joints hold nodes to the ground (fixed), with labels."""
    out = []
    for j in mo.topology["joints"]:
        for s in j["sides"]:
            if s["node"] is None and "point" in s:
                out.append((s["point"], f"{j['name']}: ground"))
    return out


def contact_displacements(mo: Motion, d: np.ndarray, frames: np.ndarray) -> np.ndarray:
    """`[F, S, 3]`: each contact point's elastic displacement, interpolated along its beam."""
    out = np.zeros((len(frames), len(mo.topology["contacts"]), 3))
    for c, contact in enumerate(mo.topology["contacts"]):
        beam = mo.topology["beams"][contact["beam"]]
        s_nodes, idx = np.array(beam["s"]), np.array(beam["nodes"])
        s = mo.contact_eta[frames, c] * beam["length"]
        for a in range(3):
            dn = d[frames][:, idx, a]
            out[:, c, a] = [np.interp(sf, s_nodes, row) for sf, row in zip(s, dn)]
    return out


def section_axis2(mo: Motion, frames: np.ndarray) -> np.ndarray:
    """`[F, P, 3]`: the section axis 2 at every beam point (the ribbon's direction)."""
    cols = []
    for b in mo.topology["beams"]:
        q = _multiply(mo.orientations[frames][:, b["nodes"]], np.array(b["section_offsets"])[None])
        cols.append(_rotate(q, np.broadcast_to([0.0, 1.0, 0.0], q.shape[:-1] + (3,))))
    if not cols:
        return np.zeros((len(frames), 0, 3))
    return np.concatenate(cols, axis=1)
