"""`waamflow backup DIR` / `waamflow restore DIR`: the server's database and run folders.

backup: a consistent copy of `waamflow.sqlite` taken with SQLite's online backup API (safe while the
server runs), the run folders (`runs/<id>/`, files copied as they are: a run folder is written
atomically, so it is complete or absent) and `manifest.json` (counts and the SHA-256 of every file).
The result cache is not backed up: it is rebuilt on demand.

restore: checks the backup against its manifest and `PRAGMA integrity_check`, then puts database and
run folders in place (atomic renames). It refuses while a server holds the data folder (the flock on
`waamflow.sqlite.lock` every server holds shared while it runs; the kernel drops it when a server
dies, even by kill -9). An existing database is first checkpointed (its WAL, e.g. a killed server's
last saves, written into the file), checked and kept as `waamflow.sqlite.before-restore-<time>`
unless --force; the copy put in place is checked against the manifest's counts.
"""

from __future__ import annotations

import hashlib
import json
import os
import shutil
import sqlite3
import time
from pathlib import Path

from contextlib import contextmanager

from .. import __version__
from ..core.errors import WaamflowError
from .store import LOCK_SUFFIX, DataFolderBusy, lock_file

DB = "waamflow.sqlite"
LOCK = DB + LOCK_SUFFIX
TABLES = ("graphs", "graph_files", "runs", "events", "audit")


class BackupError(WaamflowError):
    exit_code = 2
    kind = "backup"


def _sha256(p: Path) -> str:
    h = hashlib.sha256()
    with open(p, "rb") as f:
        for chunk in iter(lambda: f.read(1 << 20), b""):
            h.update(chunk)
    return h.hexdigest()


@contextmanager
def data_lock(data_dir: str | Path, *, exclusive: bool):
    """Hold the data folder's lock (see store.lock_file) for the duration of the block."""
    fd = lock_file(
        Path(data_dir) / DB,
        exclusive=exclusive,
        busy=f"a waamflow server is using {data_dir}: stop it first (restore replaces its database)",
    )
    try:
        yield
    finally:
        os.close(fd)


def _counts(db: Path, *, tables: bool = False) -> dict[str, int]:
    """Rows per table, after `PRAGMA integrity_check`; `tables`: every table of TABLES must exist."""
    con = sqlite3.connect(f"file:{db}?mode=ro", uri=True)
    try:
        if tables:
            have = {r[0] for r in con.execute("SELECT name FROM sqlite_master WHERE type='table'")}
            missing = [t for t in TABLES if t not in have]
            if missing:
                raise BackupError(f"{db} lacks the table(s) {', '.join(missing)}: not a complete waamflow database")
        out = {}
        for table in TABLES:
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
        manifest = {
            "waamflow": __version__,
            "created": time.time(),
            "database": DB,
            "database_sha256": _sha256(stage / DB),
            "counts": _counts(stage / DB),
            "files": files,
        }
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
    _counts(src / DB, tables=True)  # integrity check and every table, before anything is touched
    data.mkdir(parents=True, exist_ok=True)
    try:
        with data_lock(data, exclusive=True):
            kept = _replace_database(src, data, manifest, force)
    except DataFolderBusy as e:
        raise BackupError(str(e)) from None
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
    return {**manifest, "kept": kept}


def _checkpoint(db: Path) -> dict[str, int]:
    """Write the WAL of `db` (acknowledged saves a killed server left there) into the file and
    check it: the table counts, or BackupError when it is not a sound waamflow database."""
    try:
        con = sqlite3.connect(str(db), timeout=5)
        try:
            busy, _, _ = con.execute("PRAGMA wal_checkpoint(TRUNCATE)").fetchone()
            if busy:
                raise BackupError(f"{db}: its WAL could not be checkpointed (in use)")
            ok = con.execute("PRAGMA integrity_check").fetchone()[0]
            have = {r[0] for r in con.execute("SELECT name FROM sqlite_master WHERE type='table'")}
            if have and "graphs" not in have:
                raise BackupError(
                    f"{db} has no graphs table: not a waamflow database; move it away yourself, "
                    "or restore with --force to delete it"
                )
            counts = {t: con.execute(f"SELECT count(*) FROM {t}").fetchone()[0] for t in TABLES if t in have}
            con.execute("PRAGMA journal_mode=DELETE")  # the kept copy is one self-contained file
        finally:
            con.close()
    except sqlite3.DatabaseError as e:
        raise BackupError(
            f"{db} cannot be read as a database ({e}): move it away yourself, or restore with --force to delete it"
        ) from None
    if ok != "ok":
        raise BackupError(f"{db}: integrity check failed ({ok}): restore with --force to delete it")
    return counts


def _replace_database(src: Path, data: Path, manifest: dict, force: bool) -> dict | None:
    """Under the exclusive lock: set the existing database aside (checkpointed, verified) and put the
    backup's in place (verified). Returns the kept copy's {"path", "counts"} (None: nothing kept)."""
    db = data / DB
    kept = None
    wal, shm = Path(f"{db}-wal"), Path(f"{db}-shm")
    if db.exists() and not force:
        counts = _checkpoint(db)
        aside = data / f"{DB}.before-restore-{time.strftime('%Y%m%d-%H%M%S')}-{os.getpid()}"
        os.replace(db, aside)
        wal.unlink(missing_ok=True)  # empty after the checkpoint
        shm.unlink(missing_ok=True)
        again = _counts(aside)  # the copy as it lies on disk now, without any WAL
        if again != {t: counts.get(t, 0) for t in TABLES}:
            raise BackupError(f"{aside}: after setting it aside it holds {again}, before {counts}")
        kept = {"path": str(aside), "counts": again}
    else:
        db.unlink(missing_ok=True)
        wal.unlink(missing_ok=True)
        shm.unlink(missing_ok=True)
    tmp = data / f".{DB}.restore"
    shutil.copy2(src / DB, tmp)
    try:
        got = _counts(tmp, tables=True)
    except BackupError:
        tmp.unlink(missing_ok=True)
        raise
    if got != manifest["counts"]:
        tmp.unlink(missing_ok=True)
        raise BackupError(f"the restored copy holds {got}, the manifest says {manifest['counts']}")
    os.replace(tmp, db)
    return kept
