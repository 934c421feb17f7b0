"""Fixtures shared by every test package."""

from __future__ import annotations

import os
import shutil
import socket
import subprocess
import time
import uuid
from collections.abc import Iterator
from pathlib import Path

import pytest

from symbolic.data_dir import DATA_DIR_ENV, default_data_dir


@pytest.fixture(scope="session")
def shared_data_dir() -> Path:
    """The shared data directory; tests that need it skip (with the reason) when it is absent."""
    path = default_data_dir()
    if not path.is_dir():
        pytest.skip(f"shared data directory {path} is absent; set {DATA_DIR_ENV} to run this test")
    return path


REDIS_URL_ENV = "JARVIS_TEST_REDIS_URL"
DEFAULT_TEST_REDIS_URL = "redis://127.0.0.1:6379/0"


def _redis_answers(url: str) -> bool:
    import redis

    try:
        return bool(redis.Redis.from_url(url, socket_connect_timeout=1.0).ping())
    except redis.RedisError:
        return False


@pytest.fixture(scope="session")
def redis_url(tmp_path_factory: pytest.TempPathFactory) -> Iterator[str]:
    """A real Redis server: ``$JARVIS_TEST_REDIS_URL`` (default 127.0.0.1:6379), else one started from the
    ``redis-server`` binary on PATH for this test run. Without either the test skips, except under CI
    (``CI=true``), where a missing Redis fails: the Redis store must be tested there, never mocked."""
    url = os.environ.get(REDIS_URL_ENV, DEFAULT_TEST_REDIS_URL)
    if _redis_answers(url):
        yield url
        return
    binary = shutil.which("redis-server")
    if binary is None:
        reason = f"no Redis answers at {url} (set {REDIS_URL_ENV}) and no redis-server binary is on PATH"
        if os.environ.get("CI") == "true":
            pytest.fail(f"CI must test the Redis store: {reason}")
        pytest.skip(reason)
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        port = probe.getsockname()[1]
    workdir = tmp_path_factory.mktemp("redis")
    server = subprocess.Popen(
        [binary, "--port", str(port), "--bind", "127.0.0.1", "--save", "", "--appendonly", "no"],
        cwd=workdir,
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
    )
    url = f"redis://127.0.0.1:{port}/0"
    try:
        deadline = time.monotonic() + 10.0
        while not _redis_answers(url):
            if time.monotonic() > deadline or server.poll() is not None:
                pytest.fail(f"redis-server did not start on port {port}")
            time.sleep(0.05)
        yield url
    finally:
        server.terminate()
        server.wait(timeout=10)


@pytest.fixture
def redis_prefix(redis_url: str) -> Iterator[str]:
    """A key prefix of this test's own on the shared Redis; its keys are deleted afterwards."""
    import redis

    prefix = f"jarvis-test-{uuid.uuid4().hex[:12]}"
    yield prefix
    client = redis.Redis.from_url(redis_url)
    keys = list(client.scan_iter(match=f"{prefix}:*", count=1000))
    if keys:
        client.delete(*keys)
    client.close()
