"""As-built loop (#29): scans in (point clouds, per-path heights), registration, measurement,
adaptation inside the process window, the simulated open and closed loop, `waamflow build-sim`."""

import math
from pathlib import Path

import numpy as np
import pytest
import trimesh
from shapely.geometry import MultiPolygon, box

from waamflow.asbuilt import (
    Disturbance,
    ScanError,
    Window,
    adapted_layer,
    layer_track,
    measure,
    plan_speeds,
    read_heights,
    read_points,
    register,
    simulate_build,
    synth_scan,
)
from waamflow.asbuilt.sim import event_distance
from waamflow.core.model import Layer, Layered, LayerPaths, SectionPath

ROOT = Path(__file__).resolve().parents[2]
T = 2.0  # layer height, mm
V = 8.0  # mm/s


def square_layer(index: int, side: float = 40.0, speed: float = V) -> LayerPaths:
    """A closed single-bead square wall, side `side` mm, at layer `index` (top z = (index+1)·T)."""
    z = T * (index + 1)
    c = np.array([[0, 0], [side, 0], [side, side], [0, side], [0, 0]], float)
    pts = np.column_stack([c, np.full(len(c), z)])
    n = len(pts) - 1
    sp = SectionPath(
        key="bs1/A",
        strategy="contour",
        points=pts,
        arc=np.ones(n, bool),
        inside=np.ones(n, bool),
        speed=np.full(n, speed),
    )
    ring = box(-3, -3, side + 3, side + 3).difference(box(3, 3, side - 3, side - 3))
    return LayerPaths(Layer(index=index, z=z, thickness=T, region=MultiPolygon([ring])), (sp,))


def square_part(layers: int = 10) -> Layered:
    return Layered(tuple(square_layer(k) for k in range(layers)))


def test_track_resamples_arc_on_path():
    tr = layer_track(square_layer(2), ds=1.0)
    assert tr.n == 160 and tr.length.sum() == pytest.approx(160.0)
    assert np.allclose(tr.planned_height(), 6.0) and np.allclose(tr.normal, [0, 0, 1])
    assert np.allclose(np.abs(tr.across[:, :2]).sum(axis=1), 1.0)  # horizontal, across the wall
    d = event_distance(tr, 45.0)  # 4 corners + start/end at (0,0)
    assert d.min() == pytest.approx(0.5) and d.max() == pytest.approx(19.5)


def test_scan_of_the_plan_measures_the_plan():
    tr = layer_track(square_layer(3))
    rng = np.random.default_rng(0)
    top = tr.planned_height() + 0.3
    m = measure(tr, synth_scan(tr, top, Disturbance(), rng), radius=0.75)
    assert m.coverage == 1.0
    # the crest within the scanner noise (0.02 mm) and the 90th-percentile cap bias (< 0.06 mm)
    assert np.abs(m.height - top).max() < 0.1 and abs(np.mean(m.height - top)) < 0.05


def test_scan_with_a_known_offset_and_tilt_registers_back():
    tr = layer_track(square_layer(4))
    rng = np.random.default_rng(1)
    a = math.radians(1.0)  # 1° about x, then 2 mm up
    frame = np.eye(4)
    frame[:3, :3] = [[1, 0, 0], [0, math.cos(a), -math.sin(a)], [0, math.sin(a), math.cos(a)]]
    frame[:3, 3] = [0, 0, 2.0]
    scan = synth_scan(tr, tr.planned_height(), Disturbance(scan_noise_mm=0.01), rng, frame=frame)
    with pytest.raises(ScanError, match="from the expected top"):
        measure(tr, scan, radius=0.75)  # as it comes, it lies 1.8-2.7 mm off
    fixed, reg = register(tr, scan)
    assert reg.rms_before > 0.3 and reg.rms_after < 0.05
    rot = reg.to_dict()["rotation_deg"]
    assert rot[0] == pytest.approx(-1.0, abs=0.05) and abs(rot[1]) < 0.05
    m = measure(tr, fixed, radius=0.75)
    assert np.abs(m.height - tr.planned_height()).max() < 0.1


