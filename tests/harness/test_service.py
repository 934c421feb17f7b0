"""The built-in service runner: a started service goes away with whoever started it."""

from __future__ import annotations

import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from harness.drive.service import REPO_ROOT

STARTER = """
import time
from harness.drive.service import running_service
with running_service() as service:
    print(service.process.pid, flush=True)
    time.sleep(600)
"""


def _gone(pid: int) -> bool:
    """Whether the process has exited (no longer listed, or a zombie waiting for init to reap it)."""
    status = Path(f"/proc/{pid}/status")
    try:
        return "\nState:\tZ" in status.read_text()
    except FileNotFoundError:
        return True


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="parent-death signal is Linux's")
def test_a_service_stops_when_the_process_that_started_it_is_killed() -> None:
    # A benchmark killed with SIGKILL (or SIGTERM) never reaches its ``finally``; its service had kept
    # running, spinning on a core, and slowed every later run on the machine.
    starter = subprocess.Popen(
        [sys.executable, "-c", STARTER], cwd=REPO_ROOT, stdout=subprocess.PIPE, text=True
    )
    assert starter.stdout is not None
    service_pid = int(starter.stdout.readline())
    assert not _gone(service_pid)

    starter.send_signal(signal.SIGKILL)
    starter.wait()
    deadline = time.monotonic() + 30.0
    while not _gone(service_pid) and time.monotonic() < deadline:
        time.sleep(0.2)

    assert _gone(service_pid)
