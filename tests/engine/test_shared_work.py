"""A node that hands part of its own work to the run's workers (`Context.submit`) declares it
(`Node.shared_work_s`): the cost model counts it for the nodes still to run, so the workers are
up by the time that node runs. simulate-robot declares its controller simulation (with IK)."""

from __future__ import annotations

import toy_nodes as toy

from waamflow.engine import executor, parallel
from waamflow.engine.executor import FileResolver, execute
from waamflow.engine.graph import build_graph
from waamflow.engine.node import Context, load_nodes
from waamflow.engine.recipe import parse_recipe


def _graph():
    return build_graph(
        parse_recipe(
            toy.recipe(
                [("stack", "toy-stack", {"count": 3}), ("grow", "toy-grow", {})],
                [("stack.layers", "grow.layers")],
            )
        )
    )


def _spy_warm(monkeypatch) -> list[int]:
    started: list[int] = []
    warm = parallel.LayerPool.warm

    def spy(self):
        if not self.started:
            started.append(1)
        return warm(self)

    monkeypatch.setattr(parallel.LayerPool, "warm", spy)
    monkeypatch.setattr(parallel, "BACKGROUND_START", False)
    return started


def test_declared_shared_work_of_a_later_node_starts_the_workers(monkeypatch):
    started = _spy_warm(monkeypatch)
    monkeypatch.setattr(executor.os, "getloadavg", lambda: (0.0, 0.0, 0.0))  # an idle machine
    small = execute(_graph(), resolver=FileResolver("."), workers=2)
    assert started == []  # 3 toy layers: far under MIN_PARALLEL_S
    monkeypatch.setattr(toy.ToyGrow, "shared_work_s", lambda self, params, points: parallel.MIN_PARALLEL_S + 0.1)
    big = execute(_graph(), resolver=FileResolver("."), workers=2)
    assert started == [1] and big.artifacts == small.artifacts
    started.clear()
    serial = execute(_graph(), resolver=FileResolver("."), workers=1)  # one worker: never
    assert started == [] and serial.artifacts == small.artifacts


def test_wants_workers_adds_the_declared_seconds():
    assert not parallel.wants_workers(2, points=10, min_s=1.0)
    assert parallel.wants_workers(2, points=10, min_s=1.0, extra_s=1.0)
    assert not parallel.wants_workers(1, points=10, min_s=1.0, extra_s=5.0)


def test_simulate_robot_declares_its_simulation_only_with_kinematics():
    impl = load_nodes()["simulate-robot"]()
    params = type(impl).Params()
    assert impl.shared_work_s(params, 40_000) == 40_000 * 2.2e-5  # 0.88 s: curved-bracket's size
    assert impl.shared_work_s(params.model_copy(update={"kinematics": False}), 40_000) == 0.0
    assert Context().submit(len, []) is None  # outside a run: the caller computes it


def test_declared_shared_work_needs_a_spare_core(monkeypatch):
    """Work a node runs beside its own pays only on a core of its own: on a machine whose load
    average fills its cores it does not start the workers (the cost model's own terms still may)."""
    started = _spy_warm(monkeypatch)
    monkeypatch.setattr(toy.ToyGrow, "shared_work_s", lambda self, params, points: parallel.MIN_PARALLEL_S + 0.1)
    cores = executor.os.cpu_count() or 1
    monkeypatch.setattr(executor.os, "getloadavg", lambda: (float(cores), 0.0, 0.0))
    assert not executor.spare_core()
    busy = execute(_graph(), resolver=FileResolver("."), workers=2)
    assert started == [] and busy.executor["workers"] == 2
    monkeypatch.setattr(executor.os, "getloadavg", lambda: (cores - 0.6, 0.0, 0.0))
    assert executor.spare_core()
    execute(_graph(), resolver=FileResolver("."), workers=2)
    assert started == [1]


def test_a_node_starts_the_workers_for_the_work_it_will_submit(monkeypatch):
    """`Context.start_workers(work_s)`: a node that will hand work to the workers itself (the
    sequence node's second seed on a floor plan's layers) starts them when the cost model says
    that work pays, in a run with more than one worker only; small work does not."""
    started = _spy_warm(monkeypatch)
    asked: list[float] = []
    run_layer = toy.ToyGrow.run_layer

    def starting(self, ctx, params, index, items):
        if index == 0:
            ctx.start_workers(asked[-1])
        return run_layer(self, ctx, params, index, items)

    monkeypatch.setattr(toy.ToyGrow, "run_layer", starting)
    asked.append(0.5)
    small = execute(_graph(), resolver=FileResolver("."), workers=2, cache=None)
    assert started == []
    asked.append(parallel.MIN_PARALLEL_S + 0.1)
    big = execute(_graph(), resolver=FileResolver("."), workers=2, cache=None)
    assert started == [1] and big.artifacts == small.artifacts
    started.clear()
    execute(_graph(), resolver=FileResolver("."), workers=1, cache=None)
    assert started == []
    Context().start_workers(100.0)  # outside a run: nothing to start
