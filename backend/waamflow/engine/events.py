"""The fixed event vocabulary of a run, shared by the CLI progress bar, the SSE stream and the GUI."""

from __future__ import annotations

import time
from dataclasses import asdict, dataclass, field
from typing import Any, Callable, Literal

EventKind = Literal[
    "run_started",
    "node_started",
    "node_cached",
    "node_progress",
    "node_finished",
    "node_error",
    "warning",
    "run_finished",
    "run_failed",
    "run_cancelled",
]
EVENT_KINDS: tuple[str, ...] = EventKind.__args__  # type: ignore[attr-defined]
TERMINAL_KINDS = frozenset({"run_finished", "run_failed", "run_cancelled"})


@dataclass
class Event:
    """One progress event. `progress` is the whole run's fraction done (0..1)."""

    kind: EventKind
    node: str | None = None
    layer: int | None = None
    section: str | None = None
    progress: float = 0.0
    message: str = ""
    seconds: float | None = None
    compute_seconds: float | None = None  # node_finished of a layer node: its layers' compute time
    cached: bool | None = None
    error: dict[str, Any] | None = None
    seq: int = 0
    time: float = field(default_factory=time.time)

    def to_dict(self) -> dict[str, Any]:
        return {k: v for k, v in asdict(self).items() if v is not None}


EventSink = Callable[[Event], None]
