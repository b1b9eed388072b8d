"""Bead models as data: bead width and height as functions of wire feed speed and travel speed,
fitted from the user's bead trials (issue 16).

Form. Mass conservation makes the bead cross-section A ∝ WFS/TS (A = η·(π·d²/4)·WFS/TS), and the
single-bead literature fits width and height as power laws of the two speeds (e.g. Xiong, Zhang,
Hu, Wu, "Bead geometry prediction for robotic GMAW-based rapid manufacturing through a neural
network and a second-order regression analysis", J. Intell. Manuf. 25 (2014) 157–163; Ding, Pan,
Cuiuri, Li, "A multi-bead overlapping model for robotic WAAM", RCIM 31 (2015) 101–110). We use

    power:        y = a · WFS^b · TS^c        (y = width or height, mm)
    power-ratio:  y = a · (WFS / TS)^b        (the special case c = −b)

with WFS in m/min (as on the power source) and TS in mm/s. A start from the log-linear least
squares fit, then `scipy.optimize.curve_fit` on the measured scale (so residuals are in mm);
parameter standard errors from its covariance. Each model also states the trial range it is valid
for. Inverse: a target (height, width) fixes (WFS, TS) by solving the two log-linear equations.

Trials CSV: a header row naming at least the four columns (case-insensitive; units may follow in
brackets or after an underscore): `wfs` (or `wire_feed_speed`, m/min), `ts` (or `travel_speed`,
mm/s), `width` (mm), `height` (mm); optional `area` (measured bead cross-section, mm²),
`material`, `process`. Lines starting with '#' are comments. A non-numeric or non-positive value
fails naming its row and column.

Mass balance (issue #22 item 5). The model also states the wire diameter d, the deposition
efficiency η and the bead shape factor k (cross-section = k·w·h): k is fitted from the trials'
measured areas when the CSV has an `area` column (k = mean of area / (w·h)), else the stated
constant (`core.process.BEAD_SHAPE_FACTOR`). The fit record's `mass_balance` gives, per trial,
the metal fed per mm η·WFS·(π d²/4)/TS over k·w·h: a real bead is 1 within its scatter, so a
trials file far from 1 has a unit or measurement error (see process/mass.py).
"""

from __future__ import annotations

import csv
import io
import json
import math
import re
from dataclasses import dataclass, field, replace

import numpy as np

from ..core.errors import InputFileError
from ..core.process import BEAD_SHAPE_FACTOR, DEPOSITION_EFFICIENCY, WIRE_DIAMETER_MM
from .mass import wire_per_mm

FORMAT = "waamflow/bead-model/1"
#: Centre distance / width for a flat top between neighbouring beads (Ding et al. 2015, TOM).
TANGENT_OVERLAP = 0.738
FORMS = ("power", "power-ratio")

_ALIASES = {
    "wfs": ("wfs", "wire_feed_speed", "wire_feed", "wirefeed"),
    "ts": ("ts", "travel_speed", "speed", "travel"),
    "width": ("width", "w", "bead_width"),
    "height": ("height", "h", "bead_height"),
}
_OPTIONAL = {"area": ("area", "bead_area", "cross_section", "section_area")}


@dataclass(frozen=True)
class Trials:
    """Measured beads: (n,) arrays. wfs m/min, ts mm/s, width and height mm."""

    wfs: np.ndarray
    ts: np.ndarray
    width: np.ndarray
    height: np.ndarray
    source: str = ""
    area: np.ndarray | None = None  # (n,) measured cross-section, mm² (optional column)


def _column(name: str) -> str | None:
    key = re.sub(r"\s*[\[(].*$", "", name.strip().lower()).replace(" ", "_")
    for canon, names in (*_ALIASES.items(), *_OPTIONAL.items()):
        for n in names:
            if key == n or key.startswith(n + "_"):
                return canon
    return None


