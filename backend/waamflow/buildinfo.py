"""Which build of waamflow wrote a file: the package version and the source revision.

`source_revision()` is `git describe --always --dirty` of the source tree when the package runs
from a git checkout (e.g. `c4826a0-dirty`); else the commit an installer recorded
(PEP 610 `direct_url.json`, `vcs_info.commit_id`); else `WAAMFLOW_REVISION` when set (build
metadata of a packaged build); else "unknown". Computed once per process (a program header must
not depend on when in a run it was written).
"""

from __future__ import annotations

import json
import os
import subprocess
from functools import lru_cache
from pathlib import Path

from . import __version__

PACKAGE_DIR = Path(__file__).resolve().parent


@lru_cache(maxsize=1)
def source_revision() -> str:
    env = os.environ.get("WAAMFLOW_REVISION", "").strip()
    try:
        top = subprocess.run(
            ["git", "rev-parse", "--show-toplevel"], cwd=PACKAGE_DIR, capture_output=True, text=True, timeout=10
        )
        if top.returncode == 0 and PACKAGE_DIR.is_relative_to(Path(top.stdout.strip()).resolve()):
            out = subprocess.run(
                ["git", "describe", "--always", "--dirty"],
                cwd=top.stdout.strip(),
                capture_output=True,
                text=True,
                timeout=30,
            )
            if out.returncode == 0 and out.stdout.strip():
                return out.stdout.strip()
    except (OSError, subprocess.SubprocessError):
        pass
    try:
        from importlib.metadata import distribution

        text = distribution("waamflow").read_text("direct_url.json")
        commit = (json.loads(text or "{}").get("vcs_info") or {}).get("commit_id", "")
        if commit:
            return commit[:12]
    except Exception:  # no metadata (source tree on sys.path) or a malformed file
        pass
    return env or "unknown"


def build_id() -> str:
    """'0.1.0 (c4826a0-dirty)'."""
    return f"{__version__} ({source_revision()})"
