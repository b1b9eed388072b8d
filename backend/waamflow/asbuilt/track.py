"""The planned bead crests of one layer, resampled: what a scan is compared with and what the
next layer's adaptation changes.

A layer's arc-ON segments are resampled every `ds` mm (each segment into ceil(L/ds) equal
pieces, sample at each piece's middle). Per sample: the planned crest position (the programmed
point: the torch deposits the bead top there), the build direction n (−tool axis; up for planar
layers, along the fan for curved ones), the direction across the bead (n × path tangent), the
programmed speed (mm/s), the section key and the source segment (section index, segment index)
so that a speed found per sample can be written back per segment.

Heights are measured along n: a crest at p with build direction n has height p·n.

Units: mm, mm/s.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..core.model import LayerPaths

DOWN = np.array([0.0, 0.0, -1.0])


@dataclass(frozen=True, eq=False)
class Track:
    """Resampled arc-ON crests of one layer (all arrays of length n)."""

    layer: int
    thickness: float  # planned layer height, mm
    points: np.ndarray  # (n, 3) planned crest positions, world mm
    normal: np.ndarray  # (n, 3) unit build direction
    across: np.ndarray  # (n, 3) unit, across the bead, ⟂ normal and tangent
    speed: np.ndarray  # (n,) programmed mm/s
    section: np.ndarray  # (n,) int: index into the layer's sections
    segment: np.ndarray  # (n,) int: segment index inside that section
    keys: tuple[str, ...]  # section keys
    length: np.ndarray  # (n,) mm of path each sample stands for

    @property
    def n(self) -> int:
        return len(self.points)

    def planned_height(self) -> np.ndarray:
        """Planned crest height along the build direction, mm."""
        return np.einsum("ij,ij->i", self.points, self.normal)


def layer_track(lp: LayerPaths, ds: float = 1.0) -> Track:
    """The arc-ON crests of `lp` every ≤ `ds` mm (see module doc)."""
    if not ds > 0:
        raise ValueError("ds must be > 0 mm")
    pts, nor, acr, spd, sec, seg, ln = [], [], [], [], [], [], []
    keys = tuple(sp.key for sp in lp.sections)
    for si, sp in enumerate(lp.sections):
        if sp.tool:  # rolling/peening passes deposit nothing
            continue
        P = np.asarray(sp.points, float)
        axis = np.asarray(sp.tool_axis, float) if sp.tool_axis is not None else np.tile(DOWN, (len(P), 1))
        for j in np.flatnonzero(np.asarray(sp.arc, bool)):
            a, b = P[j], P[j + 1]
            L = float(np.linalg.norm(b - a))
            if L <= 1e-9:
                continue
            k = max(1, math.ceil(L / ds))
            t = (np.arange(k) + 0.5) / k
            p = a + t[:, None] * (b - a)
            n = -(axis[j] * (1 - t[:, None]) + axis[j + 1] * t[:, None])
            n /= np.linalg.norm(n, axis=1)[:, None]
            tan = (b - a) / L
            c = np.cross(n, tan)
            cn = np.linalg.norm(c, axis=1)
            c = np.where(cn[:, None] > 1e-9, c / np.maximum(cn, 1e-12)[:, None], np.array([1.0, 0.0, 0.0]))
            v = float(sp.speed[j]) if np.isfinite(sp.speed[j]) and sp.speed[j] > 0 else np.nan
            pts.append(p)
            nor.append(n)
            acr.append(c)
            spd.append(np.full(k, v))
            sec.append(np.full(k, si))
            seg.append(np.full(k, j))
            ln.append(np.full(k, L / k))
    if not pts:
        z = np.zeros((0, 3))
        e = np.zeros(0)
        return Track(lp.index, float(lp.layer.thickness), z, z, z, e, e.astype(int), e.astype(int), keys, e)
    return Track(
        lp.index,
        float(lp.layer.thickness),
        np.vstack(pts),
        np.vstack(nor),
        np.vstack(acr),
        np.concatenate(spd),
        np.concatenate(sec).astype(int),
        np.concatenate(seg).astype(int),
        keys,
        np.concatenate(ln),
    )
