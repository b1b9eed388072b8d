"""How `waamflow serve` runs uvicorn: the h11 protocol with a connection cap and a header timeout
(uvicorn has neither: a connection that never sends its request head is kept for good, so
~20,000 half-open connections ran the server out of file descriptors), the keep-alive timeout,
a bound on the request head's size, and the file-descriptor limit raised to its hard maximum."""

from __future__ import annotations

import asyncio
import logging
import resource

import h11
from uvicorn.protocols.http.h11_impl import H11Protocol

log = logging.getLogger("waamflow.server")


class GuardedH11Protocol(H11Protocol):
    """uvicorn's h11 protocol, plus: a connection beyond `max_connections`, or beyond
    `max_per_client` from one address, is closed as soon as it is accepted; one that has not sent
    a complete request head `header_timeout_s` after it
    opened (or after its previous response) is closed (slowloris)."""

    max_connections = 1000
    max_per_client = 64
    header_timeout_s = 10.0
    per_client: dict = {}  # client address → open connections (one dict per configured subclass)

    def connection_made(self, transport: asyncio.Transport) -> None:  # type: ignore[override]
        self._head_timer: asyncio.TimerHandle | None = None
        self._counted: str | None = None
        super().connection_made(transport)
        addr = self.client[0] if self.client else "?"
        if len(self.connections) > self.max_connections or self.per_client.get(addr, 0) >= self.max_per_client:
            transport.abort()  # one address cannot take every connection from the others
            return
        self.per_client[addr] = self.per_client.get(addr, 0) + 1
        self._counted = addr
        self._arm()

    def _arm(self) -> None:
        waiting = self.conn.their_state is h11.IDLE
        if waiting and self._head_timer is None:
            self._head_timer = self.loop.call_later(self.header_timeout_s, self._head_timeout)
        elif not waiting and self._head_timer is not None:
            self._head_timer.cancel()
            self._head_timer = None

    def _head_timeout(self) -> None:
        self._head_timer = None
        if self.conn.their_state is h11.IDLE and not self.transport.is_closing():
            self.transport.close()

    def data_received(self, data: bytes) -> None:
        super().data_received(data)
        if not self.transport.is_closing():
            self._arm()

    def on_response_complete(self) -> None:
        super().on_response_complete()
        # uvicorn's keep-alive timer closes an idle connection; ours is armed when bytes come
        if self._head_timer is not None and self.conn.their_state is not h11.IDLE:
            self._head_timer.cancel()
            self._head_timer = None

    def connection_lost(self, exc: Exception | None) -> None:
        # getattr: a connection closed before connection_made ran has no timer attribute yet
        timer: asyncio.TimerHandle | None = getattr(self, "_head_timer", None)
        if timer is not None:
            timer.cancel()
            self._head_timer = None
        addr = getattr(self, "_counted", None)
        if addr is not None:
            self._counted = None
            n = self.per_client.get(addr, 1) - 1
            if n > 0:
                self.per_client[addr] = n
            else:
                self.per_client.pop(addr, None)
        super().connection_lost(exc)


def raise_fd_limit() -> int:
    """Soft RLIMIT_NOFILE up to the hard limit; returns the new soft limit."""
    soft, hard = resource.getrlimit(resource.RLIMIT_NOFILE)
    if hard == resource.RLIM_INFINITY:
        hard = 1 << 20
    if soft < hard:
        try:
            resource.setrlimit(resource.RLIMIT_NOFILE, (hard, hard))
            soft = hard
        except (ValueError, OSError):
            pass
    return soft


def uvicorn_options(settings) -> dict:
    """Keyword arguments of `uvicorn.run` for these settings."""
    fds = raise_fd_limit()
    cap = min(settings.max_connections, max(64, fds - 256))  # room for the database, runs and workers

    class Protocol(GuardedH11Protocol):
        max_connections = cap
        max_per_client = min(cap, settings.max_connections_per_client)
        header_timeout_s = settings.header_timeout_s
        per_client: dict = {}

    return dict(
        http=Protocol,
        timeout_keep_alive=int(max(1, settings.keep_alive_s)),
        h11_max_incomplete_event_size=settings.max_header_kb * 1024,
        limit_concurrency=cap,
        backlog=min(2048, cap),
    )
