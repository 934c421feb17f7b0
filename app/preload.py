"""Load the models sessions need at start-up, in a background thread, so readiness means it (DESIGN.md §4).

The language planner takes 6-18 s to load and used to load on the first request that needed it, while
``/readyz`` already said ready. Here the lifespan starts the loads in a thread: ``/healthz`` answers while
they run, ``/readyz`` answers 503 naming what is still loading, and an orchestrator routes traffic only
once they are done. The loaders are the ones sessions use (``agent.model_planner.load_generator`` and
``agent.perception.learned.load_learned_models``, both cached once per process and taken under a lock), so
a request that needs a model during the load waits for that same load instead of starting its own, and
gets the loaded model.

A load that fails (a missing or broken checkpoint) is logged and counts as finished: the service is still
useful without it (oracle planner and perception), and the requests that need it answer 422 as before.
"""

from __future__ import annotations

import logging
import threading
import time
from collections.abc import Callable, Mapping
from pathlib import Path

from app.logging_json import adopt_library_logs
from app.session_builder import network_paths
from app.settings import Settings

_LOG = logging.getLogger("app.preload")

PLANNER = "language planner"
PERCEPTION = "perception networks"


class ModelPreload:
    """Runs named loaders one after the other in a daemon thread and says which are still pending."""

    def __init__(self, loaders: Mapping[str, Callable[[], object]]) -> None:
        self._loaders = dict(loaders)
        self._pending = list(self._loaders)
        self._lock = threading.Lock()
        self._done = threading.Event()
        self.failures: dict[str, str] = {}
        """Loader name -> the error it raised (empty when all loaded)."""
        self.seconds: dict[str, float] = {}
        """Loader name -> wall seconds it took."""

    @classmethod
    def for_settings(cls, settings: Settings) -> ModelPreload:
        """The perception networks (when both checkpoint directories exist; small, first, so the window
        in which a learned session could race the load is short) and the language planner."""

        def planner() -> object:
            from agent.model_planner import DEFAULT_CHECKPOINT_DIR, load_generator

            return load_generator(settings.planner_checkpoint or DEFAULT_CHECKPOINT_DIR)

        paths = network_paths(settings)

        def perception() -> object:
            from agent.perception.learned import load_learned_models

            return load_learned_models(Path(paths.depth), Path(paths.segmentation))

        loaders: dict[str, Callable[[], object]] = {}
        if Path(paths.depth).is_dir() and Path(paths.segmentation).is_dir():
            loaders[PERCEPTION] = perception
        loaders[PLANNER] = planner
        return cls(loaders)

    def start(self) -> None:
        threading.Thread(target=self._run, name="model-preload", daemon=True).start()

    def pending(self) -> list[str]:
        """Names of the loads not finished yet, in load order."""
        with self._lock:
            return list(self._pending)

    def wait(self, timeout_s: float | None = None) -> bool:
        """True once every load finished (loaded or failed) within ``timeout_s``."""
        return self._done.wait(timeout_s)

    def _run(self) -> None:
        try:
            adopt_library_logs(import_model_libraries=True)
        except Exception:  # plain-text library lines are no reason to stay unready
            _LOG.exception("library_log_adoption_failed")
        for name, load in self._loaders.items():
            started = time.perf_counter()
            try:
                load()
            except Exception as error:  # a broken checkpoint must not leave the service never ready
                self.failures[name] = f"{type(error).__name__}: {error}"
                _LOG.exception("model_preload_failed", extra={"model": name})
            seconds = time.perf_counter() - started
            self.seconds[name] = seconds
            if name not in self.failures:
                _LOG.info("model_loaded", extra={"model": name, "seconds": round(seconds, 3)})
            with self._lock:
                self._pending.remove(name)
        self._done.set()
