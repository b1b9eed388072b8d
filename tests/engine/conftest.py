"""Spies shared by the engine's parallel and Dask tests."""

import pytest


@pytest.fixture()
def parent_sequenced(monkeypatch) -> list[int]:
    """One entry per layer the sequencing kernel orders in this process (a worker's are not seen)."""
    from waamflow.sequencing import layer_path

    here: list[int] = []
    real = layer_path.sequence_layer
    monkeypatch.setattr(layer_path, "sequence_layer", lambda *a, **k: here.append(1) or real(*a, **k))
    return here


@pytest.fixture()
def ahead_given(monkeypatch) -> list[list]:
    """What each whole-part node's run was given as ahead results (`RunContext.ahead`), per call."""
    from waamflow.engine import executor

    given: list[list] = []
    real = executor.RunContext.ahead
    monkeypatch.setattr(executor.RunContext, "ahead", lambda self: given.append(real(self)) or given[-1])
    return given
