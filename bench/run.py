"""`make bench`: run every bench/bench_*.py module's `run()` and write out/bench/results.json.

Each module returns a list of {"name", "value", "unit", "peer", "ratio", "notes"}; ratios are
measured side by side in the same run (never against numbers from another machine or day).
"""

from __future__ import annotations

import importlib.util
import json
import platform
import sys
import time
import traceback
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def main() -> int:
    only = set(sys.argv[1:])
    results, failures = [], []
    for path in sorted((ROOT / "bench").glob("bench_*.py")):
        if only and path.stem not in only:
            continue
        spec = importlib.util.spec_from_file_location(path.stem, path)
        mod = importlib.util.module_from_spec(spec)
        t0 = time.perf_counter()
        try:
            spec.loader.exec_module(mod)
            entries = mod.run()
        except Exception:
            failures.append({"module": path.stem, "error": traceback.format_exc()})
            print(f"{path.stem}: FAILED\n{failures[-1]['error']}", file=sys.stderr)
            continue
        for e in entries:
            e.setdefault("peer", None)
            e.setdefault("ratio", None)
            e.setdefault("notes", "")
            results.append(e)
            print(f"{e['name']:32s} {e['value']!s:>14} {e['unit']:8s} ratio={e['ratio']} peer={e['peer']}")
        print(f"  ({path.stem}: {time.perf_counter() - t0:.1f} s)")
    out = ROOT / "out" / "bench"
    out.mkdir(parents=True, exist_ok=True)
    doc = {"results": results, "failures": failures,
           "machine": {"python": platform.python_version(), "platform": platform.platform()}}
    (out / "results.json").write_text(json.dumps(doc, indent=2))
    print(f"wrote {out / 'results.json'}")
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
