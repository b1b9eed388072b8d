"""simulate-robot with a worker (`submit`): the controller simulation runs in another process
while the IK is solved here, and is taken only when the IK's speed caps leave the program speeds
as they were; part of trace.csv's rows are formatted in a worker. The serial path and the worker
path give the same bytes: simulation.json, trace.csv and deposit.csv compared whole, on the
arm-only and the cell configurations."""

from __future__ import annotations

import json
import multiprocessing as mp
from concurrent.futures import Future, ProcessPoolExecutor
from dataclasses import replace

import numpy as np
import pytest

from waamflow.trajectory import run as run_mod
from waamflow.trajectory import runreport, simworkers
from waamflow.trajectory import study
from waamflow.trajectory.cell import load_cell
from waamflow.trajectory.profile import load_profile
from waamflow.trajectory.run import KinematicsOptions, deposit_csv, simulate_program, simulation_json
from waamflow.trajectory.simulate import SimOptions, program_speeds, simulate
from waamflow.trajectory import trace as trace_mod
from waamflow.trajectory.trace import start_trace_csv, trace_csv

PROFILE = load_profile("kuka_kr100ha_krc2")


@pytest.fixture(scope="module")
def pool():
    with ProcessPoolExecutor(1, mp_context=mp.get_context("forkserver")) as ex:
        yield ex


def _files(res) -> tuple[str, str, str]:
    return json.dumps(simulation_json(res, SimOptions()), indent=1), trace_csv(res), deposit_csv(res)


def _kins():
    cell = load_cell("kr150_tilt_rotate")
    return {
        "arm": KinematicsOptions(step_mm=5.0),
        "cell": KinematicsOptions(
            description=cell.robot_urdf,
            tcp_offset_mm=tuple(cell.tool.tcp_mm),
            step_mm=5.0,
            cell=cell,
            positioner_policy="gravity",
        ),
    }


@pytest.mark.parametrize("config", ["arm", "cell"])
def test_worker_path_gives_the_serial_bytes(pool, monkeypatch, config):
    monkeypatch.setattr(run_mod, "SPECULATE_MIN_POINTS", 0)
    moves = study.raster(10.0)
    kin = _kins()[config]
    serial = simulate_program(moves, PROFILE, SimOptions(), kin)
    submitted: list[Future] = []

    def submit(fn, item):
        fut = pool.submit(fn, item)
        submitted.append(fut)
        return fut

    here = []  # simulations run in this process
    monkeypatch.setattr(run_mod, "simulate", lambda *a, **k: here.append(1) or simulate(*a, **k))
    par = simulate_program(moves, PROFILE, SimOptions(), kin, submit=submit)
    assert PROFILE.time_model  # the closed-form estimate goes to a worker too
    assert len(submitted) == 2 and all(f.done() for f in submitted)
    assert par.estimate == serial.estimate and par.estimate["total_time_s"] > 0
    assert here == []  # the worker's simulation was taken: the caps leave 10 mm/s alone
    a, b = _files(serial), _files(par)
    assert len(a[1]) > 10_000 and a[1].count("\n") > 300
    assert a == b
    assert par.metrics == serial.metrics and par.warnings == serial.warnings


def test_a_cap_that_binds_is_simulated_here():
    """The worker simulated on other program speeds (a cap binds): not taken, simulated here."""
    moves = study.raster(10.0)
    opt = SimOptions()
    n = len(moves.points) - 1
    cap = np.full(n, np.inf)
    cap[3] = 4.0  # mm/s, under the 10 mm/s programmed
    capped = replace(opt, segment_cap=cap)
    assert program_speeds(moves, PROFILE, capped).min() == 4.0
    fut: Future = Future()
    fut.set_result("the uncapped simulation")
    assert simworkers.speculative([(moves, opt, fut)], moves, PROFILE, capped) is None
    # caps above every speed leave the speeds to the bit: taken
    high = replace(opt, segment_cap=np.full(n, 1e6))
    assert program_speeds(moves, PROFILE, high).tobytes() == program_speeds(moves, PROFILE, opt).tobytes()
    assert simworkers.speculative([(moves, opt, fut)], moves, PROFILE, high) == "the uncapped simulation"
    # other moves (a turn in place added a dwell): not taken
    other = replace(moves, dwell_before=np.asarray(moves.dwell_before, float) + 1.0)
    assert simworkers.speculative([(moves, opt, fut)], other, PROFILE, high) is None