def read_trials(text: str, source: str = "trials") -> Trials:
    rows = [r for r in csv.reader(io.StringIO(text)) if r and not r[0].lstrip().startswith("#")]
    if not rows:
        raise InputFileError(f"{source}: no rows")
    cols: dict[str, int] = {}
    for j, name in enumerate(rows[0]):
        c = _column(name)
        if c and c not in cols:
            cols[c] = j
    missing = [c for c in _ALIASES if c not in cols]
    if missing:
        raise InputFileError(
            f"{source}: header lacks column(s) {', '.join(missing)} "
            f"(need wfs [m/min], ts [mm/s], width [mm], height [mm])"
        )
    data: dict[str, list[float]] = {c: [] for c in cols}
    for i, r in enumerate(rows[1:], start=2):
        for c, j in cols.items():
            try:
                v = float(r[j])
            except (IndexError, ValueError):
                raise InputFileError(f"{source}: row {i}, column {rows[0][j]!r}: not a number") from None
            if not (math.isfinite(v) and v > 0):
                raise InputFileError(f"{source}: row {i}, column {rows[0][j]!r}: must be positive, got {v}")
            data[c].append(v)
    if len(data["wfs"]) < 3:
        raise InputFileError(f"{source}: need at least 3 measured beads, got {len(data['wfs'])}")
    return Trials(
        np.asarray(data["wfs"]),
        np.asarray(data["ts"]),
        np.asarray(data["width"]),
        np.asarray(data["height"]),
        source=source,
        area=np.asarray(data["area"]) if "area" in data else None,
    )


@dataclass(frozen=True)
class PowerLaw:
    """y = a · WFS^b · TS^c (mm; WFS m/min, TS mm/s)."""

    a: float
    b: float
    c: float
    form: str = "power"
    stderr: tuple[float, ...] = ()

    def __call__(self, wfs, ts):
        return self.a * np.power(wfs, self.b) * np.power(ts, self.c)

    def to_json(self) -> dict:
        out = {"form": self.form, "a": self.a, "b": self.b, "c": self.c}
        if self.stderr:
            out["stderr"] = list(self.stderr)
        return out

    @classmethod
    def from_json(cls, d: dict) -> "PowerLaw":
        form = d.get("form", "power")
        c = float(d["c"]) if "c" in d else -float(d["b"])
        return cls(float(d["a"]), float(d["b"]), c, form, tuple(d.get("stderr", ())))


def fit_power(wfs: np.ndarray, ts: np.ndarray, y: np.ndarray, form: str = "power") -> PowerLaw:
    """Least-squares fit of y = a·WFS^b·TS^c (or a·(WFS/TS)^b) on the measured scale."""
    from scipy.optimize import curve_fit  # lazy: keeps start-up light

    if form not in FORMS:
        raise ValueError(f"unknown bead-model form {form!r}; known: {', '.join(FORMS)}")
    lw, lt, ly = np.log(wfs), np.log(ts), np.log(y)
    if form == "power":
        A = np.column_stack([np.ones_like(lw), lw, lt])
        p0, *_ = np.linalg.lstsq(A, ly, rcond=None)

        def power(X, a, b, c):
            return a * X[0] ** b * X[1] ** c

        p, cov = curve_fit(power, np.vstack([wfs, ts]), y, p0=[math.exp(p0[0]), p0[1], p0[2]], maxfev=20000)
        err = tuple(float(e) for e in np.sqrt(np.abs(np.diag(cov)))) if np.all(np.isfinite(cov)) else ()
        return PowerLaw(float(p[0]), float(p[1]), float(p[2]), form, err)
    A = np.column_stack([np.ones_like(lw), lw - lt])
    p0, *_ = np.linalg.lstsq(A, ly, rcond=None)

    def power_ratio(r, a, b):
        return a * r**b

    p, cov = curve_fit(power_ratio, wfs / ts, y, p0=[math.exp(p0[0]), p0[1]], maxfev=20000)
    err = tuple(float(e) for e in np.sqrt(np.abs(np.diag(cov)))) if np.all(np.isfinite(cov)) else ()
    return PowerLaw(float(p[0]), float(p[1]), -float(p[1]), form, err)


