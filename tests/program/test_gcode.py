"""G-code writer + parser: the program read back reproduces the toolpath's deposition."""

import re

import numpy as np
import pytest

from waamflow.core.moves import flatten
from waamflow.program import GcodeSettings, PlanSettings, parse_gcode, post_process

from conftest import SPEED, build_toolpath
from helpers import arc_runs, polyline_length


@pytest.fixture(scope="module")
def moves():
    return flatten(build_toolpath())


def _expected_ignition_dwell(moves, a, default=0.5):
    return moves.zone_params[(int(moves.section[a]), int(moves.zone[a]))].get("dwell", default)


@pytest.mark.parametrize("tol", [0.0, 0.05])
def test_round_trip_deposition(moves, tol):
    prog = post_process(moves, "gcode", PlanSettings(ignition_dwell=0.5, arc_tolerance=tol))
    parsed = parse_gcode(prog.files["gcode"])
    runs = arc_runs(moves)
    assert len(runs) == 15  # 3 layers × (wall 1 + ring 1 + raster 3 passes)
    assert len(parsed.runs) == len(runs)
    assert parsed.ignitions == parsed.extinctions == len(runs)
    assert parsed.ended
    for (a, b), run in zip(runs, parsed.runs):
        want = moves.points[a : b + 1]
        assert np.allclose(run.points[0], want[0], atol=1e-3) and np.allclose(run.points[-1], want[-1], atol=1e-3)
        assert abs(run.length - polyline_length(want)) <= 0.005 * polyline_length(want)
        assert run.ignition_dwell_s == pytest.approx(_expected_ignition_dwell(moves, a))
        if tol == 0.0:  # one G1 per point: same vertices, feed = segment speed × 60
            assert run.points.shape == want.shape
            assert np.allclose(run.points, want, atol=1e-3)
            assert np.allclose(run.feed_mm_min, moves.speed[a:b] * 60.0)
    total = sum(polyline_length(moves.points[a : b + 1]) for a, b in runs)
    assert parsed.deposition_length_mm == pytest.approx(total, rel=0.005)
    assert prog.stats["deposition_length_mm"] == pytest.approx(total, abs=1e-3)


def test_feeds_are_zone_speeds_and_interlayer_dwell(moves):
    text = post_process(moves, "gcode").files["gcode"]
    feeds = {float(f) for f in re.findall(r"^G1 .*F([\d.]+)", text, re.M)}
    assert feeds == {v * 60.0 for v in SPEED.values()}  # 300, 360, 420 mm/min
    parsed = parse_gcode(text)
    off_dwells = [s for _, s, on in parsed.dwells if not on]
    assert off_dwells == [20.0, 20.0]  # between layers 0→1 and 1→2 (none after the last)
    on_dwells = [s for _, s, on in parsed.dwells if on]
    assert len(on_dwells) == 15 and on_dwells.count(0.8) == 9  # zone "start" dwell 0.8 s
    assert text.rstrip().endswith("M30 ; end of program")
    assert "G21" in text and "G90" in text and "G17" not in text
    assert len(re.findall(r"^G0 ", text, re.M)) == int(np.sum(moves.kind == 0)) + 1


def test_every_ignition_followed_by_dwell_in_ms():
    text = post_process(
        build_toolpath(),
        "gcode",
        PlanSettings(ignition_dwell=1.25),
        GcodeSettings(arc_on="M101 P1", arc_off="M103", dwell_units="ms"),
    ).files["gcode"]
    lines = [l.split(";")[0].strip() for l in text.splitlines()]
    lines = [l for l in lines if l]
    ons = [i for i, l in enumerate(lines) if l == "M101 P1"]
    assert len(ons) == 15
    assert all(re.fullmatch(r"G4 P\d+", lines[i + 1]) for i in ons)
    assert {lines[i + 1] for i in ons} == {"G4 P800", "G4 P1250"}
    parsed = parse_gcode(text)  # codes and units read from the header line
    assert parsed.ignitions == 15 and parsed.extinctions == 15
    assert sorted({r.ignition_dwell_s for r in parsed.runs}) == [0.8, 1.25]


def test_process_codes_where_zone_changes(moves):
    codes = {"wire_feed_speed": "M100 S{value:.1f}", "job": "M99 P{value:.0f}", "current": "M98 S{value:.0f}"}
    text = post_process(moves, "gcode", writer_settings=GcodeSettings(process_codes=codes)).files["gcode"]
    # each section path has 3 zones; each (section, zone) change among arc-on segments restates them
    assert text.count("M100 S11.0") == 9 and text.count("M100 S10.0") == 9 and text.count("M100 S8.5") == 9
    assert text.count("M99 P12") == 9  # only the start zone has a job number
    assert text.count("M98 S220") == 9
    # commands come before the arc on of a run
    first = text.index("M100 S11.0")
    assert first < text.index("M3 ; arc on")
    assert "; zone start: current 220 A, voltage 21 V, wire_feed_speed 11 m/min" in text


