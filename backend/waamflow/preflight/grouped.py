"""Rows of an array grouped by label, for checks that look at a program layer by layer."""

from __future__ import annotations

import numpy as np


class Grouped:
    """Row indices of an array of labels (layer indices) grouped by label, each group in its rows'
    own order: what `labels == v` selects, without a pass over every row per label (which made the
    3D coverage check O(layers × bead points): a fan-sliced part has thousands of layers)."""

    def __init__(self, labels: np.ndarray) -> None:
        self.labels = np.asarray(labels)
        self.order = np.argsort(self.labels, kind="stable")
        self.sorted = self.labels[self.order]

    def rows(self, value) -> np.ndarray:
        lo, hi = np.searchsorted(self.sorted, value, "left"), np.searchsorted(self.sorted, value, "right")
        return self.order[lo:hi]