def _stats(y: np.ndarray, pred: np.ndarray) -> dict:
    res = y - pred
    ss = float(((y - y.mean()) ** 2).sum())
    return {
        "rmse_mm": float(np.sqrt((res**2).mean())),
        "max_abs_residual_mm": float(np.abs(res).max()),
        "r2": 1.0 - float((res**2).sum()) / ss if ss > 0 else 1.0,
    }


@dataclass(frozen=True)
class BeadFit:
    """A bead model: width(WFS, TS), height(WFS, TS), the trial range and the fit statistics."""

    width: PowerLaw
    height: PowerLaw
    wfs_range: tuple[float, float]
    ts_range: tuple[float, float]
    material: str = ""
    process: str = ""
    wire_diameter_mm: float | None = None
    fit: dict = field(default_factory=dict)
    #: The bead the process is set up for (mm): the bead-fit node's `height`/`width`. Nodes that
    #: take a connected model read their layer height (slice) and step-over (strategy) from it.
    target_height_mm: float | None = None
    target_width_mm: float | None = None
    #: Mass balance: η (stated) and k in area = k·w·h (fitted from measured areas, else stated).
    deposition_efficiency: float = DEPOSITION_EFFICIENCY
    shape_factor: float = BEAD_SHAPE_FACTOR
    shape_factor_source: str = "stated"

    @property
    def wire_d(self) -> float:
        """Wire diameter for the mass balance, mm (the stated 1.2 mm when the model does not say)."""
        return float(self.wire_diameter_mm or WIRE_DIAMETER_MM)

    def bead_area(self, wfs, ts):
        """Bead cross-section k·w·h (mm²) the model predicts at (WFS m/min, TS mm/s)."""
        return self.shape_factor * self.width(wfs, ts) * self.height(wfs, ts)

    def wire_per_mm(self, wfs: float, ts: float) -> float:
        """Metal fed per mm of path, η·WFS·(π d²/4)/TS (mm³/mm)."""
        return wire_per_mm(wfs, ts, self.wire_d, self.deposition_efficiency)

    def with_targets(self, height_mm: float | None, width_mm: float | None) -> "BeadFit":
        return replace(self, target_height_mm=height_mm, target_width_mm=width_mm)

    def target_step_over(self) -> float | None:
        """Centre distance of neighbouring passes for the target width (tangent overlap model), mm."""
        return None if self.target_width_mm is None else self.step_over(self.target_width_mm)

    def step_over(self, width_mm: float) -> float:
        """Centre distance between neighbouring beads for a flat top (tangent overlap model), mm."""
        return TANGENT_OVERLAP * width_mm

    def speeds_for(self, height_mm: float, width_mm: float) -> tuple[float, float]:
        """(WFS m/min, TS mm/s) giving the target bead height and width (log-linear solve)."""
        M = np.array([[self.width.b, self.width.c], [self.height.b, self.height.c]])
        rhs = np.array([math.log(width_mm / self.width.a), math.log(height_mm / self.height.a)])
        if abs(np.linalg.det(M)) < 1e-9:
            raise ValueError(
                "the bead model cannot set width and height independently (its exponents are "
                "proportional, e.g. the power-ratio form): give a travel speed instead"
            )
        lw, lt = np.linalg.solve(M, rhs)
        return float(math.exp(lw)), float(math.exp(lt))

    def wfs_for(self, height_mm: float, ts: float) -> float:
        """WFS (m/min) giving the target height at travel speed ts (mm/s)."""
        return float((height_mm / (self.height.a * ts**self.height.c)) ** (1.0 / self.height.b))

    def height_polynomial(self, wfs: float | None = None) -> tuple[float, float, float, float, float]:
        """The height law at a fixed WFS (m/min; default the middle of the trials) as the curved-parts
        study's form H(Ts) = a2·Ts² + a1·Ts + a0 with Ts in mm/min, least squares over the trials'
        travel-speed range: (a2, a1, a0, ts_min, ts_max), for the bead-model node."""
        wfs = 0.5 * (self.wfs_range[0] + self.wfs_range[1]) if wfs is None else wfs
        ts = np.linspace(self.ts_range[0], self.ts_range[1], 200)  # mm/s
        a2, a1, a0 = np.polyfit(ts * 60.0, self.height(wfs, ts), 2)
        return float(a2), float(a1), float(a0), self.ts_range[0] * 60.0, self.ts_range[1] * 60.0

    def in_range(self, wfs: float, ts: float) -> bool:
        return (
            self.wfs_range[0] * 0.999 <= wfs <= self.wfs_range[1] * 1.001
            and self.ts_range[0] * 0.999 <= ts <= self.ts_range[1] * 1.001
        )

    def to_json(self) -> dict:
        return {
            "format": FORMAT,
            "material": self.material,
            "process": self.process,
            "wire_diameter_mm": self.wire_diameter_mm,
            "deposition_efficiency": self.deposition_efficiency,
            "shape_factor": {
                "k": self.shape_factor,
                "source": self.shape_factor_source,
                "definition": "bead cross-section = k * width * height",
            },
            "units": {"wfs": "m/min", "ts": "mm/s", "width": "mm", "height": "mm"},
            "width": self.width.to_json(),
            "height": self.height.to_json(),
            "validity": {"wfs_m_min": list(self.wfs_range), "ts_mm_s": list(self.ts_range)},
            **(
                {"targets": {"height_mm": self.target_height_mm, "width_mm": self.target_width_mm}}
                if self.target_height_mm is not None or self.target_width_mm is not None
                else {}
            ),
            "fit": self.fit,
        }

    @classmethod
    def from_json(cls, d: dict, source: str = "bead model") -> "BeadFit":
        try:
            if d.get("format") != FORMAT:
                raise ValueError(f"format must be {FORMAT!r}")
            v = d["validity"]
            t = d.get("targets") or {}
            sf = d.get("shape_factor") or {}
            th, tw = t.get("height_mm"), t.get("width_mm")
            return cls(
                PowerLaw.from_json(d["width"]),
                PowerLaw.from_json(d["height"]),
                _range(v, "wfs_m_min"),
                _range(v, "ts_mm_s"),
                d.get("material", ""),
                d.get("process", ""),
                d.get("wire_diameter_mm"),
                d.get("fit", {}),
                None if th is None else float(th),
                None if tw is None else float(tw),
                float(d.get("deposition_efficiency", DEPOSITION_EFFICIENCY)),
                float(sf.get("k", BEAD_SHAPE_FACTOR)),
                str(sf.get("source", "stated")),
            )
        except (KeyError, TypeError, ValueError) as e:
            raise InputFileError(f"{source}: not a bead model ({e})") from None


