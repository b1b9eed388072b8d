"""`make bench`: run every bench/bench_*.py module's `run()` and write out/bench/results.json.

Each module returns a list of {"name", "value", "unit", "peer", "ratio", "notes"}; ratios are
measured side by side in the same run (never against numbers from another machine or day).

Usage: `bench/run.py [bench_sim bench_slice ...]`: with module names, only those run and their
entries replace the ones they wrote before in results.json (the other modules' entries are kept;
each entry names its `module`). `-h` / `--help`: this text.
"""

from __future__ import annotations

import importlib.util
import json
import os
import platform
import sys
import time
import traceback
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def _byte_compile() -> None:
    """Byte-compile waamflow's sources before anything is timed, as `pip install` does for an
    installed package: with PYTHONDONTWRITEBYTECODE set (as on the CI machines) an editable
    install would otherwise recompile every module it imports in every CLI run it times (~0.17 s
    of CPU on the bracket). compileall writes the .pyc files whatever that variable says."""
    import compileall

    compileall.compile_dir(str(ROOT / "backend" / "waamflow"), quiet=1)


def main() -> int:
    args = sys.argv[1:]
    if any(a in ("-h", "--help") for a in args):
        print(__doc__)
        return 0
    modules = sorted((ROOT / "bench").glob("bench_*.py"))
    only = set(args)
    unknown = only - {p.stem for p in modules}
    if unknown:
        print(
            f"unknown bench module(s): {', '.join(sorted(unknown))}; the modules are: "
            f"{', '.join(p.stem for p in modules)}",
            file=sys.stderr,
        )
        return 2
    _byte_compile()
    results, failures = [], []
    load = os.getloadavg()[0]  # other work on the machine slows every figure: recorded with them
    for path in modules:
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
            e["module"] = path.stem
            e.setdefault("peer", None)
            e.setdefault("ratio", None)
            e.setdefault("notes", "")
            results.append(e)
            print(f"{e['name']:32s} {e['value']!s:>14} {e['unit']:8s} ratio={e['ratio']} peer={e['peer']}")
        print(f"  ({path.stem}: {time.perf_counter() - t0:.1f} s)")
    out = ROOT / "out" / "bench"
    out.mkdir(parents=True, exist_ok=True)
    if only and (out / "results.json").is_file():
        # a selection: keep what the other modules wrote last time
        old = json.loads((out / "results.json").read_text())
        names = {e["name"] for e in results}
        results = [
            e for e in old.get("results", []) if e.get("module") not in only and e.get("name") not in names
        ] + results
        failures = [f for f in old.get("failures", []) if f.get("module") not in only] + failures
    doc = {
        "results": results,
        "failures": failures,
        "machine": {
            "python": platform.python_version(),
            "platform": platform.platform(),
            "cpus": os.cpu_count(),
            "load_average_1min_at_start": round(load, 2),
            "date_utc": time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime()),
        },
    }
    (out / "results.json").write_text(json.dumps(doc, indent=2))
    print(f"wrote {out / 'results.json'}")
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
