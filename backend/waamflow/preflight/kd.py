"""k-d tree queries of the preflight's checks that run in the run's own process (the 3D coverage,
the distance to a midsurface or a mesh): a large query runs on every core, in scipy's own threads.
Each point's answer is the one a single thread gives; only the time changes (14 million samples
of a 93 × 78 m wall plan against its curves: 9 s on one core)."""

from __future__ import annotations

from typing import Any

import numpy as np

#: Queries of fewer points stay on one thread (starting threads costs more than they save).
PARALLEL_MIN = 50_000


def query(tree: Any, pts: np.ndarray, **kw: Any) -> tuple[np.ndarray, np.ndarray]:
    """`tree.query(pts, **kw)` (a scipy cKDTree), on every core when pts has PARALLEL_MIN points or more."""
    return tree.query(pts, workers=-1 if len(pts) >= PARALLEL_MIN else 1, **kw)
