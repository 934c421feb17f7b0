"""The stamp every bench results file opens with: which code, machine, threads, libraries and command made it.

A result is compared with others long after it was made, when the code, the libraries or the machine's load
may have changed; a number that cannot say what produced it cannot be compared. So every bench script starts
a ``BenchRun`` before it measures and writes its JSON through ``BenchRun.write``, which puts one ``"stamp"``
object first: the commit and whether the working tree differed from it, the command line, the machine, the
thread counts, the versions of the project's libraries, the load average at start and end, the share of CPU
time the host took away during the run (steal, on a virtual machine) and a fixed workload's time at start and
end. The last two say whether a slower figure is the code's or the machine's: on a shared host the same code
has measured twice as slow.
``tests/bench/test_results_stamped.py`` holds every committed file in ``bench/results/`` to it.
"""

from __future__ import annotations

import json
import os
import platform
import re
import shutil
import subprocess
import sys
import time
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass
from datetime import UTC, datetime
from importlib.metadata import PackageNotFoundError, requires, version
from pathlib import Path
from typing import Any

REPO_ROOT = Path(__file__).resolve().parents[1]
RESULTS_DIR = REPO_ROOT / "bench" / "results"
PROJECT = "jarvis-service"
"""The distribution whose declared dependencies are the libraries a stamp lists."""
THREAD_VARIABLES = ("OMP_NUM_THREADS", "MKL_NUM_THREADS", "OPENBLAS_NUM_THREADS")
UNKNOWN_COMMIT = "unknown"
PROBE_ITERATIONS = 1_000_000
"""Additions in ``speed_probe_ms`` (tens of milliseconds: short beside any bench)."""


def results_path(name: str) -> Path:
    """Where bench ``name`` writes by default: ``bench/results/<name>.json``."""
    return RESULTS_DIR / f"{name}.json"


def _git(*args: str, cwd: Path = REPO_ROOT) -> str | None:
    """``git args`` in ``cwd``: its output as written, or None outside a checkout or without git."""
    try:
        done = subprocess.run(["git", *args], cwd=cwd, capture_output=True, text=True, check=False)
    except FileNotFoundError:
        return None
    return done.stdout if done.returncode == 0 else None


def head_commit(folder: Path = REPO_ROOT) -> str:
    """The full hash of the commit checked out in ``folder`` (``unknown`` when it is no git checkout)."""
    commit = _git("rev-parse", "HEAD", cwd=folder)
    return commit.strip() if commit else UNKNOWN_COMMIT


def uncommitted_paths(repo: Path = REPO_ROOT) -> list[str]:
    """Paths whose working-tree state differs from the commit (changed, staged or untracked, not ignored).

    ``bench/results`` is left out: ``python -m bench`` runs the scripts one after another, and the files the
    earlier ones wrote are results, not code that could colour the later ones."""
    status = _git("status", "--porcelain=v1", "--", ".", ":(exclude)bench/results", cwd=repo)
    return [line[3:] for line in status.splitlines()] if status else []


def machine() -> dict[str, Any]:
    """The CPU's model name, the cores this process may run on, the OS and the Python version."""
    cpu = platform.processor() or platform.machine()
    try:
        lines = Path("/proc/cpuinfo").read_text().splitlines()
        names = [line.split(":", 1)[1].strip() for line in lines if line.startswith("model name")]
        cpu = names[0] if names else cpu
    except OSError:
        pass
    return {
        "cpu": cpu,
        "cores": len(os.sched_getaffinity(0)),
        "platform": platform.platform(),
        "python": platform.python_version(),
    }


def threads() -> dict[str, Any]:
    """Thread counts that set how fast the numbers came: torch's in this process (when the bench loaded it),
    the OpenMP/BLAS variables, and the threads per worker of a service this process starts."""
    from app.settings import Settings  # the service's own default, and JARVIS_THREADS_PER_WORKER if set

    torch = sys.modules.get("torch")
    return {
        "torch": torch.get_num_threads() if torch is not None else "not loaded",
        **{name: os.environ.get(name) for name in THREAD_VARIABLES},
        "service_per_worker": Settings().threads_per_worker,
    }


def library_versions(extra: Sequence[str] = ()) -> dict[str, str]:
    """Installed versions of the project's declared dependencies (none listed when the project is not
    installed), and of ``extra`` (a bench's own)."""
    try:
        declared = [req for req in requires(PROJECT) or [] if "extra ==" not in req]
    except PackageNotFoundError:
        declared = []
    names = [re.split(r"[\s;<>=!~\[]", req, maxsplit=1)[0] for req in declared]
    found = {}
    for name in sorted({*names, *extra}, key=str.lower):
        try:
            found[name] = version(name)
        except PackageNotFoundError:
            found[name] = "not installed"
    return found


def load_average() -> list[float]:
    """The 1, 5 and 15 minute load averages: how busy the shared machine was."""
    return [round(value, 2) for value in os.getloadavg()]


