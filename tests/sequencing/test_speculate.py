"""Runs of layers sequenced ahead in the workers (sequencing.layer_path.sequence_part's
`map_chunks`): the result is the serial one, a layer is taken only when what it was given is what
the chain reaches, and any other layer is sequenced again here."""

import numpy as np
import pytest
from test_seams import cross_layer

from waamflow.sequencing import layer_path
from waamflow.sequencing.layer_path import SPECULATE_CHUNKS, _Sequenced, sequence_part
from waamflow.sequencing.seams import SeamSpec


@pytest.fixture()
def here_calls(monkeypatch):
    """Layers sequenced by `sequence_part` itself (not inside a run of layers)."""
    calls = {"here": 0, "ahead": 0}
    real = layer_path.sequence_layer
    where = ["here"]

    def counted(*a, **k):
        calls[where[0]] += 1
        return real(*a, **k)

    def in_chunks(fn, items):
        where[0] = "ahead"
        try:
            return [fn(it) for it in items]
        finally:
            where[0] = "here"

    monkeypatch.setattr(layer_path, "sequence_layer", counted)
    return calls, in_chunks


def same_layers(a, b):
    assert len(a) == len(b)
    for x, y in zip(a, b):
        assert (x is None) == (y is None)
        if x is None:
            continue
        assert [s.key for s in x.sections] == [s.key for s in y.sections]
        for s, t in zip(x.sections, y.sections):
            assert np.array_equal(s.points, t.points) and s.zone == t.zone
            assert np.array_equal(s.approach, t.approach) if s.approach is not None else t.approach is None


KWS = [
    {"seam": SeamSpec("auto", 6.0, 12.0)},
    {"seam": SeamSpec("auto", 6.0, 12.0), "order": "nearest", "min_run": 12.0},
    {"seam": SeamSpec("alternate"), "alternate": True},
]


