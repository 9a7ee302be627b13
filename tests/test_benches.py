"""The benchmark scripts' own arithmetic (their timings are measured, never tested)."""

import json
import subprocess
import sys
from pathlib import Path

BENCHES = Path(__file__).resolve().parent.parent / "benches"


def test_iteration_ratio_divides_each_iteration_by_the_lu_it_takes(tmp_path):
    # Criterion's layout: <group>_<bench>/new/estimates.json, medians in ns.
    medians_ns = {
        "newton_iteration_beam_pendulum_ep": 50_000,
        "assembly_beam_pendulum_ep": 22_000,
        "factorization_beam_pendulum_ep": 25_000,
        "solve_beam_pendulum_ep": 3_000,
        "newton_iteration_beam_pendulum_ed": 170_000,
        "assembly_beam_pendulum_ed": 106_000,
        # ED's exact iteration takes the LU by motion pairs, not the scalar one.
        "factorization_beam_pendulum_ed": 150_000,
        "factorization_beam_pendulum_ed_exact": 50_000,
        "solve_beam_pendulum_ed_exact": 4_500,
    }
    for name, ns in medians_ns.items():
        folder = tmp_path / name / "new"
        folder.mkdir(parents=True)
        (folder / "estimates.json").write_text(json.dumps({"median": {"point_estimate": ns}}))
    out = subprocess.run(
        [sys.executable, str(BENCHES / "iteration_ratio.py"), "--criterion", str(tmp_path)],
        capture_output=True,
        text=True,
        check=True,
    ).stdout
    rows = {tuple(c.strip() for c in line.split("|")[1:3]): line for line in out.splitlines()}
    assert rows[("beam_pendulum", "EP")].rstrip(" |").endswith("2.00")
    assert rows[("beam_pendulum", "ED exact")].rstrip(" |").endswith("3.40")
    # No decoupled results, no other models: said, not invented.
    assert "not benchmarked" in rows[("beam_pendulum", "ED decoupled")]
    assert "not benchmarked" in rows[("four_bar", "EP")]
