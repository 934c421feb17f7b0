"""Every command line answers --help without loading torch or transformers, says its defaults in plain text,
and refuses a bad argument with one line on stderr and exit code 2 (issue 64 §5)."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

from harness.drive.service import free_port

REPO_ROOT = Path(__file__).resolve().parents[1]
HEAVY = ("torch", "transformers", "onnxruntime")
BENCH_DIR = REPO_ROOT / "bench"
# Modules under bench/ that are no command line, with the reason (`python -m bench` still lists them).
NOT_COMMANDS = {name: "helpers the other scripts import; it has no main" for name in ("cli", "stamp")}


def bench_commands() -> list[str]:
    """Every ``bench/NAME.py`` that runs as ``python -m bench.NAME`` (it has an ``if __name__`` block)."""
    return sorted(
        path.stem
        for path in BENCH_DIR.glob("*.py")
        if not path.stem.startswith("_") and 'if __name__ == "__main__":' in path.read_text(encoding="utf-8")
    )


# A module run as `python -m`, and the arguments before --help (the subcommand, if any).
COMMANDS: list[tuple[str, list[str]]] = [
    ("harness", []),
    *[("harness", [name]) for name in ("demo", "run", "generate", "expert", "commander", "eval")],
    ("harness.perception_data", ["frames"]),
    ("harness.perception_data", ["search"]),
    *[("models.planner", [name]) for name in ("", "build-data", "train", "evaluate", "calibrate", "predict")],
    *[("models.planner", [name]) for name in ("average", "export")],
    *[("models.perception", [name]) for name in ("", "train", "add-colour", "evaluate")],
    *[("models.goal_transformer", [name]) for name in ("", "render-data", "train", "evaluate")],
    ("symbolic.mine_lexicon", []),
    ("bench", []),
    *[("bench." + name, []) for name in bench_commands()],
]

# Runs a command's main as `python -m` does and reports, after argparse has exited, what got imported.
PROBE = """
import json, runpy, sys
module, argv = sys.argv[1], sys.argv[2:]
sys.argv = [module, *argv]
try:
    runpy.run_module(module, run_name="__main__", alter_sys=True)
    code = 0
except SystemExit as stop:
    code = stop.code
print(json.dumps({"code": code, "heavy": sorted(m for m in HEAVY if m in sys.modules)}), file=sys.stderr)
""".replace("HEAVY", repr(HEAVY))


def _probe(module: str, argv: list[str]) -> tuple[int, list[str], str]:
    done = subprocess.run(
        [sys.executable, "-c", PROBE, module, *argv],
        cwd=REPO_ROOT,
        capture_output=True,
        text=True,
        timeout=120,
        check=False,
    )
    report = json.loads(done.stderr.strip().splitlines()[-1])
    return int(report["code"] or 0), report["heavy"], done.stdout


@pytest.mark.parametrize(
    ("module", "before"), COMMANDS, ids=lambda x: x if isinstance(x, str) else " ".join(x)
)
def test_help_loads_no_torch_and_shows_defaults_as_plain_text(module: str, before: list[str]) -> None:
    code, heavy, text = _probe(module, [*(a for a in before if a), "--help"])
    assert code == 0, text
    assert text.startswith("usage:"), text[:200]
    assert heavy == [], f"{module} {before} --help imported {heavy}: import them inside the command"
    assert "``" not in text, f"raw reST in the help text:\n{text}"
    if before and before[0] in ("train", "run", "demo", "frames"):
        assert "(default: " in text, f"no default shown:\n{text}"


def test_every_bench_script_is_a_command_or_says_why_not() -> None:
    scripts = {path.stem for path in BENCH_DIR.glob("*.py") if not path.stem.startswith("_")}
    commands = set(bench_commands())
    assert scripts - commands == set(NOT_COMMANDS), "a bench script without a command line and no reason"
    assert {"agent_oracle_tfd", "planner_latency", "map_update_published"} <= commands


def _run(*argv: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-m", *argv], cwd=REPO_ROOT, capture_output=True, text=True, timeout=120, check=False
    )


def _one_line_error(done: subprocess.CompletedProcess[str], *words: str) -> None:
    assert done.returncode == 2, (done.returncode, done.stderr)
    lines = done.stderr.strip().splitlines()
    assert len(lines) == 1, f"expected one line on stderr, got:\n{done.stderr}"
    assert "Traceback" not in done.stderr
    for word in words:
        assert word in lines[0], lines[0]


@pytest.mark.parametrize(
    ("argv", "words"),
    [
        (("harness", "run", "--index", "-5"), ("--index", "-5")),
        (("harness", "demo", "--camera", "0"), ("--camera", "0")),
        (("harness", "eval", "--benchmark", "tfd", "--n", "0"), ("--n",)),
        (
            ("harness", "generate", "--out-dir", "x", "--n", "1", "--task", "Juggle"),
            ("Juggle", "Water Plant"),
        ),
        (
            ("models.planner", "predict", "--checkpoint", "/no/such/planner"),
            ("--checkpoint", "/no/such/planner"),
        ),
        (("models.perception", "evaluate", "--checkpoint", "/no/such", "--frames", "."), ("/no/such",)),
        (
            ("models.goal_transformer", "train", "--episodes", ".", "--out-dir", "x", "--learning-rate", "0"),
            ("--learning-rate",),
        ),
        (("harness", "commander", "--url", "localhost:8000"), ("--url", "http://host:port")),
    ],
    ids=lambda x: " ".join(x) if isinstance(x, tuple) and len(x) > 2 else None,
)
def test_a_bad_argument_is_one_line_and_exit_code_2(argv: tuple[str, ...], words: tuple[str, ...]) -> None:
    _one_line_error(_run(*argv), *words)


@pytest.mark.parametrize("command", ["run", "commander"])
def test_an_unreachable_url_is_one_line_and_exit_code_2(command: str) -> None:
    url = f"http://127.0.0.1:{free_port()}"  # nothing listens there
    _one_line_error(_run("harness", command, "--url", url), "no service answers", url)
