"""A process simulator for the as-built loop: lays beads along a recipe's toolpath with the
mass-balance height model plus disturbances, makes the scans a line scanner would, and runs the
build open loop (the plan as is) or closed loop (each layer adapted to the scan of the one before:
`adapt.plan_speeds`, layers added or dropped when the top is off by more than half a layer).

Disturbance model (multiplies the model height C/v, then adds; every constant a parameter).
The defaults are STATED, not fitted to any measurement here: they are of the size WAAM papers
report qualitatively (first beads spread on the cold substrate and stay low; heat accumulated on
short layers changes the bead height; the arc start and end leave a hump), chosen so that the
open-loop build drifts by about a layer over twenty.

- first layers low: × (1 − first_drop · exp(−layer / first_layers)), default 0.3 and 1.5 layers;
- heat on short layers: × (1 + heat_gain · exp(−t_cool / heat_tau_s)), t_cool the time the layer
  below had to cool (this layer's arc-ON time plus the dwell planned after the layer below),
  default 0.2 and 30 s;
- stops and corners: × (1 + stop_bump · exp(−d / stop_len_mm)), d the distance along the path to
  the nearest arc start/end or corner sharper than corner_deg; default 0.15 (a hump 15 % above
  the bead), 4 mm, 45°;
- noise: Gaussian, noise_mm per sample (default 0.05 mm), smoothed over 3 samples.

Scans: across each actual crest, `scan_points` points over the bead width (a parabolic cap of
height t), each with Gaussian sensor noise `scan_noise_mm`; optionally seen through a wrong frame.

Units: mm, mm/s, s.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, field

import numpy as np

from ..core.model import LayerPaths, Layered
from .adapt import Window, beneath, carry, plan_speeds, planned_heights
from .scan import Scan, measure
from .track import Track, layer_track


@dataclass(frozen=True)
class Disturbance:
    first_drop: float = 0.3
    first_layers: float = 1.5
    heat_gain: float = 0.2
    heat_tau_s: float = 30.0
    stop_bump: float = 0.15
    stop_len_mm: float = 4.0
    corner_deg: float = 45.0
    noise_mm: float = 0.05
    scan_noise_mm: float = 0.02
    scan_points: int = 13
    bead_width_mm: float = 6.0
    seed: int = 1


def event_distance(track: Track, corner_deg: float) -> np.ndarray:
    """Distance along the path (mm) from every sample to the nearest arc start/end or corner."""
    n = track.n
    if n == 0:
        return np.zeros(0)
    s = np.cumsum(track.length) - track.length / 2
    start = s - track.length / 2
    ev = [start[0], s[-1] + track.length[-1] / 2]
    step = np.linalg.norm(np.diff(track.points, axis=0), axis=1)
    new_seg = (np.diff(track.segment) != 0) | (np.diff(track.section) != 0)
    # a run breaks where consecutive samples are not adjacent along the path
    gap = step > (track.length[:-1] + track.length[1:]) / 2 + 1e-6
    d = np.diff(track.points, axis=0)
    d /= np.maximum(np.linalg.norm(d, axis=1), 1e-12)[:, None]
    turn = np.zeros(n - 1)
    if n > 2:
        c = np.clip((d[1:] * d[:-1]).sum(axis=1), -1, 1)
        turn[1:] = np.degrees(np.arccos(c))
    corner = new_seg & ~gap & (turn > corner_deg)
    ev += list(start[1:][gap | corner])
    ev += list((s[:-1] + track.length[:-1] / 2)[gap])
    events = np.sort(np.asarray(ev))
    k = np.clip(np.searchsorted(events, s), 1, len(events) - 1)
    return np.minimum(np.abs(s - events[k - 1]), np.abs(events[k] - s))


def bead_heights(
    track: Track,
    v: np.ndarray,
    order: int,
    dist: Disturbance,
    rng: np.random.Generator,
    h_plan: np.ndarray | None = None,
    dwell_before_s: float = 0.0,
) -> np.ndarray:
    """Heights the simulated process lays at speeds `v` on layer number `order` (0 = first);
    `h_plan`: the planned bead heights at the planned speeds (default the layer height);
    `dwell_before_s`: the dwell after the layer below."""
    C = (track.thickness if h_plan is None else h_plan) * track.speed
    t_cool = float((track.length / v).sum()) + float(dwell_before_s)
    f = (1 - dist.first_drop * math.exp(-order / dist.first_layers)) * (
        1 + dist.heat_gain * math.exp(-t_cool / dist.heat_tau_s)
    )
    h = C / v * f * (1 + dist.stop_bump * np.exp(-event_distance(track, dist.corner_deg) / dist.stop_len_mm))
    if dist.noise_mm > 0 and track.n:
        e = rng.normal(0.0, dist.noise_mm, track.n)
        if track.n >= 3:
            e = np.convolve(e, np.ones(3) / 3, mode="same") * math.sqrt(3)
        h = h + e
    return np.maximum(h, 0.0)


def synth_scan(
    track: Track, top: np.ndarray, dist: Disturbance, rng: np.random.Generator, frame: np.ndarray | None = None
) -> Scan:
    """The point cloud a line scanner gives of crests at heights `top` (see module doc); `frame`
    (4×4) maps the part frame to the scanner's (the scan is then seen in that frame)."""
    w, m = dist.bead_width_mm, dist.scan_points
    u = np.linspace(-w / 2, w / 2, m)
    crest = track.points + (top - track.planned_height())[:, None] * track.normal
    cap = track.thickness * (2 * u / w) ** 2
    P = crest[:, None, :] + u[None, :, None] * track.across[:, None, :] - cap[None, :, None] * track.normal[:, None, :]
    P = P.reshape(-1, 3)
    if dist.scan_noise_mm > 0:
        P = P + rng.normal(0.0, dist.scan_noise_mm, P.shape)
    if frame is not None:
        P = P @ frame[:3, :3].T + frame[:3, 3]
    return Scan(track.layer, points=P, source=f"simulated scan of layer {track.layer}")


