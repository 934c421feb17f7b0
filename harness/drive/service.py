"""Start the agent service as a subprocess (``python -m app``) on a free port, and stop it again.

The demo, the benchmarks and the end-to-end tests drive the service exactly as a remote harness would: over
TCP, in another process. The service's structured log (one JSON event per line on stderr) goes to a file,
not a pipe: a long run writes thousands of request events, and an undrained pipe would block the server.
"""

from __future__ import annotations

import argparse
import ctypes
import json
import os
import signal
import socket
import subprocess
import sys
import tempfile
import time
from collections.abc import Iterator, Mapping
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import httpx

from symbolic.cli_args import http_url, port

REPO_ROOT = Path(__file__).resolve().parents[2]
LOOPBACK = "127.0.0.1"
STARTUP_TIMEOUT_S = 60.0  # importing torch and transformers on a cold, shared 2-core machine takes a while
STOP_TIMEOUT_S = 10.0  # grace period after SIGTERM before SIGKILL
POLL_INTERVAL_S = 0.2
LOG_TAIL_CHARS = 4000  # how much of the service log a startup error quotes


class ServiceStartError(RuntimeError):
    """The service exited or did not become ready in time; the message quotes its log."""


def free_port(host: str = LOOPBACK) -> int:
    """A TCP port nobody listens on right now (the OS picks it)."""
    with socket.socket() as probe:
        probe.bind((host, 0))
        return int(probe.getsockname()[1])


def port_is_free(port: int, host: str = LOOPBACK) -> bool:
    with socket.socket() as probe:
        try:
            probe.bind((host, port))
        except OSError:
            return False
    return True


@dataclass
class RunningService:
    """A live service process and where its log goes."""

    base_url: str
    port: int
    process: subprocess.Popen[bytes]
    log_path: Path

    def log_text(self) -> str:
        return self.log_path.read_text(encoding="utf-8", errors="replace") if self.log_path.exists() else ""

    def log_events(self) -> list[dict[str, Any]]:
        """The service's JSON log events so far (lines that are not JSON are skipped)."""
        events = []
        for line in self.log_text().splitlines():
            try:
                event = json.loads(line)
            except ValueError:
                continue
            if isinstance(event, dict):
                events.append(event)
        return events


def _wait_until_ready(service: RunningService, timeout_s: float) -> None:
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        if service.process.poll() is not None:
            raise ServiceStartError(
                f"the service exited with code {service.process.returncode} before it was ready; its log:\n"
                f"{service.log_text()[-LOG_TAIL_CHARS:]}"
            )
        try:
            if httpx.get(f"{service.base_url}/readyz", timeout=1.0).status_code == 200:
                return
        except httpx.TransportError:
            pass
        time.sleep(POLL_INTERVAL_S)
    raise ServiceStartError(
        f"the service at {service.base_url} was not ready after {timeout_s:.0f} s; its log:\n"
        f"{service.log_text()[-LOG_TAIL_CHARS:]}"
    )


PR_SET_PDEATHSIG = 1  # Linux prctl(2): the signal a process gets when its parent dies


def _die_with_parent() -> None:
    """Run in the service's process before it starts (Linux): SIGTERM it when the process that started
    it dies, however that dies. A benchmark killed with SIGTERM or SIGKILL skips its ``finally`` and had
    left its service running (one spun at a fifth of a core for an hour, slowing every later run)."""
    ctypes.CDLL(None, use_errno=True).prctl(PR_SET_PDEATHSIG, signal.SIGTERM)


def _stop(process: subprocess.Popen[bytes]) -> None:
    if process.poll() is not None:
        return
    process.terminate()
    try:
        process.wait(timeout=STOP_TIMEOUT_S)
    except subprocess.TimeoutExpired:
        process.kill()
        process.wait()


@contextmanager
def running_service(
    port: int | None = None,
    *,
    env: Mapping[str, str] | None = None,
    log_path: Path | None = None,
    startup_timeout_s: float = STARTUP_TIMEOUT_S,
) -> Iterator[RunningService]:
    """A started and ready service for the block; stopped (terminate, then kill) when the block ends.

    ``port`` None picks a free one. ``env`` adds ``JARVIS_*`` settings (e.g. ``JARVIS_MAX_SESSIONS``).
    ``log_path`` keeps the log there; otherwise it goes to a temporary file removed afterwards.
    """
    chosen_port = free_port() if port is None else port
    environment = {
        **os.environ,
        **(env or {}),
        "JARVIS_HOST": LOOPBACK,
        "JARVIS_PORT": str(chosen_port),
    }
    with tempfile.TemporaryDirectory(prefix="jarvis-service-") as scratch:
        path = log_path or Path(scratch) / "service.log"
        path.parent.mkdir(parents=True, exist_ok=True)
        with path.open("wb") as log_file:
            process = subprocess.Popen(
                [sys.executable, "-m", "app"],
                cwd=REPO_ROOT,
                env=environment,
                stdin=subprocess.DEVNULL,
                stdout=log_file,
                stderr=subprocess.STDOUT,
                preexec_fn=_die_with_parent if sys.platform.startswith("linux") else None,
            )
            service = RunningService(
                base_url=f"http://{LOOPBACK}:{chosen_port}", port=chosen_port, process=process, log_path=path
            )
            try:
                _wait_until_ready(service, startup_timeout_s)
                yield service
            finally:
                _stop(process)


class ServiceUnreachable(RuntimeError):
    """Nothing answers ``GET /healthz`` at the URL a command was given (or at its default port)."""


def require_service(base_url: str, timeout_s: float = 5.0) -> None:
    """Fail before any work when no service answers at ``base_url``: one clear line instead of a traceback
    from the first step's connection error."""
    try:
        httpx.get(f"{base_url}/healthz", timeout=timeout_s)
    except httpx.TransportError as error:
        raise ServiceUnreachable(
            f"no service answers at {base_url} ({type(error).__name__}: {error}); "
            "start one (make serve) or pass --start-service"
        ) from None


def add_service_arguments(parser: argparse.ArgumentParser, service: str = "service") -> None:
    """``--url`` or ``--start-service``, then ``--port``: where a command finds (or starts) the ``service``
    it drives, as ``service_url`` reads them."""
    where = parser.add_mutually_exclusive_group()
    where.add_argument("--url", type=http_url, help=f"base URL of a running {service}")
    where.add_argument("--start-service", action="store_true", help=f"start a {service} for this run")
    parser.add_argument("--port", type=port, help="port of a running service (or for --start-service)")


@contextmanager
def service_url(url: str | None, port: int | None, start: bool) -> Iterator[str]:
    """The service to talk to: a given URL, a port on this machine, or one started for the run."""
    if start:
        with running_service(port) as service:
            yield service.base_url
    else:
        base_url = url or f"http://127.0.0.1:{port or 8000}"
        require_service(base_url)
        yield base_url
