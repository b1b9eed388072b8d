"""The G-code reader's plain `G1 X Y Z [F]` lines (issue #30: 0.38 -> 0.18 s of the bench vase's
68,000-line program, on the run's critical path): read the same as by the general path, runs,
travel and notes bit for bit, and left to the general path wherever such a line could mean
something else (a weld command or an arc code written with those letters)."""

import numpy as np
import pytest

from waamflow.preflight.read import gcode

HEADER = """; waamflow-post: arc_on=M3 arc_off=M5 dwell_units=s feed_units={units} end=M30
; waamflow-weld: wire_feed_speed[m/min]="M67 E0 Q{{value:.2f}}" wire_feed_speed[m/min]@start="M68 E0 Q{{value:.2f}}"
{extra}G21
G90
"""


def _program(units="mm/min", extra="", rng=None):
    rng = rng or np.random.default_rng(0)
    lines = [HEADER.format(units=units, extra=extra)]
    z = 0.0
    for layer in range(4):
        z += 1.5
        lines += [f"; layer {layer} z={z:.3f}", f"; section s{layer}", f"G0 X{rng.uniform(-5, 5):.3f} Y0 Z{z:.3f}"]
        lines += ["M68 E0 Q5.00", "M3 ; arc on", "G4 P0.5"]
        for k in range(60):
            x, y = rng.uniform(-80, 80, 2)
            feed = f" F{rng.integers(300, 900)}" if k % 17 == 0 else ""
            form = k % 7
            if form == 0:
                lines.append(f"G1 X{x:.3f} Y{y:.3f} Z{z:.3f}{feed} ; a comment")  # general path
            elif form == 1:
                lines.append(f"G1 X{x:.3f} Y{y:.3f}")  # no Z: general path
            elif form == 2:
                lines.append(f"G01 X{x:.3f} Y{y:.3f} Z{z:.3f}")  # G01: general path
            elif form == 3:
                lines.append(f"G1 X{x:.0f}. Y{-y:.4e} Z{z:.3f}{feed}")  # odd numbers, plain
            else:
                lines.append(f"G1 X{x:.3f} Y{y:.3f} Z{z:.3f}{feed}")
        lines += ["M67 E0 Q4.50", f"G1 X1.000 Y2.000 Z{z:.3f}", "M5 ; arc off", f"G0 X0 Y0 Z{z + 5:.3f}", "G1 X3 Y4 Z9"]
    lines.append("M30")
    return "\n".join(lines) + "\n"


def _read(text, fast, monkeypatch):
    monkeypatch.setattr(gcode, "FAST_PATH", fast)
    return gcode.read_gcode(text)


def _assert_same(a, b):
    assert (a.format, a.travel_mm, a.notes, a.weld_commanded) == (b.format, b.travel_mm, b.notes, b.weld_commanded)
    assert len(a.runs) == len(b.runs)
    for r, q in zip(a.runs, b.runs):
        for name in ("points", "speed", "wfs", "weld"):
            x, y = getattr(r, name), getattr(q, name)
            assert x.dtype == y.dtype and x.shape == y.shape and x.tobytes() == y.tobytes(), name
        assert (r.layer, r.section, r.line) == (q.layer, q.section, q.line)


@pytest.mark.parametrize("units", ["mm/min", "mm/s"])
def test_plain_lines_read_as_the_general_path_reads_them(units, monkeypatch):
    text = _program(units)
    fast, ref = _read(text, True, monkeypatch), _read(text, False, monkeypatch)
    _assert_same(fast, ref)
    assert len(ref.runs) == 4 and all(len(r.points) == 62 for r in ref.runs) and ref.travel_mm > 10
    assert np.nanmax(ref.runs[0].speed) > 5 and np.all(ref.runs[1].wfs[-1:] == 4.5)


def test_plain_lines_used_where_they_can_only_be_motions(monkeypatch):
    calls = []
    findall = gcode._GWORD.findall

    class Counting:
        def findall(self, s):
            calls.append(s)
            return findall(s)

    monkeypatch.setattr(gcode, "_GWORD", Counting())
    _read(_program(), True, monkeypatch)
    plain = len(calls)
    calls.clear()
    _read(_program(), False, monkeypatch)
    assert plain < len(calls) / 2  # most motions skip the word pass