@dataclass
class BuildLog:
    mode: str
    layers: list[dict] = field(default_factory=list)
    added: int = 0
    dropped: int = 0
    last_error: np.ndarray | None = None

    def summary(self) -> dict:
        e = self.last_error if self.last_error is not None else np.zeros(0)
        return {
            "mode": self.mode,
            "layers_planned": sum(1 for r in self.layers if r["kind"] == "planned") + self.dropped,
            "layers_built": len(self.layers),
            "layers_added": self.added,
            "layers_dropped": self.dropped,
            "last_layer_rms_mm": round(float(np.sqrt(np.mean(e * e))), 4) if len(e) else None,
            "last_layer_max_mm": round(float(np.max(np.abs(e))), 4) if len(e) else None,
            "last_layer_mean_mm": round(float(np.mean(e)), 4) if len(e) else None,
        }


def simulate_build(
    toolpath: Layered[LayerPaths],
    mode: str = "closed",
    dist: Disturbance = Disturbance(),
    window: Window = Window(),
    ds: float = 1.0,
) -> BuildLog:
    """Build `toolpath` in the simulator, open or closed loop (see module doc)."""
    if mode not in ("open", "closed"):
        raise ValueError("mode is 'open' or 'closed'")
    rng = np.random.default_rng(dist.seed)
    pairs = [(lp, layer_track(lp, ds)) for lp in toolpath.items if lp is not None]
    pairs = [(lp, t) for lp, t in pairs if t.n]
    tracks = [t for _, t in pairs]
    dwell_after = [float(lp.dwell_after_s) for lp, _ in pairs]
    log = BuildLog(mode)
    prev: Track | None = None
    prev_true: np.ndarray | None = None  # actual crest heights of the layer below
    prev_meas: np.ndarray | None = None  # as the scan measured them
    prev_gain: np.ndarray | None = None
    order = 0
    k = 0
    repeats = 0
    while k < len(tracks):
        tr = tracks[k]
        H = tr.planned_height()
        hp = planned_heights(tr, prev)
        below_true = beneath(tr, prev, prev_true)
        if mode == "closed":
            below_meas = beneath(tr, prev, prev_meas)
            gain = carry(tr, prev, prev_gain, 1.0)
            ad = plan_speeds(tr, below_meas, gain, window, hp)
            v, predicted = ad.speed, ad.predicted_top
            clamped = (ad.clamped_slow, ad.clamped_fast)
        else:
            below_meas = below_true
            v = tr.speed.copy()
            predicted = below_meas + hp
            clamped = (0, 0)
        h = bead_heights(tr, v, order, dist, rng, hp, dwell_after[k - 1] if k > 0 else 0.0)
        top = below_true + h
        row = {
            "layer": tr.layer,
            "kind": "repeat" if repeats else "planned",
            "order": order,
            "mean_error_mm": round(float(np.mean(top - H)), 4),
            "rms_error_mm": round(float(np.sqrt(np.mean((top - H) ** 2))), 4),
            "speed_factor": [round(float(np.min(v / tr.speed)), 3), round(float(np.max(v / tr.speed)), 3)],
            "clamped": list(clamped),
        }
        if mode == "closed":
            # the simulator knows its scan is of this layer and in the part frame: no plausibility refusal
            meas = measure(
                tr, synth_scan(tr, top, dist, rng), radius=0.75, expected=predicted, max_layer_offset=math.inf
            ).height
            with np.errstate(invalid="ignore", divide="ignore"):
                prev_gain = (meas - below_meas) / (hp * tr.speed / v)
            prev_meas = meas
            row["measured_mean_error_mm"] = round(float(np.nanmean(meas - H)), 4)
        log.layers.append(row)
        prev, prev_true = tr, top
        order += 1
        err = float(np.nanmean((prev_meas if mode == "closed" else top) - H))
        if mode == "closed" and err < -tr.thickness / 2 and repeats < 3:
            # too low by more than half a layer: lay this layer again on top of itself
            repeats += 1
            log.added += 1
            continue
        repeats = 0
        k += 1
        if mode == "closed" and err > tr.thickness / 2 and k < len(tracks) - 1:
            log.dropped += 1  # too tall by more than half a layer: skip the next one
            k += 1
    if prev is not None:
        log.last_error = prev_true - prev.planned_height()
    return log


def disturbance_doc() -> dict:
    return asdict(Disturbance())