def test_bad_scans_are_refused_with_the_reason():
    tr = layer_track(square_layer(5))
    rng = np.random.default_rng(2)
    good = synth_scan(tr, tr.planned_height(), Disturbance(), rng)
    lower = synth_scan(tr, tr.planned_height() - T, Disturbance(), rng)  # the layer below's top
    with pytest.raises(ScanError, match=r"-1\.0 layers"):
        measure(tr, lower, radius=0.75)
    with pytest.raises(ScanError, match="of layer 4, expected layer 5"):
        measure(tr, type(good)(4, points=good.points))
    with pytest.raises(ScanError, match="no points"):
        read_points(b"x y z\n", layer=5)
    with pytest.raises(ScanError, match="NaN"):
        read_points(b"0 0 1\n1 1 nan\n", layer=5)
    far = good.points + np.array([200.0, 0, 0])  # not over the part
    with pytest.raises(ScanError, match="covers 0%"):
        measure(tr, type(good)(5, points=far), radius=0.75)


def test_point_cloud_files_ply_and_xyz():
    tr = layer_track(square_layer(1))
    rng = np.random.default_rng(3)
    scan = synth_scan(tr, tr.planned_height() + 0.2, Disturbance(), rng)
    ply = trimesh.PointCloud(scan.points).export(file_type="ply")
    xyz = ("x,y,z\n" + "\n".join(f"{x:.4f},{y:.4f},{z:.4f}" for x, y, z in scan.points)).encode()
    for data in (ply, xyz):
        s = read_points(data, layer=1)
        assert len(s.points) == len(scan.points)
        assert np.mean(measure(tr, s, radius=0.75).height - tr.planned_height()) == pytest.approx(0.2, abs=0.05)


def test_per_path_heights_csv():
    tr = layer_track(square_layer(2))
    text = "layer,s,height,width\n" + "".join(f"2,{s:g},{6.0 + 0.01 * s:.4f},6.2\n" for s in range(0, 161, 4))
    scan = read_heights(text, layer=2)[2]
    m = measure(tr, scan)
    s_mid = np.cumsum(tr.length) - tr.length / 2
    assert np.allclose(m.height, 6.0 + 0.01 * s_mid, atol=1e-9) and np.allclose(m.width, 6.2)
    with pytest.raises(ScanError, match="missing 'height'"):
        read_heights("layer,s,h\n1,0,1\n")
    with pytest.raises(ScanError, match="no rows for layer 3"):
        read_heights(text, layer=3)


def test_adaptation_never_leaves_the_window():
    tr = layer_track(square_layer(6))
    rng = np.random.default_rng(4)
    w = Window(min_factor=0.7, max_factor=1.4, min_speed=1.0, max_speed=60.0)
    for _ in range(50):
        below = tr.planned_height() - T + rng.normal(0, 1.5, tr.n)  # needs from −2.5 to +6.5 mm
        ad = plan_speeds(tr, below, rng.uniform(0.3, 3.0, tr.n), w)
        assert (ad.speed >= 0.7 * V - 1e-9).all() and (ad.speed <= 1.4 * V + 1e-9).all()
        assert ad.clamped_slow + ad.clamped_fast > 0
    # where the need is in reach, the prediction meets the plan exactly
    ad = plan_speeds(tr, tr.planned_height() - 1.6, np.ones(tr.n), w)  # 1.6 mm needed: v = 2·8/1.6 = 10
    assert np.allclose(ad.speed, 10.0) and np.allclose(ad.predicted_top, tr.planned_height())


def test_adapted_layer_program_keeps_path_and_time():
    lp = square_layer(3)
    tr = layer_track(lp)
    v = V * (1.0 + 0.4 * np.sin(np.cumsum(tr.length) / 10.0))
    out = adapted_layer(lp, tr, v, piece_mm=5.0)
    sp = out.sections[0]
    assert len(sp.points) == 33 and sp.length == pytest.approx(160.0)  # 4 sides × 8 pieces
    assert float((sp.segment_lengths / sp.speed).sum()) == pytest.approx(float((tr.length / v).sum()), rel=1e-9)
    assert sp.speed.min() < 0.7 * V and sp.speed.max() > 1.3 * V


def test_closed_loop_beats_open_loop():
    part = square_part(12)
    d = Disturbance(seed=7)
    open_, closed = simulate_build(part, "open", d), simulate_build(part, "closed", d)
    so, sc = open_.summary(), closed.summary()
    assert so["layers_built"] == 12 and sc["layers_built"] == 12
    assert sc["last_layer_rms_mm"] < 0.3 and sc["last_layer_max_mm"] < 0.8
    assert so["last_layer_rms_mm"] > 3 * sc["last_layer_rms_mm"]
    # the loop never asks for a speed outside the window (0.6-1.6 × plan)
    for row in closed.layers:
        assert 0.6 - 1e-9 <= row["speed_factor"][0] <= row["speed_factor"][1] <= 1.6 + 1e-9