def test_arc_fitting_emits_g2_g3():
    moves = flatten(build_toolpath(1))
    prog = post_process(moves, "gcode", PlanSettings(arc_tolerance=0.05))
    text = prog.files["gcode"]
    g3 = re.findall(r"^G3 X([\d.-]+) Y([\d.-]+) Z[\d.-]+ I([\d.-]+) J([\d.-]+)", text, re.M)
    assert len(g3) == 3 and "G2 " not in text  # the counter-clockwise half ring, one arc per zone
    assert "G17" in text
    assert prog.stats["motions"] == prog.stats["points"] - 24 + 3
    # I/J point from each arc start to the centre (20, 30); zone arcs start at ring points 0, 8, 16
    for k, (x, y, i, j) in enumerate(g3):
        a = np.radians(-90 + 8 * k * 7.5)
        assert (float(i), float(j)) == pytest.approx((-15 * np.cos(a), -15 * np.sin(a)), abs=1e-3)
        b = np.radians(-90 + 8 * (k + 1) * 7.5)
        assert (float(x), float(y)) == pytest.approx((20 + 15 * np.cos(b), 30 + 15 * np.sin(b)), abs=1e-3)


def test_travel_as_feed_and_invalid_settings(moves):
    text = post_process(moves, "gcode", writer_settings=GcodeSettings(rapid_travel=False, travel_speed=50)).files[
        "gcode"
    ]
    assert not re.search(r"^G0 ", text, re.M)
    assert "F3000" in text
    with pytest.raises(ValueError):
        GcodeSettings(dwell_units="min")
    with pytest.raises(ValueError):
        GcodeSettings(arc_on="M3 ; on")
    with pytest.raises(ValueError):
        GcodeSettings(process_codes={"speed": "M1 {value}"})
    with pytest.raises(ValueError):
        GcodeSettings(process_codes={"current": "M1 {other}"})


def test_empty_toolpath():
    from waamflow.core.model import Layered

    prog = post_process(Layered(()), "gcode")
    parsed = parse_gcode(prog.files["gcode"])
    assert parsed.runs == () and parsed.ended and prog.stats["points"] == 0


def test_arc_fitted_program_stays_within_tolerance():
    """A finely sampled, slightly wavy ellipse: G2/G3 arcs replace hundreds of points, and the
    program read back stays within the tolerance of the original polyline."""
    from shapely.geometry import LineString, Point

    from waamflow.core.model import Layer, LayerPaths, Layered, SectionPath

    a = np.linspace(0, 2 * np.pi, 1201)[:-1]
    pts = np.column_stack([50 * np.cos(a), 30 * np.sin(a) + 0.01 * np.sin(40 * a), np.full(len(a), 3.0)])
    n = len(pts) - 1
    sp = SectionPath("e", "t", pts, np.ones(n, bool), np.ones(n, bool), np.full(n, 8.0))
    prog = post_process(Layered((LayerPaths(Layer(0, 3.0, 1.5), (sp,)),)), "gcode", PlanSettings(arc_tolerance=0.05))
    assert prog.stats["motions"] < 60 and prog.stats["circular_motions"] >= 8
    run = parse_gcode(prog.files["gcode"]).runs[0]
    line = LineString(pts[:, :2])
    dev = max(line.distance(Point(p[:2])) for p in run.points)
    assert dev <= 0.05 + 1e-3
    assert run.length == pytest.approx(polyline_length(pts), rel=0.005)
    assert np.allclose(run.feed_mm_min, 480.0)


def test_parsed_program_json(moves):
    import json

    parsed = parse_gcode(post_process(moves, "gcode").files["gcode"])
    d = json.loads(json.dumps(parsed.to_dict()))
    assert len(d["runs"]) == 15 and d["ignitions"] == 15 and d["ended"] is True
    assert sum(len(r["points"]) - 1 for r in d["runs"]) == int(moves.arc.sum())
    assert d["deposition_length_mm"] == pytest.approx(sum(r["length_mm"] for r in d["runs"]), abs=1e-3)
    assert [x["seconds"] for x in d["dwells"] if not x["arc_on"]] == [20.0, 20.0]


