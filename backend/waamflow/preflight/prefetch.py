"""The preflight's part sections, cut ahead while the nodes after the slicer run (issue #30).

The planar coverage check cuts the part at the middle of each deposited layer's slab (slabs.py):
on a million-triangle part about 1.2 s of CPU, and the preflight starts only once the last node has
written the program. Its planes are known long before, to within the program's rounding: a
layer's top is where the slicer put it (`Layer.z`), written with the posts' 3 decimals
(program/common.num), and each plane lies halfway down to the layer below (the part's bottom for
the first: coverage_planar). So once the run holds the part's mesh and its horizontal layers and
its workers are up, a background thread of the parent finds the triangles each predicted plane
cuts (slabs.plane_faces) and trickles the cuts to the workers in small tasks, one worker's worth at
a time, while the nodes after the slicer run.

The preflight then takes a prefetched section only for a plane whose z equals the program's exactly
(a float compare), cut from the very mesh arrays it checks, and cuts every other plane itself. So
the check stays independent of the plan: the program as read back decides which planes are cut,
and a plane's section is the same whichever process cut it, alone or with others (slabs.py). A
prediction that misses (a post with other digits, an empty layer, a frame the program is written
in) costs only the workers' idle time; a worker that fails costs nothing (the plane is cut again).
"""

from __future__ import annotations

import threading
from typing import Any, Callable, Protocol, Sequence

import numpy as np

from ..program.common import num
from .slabs import Renumber, SlabTask, _sub_task, cut_sections, mid_planes, plane_faces

PREDICT_DECIMALS = 3  # the posts' coordinate digits (program/common.num, every dialect's `decimals` default)
# Cut ahead only a part whose cuts are worth the round trips: the bench vase's 1,008,000 triangles
# (1.06 M cut over 133 planes, ~1.2 s of CPU) pays; the 500-layer cross (a few hundred) is cut in
# microseconds a plane, and its workers are busy with the layer chains then.
MIN_TRIANGLES = 200_000
# The cut in this many small tasks per worker (the bench vase: ~8 planes, ~70 ms of CPU each): a node's
# own tasks, queued behind one, wait little; and the parent sends the next as one finishes, polling this often.
TASKS_PER_WORKER = 8
TRICKLE_POLL_S = 0.01


class Workers(Protocol):
    """The run's workers as the prefetch uses them (engine: parallel.RunWorkers, daskpool.DaskWorkers)."""

    count: int

    def submit(self, fn: Callable[[Any], Any], item: Any) -> Any:
        """fn(item) started in a worker: a future, or None when the workers are gone."""


def predicted_planes(bottom: float, tops: Sequence[float], decimals: int = PREDICT_DECIMALS) -> list[float]:
    """The mid-planes coverage_planar will cut (slabs.mid_planes) if every layer is deposited at its
    top as a post writes it (program/common.num to `decimals`, read back as a float)."""
    return mid_planes(bottom, [float(num(z, decimals)) for z in tops])


def cut_task(task: SlabTask) -> list[Any]:
    """Worker side: the sections of a task's planes (slabs.cut_sections)."""
    return cut_sections(task.vertices, task.faces, task.plane_faces, task.zs)