@pytest.mark.parametrize(
    "extra",
    [
        '; waamflow-weld: current[A]="G1 F{value:.0f}"\n',  # a weld command spelled like a motion
        '; waamflow-weld: voltage[V]="{value:.1f}"\n',  # a pattern tried on every line
    ],
)
def test_weld_commands_that_could_be_plain_lines_keep_the_general_path(extra, monkeypatch):
    text = _program(extra=extra)
    assert gcode._plain_g1(gcode._weld_templates(text), set()) is None
    _assert_same(_read(text, True, monkeypatch), _read(text, False, monkeypatch))
    monkeypatch.setattr(gcode, "FAST_PATH", True)
    assert gcode._plain_g1(gcode._weld_templates(_program()), set()) is not None
    assert gcode._plain_g1(gcode._weld_templates(_program()), {("G", "X", "Y", "Z")}) is None


@pytest.mark.parametrize("first", ["G1 X1 Y2 Z3 F600", "G1 X1 Y2 Z3 F600 ; first position"])
def test_arc_on_before_any_position_starts_the_run_where_it_first_moves(first):
    """A program that turns the arc on before its first position (M3, then G1): the run starts at
    the first position; a one-point motion there raised IndexError in RunBuilder.move."""
    text = (
        "; waamflow-post: arc_on=M3 arc_off=M5 dwell_units=s feed_units=mm/min end=M30\n"
        f"G21\nG90\nM3\n{first}\nG1 X5 Y2 Z3\nG1 X5 Y6 Z3\nM5\nM30\n"
    )
    r = gcode.read_gcode(text)
    assert len(r.runs) == 1
    assert r.runs[0].points.tolist() == [[1.0, 2.0, 3.0], [5.0, 2.0, 3.0], [5.0, 6.0, 3.0]]
    assert r.runs[0].speed.tolist() == [10.0, 10.0]  # F600 mm/min
    assert r.travel_mm == 0.0


@pytest.mark.parametrize("cut", ["M5 ; arc off", "M3 ; arc on", "G0 X"])
def test_a_program_that_ends_in_plain_lines_reads_as_the_general_path_reads_it(cut, monkeypatch):
    """Plain lines are handed to the builder a block at a time (`_plain_block`): the block a
    program ends with (cut short before its arc-off, or with no arc on at all) is read too, the
    same as line by line: runs, travel and feeds bit for bit."""
    full = _program()
    text = full[: full.index(cut)]  # the first occurrence: layer 0, mid-run or before it
    fast, ref = _read(text, True, monkeypatch), _read(text, False, monkeypatch)
    _assert_same(fast, ref)
    assert text.rstrip().splitlines()[-1].startswith(("G1 X", "G4", "M68", "; section", "; layer"))


@pytest.mark.parametrize(
    "edit",
    [
        lambda t: t.replace("\n", "\r\n"),  # Windows line breaks: the runs are still found
        lambda t: t.replace("\n", "\r", 40),  # old Mac breaks at the top: no run (the lines differ)
        lambda t: t.replace("G1 X", "G1 X1.2.", 3),  # a number float() refuses: that run line by line
        lambda t: t.replace(" Y", " Y1e", 2),  # "1e…": not a number either
        lambda t: t.replace("\n", "\n\x0c", 1),  # a form feed: a line break for splitlines only
    ],
)
def test_runs_of_plain_lines_found_in_the_text_read_as_line_by_line(edit, monkeypatch):
    """`_plain_runs` finds the runs in the text and reads each with one findall; wherever that
    could differ from the lines as the general path sees them (other line breaks, numbers that are
    not numbers), the result is still the general path's, bit for bit."""
    text = edit(_program())
    fast, ref = _read(text, True, monkeypatch), _read(text, False, monkeypatch)
    _assert_same(fast, ref)
    assert len(ref.runs) >= 3


@pytest.mark.parametrize("piece", [60, 997, 10**9])
def test_a_long_run_is_read_in_pieces_the_same(piece, monkeypatch):
    """A run of plain lines is read a piece of PIECE_CHARS characters at a time (whole lines), so
    a spiral's million lines are never held as text tuples at once: cut anywhere, the same runs."""
    rng = np.random.default_rng(3)
    body = [
        f"G1 X{x:.3f} Y{y:.3f} Z1.500" + (f" F{int(f)}" if k % 50 == 0 else "")
        for k, (x, y, f) in enumerate(rng.uniform(1, 900, (3000, 3)))
    ]
    head = HEADER.format(units="mm/min", extra="")
    text = head + "; layer 0 z=1.500\nG0 X0 Y0 Z1.500\nM68 E0 Q5.00\nM3\n" + "\n".join(body) + "\nM5\nM30\n"
    monkeypatch.setattr(gcode, "PIECE_CHARS", piece)
    if piece < 100:
        assert len(list(gcode._pieces(text, len(head), len(text)))) > 100
    fast, ref = _read(text, True, monkeypatch), _read(text, False, monkeypatch)
    _assert_same(fast, ref)
    assert len(ref.runs) == 1 and len(ref.runs[0].points) == 3001
