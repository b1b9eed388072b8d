"""Imported once by the fork server that starts layer workers (engine/parallel.py): every node
module and the kernels they import, so each worker forked from it starts with them loaded instead
of importing them again (about 1 s of CPU per worker). What only the preflight needs (trimesh,
its slab check) each worker imports in the background once it is up (`parallel.LATE_IMPORTS`)."""

from .node import load_nodes

load_nodes()