def _range(validity: dict, key: str) -> tuple[float, float]:
    """A bead model's validity range `key`: [min, max], two numbers (ValueError otherwise)."""
    lo_hi = tuple(map(float, validity[key]))
    if len(lo_hi) != 2:
        raise ValueError(f"validity.{key} must be [min, max], got {len(lo_hi)} value(s)")
    return lo_hi[0], lo_hi[1]


def fit_trials(
    trials: Trials,
    form: str = "power",
    material: str = "",
    process: str = "",
    wire_diameter_mm: float | None = None,
    deposition_efficiency: float = DEPOSITION_EFFICIENCY,
    shape_factor: float = BEAD_SHAPE_FACTOR,
) -> BeadFit:
    """Fit width and height; the fit record holds statistics and per-trial residuals (mm)."""
    w = fit_power(trials.wfs, trials.ts, trials.width, form)
    h = fit_power(trials.wfs, trials.ts, trials.height, form)
    pw, ph = w(trials.wfs, trials.ts), h(trials.wfs, trials.ts)
    rect = trials.width * trials.height
    k, k_src = (float(np.mean(trials.area / rect)), "fitted") if trials.area is not None else (shape_factor, "stated")
    d = float(wire_diameter_mm or WIRE_DIAMETER_MM)
    fed = np.array([wire_per_mm(a, b, d, deposition_efficiency) for a, b in zip(trials.wfs, trials.ts)])
    mb = fed / (k * rect)
    fit = {
        "trials": int(len(trials.wfs)),
        "source": trials.source,
        "width": _stats(trials.width, pw),
        "height": _stats(trials.height, ph),
        "mass_balance": {
            "definition": "eta * WFS * (pi d^2/4) / TS over k * width * height, per trial",
            "mean": round(float(mb.mean()), 4),
            "min": round(float(mb.min()), 4),
            "max": round(float(mb.max()), 4),
            "shape_factor_k": round(k, 4),
            **(
                {"shape_factor_k_stderr": round(float(np.std(trials.area / rect, ddof=1) / math.sqrt(len(rect))), 4)}
                if trials.area is not None
                else {}
            ),
        },
        "residuals": [
            {
                "wfs_m_min": float(a),
                "ts_mm_s": float(b),
                "width_mm": float(c),
                "height_mm": float(d),
                "width_residual_mm": round(float(c - e), 5),
                "height_residual_mm": round(float(d - f), 5),
            }
            for a, b, c, d, e, f in zip(trials.wfs, trials.ts, trials.width, trials.height, pw, ph)
        ],
    }
    return BeadFit(
        w,
        h,
        (float(trials.wfs.min()), float(trials.wfs.max())),
        (float(trials.ts.min()), float(trials.ts.max())),
        material,
        process,
        wire_diameter_mm,
        fit,
        deposition_efficiency=deposition_efficiency,
        shape_factor=k,
        shape_factor_source=k_src,
    )


