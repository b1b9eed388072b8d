"""Short arc runs are warned once a section, not once a run.

compas_slicer's branches_70 test part (70 pins of ~3 mm on a plate) with 5 mm contour beads: the
sequence node dropped 6,810 runs of 2.7-3.0 mm and warned each — 6,862 warnings in summary.json,
the CLI's first 50 all alike, and what to do said nowhere."""

from waamflow.nodes.sequence import SequenceNode, _report


class _Ctx:
    def __init__(self):
        self.warnings: list[tuple[str, int | None, str | None]] = []
        self.reported: dict = {}

    def warn(self, message, *, layer=None, section=None):
        self.warnings.append((message, layer, section))

    def report(self, data):
        self.reported.update(data)


def _notes():
    notes = []
    for layer in range(2, 100):  # 16 pins a layer, each run dropped; two runs of layer 5 bridged
        for pin in range(16):
            notes.append(
                {
                    "kind": "dropped",
                    "layer": layer,
                    "section": f"region{pin}",
                    "length": 2.5 + 0.005 * layer + 0.01 * pin,
                    "at": [10.0 * pin, 4.0, 2.0 * layer],
                }
            )
    notes += [
        {"kind": "bridged", "layer": 5, "section": "region0", "length": 0.4, "at": [1.0, 2.0, 10.0]},
        {"kind": "bridged", "layer": 7, "section": "region0", "length": 0.6, "at": [1.5, 2.0, 14.0]},
    ]
    return notes


def test_one_warning_per_section_and_kind_with_count_layers_and_lengths():
    ctx = _Ctx()
    params = SequenceNode.Params(bead_width=5.0)
    _report(ctx, params, [], _notes())
    short = [w for w in ctx.warnings if "minimum arc run" in w[0]]
    assert len(short) == 16 + 1  # was 1,570: one per run
    dropped0 = next(w for w in short if w[2] == "region0" and "dropped" in w[0])
    msg, layer, section = dropped0
    assert layer == 2 and section == "region0"
    assert "98 arc-ON runs of 2.51-3.00 mm" in msg
    assert "on 98 layers (2-99)" in msg
    assert "minimum arc run (10 mm" in msg and "min_arc_run_mm" in msg
    assert "first at layer 2 [0.0, 4.0]" in msg
    bridged = next(w for w in short if "bridged" in w[0])
    assert "2 arc-ON runs of 0.40-0.60 mm" in bridged[0] and "on 2 layers (5, 7)" in bridged[0]
    assert ctx.reported["short_runs_dropped"] == 98 * 16 and ctx.reported["short_runs_bridged"] == 2


def test_a_single_run_reads_as_before():
    ctx = _Ctx()
    _report(ctx, SequenceNode.Params(min_arc_run_mm=4.0), [], [_notes()[0]])
    ((msg, layer, section),) = ctx.warnings
    assert (layer, section) == (2, "region0")
    assert msg.startswith("arc-ON run of 2.51 mm at [0.0, 4.0] on layer 2 is shorter than the minimum arc run (4 mm")