@pytest.mark.parametrize("kw", KWS)
def test_layers_sequenced_ahead_are_the_serial_layers_and_notes(kw, here_calls):
    calls, in_chunks = here_calls
    layers = [cross_layer(i) for i in range(40)]
    layers[25] = None  # a partial run: the chain starts again after it
    notes_serial, notes_ahead = [], []
    serial, t_serial = sequence_part(layers, notes=notes_serial, **kw)
    assert calls["here"] == 39 and calls["ahead"] == 0
    calls["here"] = 0
    ahead, t_ahead = sequence_part(layers, map_chunks=in_chunks, notes=notes_ahead, **kw)
    same_layers(serial, ahead)
    assert t_ahead == t_serial and notes_ahead == notes_serial
    # every layer but the warm-up ones was sequenced once ahead; none again here (the seams of the
    # cross repeat every other layer: two layers of warm-up reach the chain's)
    assert calls["here"] == 0
    todo = [k for k, lp in enumerate(layers) if lp is not None]
    spans = layer_path._runs_of(todo, -(-len(todo) // SPECULATE_CHUNKS))
    assert len(spans) == 8 and [a for a, _ in spans] == [0, 5, 10, 15, 20, 26, 31, 36]  # none across the gap
    warm = sum(lp is not None for a, _ in spans for lp in layers[max(0, a - layer_path.WARMUP_LAYERS) : a])
    assert warm == 2 * 6 + 1  # layer 26's warm-up holds the missing layer 25
    assert calls["ahead"] == 39 + warm


def test_a_layer_given_another_start_is_sequenced_again_here(here_calls):
    """A run whose first layer was given another torch position (the map's answer is a guess): that
    layer and the ones after it that the guess carried over are sequenced here; the result is the
    serial one."""
    calls, in_chunks = here_calls
    layers = [cross_layer(i) for i in range(32)]
    kw = {"seam": SeamSpec("auto", 6.0, 12.0), "order": "nearest"}
    serial, _ = sequence_part(layers, **kw)

    def wrong_start(fn, items):
        got = in_chunks(fn, items)
        g = got[2][0]  # the first layer of the third run: another position before it
        got[2][0] = _Sequenced(g.prev_end + 1.0, g.below, g.layer, g.travel, g.notes)
        return got

    calls["here"] = 0
    ahead, _ = sequence_part(layers, map_chunks=wrong_start, **kw)
    same_layers(serial, ahead)
    assert calls["here"] == 1  # that layer only: the next one was given what the chain reaches


def test_a_map_that_runs_here_is_not_asked_and_short_parts_stay_serial(here_calls):
    calls, _ = here_calls
    layers = [cross_layer(i) for i in range(2 * SPECULATE_CHUNKS - 1)]
    asked = []
    sequence_part(layers, map_chunks=lambda fn, items: asked.append(1), seam=SeamSpec("auto"))
    assert asked == [] and calls["here"] == len(layers)
    calls["here"] = 0
    layers = [cross_layer(i) for i in range(2 * SPECULATE_CHUNKS)]
    serial, _ = sequence_part(layers, seam=SeamSpec("auto"))
    calls["here"] = 0
    out, _ = sequence_part(layers, map_chunks=lambda fn, items: None, seam=SeamSpec("auto"))
    same_layers(serial, out)
    assert calls["here"] == len(layers)  # the map would have run here (None): every layer once


def test_each_layer_is_reported_and_a_cancel_stops_between_layers():
    """The sequence node's progress and cancel (`on_layer`): ezdxf's recover01.dxf spent 64 s in
    it, ~3,000 walls a layer, with no sign of life and no way to stop it."""
    layers = [cross_layer(i) for i in range(6)]
    layers[3] = None
    seen = []
    sequence_part(layers, on_layer=lambda k, n: seen.append((k, n)), seam=SeamSpec("auto", 6.0, 12.0))
    assert seen == [(1, 6), (2, 6), (3, 6), (5, 6), (6, 6)]  # the missing layer is passed over

    class Stop(Exception):
        pass

    def stop_at_two(k, n):
        if k == 2:
            raise Stop

    with pytest.raises(Stop):
        sequence_part(layers, on_layer=stop_at_two)


def test_layers_sequenced_ahead_where_they_were_made_are_taken_for_those_layers_only(here_calls):
    """`ahead` (the chain tasks' `sequence_ahead`, each run of layers from nothing): a layer's
    result is taken when it was made from that very layer object and given what the chain
    reaches; a run's first layers, given nothing, are sequenced again here until the chain meets
    the guesses. Results made from an equal copy of a layer are never taken."""
    import copy

    calls, _ = here_calls
    layers = [cross_layer(i) for i in range(40)]
    layers[25] = None
    kw = {"seam": SeamSpec("auto", 6.0, 12.0), "order": "nearest", "min_run": 12.0}
    notes_serial: list = []
    serial, t_serial = sequence_part(layers, notes=notes_serial, **kw)
    calls["here"] = 0
    runs = [(0, 13), (13, 25), (26, 40)]  # as chain tasks make them: the gap ends a run
    ahead = [layer_path.sequence_ahead(layers[a:b], **kw) for a, b in runs]
    made_ahead = calls["here"]
    assert made_ahead == 39
    calls["here"] = 0
    notes: list = []
    out, t_out = sequence_part(layers, ahead=ahead, notes=notes, **kw)
    same_layers(serial, out)
    assert t_out == t_serial and notes == notes_serial
    # run 0 starts where the part does, run 26 after the gap: both given what the chain has
    # (nothing); run 13 was given nothing where the chain has layer 12's end and ignitions: its
    # first layer is sequenced again, and gives layer 14 what the guess had
    assert calls["here"] == 1
    calls["here"] = 0
    copies = [copy.deepcopy(lp) for lp in layers]
    out, _ = sequence_part(copies, ahead=ahead, **kw)
    same_layers(serial, out)
    assert calls["here"] == 39  # equal layers, other objects: nothing taken
    # the layers ahead cover all but run 13's: too few left to speculate in chunks, done here
    calls["here"] = 0
    asked = []
    out, _ = sequence_part(
        layers, ahead=[ahead[0], ahead[2]], map_chunks=lambda fn, items: asked.append(len(items)), **kw
    )
    same_layers(serial, out)
    assert asked == [] and calls["here"] == 12


def _asked_by_the_node(layers, ahead_from, params_json=None):
    """(items, seconds) of each `Context.map_in_workers` question the sequence node asks, when
    the chain tasks ran ahead on layers `ahead_from`: (start, stop, step) of runs."""
    from waamflow.core.model import Layered
    from waamflow.engine.node import Context
    from waamflow.nodes.sequence import SequenceNode, _kernel_kw

    params = SequenceNode.Params.model_validate(params_json or {"order": "nearest", "retract_height": 10})
    asked: list[tuple[int, float]] = []
    a0, a1, step = ahead_from

    class Ctx(Context):
        node_id = "sequence"

        def ahead(self):
            return [layer_path.sequence_ahead(layers[a : a + step], **_kernel_kw(params)) for a in range(a0, a1, step)]

        def map_in_workers(self, fn, items, *, layers=0, points=0, seconds=None):
            asked.append((len(items), seconds))
            return None

        def check_cancelled(self):
            pass

        def progress(self, fraction, message=""):
            pass

    out = SequenceNode().run(Ctx(), params, {"toolpath": Layered(tuple(layers))})
    assert len(out["toolpath"]) == len(layers)
    return asked


def test_the_sequence_node_asks_the_workers_for_what_it_sends_them_not_for_the_whole_part():
    """The node's cost question (`Context.map_in_workers`' seconds) is about the layers it would
    send: with the chain tasks' results for all but 16 of 200 layers (the layers the parent timed
    itself), the question is about those 16 layers' sections, not the part's 200, and the answer
    is no: 16 layers in 8 runs of 2 (each started 2 layers early, and each run's first layer
    ordered again here) had cost a Dask run 0.3 s."""
    from waamflow.engine import parallel

    layers = [cross_layer(i) for i in range(200)]
    asked = _asked_by_the_node(layers, (16, 200, 46))
    # 8 runs of 2 layers, each but the first started WARMUP_LAYERS early: layers 0-1, 0-3, 2-5, ...
    sent = layers[0:2] + [lp for a in range(2, 16, 2) for lp in layers[a - layer_path.WARMUP_LAYERS : a + 2]]
    assert len(sent) == 16 + 7 * layer_path.WARMUP_LAYERS
    sections = sum(len(lp.sections) for lp in sent)
    assert asked == [(8, pytest.approx(layer_path.SEQUENCE_S_PER_SECTION * sections, rel=1e-9))]
    assert asked[0][1] < parallel.DASK_MIN_PARALLEL_S and asked[0][1] < parallel.WARM_MIN_PARALLEL_S


def test_the_sequence_node_prices_the_layers_it_would_send_at_what_sequencing_costs():
    """The 500-layer cross of the bench: the parent timed 25 layers itself before its workers
    were up, the chain tasks ran ahead on the other 475. The node's question is the kernel's own
    price of those 25 layers (37 sent with the warm-up layers: 0.04 s of work, 0.4 ms a section):
    not worth the round trip. Asked in the engine's generic terms (5 ms a layer, 25 µs a path
    point), the 37 layers came to 0.24 s, over the 0.2 s threshold of running workers: they were
    sent, and the run waited 0.17-0.23 s for 0.04 s of work behind the artifacts the workers were
    writing. With no layer made ahead, all 500 are priced at 0.6 s and sent."""
    from waamflow.engine import parallel

    layers = [cross_layer(i) for i in range(500)]
    [(runs, seconds)] = _asked_by_the_node(layers, (25, 500, 48))
    assert runs == 7  # runs of 4 layers (25 / SPECULATE_CHUNKS, rounded up), the last of 1
    sent = 25 + (runs - 1) * layer_path.WARMUP_LAYERS
    assert sent == 37
    per_layer = len(layers[0].sections)
    assert seconds == pytest.approx(layer_path.SEQUENCE_S_PER_SECTION * per_layer * sent, rel=1e-9)
    assert not parallel.wants_workers(2, min_s=parallel.WARM_MIN_PARALLEL_S, extra_s=seconds)
    points = sum(len(sp.points) for lp in layers[:sent] for sp in lp.sections)
    assert parallel.wants_workers(2, 0, sent, points, parallel.WARM_MIN_PARALLEL_S)  # the generic model's yes
    [(runs, seconds)] = _asked_by_the_node(layers, (0, 0, 1))
    assert runs == layer_path.SPECULATE_CHUNKS
    assert seconds > parallel.WARM_MIN_PARALLEL_S
