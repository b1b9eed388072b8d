"""Where the layers are: the layer schedule along the build direction (+Z).

Convention (see `core.model.Layer`): layer i occupies [top_i − t_i, top_i]; `Layer.z` = top_i,
the height the bead top reaches and the torch deposits at; the geometry is cut at mid-layer,
cut_i = top_i − t_i / 2, which is the cross-section a bead of that height best represents
(a cut at the top would lose the last layer of a part whose height is a multiple of t).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Sequence

import numpy as np

MAX_LAYERS = 200_000  # a 10 m part at 0.05 mm; beyond that a schedule is surely a unit mistake


@dataclass(frozen=True, eq=False)
class LayerSchedule:
    """tops: (n,) float mm, layer top heights (`Layer.z`). thickness: (n,) float mm."""

    tops: np.ndarray
    thickness: np.ndarray

    @property
    def cuts(self) -> np.ndarray:
        """(n,) float mm: cutting-plane heights, mid-layer."""
        return self.tops - self.thickness / 2.0

    def __len__(self) -> int:
        return len(self.tops)


def layer_schedule(
    bottom: float,
    top: float,
    *,
    layer_height: float,
    thicknesses: Sequence[float] = (),
    start_offset: float = 0.0,
    layer_count: int | None = None,
    z_min: float | None = None,
    z_max: float | None = None,
) -> LayerSchedule:
    """Layer tops and thicknesses for a part spanning [bottom, top] (mm).

    Layer 0 starts at `base = (z_min if given else bottom) + start_offset`. Thicknesses come from
    `thicknesses` in order, then `layer_height` for the rest. Layers are produced while their
    cutting plane lies below the end of the range, `min(top, z_max)`, and at most `layer_count`.
    Uniform tops are computed as base + Σ listed + k·layer_height (no running sum), so
    1.5 mm layers land exactly on multiples of 1.5.
    """
    if not layer_height > 0:
        raise ValueError(f"layer_height must be > 0 mm (got {layer_height})")
    listed = np.asarray(list(thicknesses), dtype=float)
    if listed.size and not (listed > 0).all():
        raise ValueError(f"thicknesses must all be > 0 mm (got {listed.tolist()})")
    base = (bottom if z_min is None else z_min) + start_offset
    end = top if z_max is None else min(top, z_max)
    listed_tops = base + np.cumsum(listed)
    last = listed_tops[-1] if listed.size else base
    n_uniform = max(0, int(np.ceil((end - last) / layer_height - 0.5)) + 1)
    if listed.size + n_uniform > MAX_LAYERS:
        raise ValueError(
            f"{listed.size + n_uniform} layers exceed the limit of {MAX_LAYERS}: check the units of the part and layer_height"
        )
    uniform_tops = last + layer_height * np.arange(1, n_uniform + 1)
    tops = np.concatenate([listed_tops, uniform_tops])
    thick = np.concatenate([listed, np.full(n_uniform, float(layer_height))])
    keep = tops - thick / 2.0 < end
    # keep the prefix only: a listed thick layer may reach past the end before thinner ones
    n = int(np.argmin(keep)) if not keep.all() else len(keep)
    if layer_count is not None:
        n = min(n, int(layer_count))
    return LayerSchedule(tops=tops[:n], thickness=thick[:n])