def test_a_short_layer_pushes_a_layer_out_and_a_missing_one_is_added():
    part = square_part(10)
    # much more metal than planned on every layer, more than the window can take back: layers dropped
    tall = simulate_build(part, "closed", Disturbance(first_drop=0.0, heat_gain=1.5, heat_tau_s=1e9, noise_mm=0.0))
    assert tall.dropped >= 1 and tall.summary()["layers_built"] == 10 - tall.dropped
    low = simulate_build(part, "closed", Disturbance(first_drop=0.8, first_layers=3.0, heat_gain=0.0, noise_mm=0.0))
    assert low.added >= 1


def test_build_sim_cli(tmp_path, capsys):
    import json

    from waamflow.cli import main

    out = tmp_path / "o"
    assert main(["build-sim", str(ROOT / "graphs" / "mpp-cross.json"), "--out", str(out)]) == 0
    assert "closed loop: last layer top error RMS" in capsys.readouterr().out
    doc = json.loads((out / "asbuilt.json").read_text())
    o, c = doc["builds"]["open"], doc["builds"]["closed"]
    assert doc["layers_planned"] == 8 and o["layers_built"] == 8 and doc["toolpath_node"] == "sequence"
    assert c["last_layer_rms_mm"] < 0.3 and o["last_layer_rms_mm"] > 3 * c["last_layer_rms_mm"]
    assert (out / "asbuilt.svg").read_text().startswith("<svg")
    assert main(["build-sim", str(tmp_path / "nope.json")]) == 2
    assert capsys.readouterr().err.startswith("error:")


def test_live_build_session_adapts_persists_and_resumes(tmp_path):
    from waamflow.asbuilt import BuildSession
    from waamflow.asbuilt.run import plan_for_build
    from waamflow.engine.executor import FileResolver
    from waamflow.engine.recipe import load_recipe

    toolpath, post, src = plan_for_build(load_recipe(ROOT / "graphs" / "mpp-cross.json"), FileResolver(ROOT / "graphs"))
    assert src == "sequence" and post is not None
    folder = tmp_path / "b1"
    s = BuildSession.create(folder, toolpath, {"recipe": "mpp-cross", "layers": 8}, who="alice", post=post)
    first = s.next_program("alice")
    assert first["layer"] == 0 and first["adaptation"]["adapted"] is False
    ((name, gcode),) = first["files"].items()
    assert name == "post.gcode" and "G1" in gcode
    rng = np.random.default_rng(5)
    tr0 = s.tracks[0]
    with pytest.raises(ScanError, match="expects layer 0"):
        s.add_scan(synth_scan(s.tracks[1], s.tracks[1].planned_height(), Disturbance(), rng), who="alice")
    low = tr0.planned_height() - 0.4  # the first layer came out 0.4 mm low
    row = s.add_scan(synth_scan(tr0, low, Disturbance(), rng), who="alice")
    assert row["layer"] == 0 and row["mean_error_mm"] == pytest.approx(-0.4, abs=0.05)
    # a server restart: a new session object from the folder and the re-planned recipe
    s2 = BuildSession.load(folder, toolpath, post=post)
    assert s2.next_layer == 1 and s2.summary()["layers_scanned"] == 1
    nxt = s2.next_program("bob")
    assert nxt["layer"] == 1 and nxt["adaptation"]["adapted"] is True
    # 1.9 mm to fill with a measured gain of 0.73 (1.1 of 1.5 mm): v = 0.73 · 1.5 / 1.9 = 0.58 × plan,
    # below the window: clamped at 0.6 × plan nearly everywhere, and said so
    ad = nxt["adaptation"]
    assert ad["speed_factor_min"] == pytest.approx(0.6) and ad["speed_factor_max"] < 0.63
    assert ad["clamped_slow"] > 0.9 * ad["samples"]
    import re

    planned = {int(x) for x in re.findall(r"F(\d+)", gcode)}
    assert planned == {240, 360, 480}  # the zones' 4, 6, 8 mm/s
    adapted = [float(x) for x in re.findall(r"F(\d+(?:\.\d+)?)", next(iter(nxt["files"].values())))]
    assert adapted and all(any(0.6 - 1e-6 <= f / p <= 0.63 for p in planned) for f in adapted)
    log = [e["action"] for e in s2.summary()["log"]]
    assert log == ["start", "program", "scan_refused", "scan", "program"]
    assert [e["who"] for e in s2.summary()["log"]][-1] == "bob"
