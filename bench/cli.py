"""The command line every bench script shares: ``python -m bench.<name>``, described by its docstring's first
paragraph, with ``--out`` for the results file (default ``bench/results/<name>.json``)."""

from __future__ import annotations

from pathlib import Path

from bench.stamp import results_path
from symbolic.cli_args import Parser, plain


def bench_parser(name: str, doc: str | None, *, out: bool = True) -> Parser:
    """The parser of ``python -m bench.<name>``; ``out=False`` leaves ``--out`` to a bench whose default
    file depends on its other options."""
    parser = Parser(prog=f"python -m bench.{name}", description=plain((doc or "").split("\n\n")[0]))
    if out:
        parser.add_argument("--out", type=Path, default=results_path(name), help="results file")
    return parser
