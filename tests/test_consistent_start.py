"""Consistent starts (issue 19): a mechanism driven from t = 0 starts in its rigid motion with
its beams following (not lagging at rest behind their supports), a warning says when beams
still start unstrained under the motion's loads, and the reactions and driving forces of the
first and last samples are solved at those instants instead of extrapolated.

The model is a user's own slider-crank, not an example: a 0.1 m crank driven at 10 rev/s, a
0.4 m steel connecting rod (10 mm diameter, six cubic elements) pinned to it, and a 0.3 kg
slider on a rail along x; and the same with a rigid rod of the same mass and inertia."""

from pathlib import Path

import numpy as np
import pytest

import flexdyn as fd

ROOT = Path(__file__).resolve().parent.parent

W = 2 * np.pi * 10  # crank speed, rad/s
R, L = 0.1, 0.4  # crank radius and rod length, m
RADIUS, E, G, RHO = 0.005, 2.1e11, 8e10, 7800.0
AREA, I = np.pi * RADIUS**2, np.pi * RADIUS**4 / 4
ROD = {
    "ea": E * AREA,
    "ga2": 0.9 * G * AREA,
    "ga3": 0.9 * G * AREA,
    "gj": 2 * G * I,
    "ei2": E * I,
    "ei3": E * I,
    "m": RHO * AREA,
    "i22": RHO * I,
    "i33": RHO * I,
}
AT_SPEED = f"{W}*t"
T_RAMP = 0.05  # about six periods of the rod's first bending mode (127 Hz)
#: The rate W·smoothstep(0, T, t), as docs/expressions.md writes it.
RAMP = f"t < {T_RAMP} ? {T_RAMP}*{W}*((t/{T_RAMP})^3 - (t/{T_RAMP})^4/2) : {W}*(t - {T_RAMP}/2)"


def slider_crank(flexible, drive, t_end=0.3):
    m = fd.Model("user slider-crank", gravity=[0, -9.81, 0])
    m.node("crank", [0, 0, 0]).body("crank_body", "crank", mass=0.5, inertia=[1e-3, 1e-3, 1e-3])
    m.node("slider", [R + L, 0, 0]).body("slider_body", "slider", mass=0.3, inertia=[1e-4] * 3)
    m.revolute("shaft", "ground", "crank", position=[0, 0, 0], axis=[0, 0, 1], drive=drive)
    if flexible:
        m.beam("rod", [R, 0, 0], [R + L, 0, 0], elements=6, section=ROD, e2=[0, 1, 0])
        rod_start, rod_end = "rod.0", "rod.18"
        for k in (6, 9, 12):
            m.sensor("node_velocity", f"v{k}", node=f"rod.{k}")
    else:
        mass = ROD["m"] * L
        m.node("rod", [R + L / 2, 0, 0])
        m.body("rod_body", "rod", mass=mass, inertia=[1e-7, mass * L**2 / 12, mass * L**2 / 12])
        rod_start = rod_end = "rod"
    m.spherical("pin", "crank", rod_start, position=[R, 0, 0])
    m.universal("wrist", rod_end, "slider", position=[R + L, 0, 0], axis1=[0, 0, 1], axis2=[0, 1, 0])
    m.prismatic("slide", "ground", "slider", position=[R + L, 0, 0], axis=[1, 0, 0])
    m.sensor("joint_reaction", "rail", joint="slide").sensor("drive_force", "motor", joint="shaft")
    m.simulation(t_end=t_end)  # everything else at its default
    return m


def test_a_rod_driven_at_speed_from_t0_starts_in_the_rigid_motion():
    res = fd.simulate(slider_crank(True, AT_SPEED, t_end=1e-3))
    # At t = 0 the crank pin moves at W·R along y and the slider stands at dead centre, so the
    # rod turns rigidly about its slider end at −W R/L: its nodes at s along it move at
    # W R (1 − s/L) along y, all with the rod's angular velocity. (They used to start at rest
    # between moving ends and ring at the rod's modes for the whole run.) To 1e-4 of W R:
    # the rod starts pre-loaded (below), bent and compressed by a few µm, and turns rigidly
    # in that shape (measured 4e-5).
    for k in (6, 9, 12):
        s = L * k / 18
        v = [res[f"v{k}.{c}"].values[0] for c in ("vx", "vy", "vz", "wx", "wy", "wz")]
        np.testing.assert_allclose(v, [0, W * R * (1 - s / L), 0, 0, 0, -W * R / L], atol=1e-4 * W * R)
    assert res.attrs["warnings"] == ""


@pytest.mark.parametrize("scheme", ["ed", "ep"])
def test_a_rod_driven_at_speed_from_t0_carries_the_rigid_mechanism_loads(scheme):
    # The check: started at full speed, the rod carries the rigid mechanism's loads
    # after its first period (127 Hz). Unstrained at the start, it had to take the slider's
    # 150 N deceleration at once and rang at its axial mode with the slider (1.9 kHz) for the
    # whole run: rail force ±43 N off a rigid peak of 37 N, 11 954 steps. Pre-loaded by the
    # motion's inertial loads, it is within 10 % (measured 6.9 %; the motor torque 2 %),
    # in 843 steps. EP's multipliers carry an undamped period-2 ripple that the rigid
    # mechanism shows too, so EP is compared at step ends, where neighbouring steps cancel it.
    rigid = fd.simulate(slider_crank(False, AT_SPEED), scheme=scheme)
    flexible = fd.simulate(slider_crank(True, AT_SPEED), scheme=scheme)
    assert flexible.attrs["warnings"] == ""
    t = rigid["time"].values
    after = flexible["time"].values > 1 / 127
    for channel in ("rail.F1", "motor.torque"):
        a = rigid[channel].values
        b = np.interp(flexible["time"].values, t, a)
        assert np.abs(b - flexible[channel].values)[after].max() < 0.1 * np.abs(a).max(), channel
    assert flexible.flexdyn.stats["steps"] < 2000


