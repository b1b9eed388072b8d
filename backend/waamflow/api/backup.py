"""`waamflow backup DIR` / `waamflow restore DIR`: the server's database and run folders.

backup: a consistent copy of `waamflow.sqlite` taken with SQLite's online backup API (safe while the
server runs), the run folders (`runs/<id>/`, files copied as they are: a run folder is written
atomically, so it is complete or absent) and `manifest.json` (counts and the SHA-256 of every file).
The result cache is not backed up: it is rebuilt on demand.

restore: checks the backup against its manifest and `PRAGMA integrity_check`, then puts database and
run folders in place (atomic renames). Stop the server first; an existing database is kept as
`waamflow.sqlite.before-restore-<time>` unless --force.
"""

from __future__ import annotations

import hashlib
import json
import os
import shutil
import sqlite3
import time
from pathlib import Path

from .. import __version__
from ..core.errors import WaamflowError

DB = "waamflow.sqlite"


class BackupError(WaamflowError):
    exit_code = 2
    kind = "backup"


def _sha256(p: Path) -> str:
    h = hashlib.sha256()
    with open(p, "rb") as f:
        for chunk in iter(lambda: f.read(1 << 20), b""):
            h.update(chunk)
    return h.hexdigest()


def _counts(db: Path) -> dict[str, int]:
    con = sqlite3.connect(f"file:{db}?mode=ro", uri=True)
    try:
        out = {}
        for table in ("graphs", "graph_files", "runs", "events", "audit"):
            try:
                out[table] = con.execute(f"SELECT count(*) FROM {table}").fetchone()[0]
            except sqlite3.OperationalError:
                out[table] = 0
        ok = con.execute("PRAGMA integrity_check").fetchone()[0]
        if ok != "ok":
            raise BackupError(f"{db}: integrity check failed: {ok}")
        return out
    finally:
        con.close()


def backup(data_dir: str | Path, dest: str | Path) -> dict:
    data, out = Path(data_dir), Path(dest)
    src_db = data / DB
    if not src_db.is_file():
        raise BackupError(f"no database at {src_db} (is --data the server's data folder?)")
    if out.exists() and any(out.iterdir()):
        raise BackupError(f"{out} is not empty: back up into a new folder")
    stage = out.parent / f".{out.name}.partial-{os.getpid()}"
    shutil.rmtree(stage, ignore_errors=True)
    stage.mkdir(parents=True)
    try:
        src = sqlite3.connect(str(src_db), timeout=30)
        dst = sqlite3.connect(str(stage / DB))
        try:
            src.backup(dst)  # online backup: consistent even while the server writes
        finally:
            dst.close()
            src.close()
        files: dict[str, str] = {}
        runs = data / "runs"
        if runs.is_dir():
            for run in sorted(runs.iterdir()):
                if not run.is_dir() or run.name.startswith("."):
                    continue  # a run folder being written right now
                for f in sorted(run.iterdir()):
                    if f.is_file() and not f.is_symlink():
                        rel = f"runs/{run.name}/{f.name}"
                        (stage / "runs" / run.name).mkdir(parents=True, exist_ok=True)
                        shutil.copy2(f, stage / rel)
                        files[rel] = _sha256(stage / rel)
        manifest = {"waamflow": __version__, "created": time.time(), "database": DB,
                    "database_sha256": _sha256(stage / DB), "counts": _counts(stage / DB), "files": files}
        (stage / "manifest.json").write_text(json.dumps(manifest, indent=2), encoding="utf-8")
        if out.exists():
            out.rmdir()
        os.replace(stage, out)
    except BaseException:
        shutil.rmtree(stage, ignore_errors=True)
        raise
    return manifest


def restore(src: str | Path, data_dir: str | Path, *, force: bool = False) -> dict:
    src, data = Path(src), Path(data_dir)
    mpath = src / "manifest.json"
    if not mpath.is_file():
        raise BackupError(f"{src} has no manifest.json: not a waamflow backup")
    manifest = json.loads(mpath.read_text(encoding="utf-8"))
    if _sha256(src / DB) != manifest["database_sha256"]:
        raise BackupError(f"{src / DB} does not match the manifest (changed or damaged)")
    for rel, digest in manifest["files"].items():
        p = src / rel
        if ".." in Path(rel).parts or not p.is_file() or _sha256(p) != digest:
            raise BackupError(f"backup file {rel} is missing or damaged")
    _counts(src / DB)  # integrity check
    data.mkdir(parents=True, exist_ok=True)
    db = data / DB
    if db.exists():
        if force:
            db.unlink()
        else:
            os.replace(db, data / f"{DB}.before-restore-{int(time.time())}")
    for suffix in ("-wal", "-shm"):
        Path(str(db) + suffix).unlink(missing_ok=True)
    tmp = data / f".{DB}.restore"
    shutil.copy2(src / DB, tmp)
    os.replace(tmp, db)
    runs = data / "runs"
    for rel in manifest["files"]:
        run_id = Path(rel).parts[1]
        target = runs / run_id
        if target.exists():
            continue
        stage = runs / f".{run_id}.restore"
        shutil.rmtree(stage, ignore_errors=True)
        shutil.copytree(src / "runs" / run_id, stage)
        os.replace(stage, target)
    return manifest
