"""``python -m bench [NAME ...]`` (``make bench``): run every benchmark script, or the named ones.

Each script runs in its own process (``python -m bench.<name>``), so one script's memory and threads do not
colour the next one's timings, and one failing script does not stop the rest; the exit code is non-zero if
any failed. Each writes its JSON result to ``bench/results/``.
"""

from __future__ import annotations

import subprocess
import sys
import time
from pathlib import Path

from symbolic.cli_args import Parser, plain

BENCH_DIR = Path(__file__).resolve().parent


def bench_scripts() -> list[str]:
    """Module names of the benchmark scripts in this folder (those with a command line), alphabetically;
    helper modules such as ``stamp`` are not benchmarks."""
    return sorted(
        path.stem
        for path in BENCH_DIR.glob("*.py")
        if not path.stem.startswith("_") and 'if __name__ == "__main__":' in path.read_text()
    )


def main(argv: list[str] | None = None) -> int:
    known = bench_scripts()
    parser = Parser(prog="python -m bench", description=plain(__doc__.splitlines()[0]))
    parser.add_argument("names", nargs="*", help=f"scripts to run (default: all): {', '.join(known)}")
    args = parser.parse_args(argv)
    unknown = [name for name in args.names if name not in known]
    if unknown:
        parser.error(f"unknown benchmark(s) {', '.join(unknown)}; known: {', '.join(known)}")
    failed = []
    for name in args.names or known:
        print(f"== bench.{name}", flush=True)
        started = time.perf_counter()
        code = subprocess.call([sys.executable, "-m", f"bench.{name}"], cwd=BENCH_DIR.parent)
        print(f"== bench.{name}: exit {code} after {time.perf_counter() - started:.0f} s", flush=True)
        if code != 0:
            failed.append(name)
    if failed:
        print(f"failed: {', '.join(failed)}")
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
