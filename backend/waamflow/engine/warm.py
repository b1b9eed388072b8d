"""Imported once by the fork server that starts layer workers (engine/parallel.py): every node
module and the kernels they import, so each worker forked from it starts with them loaded instead
of importing them again (about 1 s of CPU per worker). Not what only the preflight's slab check
needs (trimesh): preloaded here it delayed every worker's start by ~0.45 s, imported by each
worker as it came up it added ~100 MB to every worker (a run's memory cap counts its whole process
tree: tests/api/test_run_memory.py); a worker imports it with its first slab task."""

import gc
import importlib

from .node import load_nodes

load_nodes()
# The preflight's layer tasks (slabs, read-backs) and the executor they reach: imported by every
# worker of every run with its first such task otherwise, ~0.07 s of CPU each (the 500-layer cross,
# 2 workers: 36 modules). None imports trimesh or scipy. numpy.ma: numpy's own `np.unique` imports it on
# its first call (the strategy's arc flags), ~12 ms of CPU in each worker of each run otherwise.
for _name in (
    "numpy.ma",
    "waamflow.core.graphs",
    "waamflow.engine.executor",
    "waamflow.preflight.check",
    "waamflow.preflight.conserve",
    "waamflow.preflight.planecut",
    "waamflow.preflight.prefetch",
    "waamflow.preflight.read",
    "waamflow.preflight.slabs",
):
    importlib.import_module(_name)
# What the fork server holds now lives as long as it: frozen, a worker's collections never scan it (nor
# write to its pages, which then stay shared). The 500-layer cross: each worker's collections
# 0.06-0.09 -> 0.03 s a run (2 workers, gc.callbacks).
gc.freeze()