class SectionPrefetch:
    """The sections of one part at predicted planes, being cut in the run's workers.

    `offer` is called with each node's outputs as the run goes: the first solid mesh and the first
    horizontal layers it sees decide the planes, and the first offer that also finds the workers
    up (`workers()` returns them, or None while they are not) starts a background thread. It finds
    each plane's triangles, then trickles the cuts to the workers in small tasks, at most
    `count − 1` at a time: the workers' queue is first come, first served, so a node's own tasks
    wait behind one small cut at most, and a core stays with the parent, whose nodes are the run's
    critical path. `take` (the preflight) sends whatever is left at once, waits and hands over the
    sections it wants; `close` (the run's end) stops the thread."""

    def __init__(self) -> None:
        self.vertices: np.ndarray | None = None
        self.faces: np.ndarray | None = None
        self.zs: list[float] = []
        self.started = False
        self._tops: list[float] | None = None
        self._tasks: list[tuple[int, int, Any]] = []  # (first plane, end, future), as sent
        self._thread: threading.Thread | None = None
        self._urgent = threading.Event()  # the preflight waits: send the rest at once
        self._stop = threading.Event()  # the run is over: send nothing more

    def offer(self, outputs: dict[str, Any], workers: Any) -> None:
        """Look at a finished node's outputs; start once mesh, layers and workers are there.
        `workers`: a callable giving the run's workers (`Workers`) or None while they are not up."""
        if self.started:
            return
        from ..core.model import Layer, Layered, MeshData

        for value in outputs.values():
            if isinstance(value, MeshData) and self.vertices is None and not value.surface:
                self.vertices, self.faces = value.vertices, value.faces
            elif isinstance(value, Layered) and self._tops is None and value.items:
                if all(isinstance(L, Layer) and L.frame is None for L in value.items):
                    self._tops = [float(L.z) for L in value.items]
        if self.vertices is None or self.faces is None or self._tops is None or len(self.faces) < MIN_TRIANGLES:
            return
        pool = workers()
        if pool is None or pool.count < 2:
            return
        self.started = True
        self.zs = predicted_planes(float(self.vertices[:, 2].min()), self._tops)
        self._thread = threading.Thread(
            target=self._start, args=(pool,), name="waamflow-preflight-prefetch", daemon=True
        )
        self._thread.start()

    def _start(self, pool: Workers) -> None:
        try:
            v = np.asarray(self.vertices, dtype=np.float64)  # as cover_part makes them
            f = np.asarray(self.faces, dtype=np.int64)
            per_plane = plane_faces(v, f, self.zs)
            weights = np.array([len(p) for p in per_plane], dtype=float) + 1.0
            limit = max(1, pool.count - 1)
            buf = Renumber(len(f), len(v))
            for a, b in even_spans(weights, pool.count * TASKS_PER_WORKER):
                task = _sub_task(v, f, per_plane[a:b], self.zs[a:b], None, 0.0, buf=buf)
                while not self._urgent.is_set() and sum(not x.done() for _a, _b, x in self._tasks) >= limit:
                    self._urgent.wait(TRICKLE_POLL_S)
                if self._stop.is_set():
                    return
                fut = pool.submit(cut_task, task)
                if fut is None:  # the workers went away: the preflight cuts the rest
                    return
                self._tasks.append((a, b, fut))
        except Exception:  # noqa: BLE001 - a prefetch that fails only leaves the preflight its own cuts
            return

    def hurry(self) -> None:
        """Send the rest at once: the run's nodes are done (the preflight reads its programs back
        first), nothing of theirs waits behind the cuts any more."""
        self._urgent.set()

    def close(self) -> None:
        """Send nothing more; the thread ends (the run is over: a failed or cancelled run would
        otherwise leave it trickling, holding the mesh)."""
        self._stop.set()
        self._urgent.set()

    def take(self, vertices: Any, faces: Any, zs: Sequence[float]) -> dict[int, Any]:
        """{i: section} for each zs[i] that was predicted and cut ahead on these very mesh arrays
        (the objects the run's mesh node handed out): what is not sent yet goes at once, and the
        cuts it uses are waited for."""
        if not self.started or vertices is not self.vertices or faces is not self.faces:
            return {}
        self._urgent.set()
        if self._thread is not None:
            self._thread.join()
        at = {z: j for j, z in enumerate(self.zs)}
        want: dict[int, list[int]] = {}
        for i, z in enumerate(zs):
            if z in at:
                want.setdefault(at[z], []).append(i)
        out: dict[int, Any] = {}
        for a, b, fut in self._tasks:
            hits = [j for j in range(a, b) if j in want]
            if not hits:
                continue
            try:
                got = fut.result()
            except Exception:  # noqa: BLE001 - the worker failed: the preflight cuts these planes
                continue
            for j in hits:
                for i in want[j]:
                    out[i] = got[j - a]
        return out


def even_spans(weights: np.ndarray, count: int) -> list[tuple[int, int]]:
    """Consecutive (start, end) spans of about equal weight, at most `count` of them."""
    cum = np.cumsum(weights, dtype=float)
    if not len(cum):
        return []
    edges = np.searchsorted(cum, cum[-1] * np.arange(1, count) / count, side="left") + 1
    bounds = sorted({0, len(cum), *(int(e) for e in edges if 0 < e < len(cum))})
    return list(zip(bounds[:-1], bounds[1:]))
