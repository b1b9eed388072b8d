"""The parts of `run.simulate_program` that go to the run's workers (`Context.submit`): the
controller simulation started beside the IK and taken only when the IK's speed caps leave the
program speeds as they were (`speculative`), and the closed-form time estimate. Each falls back
to this process when no worker is up or the worker fails, with the same result."""

from __future__ import annotations

from typing import Any

from ..core.moves import Moves
from .estimate import estimate_moves
from .profile import RobotProfile
from .simulate import SimOptions, SimulationResult, program_speeds, simulate


def simulate_task(task: tuple[Moves, RobotProfile, SimOptions]) -> SimulationResult:
    """Worker side of `simulate_program`'s speculative simulation."""
    moves, profile, opt = task
    return simulate(moves, profile, opt)


def estimate_task(task: tuple[Moves, dict, float, tuple[str, ...] | None]) -> Any:
    """`estimate_moves` on (moves, time model, travel speed, strategies): here or in a worker."""
    moves, time_model, travel, strategies = task
    return estimate_moves(moves, time_model, travel, strategies=strategies)


def estimate_result(fut: Any, task: tuple[Moves, dict, float, tuple[str, ...] | None]) -> Any:
    """The estimate a worker made (`fut`, or None), else made here (it failed or none was asked)."""
    if fut is not None:
        try:
            return fut.result()
        except Exception:  # the worker died, or the estimate failed: again here, which raises it located
            pass
    return estimate_task(task)


def speculative(
    started: list[tuple[Moves, SimOptions, Any]], moves: Moves, profile: RobotProfile, opt: SimOptions
) -> SimulationResult | None:
    """The simulation a worker ran on `started`'s options, when it is the one of `opt`: the same
    moves and, to the bit, the same program speeds (the caps enter a simulation only there,
    `simulate.program_speeds`); None when it is not (or the worker failed): simulate here."""
    if not started:
        return None
    spec_moves, spec_opt, fut = started[0]
    same = spec_moves is moves and (
        program_speeds(moves, profile, spec_opt).tobytes() == program_speeds(moves, profile, opt).tobytes()
    )
    if not same:
        fut.cancel()
        return None
    try:
        return fut.result()
    except Exception:  # the worker died, or the simulation failed: again here, which raises it located
        return None
