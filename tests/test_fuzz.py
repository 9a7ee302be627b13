"""A seeded, time-bounded fuzz test of the model loader, the expression language and the first
steps of a run: whatever the input, flexdyn answers with a result or with its own error
(ModelError, SolverError) — never another exception, a panic or a crash of the interpreter.

FLEXDYN_FUZZ_SECONDS (default 40) bounds the time; FLEXDYN_FUZZ_SEED picks the inputs (the
seed of a failure is in its message, so it can be replayed).
"""

import json
import os
import random
import re
import time
from pathlib import Path

import pytest

import flexdyn as fd
from flexdyn import _core

EXAMPLES = sorted((Path(__file__).resolve().parent.parent / "examples").glob("*.yaml"))
SECONDS = float(os.environ.get("FLEXDYN_FUZZ_SECONDS", "40"))
SEED = int(os.environ.get("FLEXDYN_FUZZ_SEED", "16"))

ODD_NUMBERS = [
    ".nan",
    ".inf",
    "-.inf",
    "0",
    "-1",
    "1e308",
    "-1e308",
    "1e-320",
    "2.7",
    "1e9",
    "'x'",
    "[]",
    "{}",
    "null",
]
FUNCTIONS = [
    "sin",
    "cos",
    "tan",
    "exp",
    "log",
    "sqrt",
    "abs",
    "floor",
    "atan",
    "tanh",
    "cbrt",
    "sign",
    "asin",
]
FUNCTIONS2 = ["min", "max", "pow", "atan2", "mod"]
SYMBOLS = list("+-*/^()?:<>=!&|,. ") + ["t", "pi", "e", "1e-3", "2", "**", "&&", "||", "sin(", "max("]


def random_expression(rng: random.Random, depth: int) -> str:
    if depth <= 0 or rng.random() < 0.2:
        return rng.choice(["t", "pi", f"{rng.uniform(-5, 5):.3g}", "1e-3", "2.5E+1", "e"])
    kind = rng.randrange(7)

    def sub():
        return random_expression(rng, depth - 1)

    if kind == 0:
        return f"{rng.choice(FUNCTIONS)}({sub()})"
    if kind == 1:
        return f"{rng.choice(FUNCTIONS2)}({sub()}, {sub()})"
    if kind == 2:
        return f"({sub()} {rng.choice(['<', '>=', '==', '!='])} {sub()} ? {sub()} : {sub()})"
    if kind == 3:
        return f"-{sub()}"
    if kind == 4:
        return f"smoothstep({sub()}, {sub()}, {sub()})"
    return f"({sub()} {rng.choice(['+', '-', '*', '/', '^'])} {sub()})"


def random_drive(rng: random.Random) -> str:
    r = rng.random()
    if r < 0.5:
        return random_expression(rng, rng.randrange(1, 12))
    if r < 0.7:  # character soup from the language's own alphabet
        return "".join(rng.choice(SYMBOLS) for _ in range(rng.randrange(1, 40)))
    if r < 0.8:  # long flat chains and deep nests, around the limits
        n = rng.choice([10, 90, 1000, 6000])
        return rng.choice(["+", "*", "-"]).join(["t"] * n)
    depth = rng.choice([10, 46, 63, 64, 65, 200])
    return f"{rng.choice(FUNCTIONS)}(" * depth + "t" + ")" * depth


def mutate(rng: random.Random, text: str) -> str:
    lines = text.splitlines()
    for _ in range(rng.randrange(1, 4)):
        op = rng.randrange(8)
        i = rng.randrange(len(lines))
        if op == 0:  # a number becomes something odd
            numbers = list(re.finditer(r"-?\d+\.?\d*(e[-+]?\d+)?", lines[i]))
            if numbers:
                m = rng.choice(numbers)
                lines[i] = lines[i][: m.start()] + rng.choice(ODD_NUMBERS) + lines[i][m.end() :]
        elif op == 1:
            del lines[i]
        elif op == 2:
            lines.insert(i, lines[rng.randrange(len(lines))])
        elif op == 3:
            j = rng.randrange(len(lines))
            lines[i], lines[j] = lines[j], lines[i]
        elif op == 4:  # a key misspelt
            lines[i] = re.sub(r"(\w+):", lambda m: m.group(1)[::-1] + ":", lines[i], count=1)
        elif op == 5:
            pos = rng.randrange(len(lines[i]) + 1)
            lines[i] = (
                lines[i][:pos] + "".join(chr(rng.randrange(1, 0x3000)) for _ in range(3)) + lines[i][pos:]
            )
        elif op == 6:
            return "\n".join(lines)[: rng.randrange(len(text) + 1)]
        else:  # a drive on the first joint, or a name that is not a name
            if lines[i].strip().startswith("- {type:") and "drive" not in lines[i]:
                lines[i] = lines[i].rstrip("}") + f", drive: {json.dumps(random_drive(rng))}}}"
            else:
                lines[i] = lines[i].replace(
                    "name: ", f"name: {rng.choice(['a/b', 'x.y', '', 'é', '1a', 'ok_name'])}", 1
                )
        if not lines:
            return ""
    return "\n".join(lines)


def first_steps(model_json: str):
    """Compiles a model and runs its first few steps (or load steps), bounded in time."""
    sim = _core.Simulation(model_json)
    if sim.size["unknowns"] > 5000:
        return
    if sim.is_static:
        sim.solve_static()
    else:
        sim.advance_to(min(sim.t_end, 5 * sim.dt), 0.5)
    sim.take_samples()


@pytest.mark.parametrize("target", ["loader", "expressions"])
def test_fuzz(target):
    rng = random.Random(f"{SEED}-{target}")
    texts = [p.read_text() for p in EXAMPLES]
    pendulum = next(p for p in EXAMPLES if p.name == "pendulum.yaml").read_text()
    deadline = time.monotonic() + SECONDS / 2
    tried = accepted = ran = 0
    while time.monotonic() < deadline:
        case = f"seed {SEED}, {target} case {tried}"
        if target == "loader":
            text = mutate(rng, rng.choice(texts))
        else:
            drive = random_drive(rng)
            text = pendulum.replace("damping: 0.2}", f"damping: 0.2}}\n    drive: {json.dumps(drive)}")
        tried += 1
        try:
            canonical = _core.parse_yaml(text)
        except fd.ModelError:
            continue
        except Exception as e:  # noqa: BLE001 (anything else is the bug this test looks for)
            pytest.fail(f"{case}: parse_yaml raised {type(e).__name__}: {e}\n--- input ---\n{text[:3000]}")
        accepted += 1
        # Runs are the slow part: every expression case, one loader case in ten.
        if target == "loader" and tried % 10:
            continue
        try:
            first_steps(canonical)
            ran += 1
        except (fd.ModelError, fd.SolverError):
            pass
        except Exception as e:  # noqa: BLE001 (as above)
            pytest.fail(f"{case}: the run raised {type(e).__name__}: {e}\n--- input ---\n{text[:3000]}")
    print(f"{target}: {tried} inputs, {accepted} accepted, {ran} ran their first steps")
    # The fuzzer must exercise both sides: rejected and accepted inputs (else it tests nothing).
    assert tried > 50 and 0 < accepted < tried
