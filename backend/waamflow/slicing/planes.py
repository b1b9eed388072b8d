"""Where the layers are: the layer schedule along the build direction (+Z).

Convention (see `core.model.Layer`): layer i occupies [top_i − t_i, top_i]; `Layer.z` = top_i,
the height the bead top reaches and the torch deposits at; the geometry is cut at mid-layer,
cut_i = top_i − t_i / 2, which is the cross-section a bead of that height best represents
(a cut at the top would lose the last layer of a part whose height is a multiple of t).

How the last layer meets the part's top (`top`, issue #22):

- ``ceil`` (default): the last layer's top is the part's top (within `TOL.join`). The remainder r
  above the last whole layer becomes a thinned last layer when r ≥ `TOP_MIN_FRACTION` of the
  thickness that layer would have had; a thinner remainder is merged into the layer below, which
  is thickened while it stays ≤ `TOP_MAX_FACTOR` × its own thickness; otherwise (no layer below, or
  a tighter factor) one more layer of `TOP_MIN_FRACTION` × t is built and overshoots the top (the
  fit reports it; that layer is cut in the middle of the part's material it covers).
- ``nearest``: the rounding of old: a layer is kept while its mid-layer cut is below the top, so
  the stack ends within half a layer of it, below or above; the fit reports the gap.
- ``exact``: whole layers only; PlanningError (exit 3) when they do not end on the top, naming
  the part height, the layer height and the two layer heights that would fit.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal, Sequence

import numpy as np

from ..core.errors import PlanningError
from ..core.tolerances import TOL

MAX_LAYERS = 200_000  # a 10 m part at 0.05 mm; beyond that a schedule is surely a unit mistake

TopPolicy = Literal["ceil", "nearest", "exact"]

# A last layer is at least half as thick as its nominal layer. At a fixed bead width the height
# follows the deposited cross-section, wire feed / travel speed: half the height is twice the
# travel speed or half the wire feed, the edge of an ordinary CMT/GMAW window (the curved-parts
# study spans 2.2–3.2 mm by travel speed alone at one wire feed). Thinner, the process cannot lay
# the bead, and its mid-layer cut would lie within a quarter layer of the one below.
TOP_MIN_FRACTION = 0.5
# A remainder under that is merged into the layer below while it stays ≤ 1.5 × its thickness:
# the mirror of the 0.5 (a bead 1.5× higher is half as much again of wire per mm; the study's
# window alone is 1.45×). With 0.5 and 1.5 every remainder is thinned or merged; an overshoot is
# left only for a part lower than half a layer, or a tighter factor given by the user. The weld
# data of the thinned or thickened layer follow its thickness (`fill` checks the bead model's range).
TOP_MAX_FACTOR = 1.5


@dataclass(frozen=True)
class TopFit:
    """How the full schedule (before `layer_count`) meets the top it aims for, all mm.

    target: the part's top (or z_max) along the build direction. reached: the last layer's top.
    layer: index of that layer. nominal: the thickness it would have had (listed or layer height);
    thickness: the one it has. action: "exact" (whole layers end on the target within
    `TOL.join`), "thinned" / "thickened" (ceil: the last layer made to end on it), "overshoot"
    (ceil: one thin layer more, above it), "nearest" (the nearest whole layer, gap left).
    """

    policy: str
    target: float
    reached: float
    layer: int
    nominal: float
    thickness: float
    action: str
    limit: str = "the part's top"  # what `target` is: "the part's top" or "z_max"

    @property
    def gap(self) -> float:
        """target − reached (mm): > 0 the top is not reached, < 0 the stack overshoots it."""
        return self.target - self.reached


@dataclass(frozen=True, eq=False)
class LayerSchedule:
    """tops: (n,) float mm, layer top heights (`Layer.z`). thickness: (n,) float mm.

    cut_heights: (n,) float mm cutting planes where they differ from mid-layer (an overshoot
    layer is cut in the part's material), else None. fit: how the full schedule meets the top;
    total: its number of layers (≥ n when `layer_count` kept only the first ones).
    """

    tops: np.ndarray
    thickness: np.ndarray
    cut_heights: np.ndarray | None = None
    fit: TopFit | None = None
    total: int = 0

    @property
    def cuts(self) -> np.ndarray:
        """(n,) float mm: cutting-plane heights, mid-layer (inside the part for an overshoot layer)."""
        if self.cut_heights is not None:
            return self.cut_heights
        return self.tops - self.thickness / 2.0

    def __len__(self) -> int:
        return len(self.tops)


def _g(x: float) -> str:
    """A length for a message: up to 4 decimals, no trailing zeros (31 → "31", 2.06667 → "2.0667")."""
    return f"{round(float(x), 4):g}" if abs(x) < 1e5 else f"{x:.1f}"


def _exact_error(
    end: float,
    base: float,
    last: float,
    listed: np.ndarray,
    layer_height: float,
    n_full: int,
    tol: float,
    end_name: str,
) -> PlanningError:
    """The PlanningError of `top: exact` when whole layers do not end on the top."""
    height = end - base
    what = (
        f"the part is {_g(height)} mm tall (from {_g(base)} to its top at {_g(end)} mm)"
        if end_name != "z_max"
        else f"the layers span {_g(height)} mm (from {_g(base)} to z_max {_g(end)} mm)"
    )
    if last > end + tol:  # the listed thicknesses alone pass the top
        return PlanningError(
            f"top 'exact': {what} and the listed "
            f"thicknesses pass its top: layer {n_full} would top at {_g(base + np.cumsum(listed)[n_full])} mm; "
            f"shorten `thicknesses` or use top 'ceil'",
            layer=n_full,
        )
    span = end - last
    n = span / layer_height
    lo = int(np.floor(n + tol / layer_height))
    hi = lo + 1
    above = f" above the listed thicknesses ({_g(last - base)} mm), {_g(span)} mm remain and" if listed.size else ""
    fits = [f"{_g(span / hi)} mm ({hi} layers)"] + ([f"{_g(span / lo)} mm ({lo} layers)"] if lo >= 1 else [])
    return PlanningError(
        f"top 'exact': {what};{above} "
        f"{_g(layer_height)} mm layers do not end on its top ({round(n, 4):g} layers; the last whole layer tops at "
        f"{_g(last + lo * layer_height)} mm, {_g(span - lo * layer_height)} mm below). Layer heights that fit: "
        f"{' or '.join(fits)}; or use top 'ceil' (last layer thinned or merged) or 'nearest'",
        layer=n_full,
    )


def _checked_arguments(
    layer_height: float, thicknesses: Sequence[float], top_policy: str, min_fraction: float, max_factor: float
) -> np.ndarray:
    """`layer_schedule`'s arguments checked (ValueError naming the bad one); the listed thicknesses."""
    if not layer_height > 0:
        raise ValueError(f"layer_height must be > 0 mm (got {layer_height})")
    if top_policy not in ("ceil", "nearest", "exact"):
        raise ValueError(f"top must be 'ceil', 'nearest' or 'exact' (got {top_policy!r})")
    if not (0 < min_fraction <= 1 and max_factor >= 1):
        raise ValueError(f"need 0 < min_fraction ≤ 1 and max_factor ≥ 1 (got {min_fraction}, {max_factor})")
    listed = np.asarray(list(thicknesses), dtype=float)
    if listed.size and not (listed > 0).all():
        raise ValueError(f"thicknesses must all be > 0 mm (got {listed.tolist()})")
    return listed


def _top_fit(
    policy: TopPolicy, end: float, tops: np.ndarray, thick: np.ndarray, action: str, limit: str, nominal: float
) -> TopFit:
    """How the last of the layers `tops`/`thick` meets the end: `layer_schedule`'s `fit`."""
    i = len(tops) - 1
    return TopFit(
        policy=policy,
        target=float(end),
        reached=float(tops[i]),
        layer=i,
        nominal=nominal if action in ("thinned", "thickened", "overshoot") else float(thick[i]),
        thickness=float(thick[i]),
        action=action,
        limit=limit,
    )


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
    top_policy: TopPolicy = "ceil",
    min_fraction: float = TOP_MIN_FRACTION,
    max_factor: float = TOP_MAX_FACTOR,
) -> LayerSchedule:
    """Layer tops and thicknesses for a part spanning [bottom, top] (mm).

    Layer 0 starts at `base = (z_min if given else bottom) + start_offset`. Thicknesses come from
    `thicknesses` in order, then `layer_height` for the rest, up to `end = min(top, z_max)` by the
    `top_policy` (module docstring; `min_fraction`, `max_factor` as there). `layer_count` keeps
    only the first layers of that schedule (a quick look); `fit` and `total` describe the whole.
    Uniform tops are computed as base + Σ listed + k·layer_height (no running sum), so 1.5 mm
    layers land exactly on multiples of 1.5. Raises ValueError on bad arguments, PlanningError
    for `exact` when whole layers do not end on the top.
    """
    listed = _checked_arguments(layer_height, thicknesses, top_policy, min_fraction, max_factor)
    tol = TOL.join
    base = (bottom if z_min is None else z_min) + start_offset
    end = top if z_max is None else min(top, z_max)
    limit = "the part's top" if z_max is None or top <= z_max else "z_max"
    empty = LayerSchedule(tops=np.zeros(0), thickness=np.zeros(0))
    if not end - base > tol:
        return empty

    # whole layers whose top is at or below the end (within tol)
    listed_tops = base + np.cumsum(listed)
    n_listed = int(np.searchsorted(listed_tops, end + tol, side="right"))
    last = listed_tops[-1] if listed.size else base
    if n_listed < listed.size:  # the listed layers cross the end
        n_uniform = 0
        prev = listed_tops[n_listed - 1] if n_listed else base
        nominal = float(listed[n_listed])
    else:
        n_uniform = int(np.floor((end + tol - last) / layer_height))
        prev = last + layer_height * n_uniform
        nominal = float(layer_height)
    n_full = n_listed + n_uniform
    if n_full + 1 > MAX_LAYERS:
        raise ValueError(
            f"{n_full + 1} layers exceed the limit of {MAX_LAYERS}: check the units of the part and layer_height"
        )
    tops = np.concatenate([listed_tops[:n_listed], last + layer_height * np.arange(1, n_uniform + 1)])
    thick = np.concatenate([listed[:n_listed], np.full(n_uniform, float(layer_height))])
    cut_heights = None
    rest = end - prev  # in [−tol, nominal − tol)

    if rest <= tol:
        action = "exact"
    elif top_policy == "exact":
        raise _exact_error(end, base, last, listed, float(layer_height), n_full, tol, limit)
    elif top_policy == "nearest":
        action = "nearest"
        if prev + nominal / 2.0 < end:  # the old rule: a layer is kept while its cut is below the end
            tops, thick = np.append(tops, prev + nominal), np.append(thick, nominal)
    elif rest >= min_fraction * nominal - 1e-12:
        action = "thinned"
        tops, thick = np.append(tops, end), np.append(thick, rest)
    elif n_full and thick[-1] + rest <= max_factor * thick[-1] + 1e-12:
        action = "thickened"
        nominal = float(thick[-1])
        thick = thick.copy()
        thick[-1] += rest
        tops = tops.copy()
        tops[-1] = end
    else:
        action = "overshoot"
        t = min_fraction * nominal
        tops, thick = np.append(tops, prev + t), np.append(thick, t)
        cut_heights = np.append(tops[:-1] - thick[:-1] / 2.0, prev + rest / 2.0)

    n_total = len(tops)
    if n_total == 0:
        return empty
    fit = _top_fit(top_policy, end, tops, thick, action, limit, nominal)
    n = n_total if layer_count is None else min(n_total, int(layer_count))
    return LayerSchedule(
        tops=tops[:n],
        thickness=thick[:n],
        cut_heights=None if cut_heights is None else cut_heights[:n],
        fit=fit,
        total=n_total,
    )
