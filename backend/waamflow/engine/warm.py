"""Imported once by the fork server that starts layer workers (engine/parallel.py): every node
module and the kernels they import, so each worker forked from it starts with them loaded instead
of importing them again (about 1 s of CPU per worker). Not what only the preflight's slab check
needs (trimesh): preloaded here it delayed every worker's start by ~0.45 s, imported by each
worker as it came up it added ~100 MB to every worker (a run's memory cap counts its whole process
tree: tests/api/test_run_memory.py); a worker imports it with its first slab task."""

from .node import load_nodes

load_nodes()
