import os
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests"))

# TestClient sends `Host: testserver`; a server without a token answers only the Host names of
# this machine (DNS-rebinding protection), so the tests name theirs, as Django's test runner does.
os.environ.setdefault("WAAMFLOW_ALLOWED_HOSTS", '["testserver"]')
# every test server keeps a disk reserve in its data folder: 1 MB, not the 16 MB of a real one
os.environ.setdefault("WAAMFLOW_DISK_RESERVE_MB", "1")
# token files the tests write must not be readable by every user (the server refuses those)
os.umask(0o027)
