"""Bounded memory under repeated publishing, and display decimation of a large part."""

import gc
import tracemalloc

import numpy as np

from viewer_fixtures import RECIPE, make_layers, make_simulation, make_toolpath, outputs


def _buffer_size(v) -> int:
    return len(v.server._websock_server._broadcast_buffer.message_from_id)


def test_memory_bounded_over_50_republishes(viewer):
    a = outputs(4)
    b = outputs(4)
    b["zone"]["toolpath"] = make_toolpath(make_layers(4), pts_per_pass=12)  # every layer differs
    b["simulate"]["simulation"] = make_simulation(b["zone"]["toolpath"], cut=0.5)
    tracemalloc.start()
    try:
        samples = {}
        for i in range(50):
            stats = viewer.publish("k", RECIPE, a if i % 2 == 0 else b)
            if i > 0:
                assert stats["redrawn"] >= 4  # the alternation really redraws
            if i + 1 in (10, 50):
                gc.collect()
                samples[i + 1] = (tracemalloc.get_traced_memory()[0], _buffer_size(viewer), len(viewer.scene_names()))
        same = [viewer.publish("k", RECIPE, b)["redrawn"] for _ in range(50)]
        gc.collect()
        after_same = tracemalloc.get_traced_memory()[0]
    finally:
        tracemalloc.stop()
    (m10, buf10, n10), (m50, buf50, n50) = samples[10], samples[50]
    print(
        f"traced KB after 10 / 50 alternating publishes: {m10 // 1024} / {m50 // 1024}; "
        f"after 50 more identical: {after_same // 1024}; viser buffer {buf10} / {buf50} messages"
    )
    assert n10 == n50 and buf10 == buf50  # no scene or message-buffer leak
    assert m50 - m10 < 256 * 1024  # < 256 KB growth over 40 redraws of ~45 nodes
    assert same == [0] * 50 and after_same - m50 < 64 * 1024


def test_large_part_is_decimated_for_display_only(viewer):
    layers = make_layers(500)
    tp = make_toolpath(layers, pts_per_pass=200, passes=5)  # 500 layers × 2000 points
    sim = make_simulation(tp)
    n_points = sum(len(sp.points) for lp in tp for sp in lp.sections)
    assert n_points >= 1_000_000
    stats = viewer.publish("big", {"nodes": []}, {"zone": {"toolpath": tp}, "sim": {"simulation": sim}})
    assert stats["redrawn"] == 500 + 501
    part = viewer.parts[("zone", "toolpath")]
    shown = sum(len(e["disp"]) for e in part.entries.values())
    source = sum(e["disp"].n_source for e in part.entries.values())
    assert source == 500 * (2 * 999 + 1)
    assert shown <= viewer.max_segments and shown < source / 3
    h = viewer.server.scene.get_handle_by_name("/graph/zone/toolpath/L0250")
    assert h.points.shape[0] == len(part.entries[250]["disp"])
    # every zone change survives decimation: the drawn colours still hold all three zones
    assert len(np.unique(h.colors.reshape(-1, 3), axis=0)) >= 4  # 3 zones + travel
    sim_segments = sum(
        viewer.server.scene.get_handle_by_name(f"/graph/sim/simulation/L{i:04d}/simulated").points.shape[0]
        for i in range(500)
    )
    print(
        f"large part: {n_points} path points in 500 layers → {shown} toolpath segments drawn "
        f"(of {source}), {sim_segments} simulated segments (of {len(sim.trace['t']) - 1})"
    )
    assert sim_segments <= viewer.max_segments
    assert tp[250].sections[0].points.shape == (1000, 3)  # the data is untouched
    assert viewer.publish("big", {"nodes": []}, {"zone": {"toolpath": tp}, "sim": {"simulation": sim}})["redrawn"] == 0
