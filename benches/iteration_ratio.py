"""A Newton iteration's cost against one sparse LU of its matrix (issue 17, item 1), from the
criterion benchmarks' last results.

    cargo bench --bench kernels -- "newton_iteration|assembly|factorization|solve"
    python benches/iteration_ratio.py [--criterion target/criterion]

Prints, per model of `benches/kernels.rs` and per iteration — EP's; ED's default one on its
decoupled complex system (what modified Newton factors); ED's exact one (full Newton, and
where ED prefers its exact factors), whose LU is taken by motion pairs — the median times of
the iteration, its tangent assembly, its LU and its back-substitution, and the iteration over
the LU. Models not benchmarked yet are skipped with a note.
"""

import argparse
import json
from pathlib import Path

MODELS = ("beam_pendulum", "free_collar", "chain64", "four_bar")
# (label, the iteration's bench, its assembly's, its LU's, its solve's), after the model name.
ITERATIONS = (
    ("EP", "ep", "ep", "ep", "ep"),
    ("ED decoupled", "ed_decoupled", "ed_decoupled", "ed_decoupled", "ed_decoupled"),
    ("ED exact", "ed", "ed", "ed_exact", "ed_exact"),
)


def median_us(root: Path, group: str, name: str) -> float | None:
    """The median of bench `group/name` in µs, None if it has no results."""
    path = root / f"{group}_{name}" / "new" / "estimates.json"
    if not path.exists():
        return None
    return json.loads(path.read_text())["median"]["point_estimate"] / 1e3


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    default = Path(__file__).resolve().parent.parent / "target" / "criterion"
    ap.add_argument("--criterion", type=Path, default=default, help="criterion's output folder")
    root = ap.parse_args().criterion
    print("| model | iteration | µs | assembly µs | LU µs | solve µs | iteration / LU |")
    print("| --- | --- | --- | --- | --- | --- | --- |")
    for model in MODELS:
        for label, it, asm, lu, solve in ITERATIONS:
            times = [
                median_us(root, group, f"{model}_{suffix}")
                for group, suffix in (
                    ("newton_iteration", it),
                    ("assembly", asm),
                    ("factorization", lu),
                    ("solve", solve),
                )
            ]
            if None in times:
                print(f"| {model} | {label} | not benchmarked | | | | |")
                continue
            t_it, t_asm, t_lu, t_solve = times
            print(
                f"| {model} | {label} | {t_it:.1f} | {t_asm:.1f} | {t_lu:.1f} | {t_solve:.2f} "
                f"| {t_it / t_lu:.2f} |"
            )


if __name__ == "__main__":
    main()
