"""A live build: the plan, what was measured after each layer, and the next layer's program.

The cell (or its PC) builds layer k from the program it was given, scans it, and posts the scan;
the session measures it against the plan, keeps the measured tops and the gain of every sample
(`adapt`), and answers with the program of the next layer adapted to what was built. State lives
in one folder and is written atomically after every step (`state.json` + the scans as received),
so a server restart resumes the build where it stood (the per-sample arrays of each scanned
layer in `layer_<k>.npz`, written once): the plan itself is not stored but
re-planned from the recipe (deterministic, and cached on content signatures).

Log: every step (start, scan received, program issued, refusals) with who, when (UTC) and what:
which scan (the file kept, its size and SHA-256 prefix) and which program (file names, SHA-256
prefixes of their text).

Interpass dwell (`dwell`): a scan may come with the part temperature measured after its layer;
the next layer's program then starts with a wait until the lumped heat model says the part is at
the build's target interpass temperature (clamped, stated in the program header, the log, the
layer's row and `asbuilt.json`). Without a temperature nothing changes.

`asbuilt.json` in the build's folder (rewritten after every step): the build's figures per layer
— as-built errors, the adaptation and the dwell of every program issued.

Units: mm, mm/s.
"""

from __future__ import annotations

import hashlib
import json
import os
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Protocol

import numpy as np

from ..core.model import LayerPaths, Layered
from .adapt import Window, adapted_layer, beneath, carry, plan_speeds, planned_heights
from .dwell import DwellRule, approach_time, check_temperature, interpass_dwell, note, time_constants
from .scan import Scan, ScanError, measure, register
from .track import Track, layer_track

STATE = "state.json"
MAX_REPEATS = 3  # a layer is laid at most this many extra times
ASBUILT = "asbuilt.json"


def _write_atomic(path: Path, text: str) -> None:
    tmp = path.with_name(path.name + ".tmp")
    with open(tmp, "w", encoding="utf-8") as f:
        f.write(text)
        f.flush()
        os.fsync(f.fileno())
    os.replace(tmp, path)


def _utc() -> str:
    return time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime())


class LayerPost(Protocol):
    """Writes a one-layer program, `{file name: text}` (`run.post_callable` makes one from a
    recipe's post-process node): `header` lines go in the program's header comments, `dwell_s` > 0
    makes it wait that long at its start (`dwell_why` beside it)."""

    def __call__(
        self, lp: LayerPaths, /, header: list[str] = ..., dwell_s: float = ..., dwell_why: str = ...
    ) -> dict[str, str]: ...


@dataclass
class LayerRecord:
    layer: int
    measured_top: np.ndarray
    gain: np.ndarray
    speed: np.ndarray


