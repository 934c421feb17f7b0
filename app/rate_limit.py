"""Request rates per API key: a token bucket per key, in this process or in Redis (shared by all workers).

A key may send ``rate_per_s`` requests a second on average and ``burst`` at once; a request over that is
answered 429 with ``Retry-After`` (the seconds until a token is back), so a load test or a runaway client
of one key cannot starve the others. With several worker processes the buckets live in Redis, or each
worker would grant the full rate.
"""

from __future__ import annotations

import math
import threading
import time
from collections.abc import Callable
from typing import Protocol

import redis


class RateLimiter(Protocol):
    def take(self, key: str, rate_per_s: float, burst: int) -> float:
        """Take one token from ``key``'s bucket: 0 when granted, else the seconds to wait for one."""
        ...

    def close(self) -> None: ...


class InMemoryRateLimiter:
    """Buckets in a dict of this process (the in-memory store's companion)."""

    def __init__(self, clock: Callable[[], float] = time.monotonic) -> None:
        self._clock = clock
        self._buckets: dict[str, tuple[float, float]] = {}  # key -> (tokens, when counted)
        self._guard = threading.Lock()

    def take(self, key: str, rate_per_s: float, burst: int) -> float:
        now = self._clock()
        with self._guard:
            tokens, then = self._buckets.get(key, (float(burst), now))
            tokens = min(float(burst), tokens + (now - then) * rate_per_s)
            if tokens >= 1.0:
                self._buckets[key] = (tokens - 1.0, now)
                return 0.0
            self._buckets[key] = (tokens, now)
            return (1.0 - tokens) / rate_per_s

    def close(self) -> None:
        with self._guard:
            self._buckets.clear()


# KEYS: the bucket hash. ARGV: rate per second, burst. Returns the milliseconds to wait (0: granted).
_TAKE = """
local t = redis.call('TIME')
local now = tonumber(t[1]) * 1000 + tonumber(t[2]) / 1000
local rate = tonumber(ARGV[1]) / 1000
local burst = tonumber(ARGV[2])
local state = redis.call('HMGET', KEYS[1], 'tokens', 'at')
local tokens = tonumber(state[1]) or burst
local at = tonumber(state[2]) or now
tokens = math.min(burst, tokens + (now - at) * rate)
local wait = 0
if tokens >= 1 then tokens = tokens - 1 else wait = (1 - tokens) / rate end
redis.call('HSET', KEYS[1], 'tokens', tostring(tokens), 'at', tostring(now))
redis.call('PEXPIRE', KEYS[1], math.ceil(burst / rate) + 1000)
return tostring(wait)
"""


class RedisRateLimiter:
    """Buckets in Redis hashes, updated atomically by one script on Redis's clock."""

    def __init__(self, url: str, prefix: str = "jarvis") -> None:
        self._redis = redis.Redis.from_url(url, socket_timeout=10.0)
        self._take = self._redis.register_script(_TAKE)
        self.prefix = prefix

    def take(self, key: str, rate_per_s: float, burst: int) -> float:
        wait_ms = float(self._take(keys=[f"{self.prefix}:rate:{key}"], args=[rate_per_s, burst]))
        return 0.0 if wait_ms <= 0 else wait_ms / 1000.0

    def close(self) -> None:
        self._redis.close()


def retry_after_header(seconds: float) -> str:
    """``Retry-After`` in whole seconds, at least 1 (HTTP has no fractions)."""
    return str(max(1, math.ceil(seconds)))
