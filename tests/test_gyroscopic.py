"""The gyroscopic (Coriolis) matrix of a spinning model (issue 21, item 3's foundation): with
the static tangent about the steady spin (centrifugal softening included) and the mass, the
quadratic eigenproblem `λ²M + λG + K` gives the frequencies in the frame turning with the
rotor — checked against the closed forms of a whirling point mass and an overhung disc."""

import json

import numpy as np
import scipy.sparse as sp

import flexdyn as fd
from flexdyn import _core
from flexdyn.modes import _null_space
from flexdyn.results import static_model_data

EI, MASS, L, SPIN = 2.0e3, 5.0, 1.0, 12.0
# A light, axially and shear-stiff shaft (its own mass 1e-4 of the disc's).
SECTION = {"ea": 1e9, "ga2": 1e9, "ga3": 1e9, "gj": 1e3, "ei2": EI, "ei3": EI, "m": 5e-4}
SECTION |= {"i22": 1e-9, "i33": 1e-9}


def overhung(polar: float, diametral: float) -> fd.Model:
    """A vertical shaft clamped at its foot carrying a disc at its top, spinning about z."""
    m = fd.Model("overhung rotor")
    m.beam("shaft", [0, 0, 0], [0, 0, L], elements=4, section=SECTION)
    m.clamp("root", "ground", "shaft.0")
    # The beam's node triad has axis 1 along the shaft: the polar inertia goes there.
    m.body("disc", "shaft.end", mass=MASS, inertia=[polar, diametral, diametral])
    m.initial_spin(items=["shaft"], axis=[0, 0, 1], rate=SPIN)
    return m


def rotating_frequencies(model: fd.Model, count: int, gyroscopic: bool = True) -> np.ndarray:
    sim = _core.Simulation(json.dumps(static_model_data(model)))
    sim.solve_static()
    n, (kp, ki, kv), (mr, mc, mv), _, labels = sim.linearize()
    gr, gc, gv = sim.gyroscopic()
    k = sp.csc_matrix((kv, ki, kp), shape=(n, n)).toarray()
    m = sp.csc_matrix((mv, (mr, mc)), shape=(n, n)).toarray()
    g = sp.csc_matrix((gv, (gr, gc)), shape=(n, n)).toarray() * gyroscopic
    assert np.abs(g + g.T).max() == 0.0  # skew: G does no work
    rows = np.array([lab.startswith("row:") for lab in labels])
    z = _null_space(k, rows)
    kr, mr_, gr_ = (z.T @ a[np.ix_(~rows, ~rows)] @ z for a in (k, m, g))
    r = kr.shape[0]
    state = np.block([[np.zeros((r, r)), np.eye(r)], [-np.linalg.solve(mr_, kr), -np.linalg.solve(mr_, gr_)]])
    lam = np.linalg.eigvals(state)
    assert np.abs(lam.real).max() < 1e-4 * np.abs(lam).max()  # undamped: on the imaginary axis
    return np.sort(lam.imag[lam.imag > 1e-6])[:count]


def test_a_whirling_point_mass_splits_by_the_spin():
    """No rotary inertia: whirl at ω₀ = √(3EI/ML³) in both directions in the fixed frame, so
    ω₀ − Ω and ω₀ + Ω in the turning frame (Coriolis 2mΩ̃ with the softening mΩ̃Ω̃)."""
    got = rotating_frequencies(overhung(1e-9, 1e-9), 2)
    w0 = np.sqrt(3 * EI / (MASS * L**3))
    # The shaft's own mass lowers ω₀ by ~(33/140)·1e-4/2: 2e-5 measured; 1e-4 bounds it.
    np.testing.assert_allclose(got, [w0 - SPIN, w0 + SPIN], rtol=1e-4)


def test_an_overhung_disc_whirls_forward_and_backward_as_the_closed_form():
    """The disc's polar inertia stiffens forward whirl and softens backward whirl: in the fixed
    frame det[[k11 − mω², k12], [k12, k22 − J_d ω² ± J_p Ω ω]] = 0 (cantilever tip stiffness
    k11 = 12EI/L³, k12 = −6EI/L², k22 = 4EI/L); in the turning frame |ω_F − Ω| and ω_B + Ω."""
    polar, diametral = 0.08, 0.05
    got = rotating_frequencies(overhung(polar, diametral), 5)
    k11, k12, k22 = 12 * EI / L**3, -6 * EI / L**2, 4 * EI / L

    def whirl(sign):
        c = np.polymul([-MASS, 0, k11], [-diametral, sign * polar * SPIN, k22])
        c[-1] -= k12**2
        roots = np.roots(c)
        return np.sort(roots[(abs(roots.imag) < 1e-9) & (roots.real > 0)].real)

    forward, backward = whirl(+1), whirl(-1)
    expected = np.sort(np.r_[np.abs(forward - SPIN), backward + SPIN])
    torsion = np.sqrt(1e3 / (L * polar))  # √(GJ/(L J_p)), untouched by the spin
    whirls = got[np.abs(got - torsion) > 1e-6 * torsion]
    assert len(whirls) == 4 and np.isclose(got, torsion, rtol=1e-6).sum() == 1
    # 6.6e-5 measured at the high pair (4 cubic elements, the shaft's mass): 2e-4 bounds it.
    np.testing.assert_allclose(whirls, expected, rtol=2e-4)
    # Without the gyroscopic matrix the low pair would not split (and the softening alone
    # would give √(ω₀² − Ω²) twice): far from both.
    without = rotating_frequencies(overhung(polar, diametral), 2, gyroscopic=False)
    assert np.abs(without - expected[:2]).min() > 0.1 * expected[0]
