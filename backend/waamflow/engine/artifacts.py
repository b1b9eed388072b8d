"""Write a run's files so that a folder is either a complete result or not there at all."""

from __future__ import annotations

import os
import shutil
import tempfile
from pathlib import Path
from typing import Any

from ..core.serialize import dumps_report


def write_run_dir(out_dir: str | Path, files: dict[str, bytes], summary: dict[str, Any]) -> Path:
    """Stage every artifact plus summary.json in a sibling temp folder, then swap it into place.

    The previous result (if any) is replaced only once the new one is complete.
    """
    out = Path(out_dir).resolve()
    out.parent.mkdir(parents=True, exist_ok=True)
    stage = Path(tempfile.mkdtemp(dir=out.parent, prefix=f".{out.name}.partial-"))
    try:
        for name, data in files.items():
            if "/" in name or "\\" in name or name.startswith("."):
                raise ValueError(f"bad artifact name {name!r}")
            (stage / name).write_bytes(data)
        # orjson, 2 spaces, as preflight.json (json.dumps(indent=2) took 22 ms of the bracket's run)
        (stage / "summary.json").write_bytes(dumps_report(summary))
        old = None
        if out.exists():
            old = out.parent / f".{out.name}.old-{os.getpid()}"
            os.replace(out, old)
        os.replace(stage, out)
        if old is not None:
            shutil.rmtree(old, ignore_errors=True)
    except BaseException:
        shutil.rmtree(stage, ignore_errors=True)
        raise
    return out
