"""core.gcpause: the cyclic GC paused while a program is planned, written and read back (a
1.76-million-point program set off 17 full collections that freed nothing), and restored after."""

import gc

import numpy as np
import pytest

from waamflow.core.gcpause import paused_gc
from waamflow.core.model import Layer, LayerPaths, Layered, SectionPath, as_multipolygon
from waamflow.preflight.read import read_program
from waamflow.program import post_process
from shapely.geometry import box


@pytest.fixture(autouse=True)
def _gc_back_on():
    was = gc.isenabled()
    yield
    (gc.enable if was else gc.disable)()


def test_paused_inside_and_restored_after_even_on_error():
    gc.enable()
    with paused_gc():
        assert not gc.isenabled()
        with paused_gc():  # nested: the inner one leaves it to the outer
            assert not gc.isenabled()
        assert not gc.isenabled()
    assert gc.isenabled()
    with pytest.raises(ValueError), paused_gc():
        raise ValueError("boom")
    assert gc.isenabled()
    gc.disable()  # a caller that runs without the collector keeps it off
    with paused_gc():
        pass
    assert not gc.isenabled()


def _toolpath(layers: int = 3, n: int = 40000) -> Layered:
    out = []
    for k in range(layers):
        z = 1.5 * (k + 1)
        layer = Layer(index=k, z=z, thickness=1.5, region=as_multipolygon(box(0, 0, 100, 10)))
        t = np.linspace(0, 2 * np.pi, n)
        pts = np.column_stack([50 + 40 * np.cos(t), 5 + 4 * np.sin(t), np.full(n, z)])
        sp = SectionPath(
            key="a",
            strategy="contour",
            points=pts,
            arc=np.ones(n - 1, bool),
            inside=np.ones(n - 1, bool),
            speed=np.full(n - 1, 10.0),
        )
        out.append(LayerPaths(layer=layer, sections=(sp,)))
    return Layered(tuple(out))


def test_no_full_collection_while_a_program_is_written_and_read_back_and_gc_on_after():
    """120,000 points: no collection of the oldest generation runs inside post_process or
    read_program (each Motion and line is garbage-free), and the collector is on after both."""
    gc.enable()
    full = []

    def watch(phase, info):
        if phase == "start" and info["generation"] == 2:
            full.append(info)

    gc.collect()
    gc.callbacks.append(watch)
    try:
        prog = post_process(_toolpath(), "gcode")
        assert gc.isenabled()
        read = read_program("gcode", prog.files)
        assert gc.isenabled()
    finally:
        gc.callbacks.remove(watch)
    assert full == []
    assert sum(len(r.points) for r in read.runs) == 3 * 40000