class BuildSession:
    """One build (see module doc). `post` (a LayerPost) writes a one-layer program."""

    def __init__(
        self,
        folder: Path,
        toolpath: Layered[LayerPaths],
        state: dict,
        post: LayerPost | None = None,
        window: Window = Window(),
    ):
        self.folder = Path(folder)
        self.items = [lp for lp in toolpath.items if lp is not None]
        self.tracks = [layer_track(lp) for lp in self.items]
        self.state = state
        self.post = post
        self.window = window
        self.dwell_rule = DwellRule.from_dict(state["meta"].get("interpass"))
        self._taus: list[float] | None = None

    # ---- persistence -------------------------------------------------------------------------
    @classmethod
    def create(
        cls,
        folder: Path,
        toolpath: Layered[LayerPaths],
        meta: dict,
        who: str | None = None,
        post: LayerPost | None = None,
        window: Window = Window(),
    ) -> "BuildSession":
        folder = Path(folder)
        folder.mkdir(parents=True, exist_ok=False)
        state = {"meta": meta, "created": _utc(), "next_layer": 0, "status": "building", "records": {}, "log": []}
        s = cls(folder, toolpath, state, post, window)
        if not s.tracks:
            raise ValueError("the plan has no layers to build")
        s._log(who, "start", layers=len(s.tracks))
        s.save()
        return s

    @classmethod
    def load(
        cls, folder: Path, toolpath: Layered[LayerPaths], post: LayerPost | None = None, window: Window = Window()
    ) -> "BuildSession":
        state = json.loads((Path(folder) / STATE).read_text(encoding="utf-8"))
        s = cls(folder, toolpath, state, post, window)
        if len(s.tracks) != state["meta"].get("layers", len(s.tracks)):
            raise ValueError(
                f"the re-planned recipe has {len(s.tracks)} layers, the build was started with "
                f"{state['meta']['layers']}: the recipe or its inputs changed"
            )
        return s

    def save(self) -> None:
        _write_atomic(self.folder / STATE, json.dumps(self.state, indent=1))
        _write_atomic(self.folder / ASBUILT, json.dumps(self.asbuilt(), indent=1))

    def asbuilt(self) -> dict:
        """The build's as-built document (see module doc)."""
        return {
            "build": self.state["meta"].get("id"),
            "run": self.state["meta"].get("run"),
            "status": self.state["status"],
            "layers_planned": len(self.tracks),
            "interpass": self.dwell_rule.to_dict(),
            "layers": self.state.get("layers", []),
            "programs": self.state.get("programs", []),
            "layers_added": int(self.state.get("added", 0)),
            "layers_dropped": int(self.state.get("dropped", 0)),
            "skipped": list(self.state.get("skipped", [])),
        }

    def refuse(self, who: str | None, layer: int, reason: str) -> None:
        """Log a scan refused before it reached the session (unreadable file) and save."""
        self._log(who, "scan_refused", layer=layer, reason=reason)
        self.save()

    def _log(self, who: str | None, action: str, **detail: Any) -> None:
        self.state["log"].append({"time": _utc(), "who": who, "action": action, **detail})

    # ---- state -------------------------------------------------------------------------------
    @property
    def next_layer(self) -> int:
        return int(self.state["next_layer"])

    @property
    def done(self) -> bool:
        return self.next_layer >= len(self.tracks)

    def record(self, k: int) -> LayerRecord | None:
        name = self.state["records"].get(str(k))
        if name is None:
            return None
        with np.load(self.folder / name, allow_pickle=False) as z:
            return LayerRecord(k, z["measured_top"], z["gain"], z["speed"])

    def _track(self, k: int) -> Track:
        return self.tracks[k]

    def passes(self, k: int) -> int:
        """How many times layer k has been scanned (a repeated layer: more than once)."""
        return int(self.state.get("scans", {}).get(str(k), 0))

    def basis(self, k: int) -> tuple[np.ndarray, np.ndarray, np.ndarray, str | None]:
        """What layer k is laid on: (top beneath each sample, the gain carried to it, the planned
        bead height, what it lies on). A repeated layer lies on its own measured top; else on the
        measured top of the last scanned layer below (the one before a dropped layer), the plan
        where nothing was scanned. The planned bead height is always the plan's own (its crest
        above the planned layer below)."""
        tr = self._track(k)
        hp = planned_heights(tr, self._track(k - 1) if k > 0 else None)
        own = self.record(k) if self.next_layer == k else None
        if own is not None:  # a repeat: on the layer's own scanned top
            top = np.where(np.isfinite(own.measured_top), own.measured_top, tr.planned_height() - tr.thickness)
            return top, np.where(np.isfinite(own.gain), own.gain, 1.0), hp, f"its own scan (pass {self.passes(k)})"
        j = next((i for i in range(k - 1, -1, -1) if str(i) in self.state["records"]), None)
        rec = self.record(j) if j is not None else None
        if j is None or rec is None:
            return beneath(tr, None, None), np.ones(tr.n), hp, None
        pt = self._track(j)
        return beneath(tr, pt, rec.measured_top), carry(tr, pt, rec.gain, 1.0), hp, f"the scan of layer {pt.layer}"

    def speeds_for(self, k: int) -> tuple[np.ndarray, dict]:
        """Speeds for layer k from what was measured beneath it (`basis`; the plan's on layer 0 or
        when nothing below was scanned)."""
        tr = self._track(k)
        below, gain, hp, on = self.basis(k)
        if on is None:
            return tr.speed.copy(), {"layer": tr.layer, "adapted": False, "reason": "no scan of the layer below"}
        ad = plan_speeds(tr, below, gain, self.window, hp)
        return ad.speed, {**ad.summary(tr), "adapted": True, "laid_on": on, "pass": self.passes(k) + 1}

    def dwell_for(self, k: int) -> dict | None:
        """The interpass dwell before layer k from the temperature measured with the last scan
        (after the layer below, or after the first pass of a repeated layer; None when none was
        posted: the program is the planned one). τ is the heat model's after that layer."""
        rows = self.state.get("layers", [])
        if k == 0 or not rows or rows[-1].get("interpass_measured_c") is None:
            return None
        row = rows[-1]
        j = max(i for i in range(k + 1) if self._track(i).layer == row["layer"])
        if self._taus is None:
            self._taus = time_constants(self.items, self.dwell_rule.model)
        d = interpass_dwell(
            row["interpass_measured_c"],
            self._taus[j],
            self.dwell_rule,
            approach_time(self.items[k], self.dwell_rule.model.travel_speed),
        )
        return {**d, "after_layer": row["layer"], "note": note(d, row["layer"])}

    def next_program(self, who: str | None = None) -> dict:
        """The program of the next layer (adapted, and waiting for the part to cool when a
        temperature was measured), as files, with what was adapted."""
        if self.done:
            raise ValueError("the build is complete: every planned layer has been scanned")
        k = self.next_layer
        v, why = self.speeds_for(k)
        dwell = self.dwell_for(k)
        if dwell is not None:
            why = {**why, "interpass_dwell_s": dwell["dwell_s"], "interpass": dwell}
        lp = adapted_layer(self.items[k], self._track(k), v)
        header = [
            f"as-built build {self.state['meta'].get('id', '')}: layer {self._track(k).layer}, "
            + (
                f"travel speed x{why['speed_factor_min']:.3f}..x{why['speed_factor_max']:.3f} of plan "
                f"(samples clamped: {why['clamped_slow']} slow, {why['clamped_fast']} fast)"
                if why.get("adapted")
                else f"as planned ({why.get('reason', '')})"
            )
        ]
        if dwell is not None:
            header.append(dwell["note"])
        files = (
            self.post(
                lp, header=header, dwell_s=dwell["dwell_s"] if dwell else 0.0, dwell_why=dwell["note"] if dwell else ""
            )
            if self.post is not None
            else {}
        )
        entry = {
            "layer": self._track(k).layer,
            "pass": self.passes(k) + 1,
            "adapted": why.get("adapted", False),
            **{x: why[x] for x in ("speed_factor_min", "speed_factor_max", "clamped_slow", "clamped_fast") if x in why},
            "files": sorted(files),
            "sha256": {n: hashlib.sha256(t.encode()).hexdigest()[:16] for n, t in sorted(files.items())},
        }
        if dwell is not None:
            entry.update(
                interpass_measured_c=dwell["measured_c"],
                interpass_target_c=dwell["target_c"],
                dwell_s=dwell["dwell_s"],
                dwell_clamped=dwell["clamped"],
            )
        self._log(who, "program", **entry)
        progs = self.state.setdefault("programs", [])
        progs[:] = [p for p in progs if (p["layer"], p.get("pass", 1)) != (entry["layer"], entry["pass"])] + [
            {**entry, "time": _utc()}
        ]
        self.save()
        return {"layer": self._track(k).layer, "adaptation": why, "files": files, "toolpath": lp}

    def add_scan(
        self,
        scan: Scan,
        who: str | None = None,
        register_frame: bool = False,
        raw: bytes | None = None,
        interpass_c: float | None = None,
    ) -> dict:
        """Measure the scan of the next layer, keep it, and return the layer's as-built figures;
        `interpass_c`: the part temperature measured after the layer (°C), for the next dwell."""
        if interpass_c is not None:
            check_temperature(interpass_c)
        if self.done:
            raise ScanError("the build is complete: no further layer expects a scan")
        k = self.next_layer
        tr = self._track(k)
        if scan.layer != tr.layer:
            self._log(who, "scan_refused", layer=scan.layer, reason=f"expected layer {tr.layer}")
            self.save()
            raise ScanError(f"{scan.source}: the scan is of layer {scan.layer}, the build expects layer {tr.layer}")
        v, _ = self.speeds_for(k)
        below, g, hp, _ = self.basis(k)
        expected = below + np.clip(g, self.window.min_gain, self.window.max_gain) * hp * tr.speed / v  # as plan_speeds
        reg = None
        try:
            if register_frame and scan.kind == "cloud":
                scan, reg = register(tr, scan)
            m = measure(tr, scan, expected=expected)
        except ScanError as err:
            self._log(who, "scan_refused", layer=tr.layer, reason=str(err))
            self.save()
            raise
        with np.errstate(invalid="ignore", divide="ignore"):
            gain = (m.height - below) / (hp * tr.speed / v)
        dev = m.height - tr.planned_height()
        if raw is not None:
            (self.folder / f"scan_{tr.layer:05d}.bin").write_bytes(raw)
        name = f"layer_{k:05d}.npz"
        tmp = self.folder / (name + ".tmp.npz")
        np.savez(tmp, measured_top=m.height, gain=gain, speed=v)
        os.replace(tmp, self.folder / name)
        self.state["records"][str(k)] = name
        fin = np.isfinite(dev)
        planned_top = float(np.mean(tr.planned_height()[fin])) if fin.any() else float("nan")
        row: dict[str, Any] = {
            "layer": tr.layer,
            "coverage": round(m.coverage, 4),
            "planned_top_mm": round(planned_top, 4),
            "asbuilt_top_mm": round(float(np.mean(m.height[fin])), 4),
            "mean_error_mm": round(float(np.mean(dev[fin])), 4),
            "rms_error_mm": round(float(np.sqrt(np.mean(dev[fin] ** 2))), 4),
            "max_error_mm": round(float(np.max(np.abs(dev[fin]))), 4),
            "registration": reg.to_dict() if reg is not None else None,
        }
        if interpass_c is not None:
            row["interpass_measured_c"] = round(float(interpass_c), 2)
        passes = self.passes(k) + 1
        self.state.setdefault("scans", {})[str(k)] = passes
        row["pass"] = passes
        # the top more than half a layer off after the window did what it could: lay the layer again
        # (too low) or leave the next one out (too tall) — as the simulator does (sim.simulate_build)
        off, t = row["mean_error_mm"], tr.thickness
        nxt = k + 1
        if off < -t / 2 and passes <= MAX_REPEATS:
            self.state["added"] = int(self.state.get("added", 0)) + 1
            row["then"] = f"layer {tr.layer} laid again ({-off:.2f} mm low, more than half the {t:g} mm layer)"
            nxt = k
        elif off > t / 2 and k + 2 < len(self.tracks):
            self.state["dropped"] = int(self.state.get("dropped", 0)) + 1
            self.state.setdefault("skipped", []).append(self._track(k + 1).layer)
            row["then"] = (
                f"layer {self._track(k + 1).layer} left out ({off:.2f} mm high, more than half the {t:g} mm layer)"
            )
            nxt = k + 2
        self.state.setdefault("layers", []).append(row)
        self.state["next_layer"] = nxt
        if self.done:
            self.state["status"] = "complete"
        scan_file = (
            {
                "scan_file": f"scan_{tr.layer:05d}.bin",
                "scan_bytes": len(raw),
                "scan_sha256": hashlib.sha256(raw).hexdigest()[:16],
            }
            if raw is not None
            else {"scan_file": scan.source}
        )
        self._log(who, "scan", **{k2: v2 for k2, v2 in row.items() if k2 != "registration"}, **scan_file)
        if nxt == k:
            self._log(who, "layer_added", layer=tr.layer, reason=row["then"])
        elif nxt == k + 2:
            self._log(who, "layer_dropped", layer=self._track(k + 1).layer, reason=row["then"])
        self.save()
        return row

    def surface(self) -> list[dict]:
        """Per scanned layer, per track sample: planned crest (x, y, z), build direction, planned
        and measured top height along it and the deviation (mm; NaN where the scan saw nothing)."""
        out = []
        for key in sorted(self.state["records"], key=int):
            k = int(key)
            rec, tr = self.record(k), self._track(k)
            if rec is None:
                continue
            planned = tr.planned_height()
            out.append(
                {
                    "layer": tr.layer,
                    "points": tr.points,
                    "normal": tr.normal,
                    "planned": planned,
                    "measured": rec.measured_top,
                    "deviation": rec.measured_top - planned,
                    "thickness": tr.thickness,
                }
            )
        return out

    def summary(self) -> dict:
        return {
            "meta": self.state["meta"],
            "status": self.state["status"],
            "created": self.state["created"],
            "next_layer": self.tracks[self.next_layer].layer if not self.done else None,
            "layers_planned": len(self.tracks),
            "layers_scanned": len(self.state.get("layers", [])),
            "plan_layers": [t.layer for t in self.tracks],
            "layers_added": int(self.state.get("added", 0)),
            "layers_dropped": int(self.state.get("dropped", 0)),
            "skipped": list(self.state.get("skipped", [])),
            "layers": self.state.get("layers", []),
            "programs": self.state.get("programs", []),
            "interpass": self.dwell_rule.to_dict(),
            "log": self.state["log"],
        }
