"""A live build adds or drops a layer (#29 item 3): the top more than half a layer low after a
scan → the layer is laid again on its own scanned top; more than half a layer high → the next
layer is left out and the one after it is laid on the last scan. As the simulator does."""

from pathlib import Path

import numpy as np
import pytest

from waamflow.asbuilt import BuildSession, Disturbance, ScanError, synth_scan
from waamflow.asbuilt.run import plan_for_build
from waamflow.engine.executor import FileResolver
from waamflow.engine.recipe import load_recipe

ROOT = Path(__file__).resolve().parents[2]


@pytest.fixture(scope="module")
def cross():
    return plan_for_build(load_recipe(ROOT / "graphs" / "mpp-cross.json"), FileResolver(ROOT / "graphs"))


def _scan(s, k, offset, seed=0):
    tr = s.tracks[k]
    return synth_scan(tr, tr.planned_height() + offset, Disturbance(scan_noise_mm=0.0), np.random.default_rng(seed))


def test_low_layer_is_laid_again_and_a_tall_one_drops_the_next(tmp_path, cross):
    tp, post, _ = cross
    s = BuildSession.create(tmp_path / "b", tp, {"id": "b", "layers": 8}, who="cell", post=post)
    assert s.tracks[0].thickness == 1.5
    s.next_program()
    # layer 0 came out 1.0 mm low: more than half the 1.5 mm layer → laid again
    row = s.add_scan(_scan(s, 0, -1.0), who="cell")
    assert row["pass"] == 1 and row["mean_error_mm"] == pytest.approx(-1.0, abs=0.02)
    assert "layer 0 laid again" in row["then"] and s.next_layer == 0
    again = s.next_program()
    ad = again["adaptation"]
    assert again["layer"] == 0 and ad["pass"] == 2 and ad["laid_on"] == "its own scan (pass 1)"
    # 1.0 mm to fill with the layer's own gain 0.5/1.5 (clipped to 0.5): v = 0.5 · 1.5 / 1.0 = 0.75 × plan
    assert ad["speed_factor_min"] == pytest.approx(0.75, abs=0.03) and ad["speed_factor_max"] == pytest.approx(
        0.75, abs=0.03
    )
    with pytest.raises(ScanError, match="expects layer 0"):
        s.add_scan(_scan(s, 1, 0.0), who="cell")
    row = s.add_scan(_scan(s, 0, 0.0), who="cell")
    assert row["pass"] == 2 and "then" not in row and s.next_layer == 1
    # layer 1 came out 0.8 mm high → layer 2 left out, layer 3 laid on layer 1's scan
    s.next_program()
    row = s.add_scan(_scan(s, 1, 0.8), who="cell")
    assert "layer 2 left out" in row["then"] and s.next_layer == 3
    nxt = s.next_program()
    assert nxt["layer"] == 3 and nxt["adaptation"]["laid_on"] == "the scan of layer 1"
    with pytest.raises(ScanError, match="expects layer 3"):
        s.add_scan(_scan(s, 2, 0.0), who="cell")
    sm = s.summary()
    assert (sm["layers_added"], sm["layers_dropped"], sm["skipped"]) == (1, 1, [2])
    assert [(r["layer"], r["pass"]) for r in sm["layers"]] == [(0, 1), (0, 2), (1, 1)]
    assert [p["layer"] for p in sm["programs"]] == [0, 0, 1, 3] and [p["pass"] for p in sm["programs"]] == [1, 2, 1, 1]
    actions = [e["action"] for e in sm["log"]]
    assert actions.count("layer_added") == 1 and actions.count("layer_dropped") == 1
    # a restart keeps it all
    s2 = BuildSession.load(tmp_path / "b", tp, post=post)
    assert s2.next_layer == 3 and s2.summary()["skipped"] == [2] and s2.passes(0) == 2


def test_never_more_than_three_repeats_and_no_drop_before_the_last_layer(tmp_path, cross):
    tp, post, _ = cross
    s = BuildSession.create(tmp_path / "c", tp, {"id": "c", "layers": 8}, post=post)
    for p in range(1, 5):
        s.next_program()
        row = s.add_scan(_scan(s, 0, -0.9, seed=p))
        assert row["pass"] == p
    assert s.next_layer == 1 and s.summary()["layers_added"] == 3  # the 4th pass goes on regardless
    # layers 1-4 0.5 mm low (under half a layer: go on), 5 on plan, 6 0.8 mm high: layer 7 is the last, not left out
    for k in range(1, 7):
        s.next_program()
        assert "then" not in s.add_scan(_scan(s, k, {5: 0.0, 6: 0.8}.get(k, -0.5)))
    assert s.next_layer == 7 and s.summary()["layers_dropped"] == 0
