"""Helpers shared by the tests of the server's limits (test_bounded_work.py, test_run_memory.py):
a server on a scratch data folder, a box part of a given height, a slicing recipe, layer workers
started at once, and the process groups of run trees."""

from __future__ import annotations

import io
import struct
import time

import numpy as np
from fastapi.testclient import TestClient

import toy_nodes as toy
from waamflow.api.app import create_app
from waamflow.api.tree_memory import group_pids
from waamflow.engine import parallel
from waamflow.settings import Settings


def settings(tmp_path, **kw) -> Settings:
    """Server settings on `tmp_path` (no viewer, no graphs folder, no static files), `kw` on top."""
    return Settings(data_dir=tmp_path / "data", graphs_dir=None, start_viewer=False, static_dir=None, **kw)


def client(tmp_path, **kw) -> TestClient:
    """A test client of a server made with `settings` (one run at a time unless `workers` is given)."""
    kw.setdefault("workers", 1)
    return TestClient(create_app(settings(tmp_path, **kw)))


def box_stl(height: float, size: float = 20.0) -> bytes:
    """A closed box, binary STL, `height` mm tall on a `size` mm square."""
    v = np.array([[x, y, z] for x in (0, size) for y in (0, size) for z in (0, height)], dtype=np.float32)
    faces = [
        (0, 1, 3),
        (0, 3, 2),
        (4, 6, 7),
        (4, 7, 5),
        (0, 4, 5),
        (0, 5, 1),
        (2, 3, 7),
        (2, 7, 6),
        (0, 2, 6),
        (0, 6, 4),
        (1, 5, 7),
        (1, 7, 3),
    ]
    out = io.BytesIO()
    out.write(b"\0" * 80 + struct.pack("<I", len(faces)))
    for f in faces:
        out.write(struct.pack("<3f", 0, 0, 0) + v[list(f)].tobytes() + b"\0\0")
    return out.getvalue()


def sliced(path: str, layer_height: float = 1.5) -> dict:
    """A recipe: the mesh file `path`, sliced at `layer_height` mm."""
    return toy.recipe(
        [("part", "mesh", {"path": path}), ("layers", "slice", {"layer_height": layer_height})],
        [("part.mesh", "layers.mesh")],
    )


def parallel_now(monkeypatch) -> None:
    """Layers go to the layer workers at once (no timing of a first layer, workers started in the foreground)."""
    for name, value in (
        ("MIN_PARALLEL_S", 0.0),
        ("WARM_MIN_PARALLEL_S", 0.0),
        ("TIMING_S", 0.0),
        ("BACKGROUND_START", False),
    ):
        monkeypatch.setattr(parallel, name, value)


def gone(pgid: int, timeout: float = 3.0) -> list[int]:
    """The living members of process group `pgid` once none is left ([]), or after `timeout`."""
    t0 = time.monotonic()
    while (left := group_pids(pgid)) and time.monotonic() - t0 < timeout:
        time.sleep(0.05)
    return left
