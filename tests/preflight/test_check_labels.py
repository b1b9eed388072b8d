"""Every check the preflight can report has a human name in the GUI's problems panel
(frontend/src/preflight/preflight.ts CHECK_LABEL): `hole`, `layer_volume_ratio`, `skipped_layers`,
`outside`, `wire_feed` and `deposit_changed` were listed by their raw names."""

from __future__ import annotations

import re
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]


def _backend_checks() -> set[str]:
    found: set[str] = set()
    for path in (ROOT / "backend/waamflow").rglob("*.py"):
        text = path.read_text(encoding="utf-8")
        found |= set(re.findall(r"\bproblem\(\s*\"([a-z_]+)\"", text))
        found |= set(re.findall(r"\"check\": \"([a-z_]+)\"", text))
    return found


def test_every_check_has_a_label_in_the_gui():
    ts = (ROOT / "frontend/src/preflight/preflight.ts").read_text(encoding="utf-8")
    block = ts[ts.index("export const CHECK_LABEL") : ts.index("};", ts.index("export const CHECK_LABEL"))]
    labelled = set(re.findall(r"\b([a-z_]+):\s*\"", block))
    checks = _backend_checks()
    assert {"hole", "layer_volume_ratio", "uncovered", "top_gap"} <= checks and len(checks) >= 24
    assert checks - labelled == set()
