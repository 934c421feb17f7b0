"""What every service bench's results file says about the run that made it, and how it is written.

The guide's rule: a result records the commit, machine, threads and command that made it (the load average
is each bench's own, taken around what it measures).
"""

from __future__ import annotations

import json
import os
import platform
import sys
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from bench.tatc_commander import current_commit


def provenance(name: str, argv: Sequence[str] | None) -> dict[str, Any]:
    """The bench's name, command line, commit, machine and the service's threads per worker."""
    return {
        "bench": name,
        "command": " ".join(["python", "-m", f"bench.{name}", *(argv if argv is not None else sys.argv[1:])]),
        "commit": current_commit(),
        "machine": {
            "cpu": platform.processor() or platform.machine(),
            "cores": len(os.sched_getaffinity(0)),
            "python": platform.python_version(),
        },
        "threads_per_worker": os.environ.get("JARVIS_THREADS_PER_WORKER", "1 (the service's default)"),
    }


def write_results(out: Path, report: dict[str, Any], headline: str) -> None:
    """Write ``report`` to ``out`` and print its ``headline`` entry and where it went."""
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(json.dumps(report, indent=1) + "\n")
    print(json.dumps(report[headline], indent=1))
    print(f"wrote {out}")