@pytest.mark.parametrize("code", ["bogus", "M 3", "M3 on", "3", "M3 S", "M3\tX", "M3 P1e"])
def test_an_arc_code_that_is_not_gcode_words_is_refused_where_it_is_set(code):
    """`arc_on` / `arc_off` are written as a line of the program and read back by the preflight word
    by word: a line that is not G-code words (a letter and a number each, e.g. `M3`, `M101 P1`) was
    written as it stood, and the preflight then failed itself (`bogus`: ValueError on 'OGUS')
    instead of the recipe being refused where the code is set."""
    for name in ("arc_on", "arc_off"):
        with pytest.raises(ValueError, match=rf"{name} {re.escape(repr(code))}: .*a letter and a number"):
            GcodeSettings(**{name: code})


@pytest.mark.parametrize("code", ["G1 X5", "M3 X1", "M3 G4", "S100", "M62 F600", "P1 M3"])
def test_an_arc_code_that_moves_or_is_no_m_code_is_refused(code):
    """An arc code is an M code and its parameters: a line `G1 X5` passed the word check, was written
    as the arc switch and would move the torch on the controller, while the preflight reads it as the
    arc switch only. G, axis (X Y Z A B C U V W), arc-centre (I J K) and feed (F) words are refused,
    and the line starts with its M word."""
    for name in ("arc_on", "arc_off"):
        with pytest.raises(ValueError, match=rf"{name} {re.escape(repr(code))}: .*an M code"):
            GcodeSettings(**{name: code})


@pytest.mark.parametrize(
    "on,off",
    [("M101 P1", "M103"), ("m3", "m5"), ("M62 P0.5", "M63 P-1"), (" M7 ", "M9"), ("M42 P4 S255", "M107")],
)
def test_arc_codes_of_gcode_words_are_taken_and_read_back(moves, on, off):
    from waamflow.preflight.read import read_gcode

    text = post_process(moves, "gcode", writer_settings=GcodeSettings(arc_on=on, arc_off=off)).files["gcode"]
    prog = read_gcode(text)
    assert len(prog.runs) == len(arc_runs(moves)) > 0


@pytest.mark.parametrize("tpl", ["G1 X{value}", "M67 E0 Q{value} Z1", "G0 A{value}", "G01 F{value}", "M68 I{value}"])
def test_a_weld_command_that_would_move_the_torch_is_refused(tpl):
    """A process template is written before the motions it sets the weld values for: a motion word
    (G0..G3) or an axis or arc-centre word in it would move the torch on the controller while the
    preflight reads the line as the weld value only. Refused; a dwell (G4 P), a feed (F), an S word are not."""
    for field in ("process_codes", "process_codes_start"):
        with pytest.raises(ValueError, match=r"would move the torch"):
            GcodeSettings(**{field: {"current": tpl}})
    settings = GcodeSettings(
        process_codes={"dwell": "G4 P{value}", "travel_speed": "F{value:.0f}", "current": "S{value}"}
    )
    assert settings.process_codes["dwell"] == "G4 P{value}"


def test_an_arc_code_is_refused_on_the_post_node_field_itself():
    """The post node's arc_on / arc_off are checked where they are set (the recipe's params): the
    error names the node and the field, so the GUI marks the field, before any planning."""
    from waamflow.core.errors import RecipeError
    from waamflow.engine.graph import _validate_params
    from waamflow.nodes.post import PostProcess

    with pytest.raises(RecipeError, match=r"an M code") as err:
        _validate_params("post", PostProcess, {"arc_on": "G1 X5"})
    assert (err.value.node, err.value.field) == ("post", "arc_on")
    assert _validate_params("post", PostProcess, {"arc_on": "M101 P1", "arc_off": "M103"}).arc_on == "M101 P1"


@pytest.mark.parametrize("decimals", [0, 3, 6])
def test_the_xyz_words_of_all_points_are_each_points_own(decimals):
    """`_xyz_words` formats every point in one `%` over the whole list: each word is the one a
    point formatted alone gets (negative zero written without its sign), whatever the decimals."""
    from waamflow.program.gcode import _NEG_ZERO, _xyz_words

    rng = np.random.default_rng(decimals)
    pts = np.vstack(
        [rng.uniform(-2000, 2000, (500, 3)), [[-0.0, -1e-9, 1e-9], [-0.0004, 0.0005, -0.0006], [1e7, -1e7, 0.5]]]
    )
    fmt = f"X%.{decimals}f Y%.{decimals}f Z%.{decimals}f"
    want = [_NEG_ZERO.sub("", fmt % tuple(p)) for p in pts.tolist()]
    got = _xyz_words(pts, decimals)
    assert len(got) == len(pts) == 503
    assert got == want
    assert got[500] == f"X{0:.{decimals}f} Y{0:.{decimals}f} Z{0:.{decimals}f}"  # -0, ±1e-9: no sign
    assert _xyz_words(np.zeros((0, 3)), decimals) == []
