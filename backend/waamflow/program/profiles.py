"""Machine profiles: named JSON files in `data/machines/` that preset post-process params for one
controller (generic G-code, LinuxCNC, Marlin, KUKA KR C4, ABB IRC5).

A profile is `{"title", "description", "post": {param: value}}`; the post-process node's
`profile` param picks one, and its values fill every param the recipe does not set itself.
"""

from __future__ import annotations

import json
from functools import lru_cache
from pathlib import Path

MACHINES_DIR = Path(__file__).resolve().parents[1] / "data" / "machines"


@lru_cache(maxsize=1)
def load_profiles() -> dict[str, dict]:
    """name (file stem) → {"name", "title", "description", "post"}, sorted by name."""
    out = {}
    for p in sorted(MACHINES_DIR.glob("*.json")):
        doc = json.loads(p.read_text(encoding="utf-8"))
        out[p.stem] = {
            "name": p.stem,
            "title": doc.get("title", p.stem),
            "description": doc.get("description", ""),
            "post": dict(doc.get("post", {})),
        }
    return out


def profile(name: str) -> dict:
    """One profile by name; ValueError naming the known profiles otherwise."""
    profiles = load_profiles()
    if name not in profiles:
        raise ValueError(f"unknown machine profile {name!r}; known: {', '.join(profiles)}")
    return profiles[name]
