"""Start-up stays light: the CLI and the node catalog do not import the heavy kernels' libraries."""

import json
import subprocess
import sys

HEAVY = ("pinocchio", "trimesh", "scipy", "viser", "fastapi", "uvicorn", "ruckig", "ezdxf", "OCP", "distributed")


def test_cli_and_catalog_do_not_import_heavy_libraries():
    code = (
        "import json, sys\n"
        "import waamflow.cli\n"
        "from waamflow.engine.node import catalog\n"
        "cat = catalog()\n"
        f"print(json.dumps({{'n': len(cat), 'heavy': [m for m in {HEAVY!r} if m in sys.modules]}}))\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    res = json.loads(out.stdout.strip().splitlines()[-1])
    assert res["heavy"] == []
    assert res["n"] >= 20  # every node type still registers without its kernel's libraries
