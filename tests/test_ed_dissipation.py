"""ED annihilates unresolved high frequencies but does not damp slow rigid rotation
("locking in time", ed-scheme-notes §3.5)."""

import numpy as np

import flexdyn as fd

from conftest import angular_momentum, track

I_HUB, M_TIP, I_TIP = 2.0, 1.0, 0.1


def spinning_rotor(scheme, dt=0.05, t_end=10.0, k=1e3):
    """A hub on a bearing spins at 1 rad/s; a tip mass sits on a stiff torsion hinge (axis z)
    at 1 m, its centre of mass on the hinge axis, and starts with a relative spin of
    5 rad/s. Hinge frequency ≈ sqrt(k/I_TIP) = 100 rad/s, so ω h = 5: unresolved."""
    m = fd.Model("rotor with stiff hinge")
    m.node("hub", [0, 0, 0], angular_velocity=[0, 0, 1.0])
    m.node("tip", [1, 0, 0], angular_velocity=[0, 0, 6.0], velocity=[0, 1.0, 0])
    m.body("hub_body", "hub", mass=5.0, inertia=[1.0, 1.0, I_HUB])
    m.body("tip_body", "tip", mass=M_TIP, inertia=[0.05, 0.05, I_TIP])
    m.revolute("bearing", "ground", "hub", axis=[0, 0, 1], position=[0, 0, 0])
    m.revolute("hinge", "hub", "tip", axis=[0, 0, 1], position=[1, 0, 0], spring={"stiffness": k})
    m.sensor("energy", "e").sensor("joint_coordinate", "hinge_angle", joint="hinge")
    track(m, "hub", "tip")
    m.simulation(scheme=scheme, step_control="fixed", dt=dt, t_end=t_end, newton_tol=1e-12)
    return m


def test_unresolved_vibration_is_removed_and_rigid_spin_is_kept():
    ed = fd.simulate(spinning_rotor("ed"))
    ep = fd.simulate(spinning_rotor("ep"))
    bodies = {"hub": (5.0, np.diag([1.0, 1.0, I_HUB])), "tip": (M_TIP, np.diag([0.05, 0.05, I_TIP]))}
    hz = angular_momentum(ed, bodies)[:, 2]
    # The bearing and hinge leave the axial angular momentum free: ED keeps it (1e-6 allows
    # the O(h²) momentum defect of ED with translational unknowns, notes §3.6).
    assert abs(hz[-1] - hz[0]) < 1e-6 * abs(hz[0])
    # With the vibration gone, the rotor spins rigidly with that momentum:
    # E_rigid = H²/(2 I) with I = I_HUB + I_TIP + M_TIP·1².
    e_rigid = hz[0] ** 2 / (2 * (I_HUB + I_TIP + M_TIP))
    e0 = ed["e.total"].values[0]
    vibration = e0 - e_rigid
    assert vibration > 0.05 * e0  # the hinge vibration is a sizeable part of the energy
    # ED removes the vibration energy (spectral radius 0.42 per step at ω h = 5) ...
    assert abs(ed["e.total"].values[-1] - e_rigid) < 1e-6 * vibration
    assert np.max(np.abs(ed["hinge_angle.phi_rate"].values[-20:] - 0.0)) < 1e-6
    # ... but not the rigid rotation: no locking in time.
    assert ed["e.total"].values[-1] > e_rigid * (1 - 1e-9)
    # EP keeps every bit of it, vibration included.
    assert abs(ep["e.total"].values[-1] - e0) < 1e-9 * e0
    assert np.ptp(ep["hinge_angle.phi_rate"].values[-20:]) > 0.1


def test_resolved_motion_loses_little_energy():
    # The same rotor with a soft hinge (ω ≈ 3.3 rad/s, ω h = 0.033). The linear template's
    # spectral radius is 1 − ρ ≈ 0.01 (ω h)⁴ ≈ 1.2e-8 per step (notes §2: 1e-6 at ω h = 0.1),
    # so the vibration energy decays by ≈ 2.4e-8 per step, 2.4e-5 over 1000 steps.
    ed = fd.simulate(spinning_rotor("ed", dt=0.01, k=1.0))
    e = ed["e.total"].values
    assert 0 < (e[0] - e[-1]) / e[0] < 1e-4