def cpu_times() -> tuple[int, int] | None:
    """(steal, total) clock ticks of all CPUs since boot, from ``/proc/stat``; None where there is none.
    Steal is time a virtual machine's CPUs were ready to run but the host ran something else."""
    try:
        fields = Path("/proc/stat").read_text().split("\n", 1)[0].split()
    except OSError:
        return None
    ticks = [int(value) for value in fields[1:]]
    return (ticks[7] if len(ticks) > 7 else 0), sum(ticks[:8])


def steal_share(start: tuple[int, int] | None, end: tuple[int, int] | None) -> float | None:
    """The share of CPU time the host took from this machine between two ``cpu_times``."""
    if start is None or end is None or end[1] <= start[1]:
        return None
    return round((end[0] - start[0]) / (end[1] - start[1]), 3)


def speed_probe_ms(repeats: int = 5) -> float:
    """Milliseconds of one fixed pure-Python workload (the fastest of ``repeats``): how fast a core is right
    now. A shared host that is busy, or a slower CPU, shows here before it shows in a bench's medians."""
    best = float("inf")
    for _ in range(repeats):
        started = time.perf_counter()
        total = 0
        for value in range(PROBE_ITERATIONS):
            total += value
        best = min(best, time.perf_counter() - started)
    return round(best * 1e3, 2)


def runs_for_commit(folder: Path, commit: str) -> Path:
    """``folder``, ready to resume only episodes run by this commit's code: a folder left by another
    commit (or by one not recorded) is cleared first, and said so, so a bench never mixes code versions."""
    marker = folder / "commit"
    if folder.exists() and (not marker.exists() or marker.read_text().strip() != commit):
        was = marker.read_text().strip() if marker.exists() else "an unrecorded commit"
        print(f"{folder}: results of {was}, not {commit}; starting afresh")
        shutil.rmtree(folder)
    folder.mkdir(parents=True, exist_ok=True)
    marker.write_text(commit + "\n")
    return folder


@dataclass(frozen=True)
class BenchRun:
    """One run of a bench script, started before it measures: the code is read then (a commit made while a
    long bench runs never reaches the service it started), the rest when it writes."""

    name: str
    command: str
    commit: str
    uncommitted: tuple[str, ...]
    started_at: str
    load_average_at_start: tuple[float, ...]
    cpu_at_start: tuple[int, int] | None
    speed_probe_ms_at_start: float
    started: float

    @classmethod
    def start(cls, name: str, argv: Sequence[str] | None) -> BenchRun:
        """The run of ``python -m bench.<name>`` with ``argv`` (None: this process's own arguments)."""
        arguments = list(argv) if argv is not None else sys.argv[1:]
        return cls(
            name=name,
            command=" ".join(["python", "-m", f"bench.{name}", *arguments]),
            commit=head_commit(),
            uncommitted=tuple(uncommitted_paths()),
            started_at=datetime.now(UTC).isoformat(timespec="seconds"),
            load_average_at_start=tuple(load_average()),
            cpu_at_start=cpu_times(),
            speed_probe_ms_at_start=speed_probe_ms(),
            started=time.perf_counter(),
        )

    def stamp(self, libraries: Sequence[str] = ()) -> dict[str, Any]:
        """The ``"stamp"`` object; ``libraries`` names packages beyond the project's own dependencies."""
        return {
            "bench": self.name,
            "command": self.command,
            "commit": self.commit,
            "dirty": bool(self.uncommitted),
            "uncommitted": list(self.uncommitted),
            "started_at": self.started_at,
            "wall_s": round(time.perf_counter() - self.started, 1),
            "machine": machine(),
            "threads": threads(),
            "libraries": library_versions(libraries),
            "load_average": {"start": list(self.load_average_at_start), "end": load_average()},
            "cpu_steal_share": steal_share(self.cpu_at_start, cpu_times()),
            "speed_probe_ms": {"start": self.speed_probe_ms_at_start, "end": speed_probe_ms()},
        }

    def write(self, out: Path, report: Mapping[str, Any], libraries: Sequence[str] = ()) -> None:
        """Write ``report`` to ``out`` as JSON with the stamp first (replacing one it already holds)."""
        stamped = {"stamp": self.stamp(libraries), **{k: v for k, v in report.items() if k != "stamp"}}
        out.parent.mkdir(parents=True, exist_ok=True)
        out.write_text(json.dumps(stamped, indent=2) + "\n", encoding="utf-8")
        print(f"wrote {out}")

    def finish(
        self, out: Path, report: Mapping[str, Any], summary: Iterable[str], libraries: Sequence[str] = ()
    ) -> int:
        """How a bench script ends: print its ``summary`` lines, ``write`` the report; the exit status (0)."""
        for line in summary:
            print(line)
        self.write(out, report, libraries)
        return 0