def fit_svg(model: BeadFit) -> str:
    """Measured against model width and height per trial (one panel each, the 1:1 line)."""
    from .svgplot import Chart, figure

    res = model.fit.get("residuals", [])
    charts = []
    for k, (name, color) in enumerate((("width", "#1d3557"), ("height", "#e76f51"))):
        meas = np.array([r[f"{name}_mm"] for r in res]) if res else np.zeros(0)
        pred = meas - np.array([r[f"{name}_residual_mm"] for r in res]) if res else np.zeros(0)
        lo = float(min(meas.min(), pred.min())) * 0.95 if len(meas) else 0.0
        hi = float(max(meas.max(), pred.max())) * 1.05 if len(meas) else 1.0
        st = model.fit.get(name, {})
        ch = Chart(
            60 + k * 360,
            40,
            270,
            270,
            (lo, hi),
            (lo, hi),
            x_label=f"model {name}, mm",
            y_label=f"measured {name}, mm",
            legend="left",
            title=f"{name}: RMSE {st.get('rmse_mm', 0):.3f} mm, R² {st.get('r2', 0):.3f}, n = {len(meas)}",
        )
        ch.line([lo, hi], [lo, hi], "#aaaaaa", width=1.0, label="1:1")
        ch.points(pred, meas, color, label="trial")
        charts.append(ch)
    return figure(720, 360, charts)


def main(argv: list[str] | None = None) -> int:
    """`python -m waamflow.process.bead_fit TRIALS.csv [--form power] [--out MODEL.json]`."""
    import argparse
    import sys

    ap = argparse.ArgumentParser(prog="python -m waamflow.process.bead_fit", description=main.__doc__)
    ap.add_argument("trials")
    ap.add_argument("--form", choices=FORMS, default="power")
    ap.add_argument("--material", default="")
    ap.add_argument("--process", default="")
    ap.add_argument("--out", default="")
    a = ap.parse_args(argv)
    try:
        with open(a.trials, encoding="utf-8") as f:
            model = fit_trials(read_trials(f.read(), a.trials), a.form, a.material, a.process)
    except (OSError, InputFileError, ValueError, RuntimeError) as e:
        print(f"error: {e}", file=sys.stderr)
        return 2
    text = json.dumps(model.to_json(), indent=1)
    if a.out:
        with open(a.out, "w", encoding="utf-8") as f:
            f.write(text + "\n")
    else:
        print(text)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
