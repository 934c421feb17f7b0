"""Structured logs: one JSON object per line, so a log shipper needs no parser (DESIGN.md §10).

Every line of the process is JSON, not only the service's own: uvicorn's loggers, Python warnings
(``logging.captureWarnings``) and the model libraries (transformers and huggingface_hub install their own
plain-text stderr handler and stop propagation; ``adopt_library_logs`` undoes that and turns off their
progress bars, which write to stderr directly). A line written while serving a request carries its
``request_id`` (``REQUEST_ID``, set by ``app.request_log``), so one request's lines can be found together.
"""

from __future__ import annotations

import json
import logging
import sys
from contextvars import ContextVar
from datetime import UTC, datetime

REQUEST_ID: ContextVar[str | None] = ContextVar("request_id", default=None)
"""The id of the request being served in this context (None outside requests); worker threads that run
sync handlers get a copy of the request's context, so their lines carry it too."""

UVICORN_LOGGERS = ("uvicorn", "uvicorn.error", "uvicorn.access")

# Attributes every LogRecord has; anything else was passed through ``extra=`` and belongs in the event,
# except uvicorn's terminal-coloured duplicate of its message.
_STANDARD_ATTRIBUTES = frozenset(vars(logging.LogRecord("", 0, "", 0, "", None, None))) | {
    "message",
    "asctime",
    "color_message",
}


class JsonFormatter(logging.Formatter):
    """Render a record as ``{"ts", "level", "logger", "event", "request_id"?, ...extra}`` on one line."""

    def format(self, record: logging.LogRecord) -> str:
        event: dict[str, object] = {
            "ts": datetime.fromtimestamp(record.created, UTC).isoformat(timespec="milliseconds"),
            "level": record.levelname.lower(),
            "logger": record.name,
            "event": record.getMessage(),
            "pid": record.process,  # which worker process, when several serve one port
        }
        request_id = REQUEST_ID.get()
        if request_id is not None:
            event["request_id"] = request_id
        for key, value in vars(record).items():
            if key not in _STANDARD_ATTRIBUTES and not key.startswith("_"):
                event[key] = value
        if record.exc_info:
            event["exception"] = self.formatException(record.exc_info)
        if record.stack_info:
            event["stack"] = self.formatStack(record.stack_info)
        return json.dumps(event, default=str)


class _JsonHandler(logging.StreamHandler):
    """Marks the handler we installed, so configuring twice replaces it instead of doubling lines."""


def configure_json_logging(level: str) -> None:
    """Send every logger's records to stderr as JSON lines at ``level`` (e.g. ``"info"``)."""
    numeric_level = logging.getLevelName(level.upper())
    if not isinstance(numeric_level, int):
        raise ValueError(
            f"log_level {level!r} is not a logging level (debug, info, warning, error, critical)"
        )
    root = logging.getLogger()
    for handler in [h for h in root.handlers if isinstance(h, _JsonHandler)]:
        root.removeHandler(handler)
    handler = _JsonHandler()
    handler.setFormatter(JsonFormatter())
    root.addHandler(handler)
    root.setLevel(numeric_level)
    logging.captureWarnings(True)  # warnings.warn -> the "py.warnings" logger, not a bare stderr line
    adopt_library_logs()


def adopt_library_logs(*, import_model_libraries: bool = False) -> None:
    """Route the third-party loggers that bring their own handlers through the root's JSON handler.

    uvicorn (when started with its default ``log_config``) and transformers/huggingface_hub (when imported)
    attach plain-text handlers and stop propagation. Libraries not imported yet are left alone (importing
    transformers takes seconds) unless ``import_model_libraries``: the model preload, about to import them
    anyway, adopts them first so that even the load's own lines and progress bars are handled.
    """
    if import_model_libraries:
        import huggingface_hub  # noqa: F401
        import transformers  # noqa: F401
    for name in UVICORN_LOGGERS:
        library_logger = logging.getLogger(name)
        if library_logger.handlers:  # none: uvicorn silenced it on purpose (access_log=False), leave it so
            for handler in list(library_logger.handlers):
                library_logger.removeHandler(handler)
            library_logger.propagate = True
    if "huggingface_hub" in sys.modules:
        from huggingface_hub.utils import disable_progress_bars

        hub_logger = logging.getLogger("huggingface_hub")
        for handler in list(hub_logger.handlers):
            hub_logger.removeHandler(handler)
        hub_logger.propagate = True
        disable_progress_bars()
    if "transformers" in sys.modules:
        from transformers.utils import logging as transformers_logging

        transformers_logging.disable_default_handler()
        transformers_logging.enable_propagation()
        transformers_logging.disable_progress_bar()
