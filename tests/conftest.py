import os
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests"))

# TestClient sends `Host: testserver`; a server without a token answers only the Host names of
# this machine (DNS-rebinding protection), so the tests name theirs, as Django's test runner does.
os.environ.setdefault("WAAMFLOW_ALLOWED_HOSTS", '["testserver"]')
# token files the tests write must not be readable by every user (the server refuses those)
os.umask(0o027)
