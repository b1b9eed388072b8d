"""A program larger than its controller's program memory is warned, naming the size and what to
do. PrusaSlicer's bunny read in cm (0.5 m, 536 layers, raster, 5 mm beads) posted as KRL wrote
post.src 13.4 MB and post.dat 72.7 MB without a word, where a KR C4 runs programs from its RAM
drive, about 4 MB under KSS 8.3 in field reports (robot-forum.com "KRC4 program capacity", 2024):
the program would not load. KRL's default budget is that 4 MB; `controller_memory_mb` sets the
cell's (0: no check); other formats are checked only when it is set."""

import pytest

from waamflow.engine.node import load_nodes

from conftest import PostCtx, build_toolpath


def _run(**params):
    node_cls = load_nodes()["post-process"]
    ctx = PostCtx()
    out = node_cls().run(ctx, node_cls.Params(**params), {"toolpath": build_toolpath(2)})
    size = sum(len(t.encode("utf-8")) for t in out["program"].files.values())
    return size, [w for w in ctx.warnings if "program memory" in w]


def test_a_krl_program_over_the_controller_memory_is_warned():
    size, none = _run(format="krl")
    assert none == [] and 5_000 < size < 4_000_000  # a small program: no warning at the default 4 MB
    budget = size / 2 / 1e6
    _, (w,) = _run(format="krl", controller_memory_mb=budget)
    assert f"{size / 1e6:.2f} MB" in w and f"{budget:g} MB" in w
    assert "split_per_layer" in w and "stream" in w


@pytest.mark.parametrize("fmt", ["gcode", "rapid", "tp", "inform"])
def test_other_formats_are_checked_only_against_a_stated_memory(fmt):
    size, none = _run(format=fmt)
    assert none == []
    _, warned = _run(format=fmt, controller_memory_mb=size / 2 / 1e6)
    assert len(warned) == 1


def test_zero_turns_the_check_off():
    size, _ = _run(format="krl")
    assert _run(format="krl", controller_memory_mb=0)[1] == []