def test_a_failed_worker_is_simulated_here():
    moves = study.raster(10.0)
    fut: Future = Future()
    fut.set_exception(RuntimeError("worker died"))
    assert simworkers.speculative([(moves, SimOptions(), fut)], moves, PROFILE, SimOptions()) is None
    assert simworkers.speculative([], moves, PROFILE, SimOptions()) is None
    task = (moves, PROFILE.time_model, PROFILE.travel_speed, None)
    here = simworkers.estimate_task(task)
    assert here.total_time_s > 0
    assert simworkers.estimate_result(fut, task) == here  # the estimate again here
    assert simworkers.estimate_result(None, task) == here


def test_trace_csv_split_with_a_worker_is_the_same_text(pool, monkeypatch):
    res = simulate_program(study.raster(10.0), PROFILE, SimOptions())
    whole = trace_csv(res)
    rows = whole.count("\n") - 1
    assert rows > 300
    monkeypatch.setattr(trace_mod, "CSV_SPLIT_ROWS", 10)
    monkeypatch.setattr(trace_mod, "_CSV_BLOCK", 7)  # blocks cut across the split too
    sent = []

    def submit(fn, item):
        sent.append(len(item))
        return pool.submit(fn, item)

    assert start_trace_csv(res, submit)() == whole
    assert sent == [int(trace_mod.CSV_WORKER_SHARE * rows)]
    failed: Future = Future()
    failed.set_exception(RuntimeError("worker died"))
    assert start_trace_csv(res, lambda fn, item: failed)() == whole  # the rows again here
    assert start_trace_csv(res, lambda fn, item: None)() == whole  # no worker up


def test_a_recipe_run_with_workers_gives_the_serial_bytes(monkeypatch):
    """curved-duct (KUKA cell, gravity policy, IK + collisions, 6,787 path points) run serial and
    with two workers up before simulate-robot: its simulation and estimate go to the workers, and
    every artifact of the run is the same, byte for byte."""
    from pathlib import Path

    from waamflow.engine import parallel
    from waamflow.engine.executor import FileResolver, execute
    from waamflow.engine.graph import build_graph
    from waamflow.engine.recipe import load_recipe

    monkeypatch.setattr(parallel, "MIN_PARALLEL_S", 0.0)  # the workers start after the first node
    monkeypatch.setattr(parallel, "BACKGROUND_START", False)
    monkeypatch.setattr(trace_mod, "CSV_SPLIT_ROWS", 1000)  # its trace's rows split too
    monkeypatch.setenv("SOURCE_DATE_EPOCH", "1767225600")
    sent: list[str] = []
    submit = parallel.LayerPool.submit

    def spy(self, fn, item):
        sent.append(fn.__name__)
        return submit(self, fn, item)

    monkeypatch.setattr(parallel.LayerPool, "submit", spy)
    path = Path(__file__).resolve().parents[2] / "graphs" / "curved-duct.json"

    def run(workers):
        return execute(build_graph(load_recipe(path)), resolver=FileResolver(path.parent), workers=workers)

    serial = run(1)
    assert sent == []
    par = run(2)
    assert sent[:2] == ["simulate_task", "estimate_task"] and {"_csv_rows", "deposit_files"} <= set(sent), sent
    assert sorted(par.artifacts) == sorted(serial.artifacts) and len(serial.artifacts) >= 10
    for k in serial.artifacts:
        assert par.artifacts[k] == serial.artifacts[k], k
    assert par.warnings == serial.warnings


def test_deposit_files_in_a_worker_are_the_same_texts(pool, monkeypatch):
    from waamflow.trajectory.compensate import deposit_svg

    res = simulate_program(study.raster(10.0), PROFILE, SimOptions())
    here = (deposit_csv(res), deposit_svg(res.deposit))
    assert here[0].count("\n") == len(res.deposit["length_mm"]) + 1 and "<svg" in here[1]
    monkeypatch.setattr(runreport, "DEPOSIT_SPLIT_SEGMENTS", 1)
    sent = []

    def submit(fn, item):
        sent.append(fn.__name__)
        return pool.submit(fn, item)

    assert runreport.start_deposit_files(res, submit)() == here and sent == ["deposit_files"]
    failed: Future = Future()
    failed.set_exception(RuntimeError("worker died"))
    assert runreport.start_deposit_files(res, lambda fn, item: failed)() == here
    assert runreport.start_deposit_files(res, lambda fn, item: None)() == here
    assert runreport.start_deposit_files(res)() == here
