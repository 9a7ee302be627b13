"""The beam section every benchmark uses: the paper's beam-slider section (section 7.1), as
in examples/beam_pendulum.yaml. Plain data, importable without flexdyn (the peers' venv)."""

BEAM_SECTION = {
    "ea": 44e6,  # N
    "ga2": 2.8e6,
    "ga3": 14e6,
    "gj": 28e3,  # N·m²
    "ei2": 300e3,
    "ei3": 23e3,
    "m": 1.6,  # kg/m
    "i22": 1e-3,  # kg·m
    "i33": 11e-3,
}
