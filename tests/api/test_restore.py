"""`waamflow restore` (#26 fault 1): it refuses while a server holds the data folder, and the
database it sets aside keeps every acknowledged save — also the ones still in the WAL of a server
killed with -9 (its lock dies with it)."""

import os
import signal
import sqlite3
import subprocess
import sys
import time
from pathlib import Path

from fastapi.testclient import TestClient

import toy_nodes as toy
from waamflow.api.app import create_app
from waamflow.api.backup import DB, LOCK
from waamflow.cli import main as cli
from waamflow.settings import Settings

BACKEND = Path(__file__).resolve().parents[2] / "backend"
N = 5


def _settings(data):
    return Settings(
        data_dir=data,
        graphs_dir=data.parent / "no-examples",
        start_viewer=False,
        static_dir=None,
        workers=1,
        start_workers=False,
    )


def _backup(tmp_path) -> Path:
    """A backup of a data folder holding one graph, `from-backup`."""
    src = tmp_path / "src"
    with TestClient(create_app(_settings(src))) as c:
        assert c.put("/api/graphs/from-backup", json=toy.chain()).status_code == 201
    assert cli(["backup", str(tmp_path / "bk"), "--data", str(src)]) == 0
    return tmp_path / "bk"


def _graphs(db: Path) -> list[str]:
    con = sqlite3.connect(f"file:{db}?mode=ro", uri=True)
    try:
        return [r[0] for r in con.execute("SELECT name FROM graphs ORDER BY name")]
    finally:
        con.close()


# a "server": opens the store as the server does, saves N graphs (acknowledged: committed), then
# waits to be killed; nothing checkpoints the WAL
SAVER = """
import sys, time
sys.path.insert(0, %r)
from waamflow.api.store import Store
s = Store(sys.argv[1])
for i in range(%d):
    s.put_graph(f"acked{i}", {"format": "waamflow/1", "name": f"acked{i}", "nodes": [], "edges": []})
print("saved", flush=True)
time.sleep(60)
"""


def test_restore_refuses_while_a_server_runs(tmp_path, capsys):
    bk = _backup(tmp_path)
    data = tmp_path / "data"
    capsys.readouterr()
    with TestClient(create_app(_settings(data))) as c:
        assert c.put("/api/graphs/mine", json=toy.chain()).status_code == 201
        assert cli(["restore", str(bk), "--data", str(data)]) == 2
        err = capsys.readouterr().err
        assert err.startswith("error:") and "server" in err and str(data) in err, err
        # nothing was replaced: the server still reads and writes the same database
        assert c.put("/api/graphs/after", json=toy.chain()).status_code == 201
        assert {g["name"] for g in c.get("/api/graphs").json()} == {"mine", "after"}
    assert not list(data.glob(f"{DB}.before-restore-*"))
    # stopped: restore goes ahead and keeps the old database aside with both saves
    assert cli(["restore", str(bk), "--data", str(data)]) == 0
    kept = list(data.glob(f"{DB}.before-restore-*"))
    assert len(kept) == 1 and _graphs(kept[0]) == ["after", "mine"]
    assert _graphs(data / DB) == ["from-backup"]


def test_crash_then_restore_keeps_every_acknowledged_save(tmp_path, capsys):
    bk = _backup(tmp_path)
    data = tmp_path / "data"
    data.mkdir()
    p = subprocess.Popen(
        [sys.executable, "-c", SAVER % (str(BACKEND), N), str(data / DB)], stdout=subprocess.PIPE, text=True
    )
    try:
        assert p.stdout.readline().strip() == "saved"
        # while it holds the folder: refused, the WAL untouched
        assert cli(["restore", str(bk), "--data", str(data)]) == 2
        assert "server" in capsys.readouterr().err
        os.kill(p.pid, signal.SIGKILL)
        p.wait(10)
    finally:
        if p.poll() is None:
            p.kill()
            p.wait(10)
    wal = data / f"{DB}-wal"
    assert wal.is_file() and wal.stat().st_size > 0  # the N saves (and the tables) are only in the WAL
    t0 = time.time()
    assert cli(["restore", str(bk), "--data", str(data)]) == 0  # the dead process's lock went with it
    assert time.time() - t0 < 10
    kept = list(data.glob(f"{DB}.before-restore-*"))
    assert len(kept) == 1
    assert _graphs(kept[0]) == [f"acked{i}" for i in range(N)]
    # the set-aside copy stands alone: no WAL beside it is needed
    assert not Path(f"{kept[0]}-wal").exists() and not wal.exists()
    con = sqlite3.connect(f"file:{kept[0]}?mode=ro", uri=True)
    assert con.execute("PRAGMA integrity_check").fetchone()[0] == "ok"
    con.close()
    assert _graphs(data / DB) == ["from-backup"]
    out = capsys.readouterr().out
    assert f"kept aside: {N} graphs" in out, out


