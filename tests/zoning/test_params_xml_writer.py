"""The parameter-file writer (line by line) writes exactly what ElementTree writes for the same
tree: empty files, special characters, layers and sections listed out of order, filled values."""

import pytest

from waamflow.core.process import ZONE_PARAMETERS
from waamflow.zoning.params_xml import _write, _write_etree, parse

ZONES = [
    (0, 1.5, "bs1/A", "start", "#d62728"),
    (0, 1.5, "bs1/A", "z1", "#1f77b4"),
    (0, 1.5, "bs1/B", "end", ""),
    (1, 3.0000004, 'odd "key" <&>\t\n\r', "z&1", "#abc"),
    (2, None, "bs1/A", "start", "#d62728"),
    (0, 1.5, "bs1/A", "late", "#000"),  # back to layer 0, section bs1/A: appended there
    (1, 3.0, "bs2/C", "zone", "x"),
]


@pytest.mark.parametrize("zones", [[], ZONES[:3], ZONES])
def test_line_writer_equals_elementtree(zones):
    names = [p.name for p in ZONE_PARAMETERS]
    values = {
        (0, "bs1/A", "z1"): {names[0]: 200.0, names[-1]: 3.0},
        (1, 'odd "key" <&>\t\n\r', "z&1"): {names[1]: 1e-7},
    }
    assert _write(zones, values) == _write_etree(zones, values)


def test_written_file_reads_back():
    name = ZONE_PARAMETERS[0].name
    table = parse(_write(ZONES[:3], {(0, "bs1/A", "z1"): {name: 200.0}}))
    assert table.zones == ((0, "bs1/A", "start"), (0, "bs1/A", "z1"), (0, "bs1/B", "end"))
    assert table.values == {(0, "bs1/A", "z1"): {name: 200.0}}
    assert table.layer_z == {0: 1.5}
