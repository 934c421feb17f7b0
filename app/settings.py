"""The service's one typed settings object, read from ``JARVIS_*`` environment variables."""

from __future__ import annotations

from pathlib import Path

from pydantic import Field
from pydantic_settings import BaseSettings, SettingsConfigDict

from symbolic.data_dir import default_data_dir


class Settings(BaseSettings):
    """Service configuration. Every field can be set as ``JARVIS_<NAME>`` (e.g. ``JARVIS_PORT=9000``)."""

    model_config = SettingsConfigDict(env_prefix="JARVIS_", frozen=True, extra="ignore")

    host: str = Field(
        default="127.0.0.1", description="Interface uvicorn binds to; 0.0.0.0 inside a container."
    )
    port: int = Field(default=8000, ge=1, le=65535, description="TCP port of the native and TEACh APIs.")
    data_dir: Path = Field(
        default_factory=default_data_dir,
        description="Shared read-only data (ALFRED, TEACh definitions); may be absent.",
    )
    planner_checkpoint: Path | None = Field(
        default=None,
        description="Language planner directory (any compatible seq2seq checkpoint); None: the shipped one.",
    )
    depth_checkpoint: Path | None = Field(
        default=None,
        description="Depth network directory for learned perception (e.g. trained on your own AI2-THOR "
        "frames); None: the shipped one.",
    )
    segmentation_checkpoint: Path | None = Field(
        default=None,
        description="Segmentation network directory for learned perception; None: the shipped one.",
    )
    torch_threads: int | None = Field(
        default=None,
        ge=1,
        description="Threads each network call may use; None keeps torch's default of one per core. Set 1 "
        "when several service processes share a machine: two services with the default ran learned "
        "episodes about three times slower on 2 cores. One service stepping two sessions at once ran "
        "about 15% faster with the default than with 1. DESIGN.md §8's budgets are measured with one.",
    )
    log_level: str = Field(default="info", description="Root log level; logs are one JSON event per line.")

    # Limits: a serving process must bound what one client can make it hold.
    max_sessions: int = Field(
        default=256, ge=1, description="Live sessions per replica; creation answers 429 when full."
    )
    session_ttl_s: float = Field(
        default=1800.0, gt=0, description="Idle seconds before a session is evicted."
    )
    max_body_bytes: int = Field(
        default=32 * 1024 * 1024,
        ge=1024,
        description="Largest request body; bigger ones get 413 before parsing.",
    )
    max_image_side: int = Field(
        default=2048, ge=16, description="Largest accepted camera width or height, pixels."
    )
    max_dialogue_turns: int = Field(
        default=500, ge=1, description="Utterances kept per session; more answer 413."
    )
    max_utterance_chars: int = Field(default=2000, ge=1, description="Longest single utterance.")
    max_subgoals: int = Field(
        default=300, ge=1, description="Longest plan accepted or produced (the seed's 300)."
    )
    max_steps: int = Field(default=1000, ge=1, description="TEACh's step limit per episode.")
    max_failed_actions: int = Field(default=30, ge=1, description="TEACh's failed-action limit per episode.")
    max_edh_body_bytes: int = Field(
        default=256 * 1024 * 1024,
        ge=1024,
        description="Largest body of TEACh's POST /start_new_edh_instance, which carries the whole EDH "
        "history as JPEG files (900x900 frames of ~80 kB; hundreds per instance).",
    )
    max_edh_history_frames: int = Field(
        default=2000, ge=1, description="History images accepted by POST /start_new_edh_instance."
    )
    session_lock_timeout_s: float = Field(
        default=1.0, gt=0, description="Seconds a request waits for a busy session before answering 409."
    )