def test_a_loop_its_rigidification_over_constrains_still_gets_its_inertial_pre_load():
    # A planar four-bar of revolutes with a flexible coupler, its crank at speed from t = 0:
    # made rigid, the loop is over-constrained (three redundant rows). Its singular matrix
    # used to fail the pre-load (a warning, and the coupler started unstrained); the redundant
    # rows are now solved as such, so the coupler starts bent by the motion's inertial loads,
    # without a warning.
    def four_bar(preload=None):
        m = fd.Model("four-bar", gravity=[0, -9.81, 0])
        m.node("a", [0, 0, 0]).body("crank", "a", mass=0.2, inertia=[1e-4] * 3)
        m.node("d", [0.5, 0, 0]).body("rocker", "d", mass=0.2, inertia=[1e-4] * 3)
        m.revolute("motor", "ground", "a", axis=[0, 0, 1], position=[0, 0, 0], drive=AT_SPEED)
        m.beam("coupler", [0.1, 0, 0], [0.5, 0.3, 0], elements=2, section=ROD, e2=[0, 0, 1])
        m.revolute("p1", "a", "coupler.start", axis=[0, 0, 1], position=[0.1, 0, 0])
        m.revolute("p2", "coupler.end", "d", axis=[0, 0, 1], position=[0.5, 0.3, 0])
        m.revolute("p3", "ground", "d", axis=[0, 0, 1], position=[0.5, 0, 0])
        m.simulation(t_end=1e-3, preload=preload)
        return m

    res = fd.simulate(four_bar())
    assert res.attrs["warnings"] == ""  # the old failure warned here
    assert res.flexdyn.stats["max_constraint_violation"] < 1e-9


def test_a_rod_brought_up_to_speed_smoothly_carries_the_rigid_mechanism_loads():
    rigid = fd.simulate(slider_crank(False, RAMP), output_dt=2e-4)
    flexible = fd.simulate(slider_crank(True, RAMP), output_dt=2e-4)
    assert flexible.attrs["warnings"] == ""
    # Its first bending mode (127 Hz) is 13× the crank's rate and barely excited: the loads
    # are the rigid mechanism's, within 10 % of their peak (measured: rail 5 %, motor 1.6 %),
    # in a few hundred adaptive steps (measured 790; a rod left at rest took 5e5).
    for channel in ("rail.F1", "motor.torque"):
        a, b = rigid[channel].values, flexible[channel].values
        assert np.abs(a - b).max() < 0.1 * np.abs(a).max(), channel
    assert flexible.flexdyn.stats["steps"] < 5000


def fine(model, dt):
    model.simulation(step_control="fixed", dt=dt)
    return model


@pytest.mark.parametrize("scheme", ["ed", "ep"])
def test_first_and_last_samples_of_reactions_and_drive_forces_are_solved_not_extrapolated(scheme):
    # A step's multipliers are step averages at its mid-time; the first and last samples lie
    # half a step outside them. They are the instants' own (a vanishing step from a
    # consistent state), so with 2.5 ms steps (40 per turn) they agree with a run of 1 µs
    # steps to 0.5 % of the force's peak (measured ≤ 0.03 %), where extrapolating the
    # mid-steps was off by up to 2.6 % (ED) and 4.7 % (EP).
    coarse = fd.simulate(fine(slider_crank(False, AT_SPEED, t_end=0.05), 2.5e-3), scheme=scheme)
    reference = fd.simulate(
        fine(slider_crank(False, AT_SPEED, t_end=0.05), 1e-6), scheme=scheme, output_dt=2.5e-3
    )
    for channel in ("rail.F1", "motor.torque"):
        a, b = coarse[channel].values, reference[channel].values
        size = np.abs(b).max()
        assert abs(a[0] - b[0]) < 5e-3 * size, (channel, a[0], b[0])
        assert abs(a[-1] - b[-1]) < 5e-3 * size, (channel, a[-1], b[-1])


def test_first_samples_hold_for_a_model_typed_to_nine_digits():
    # The four-bar's joint positions are typed to 9 digits, so its initial configuration
    # violates the joints by ~1e-9 m: the instant's solve first moves the positions onto the
    # joints (over a vanishing step the violation would take forces ~ m C/h²). With 10 ms
    # steps, against 1 µs ones: within 0.1 % of the peak (measured ≤ 0.05 %; extrapolated,
    # 0.4–0.8 %). The 1 µs run's own instants must stand clear of round-off: solved over
    # 1e-7 s (a tenth of its step), their motion stood only ~250× above the positions'
    # round-off and its forces were off by 0.13–0.28 % depending on rounding order.
    model = fd.load(ROOT / "examples" / "four_bar.yaml")
    model.simulation(t_end=0.1, step_control="fixed", dt=0.01)
    coarse = fd.simulate(model)
    model.simulation(dt=1e-6, output_dt=0.01)
    reference = fd.simulate(model)
    for channel in ("crank_drive.torque", "crank_bearing.Fx", "crank_bearing.Fy"):
        a, b = coarse[channel].values, reference[channel].values
        size = np.abs(b).max()
        assert abs(a[0] - b[0]) < 1e-3 * size, (channel, a[0], b[0])
        assert abs(a[-1] - b[-1]) < 1e-3 * size, (channel, a[-1], b[-1])
