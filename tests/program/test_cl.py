import csv
import io

import numpy as np

from waamflow.core.moves import flatten
from waamflow.program import post_process
from waamflow.program.cl import COLUMNS

from conftest import build_toolpath


def test_cl_rows_equal_points():
    moves = flatten(build_toolpath())
    text = post_process(moves, "csv").files["csv"]
    rows = list(csv.reader(io.StringIO(text)))
    assert tuple(rows[0]) == COLUMNS
    body = rows[1:]
    assert len(body) == len(moves.points) == 141
    xyz = np.array([[float(r[0]), float(r[1]), float(r[2])] for r in body])
    assert np.allclose(xyz, moves.points, atol=1e-4)
    ijk = np.array([[float(r[3]), float(r[4]), float(r[5])] for r in body])
    assert np.allclose(ijk, [0, 0, -1])
    arc = np.array([int(r[7]) for r in body])
    assert arc[0] == 0 and arc.sum() == int(moves.arc.sum())
    speeds = [r[6] for r in body]
    assert speeds[0] == "" and sum(s == "" for s in speeds) == 1 + int((moves.kind == 0).sum())
    assert {float(s) for s in speeds if s} == {5.0, 6.0, 7.0}
    assert {r[10] for r in body} == {"", "start", "z1", "end"}
    assert sorted({r[9] for r in body}) == ["bs1/A", "bs1/B", "bs1/C"]
    assert [float(r[11]) for r in body if float(r[11]) > 0] == [20.0, 20.0]
