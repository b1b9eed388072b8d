"""The study's time model per strategy family, read off the model's own simulated traces.

Split off `calibrate.py` (the fits) for the structure rule: this is not a fit but a reading of
the fitted profile's traces, the way `trace.identify_time_model` reads a user's measured trace.
`python -m waamflow.trajectory.calibrate --families [--write]` writes the entries into a profile.
"""

from __future__ import annotations

from typing import Callable

from ..core.moves import Moves
from . import study
from .profile import RobotProfile
from .simulate import SimOptions, simulate
from .trace import identify_time_model, read_trace_csv, trace_csv


# the study's programs per strategy family (small OR), with the arc protocols each one has.
# Spiral and swiping are left to the generic (triangular 45°) entries: read off the model's
# traces their constants make the closed form worse, not better, on the large OR (spiral −16.8 %,
# swiping −31.7 % at 40 mm/s against −8.3 / −15.3 % with the generic ones): the spiral's passes
# shrink lap by lap and the swiping's legs meet at reversals without a link, so neither has the
# equal passes and equal links the paper's T_trans + (L_t − L_trans_ref)/TS assumes.
FAMILY_PROGRAMS: dict[str, tuple[tuple[str, Callable[[float], Moves]], ...]] = {
    "raster": (("off", lambda v: study.raster(v)),),
    "semicircular": (("on", lambda v: study.semicircular(v, True)), ("off", lambda v: study.semicircular(v, False))),
    "rectangular": (("on", lambda v: study.planned("rectangular", v)),),
}


def family_time_model(profile: RobotProfile, speeds: tuple[float, ...] = (10.0, 40.0), cycle_s: float = 0.012) -> dict:
    """Table-5 entries per strategy family (`FAMILY_PROGRAMS`) read off this profile's simulated
    12 ms traces of the study's programs (small OR) by `identify_time_model`, the way a user's
    trace is read: keys "<TS>_<protocol>_<family>", each with `source` naming where it comes
    from. The study measured its constants on triangular 45° only (the profile's generic
    entries); these are the model's, for the strategies the study timed but did not identify."""
    out = {}
    for fam, progs in FAMILY_PROGRAMS.items():
        for prot, make in progs:
            for v in speeds:
                mv = make(float(v))
                res = simulate(mv, profile, SimOptions(interpolation_cycle_s=cycle_s))
                tm, _ = identify_time_model(
                    mv,
                    read_trace_csv(trace_csv(res)),
                    (fam,),
                    source=f"simulated: {profile.name} model, study program {fam} "
                    f"{v:g} mm/s small OR, {cycle_s * 1000:g} ms trace",
                )
                out.update(tm)
    return out
