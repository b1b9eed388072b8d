"""Imported once by the fork server that starts layer workers (engine/parallel.py): every node
module and the kernels they import, so each worker forked from it starts with them loaded instead
of importing them again (about 1 s of CPU per worker). The preflight's slab check and trimesh,
which it cuts sections with, too: the workers check a large part's layers (preflight/slabs.py)."""

import trimesh  # noqa: F401  (imported for the workers, not used here)

from ..preflight import slabs  # noqa: F401
from .node import load_nodes

load_nodes()
