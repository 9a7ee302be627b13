"""Structural damping of beams (issue 19): a user's aluminium flat bar clamped at one end,
40 × 8 mm and 1.2 m long (first bending mode 4.57 Hz), released into vibration by a step tip
load. Stiffness-proportional damping given as a ratio ζ at the first mode's frequency must
make that mode decay at exactly ζ (logarithmic decrement, against theory), dissipate in both
schemes with the energy balance still closing (the damping's work reported), and `modes`
must return the damped ratios the coefficients predict (ζ = μω/2, ζ = α/2ω)."""

import numpy as np
import pytest

import flexdyn as fd

E, G, RHO = 7.0e10, 2.6e10, 2700.0
B, T, L = 0.04, 0.008, 1.2
A, I2, I3 = B * T, B * T**3 / 12, T * B**3 / 12
BAR = {
    "ea": E * A,
    "ga2": 5 / 6 * G * A,
    "ga3": 5 / 6 * G * A,
    "gj": G * B * T**3 / 3 * (1 - 0.63 * T / B),
    "ei2": E * I2,
    "ei3": E * I3,
    "m": RHO * A,
    "i22": RHO * I2,
    "i33": RHO * I3,
}
TIP_LOAD = 2.0  # N, down


def bar(damping, scheme=None, t_end=1.5, analysis=None):
    m = fd.Model("damped flat bar")
    m.beam("bar", [0, 0, 0], [L, 0, 0], elements=8, section=BAR, damping=damping)
    m.clamp("root", "ground", "bar.0")
    m.force("tip_load", node="bar.24", value=[0, 0, -TIP_LOAD])
    m.sensor("node_displacement", "tip", node="bar.24").sensor("energy", "energy")
    # A step load on the unstrained bar: it rings about its static deflection (preload=False;
    # the default would start it there, at rest).
    settings = {"t_end": t_end, "preload": False}
    if scheme:
        settings["scheme"] = scheme
    if analysis:
        settings = {"analysis": analysis}
    m.simulation(**settings)
    return m


@pytest.fixture(scope="module")
def undamped_modes():
    return fd.modes(bar(None), 4, preload=False)


@pytest.fixture(scope="module")
def static_tip():
    return float(fd.simulate(bar(None, analysis="static"))["tip.z"].values[-1])


def decay_ratio(res, f1, u_static):
    """ζ of the ringing about the static deflection: a straight-line fit of log |peak| against
    time (after the first period, when the higher modes, damped more, have died out)."""
    u, t = res["tip.z"].values - u_static, res.time.values
    peaks = [i for i in range(1, u.size - 1) if abs(u[i]) >= abs(u[i - 1]) and abs(u[i]) >= abs(u[i + 1])]
    keep = t[peaks] > 1 / f1
    slope = np.polyfit(t[peaks][keep], np.log(np.abs(u[peaks][keep])), 1)[0]
    return -slope / (2 * np.pi * f1)


@pytest.mark.parametrize("scheme", ["ed", "ep"])
@pytest.mark.parametrize("zeta", [0.02, 0.1])
def test_a_ratio_at_the_first_frequency_decays_that_mode_at_that_ratio(
    scheme, zeta, undamped_modes, static_tip
):
    f1 = float(undamped_modes.frequency[0])
    res = fd.simulate(bar({"ratio": zeta, "frequency": f1}, scheme))
    # Measured 0.01999/0.02000 and 0.0997/0.1001 at default settings; 2 % allows for the
    # peaks being sampled at output instants and the schemes' O(h²) period error.
    assert decay_ratio(res, f1, static_tip) == pytest.approx(zeta, rel=0.02)
    # The step load's work ends as strain energy (half) and damping (the rest, as the ring
    # dies out): the damping's work is reported, and the balance still closes to round-off.
    work = res["energy.damper_work"].values
    assert np.all(np.diff(work) <= 1e-15) and work[-1] < 0
    dissipated = TIP_LOAD * abs(static_tip) / 2 * (1 - np.exp(-2 * zeta * 2 * np.pi * f1 * 1.5))
    assert -work[-1] == pytest.approx(dissipated, rel=0.05)  # 5 %: the higher modes' share
    assert np.abs(res["energy.balance"].values).max() < 1e-9 * abs(work[-1])
    # The scheme's own numerical dissipation is not what decays the ring.
    assert res["energy.numerical_dissipation"].values[-1] < 1e-3 * abs(work[-1])