def test_restore_refuses_a_damaged_database_to_set_aside(tmp_path, capsys):
    bk = _backup(tmp_path)
    data = tmp_path / "data"
    data.mkdir()
    (data / DB).write_bytes(b"this is not a database" * 100)
    assert cli(["restore", str(bk), "--data", str(data)]) == 2
    err = capsys.readouterr().err
    assert "--force" in err, err
    assert (data / DB).read_bytes().startswith(b"this is not")  # left as it was
    assert cli(["restore", str(bk), "--data", str(data), "--force"]) == 0
    assert _graphs(data / DB) == ["from-backup"]


def test_restore_is_locked_against_a_server_starting(tmp_path):
    """While restore holds the folder a server does not open the database (it waits, then fails)."""
    from waamflow.api.backup import data_lock
    from waamflow.api.store import DataFolderBusy, Store

    data = tmp_path / "data"
    with data_lock(data, exclusive=True):
        t0 = time.time()
        try:
            Store(data / DB, lock_timeout=0.3)
        except DataFolderBusy as e:
            assert "restore" in str(e)
        else:
            raise AssertionError("the store opened a folder being restored")
        assert 0.3 <= time.time() - t0 < 3
    s = Store(data / DB, lock_timeout=0.3)
    s.close()
    assert (data / LOCK).exists()


def test_restore_around_a_real_server_killed_with_9(tmp_path, capsys):
    """The issue's sequence with `waamflow serve`: acknowledged saves over HTTP, restore refused
    while it serves, kill -9, restore: the kept-aside copy holds every acknowledged save."""
    import httpx
    from test_operations import ALICE, _free_port, _start_server

    bk = _backup(tmp_path)
    data, port = tmp_path / "data", _free_port()
    server = _start_server(data, port)
    try:
        with httpx.Client(
            base_url=f"http://127.0.0.1:{port}", headers={"Authorization": f"Bearer {ALICE}"}, timeout=10
        ) as cl:
            for i in range(N):
                assert cl.put(f"/api/graphs/served{i}", json=toy.chain(stack={"count": 1 + i})).status_code == 201
        assert cli(["restore", str(bk), "--data", str(data)]) == 2
        assert "stop it first" in capsys.readouterr().err
        os.kill(server.pid, signal.SIGKILL)
        server.wait(10)
    finally:
        if server.poll() is None:
            server.kill()
            server.wait(10)
    assert cli(["restore", str(bk), "--data", str(data)]) == 0
    kept = list(data.glob(f"{DB}.before-restore-*"))
    assert len(kept) == 1 and _graphs(kept[0]) == [f"served{i}" for i in range(N)]
    assert _graphs(data / DB) == ["from-backup"]


def test_restore_checks_both_copies_hold_the_tables(tmp_path, capsys):
    """A database without waamflow's tables is not set aside as if it were one, and a backup whose
    database lost a table is not put in place."""
    bk = _backup(tmp_path)
    data = tmp_path / "data"
    data.mkdir()
    con = sqlite3.connect(data / DB)
    con.execute("CREATE TABLE other (x)")
    con.commit()
    con.close()
    assert cli(["restore", str(bk), "--data", str(data)]) == 2
    err = capsys.readouterr().err
    assert "graphs" in err and "--force" in err, err
    assert _graphs_or_none(data / DB) is None  # left as it was
    # a backup without the graphs table (manifest rewritten to match): refused, nothing replaced
    bad = tmp_path / "bad"
    import shutil

    shutil.copytree(bk, bad)
    con = sqlite3.connect(bad / DB)
    con.execute("DROP TABLE graphs")
    con.commit()
    con.close()
    import hashlib
    import json

    m = json.loads((bad / "manifest.json").read_text())
    m["database_sha256"] = hashlib.sha256((bad / DB).read_bytes()).hexdigest()
    m["counts"]["graphs"] = 0
    (bad / "manifest.json").write_text(json.dumps(m))
    fresh = tmp_path / "fresh"
    assert cli(["restore", str(bad), "--data", str(fresh)]) == 2
    assert "graphs" in capsys.readouterr().err
    assert not (fresh / DB).exists()
    src = tmp_path / "src"  # a folder with a database: it stays in place, nothing set aside
    assert cli(["restore", str(bad), "--data", str(src)]) == 2
    assert _graphs(src / DB) == ["from-backup"] and not list(src.glob(f"{DB}.before-restore-*"))


def _graphs_or_none(db: Path):
    try:
        return _graphs(db)
    except sqlite3.OperationalError:
        return None
