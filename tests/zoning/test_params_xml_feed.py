"""The parameter file's feed note (issue #22 item 5): each zone's bead_mm3_per_mm and a comment
comparing the wire fed with it; written alike by both writers, read back, valid against the XSD,
kept by merge with the user's values."""

import numpy as np
import pytest

from waamflow.core.model import Layer, LayerPaths, Layered, SectionPath
from waamflow.zoning.params_xml import _write, _write_etree, merge, parse, template, toolpath_beads

ZONES = [(0, 1.5, "bs1/A", "start", "#d62728"), (0, 1.5, "bs1/A", "z1", "#1f77b4"), (0, 1.5, "bs1/B", "end", "")]
VALUES = {(0, "bs1/A", "z1"): {"wire_feed_speed": 4.0, "travel_speed": 8.0, "current": 115.0}}
BEADS = {(0, "bs1/A", "start"): 9.0, (0, "bs1/A", "z1"): 9.0}


def test_writers_agree_and_the_comment_states_the_ratio():
    text = _write(ZONES, VALUES, BEADS)
    assert text == _write_etree(ZONES, VALUES, BEADS)
    # 4 m/min of 1.2 mm wire at 8 mm/s, 95 % deposited: 4000/60 · 1.131 · 0.95 / 8 = 8.95 mm³/mm
    assert '<zone id="z1" color="#1f77b4" bead_mm3_per_mm="9">' in text
    assert "<!-- feed: wire 8.95 mm³/mm vs bead 9.00 mm³/mm = 0.99 -->" in text
    assert "<!-- feed: bead 9.00 mm³/mm (set wire_feed_speed and travel_speed to compare) -->" in text
    assert text.count("feed: ") == 2 + 1  # two zones with a bead and the header note
    assert '<zone id="end" color="">' in text  # no bead known: nothing added
    table = parse(text)  # comments inside zones are skipped; XSD accepts the attribute
    assert table.values == VALUES and table.beads == BEADS


def _toolpath(speed_zone=("start", "z1", "z1", "end")):
    # two 100 mm passes 6 mm apart (arc-OFF hop), 1.5 mm layer: step 6 → 9 mm³/mm
    pts = np.array([[0, 0, 1.5], [10, 0, 1.5], [100, 0, 1.5], [100, 6, 1.5], [0, 6, 1.5]], float)
    sp = SectionPath(
        "bs1/A",
        "parallel",
        pts,
        np.array([True, True, False, True]),
        np.ones(4, bool),
        np.full(4, 8.0),
        speed_zone,
        {z: "#000000" for z in speed_zone},
    )
    layer = Layer(index=0, z=1.5, thickness=1.5, region=None)
    return Layered((LayerPaths(layer, (sp,)),))


def test_template_and_merge_keep_user_values_and_restate_the_feed():
    tp = _toolpath()
    assert toolpath_beads(tp) == {(0, "bs1/A", z): pytest.approx(9.0) for z in ("start", "z1", "end")}
    tpl = template(tp)
    assert tpl.count('bead_mm3_per_mm="9"') == 3
    user = _write(
        [(0, 1.5, "bs1/A", "z1", "#000000")], {(0, "bs1/A", "z1"): {"wire_feed_speed": 5.0, "travel_speed": 8.0}}
    )
    merged, orphans = merge(tpl, user)
    assert orphans == []
    assert parse(merged).values == {(0, "bs1/A", "z1"): {"wire_feed_speed": 5.0, "travel_speed": 8.0}}
    # 5 m/min at 8 mm/s: 11.19 mm³/mm against 9: a 1.24 over-feed, stated in the zone
    assert "<!-- feed: wire 11.19 mm³/mm vs bead 9.00 mm³/mm = 1.24 -->" in merged
    # merging again (the re-run) changes nothing
    assert merge(template(tp), merged)[0] == merged