def test_an_undamped_bar_keeps_ringing(undamped_modes, static_tip):
    """The control: without damping (EP) the ring does not decay, so the decrement measured
    above is the damping's."""
    res = fd.simulate(bar(None, "ep"))
    assert abs(decay_ratio(res, float(undamped_modes.frequency[0]), static_tip)) < 1e-3
    assert res["energy.damper_work"].values[-1] == 0


def test_modes_report_the_damping_ratios_the_coefficients_predict(undamped_modes):
    w = 2 * np.pi * undamped_modes.frequency.values
    mu, alpha = 2e-3, 0.8
    for method in ("dense", "sparse"):
        stiff = fd.modes(bar({"stiffness_proportional": mu}), 4, preload=False, method=method)
        mass = fd.modes(bar({"mass_proportional": alpha}), 4, preload=False, method=method)
        # Rayleigh damping of one uniform beam is proportional: exact to the solve's round-off.
        np.testing.assert_allclose(stiff.damping_ratio, mu * w / 2, rtol=1e-8)
        np.testing.assert_allclose(mass.damping_ratio, alpha / (2 * w), rtol=1e-8)
        for md in (stiff, mass):
            # (dense and sparse solves agree to ~1e-10)
            np.testing.assert_allclose(md.frequency, undamped_modes.frequency, rtol=1e-8)
            zeta = md.damping_ratio.values
            np.testing.assert_allclose(md.damped_frequency, md.frequency * np.sqrt(1 - zeta**2), rtol=1e-8)
            np.testing.assert_allclose(md.decay_rate, zeta * 2 * np.pi * md.frequency, rtol=1e-8)
    np.testing.assert_array_equal(undamped_modes.damping_ratio, 0)
    np.testing.assert_array_equal(undamped_modes.damped_frequency, undamped_modes.frequency)


def test_a_sectional_damping_matrix_damps_only_the_strains_it_names(undamped_modes):
    """Damping only κ₂ (bending about axis 2, the bar's weak, vertical bending) damps the
    vertical bending modes and leaves the horizontal ones undamped."""
    d = np.zeros((6, 6))
    d[4, 4] = 2e-3 * BAR["ei2"]  # the same as μ = 2 ms on the weak bending stiffness
    md = fd.modes(bar({"matrix": d.tolist()}), 4, preload=False)
    w = 2 * np.pi * md.frequency.values
    vertical = np.abs(md.shape.sel(dof="bar.24.z").values) > np.abs(md.shape.sel(dof="bar.24.y").values)
    assert vertical.any() and (~vertical).any()
    # Bending modes: shear strain carries little of the strain energy (slender bar, ~0.1 %).
    np.testing.assert_allclose(md.damping_ratio.values[vertical], 2e-3 * w[vertical] / 2, rtol=5e-3)
    np.testing.assert_allclose(md.damping_ratio.values[~vertical], 0, atol=1e-12)


@pytest.mark.parametrize(
    "damping, message",
    [
        ({"ratio": 0.02}, r"beams\[0\]\.damping\.frequency: beam `bar`: `ratio` needs the `frequency`"),
        ({"frequency": 5.0}, r"damping\.frequency: .*goes with a damping `ratio`"),
        ({"ratio": 0.02, "frequency": 5.0, "stiffness_proportional": 1e-3}, r"damping\.ratio: .*not both"),
        ({"stiffness_proportional": -1e-3}, r"damping\.stiffness_proportional: .*≥ 0"),
        ({"mass_proportional": float("nan")}, r"damping\.mass_proportional: must be a finite number"),
        ({"matrix": (-np.eye(6)).tolist()}, r"damping\.matrix: .*positive semi-definite"),
        ({"ratio": 0.01, "frequency": 5.0, "typo": 1}, r"unknown field `typo`"),
    ],
)
def test_bad_damping_is_named_with_its_fix(damping, message):
    with pytest.raises(fd.ModelError, match=message):
        bar(damping).validate()


def test_damping_in_a_model_file(tmp_path, undamped_modes):
    f1 = float(undamped_modes.frequency[0])
    path = tmp_path / "bar.yaml"
    bar({"ratio": 0.05, "frequency": f1}).to_yaml(path)
    assert "ratio: 0.05" in path.read_text()
    md = fd.modes(fd.load(path), 1, preload=False)
    assert float(md.damping_ratio[0]) == pytest.approx(0.05, rel=1e-8)
