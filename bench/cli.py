"""The command line every bench script shares: ``python -m bench.<name>``, described by its docstring's first
paragraph, with ``--out`` for the results file (default ``bench/results/<name>.json``)."""

from __future__ import annotations

from pathlib import Path

from bench.stamp import results_path
from symbolic.cli_args import Parser, http_url, int_at_least, plain


def bench_parser(name: str, doc: str | None, *, out: bool = True) -> Parser:
    """The parser of ``python -m bench.<name>``; ``out=False`` leaves ``--out`` to a bench whose default
    file depends on its other options."""
    parser = Parser(prog=f"python -m bench.{name}", description=plain((doc or "").split("\n\n")[0]))
    if out:
        parser.add_argument("--out", type=Path, default=results_path(name), help="results file")
    return parser


def add_episode_options(
    parser: Parser, *, n: int, n_help: str, run_dir: Path | None, run_dir_help: str
) -> None:
    """The options every bench that plays episodes through a service takes: how many, how many at once, a
    resumable run folder, and a running service to use instead of starting one."""
    parser.add_argument("--n", type=int_at_least(1), default=n, help=n_help)
    parser.add_argument("--workers", type=int_at_least(1), default=2, help="episodes run in parallel")
    parser.add_argument("--run-dir", type=Path, default=run_dir, help=run_dir_help)
    parser.add_argument("--url", type=http_url, help="a running service (default: start one)")
