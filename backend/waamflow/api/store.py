"""SQLite persistence: graphs (recipes + their files + parameter XML), runs and run events.

One file under the data folder; WAL mode; every write is a transaction, so a crash loses no saved
recipe. Run artifacts live in files under data/runs/<id>/ (written atomically).
"""

from __future__ import annotations

import fcntl
import hashlib
import json
import os
import re
import sqlite3
import threading
import time
from pathlib import Path
from typing import Any

# the same patterns (+ max lengths 80 / 120) are declared in the OpenAPI schema (deps.py); a dot is
# never followed by a dot, so '..' cannot occur (no look-ahead: JSON Schema and pydantic's engine)
GRAPH_NAME_PATTERN = r"^[A-Za-z0-9](?:[A-Za-z0-9 _-]|\.[A-Za-z0-9 _-])*\.?$"
FILE_NAME_PATTERN = r"^[A-Za-z0-9](?:[A-Za-z0-9_-]|\.[A-Za-z0-9_-])*\.?$"
RUN_ID_PATTERN = r"^[A-Za-z0-9]{1,40}$"
GRAPH_NAME = re.compile(GRAPH_NAME_PATTERN)
FILE_NAME = re.compile(FILE_NAME_PATTERN)

SCHEMA = """
CREATE TABLE IF NOT EXISTS graphs (
  name TEXT PRIMARY KEY, recipe TEXT NOT NULL, params_xml TEXT, example INTEGER DEFAULT 0,
  created REAL NOT NULL, updated REAL NOT NULL, revision INTEGER NOT NULL DEFAULT 1,
  params_revision INTEGER NOT NULL DEFAULT 1);
CREATE TABLE IF NOT EXISTS graph_files (
  graph TEXT NOT NULL, name TEXT NOT NULL, data BLOB NOT NULL, updated REAL NOT NULL,
  PRIMARY KEY (graph, name));
CREATE TABLE IF NOT EXISTS runs (
  id TEXT PRIMARY KEY, graph TEXT, recipe TEXT NOT NULL, inputs TEXT, status TEXT NOT NULL,
  progress REAL DEFAULT 0, error TEXT, summary TEXT, created REAL NOT NULL, started REAL, finished REAL);
CREATE TABLE IF NOT EXISTS run_params (run TEXT PRIMARY KEY, xml TEXT NOT NULL);
CREATE TABLE IF NOT EXISTS events (run TEXT NOT NULL, seq INTEGER NOT NULL, data TEXT NOT NULL,
  PRIMARY KEY (run, seq));
CREATE TABLE IF NOT EXISTS graph_revisions (graph TEXT NOT NULL, kind TEXT NOT NULL, revision INTEGER NOT NULL,
  time REAL NOT NULL, user TEXT, content TEXT, PRIMARY KEY (graph, kind, revision));
CREATE TABLE IF NOT EXISTS audit (id INTEGER PRIMARY KEY AUTOINCREMENT, time REAL NOT NULL, who TEXT,
  action TEXT NOT NULL, target TEXT, detail TEXT);
CREATE TABLE IF NOT EXISTS file_blobs (sha256 TEXT PRIMARY KEY, data BLOB NOT NULL);
CREATE TABLE IF NOT EXISTS graph_file_versions (graph TEXT NOT NULL, name TEXT NOT NULL, version INTEGER NOT NULL,
  sha256 TEXT NOT NULL, size INTEGER NOT NULL, time REAL NOT NULL, user TEXT, PRIMARY KEY (graph, name, version));
"""


# columns added after the first release: (table, column, declaration); added to older databases
# at start-up (a graph saved before revisions existed is revision 1)
MIGRATIONS = (
    ("graphs", "revision", "INTEGER NOT NULL DEFAULT 1"),
    ("graphs", "owner", "TEXT"),  # the token name that created it (#26: editors change their own)
    ("graphs", "params_revision", "INTEGER NOT NULL DEFAULT 1"),
    ("graph_files", "sha256", "TEXT"),
)


LOCK_SUFFIX = ".lock"


class DataFolderBusy(Exception):
    """The data folder's lock is held the other way (a restore while a server starts, or a server
    while a restore runs)."""


def lock_file(db: str | Path, *, exclusive: bool, timeout: float = 0.0, busy: str = "") -> int:
    """An flock on `<db>.lock` as an open file descriptor (close it to release). Servers hold it
    shared (several may share a folder), `waamflow restore` exclusive. The kernel drops it when the
    process ends, even by kill -9: a lock is never stale. DataFolderBusy after `timeout` s."""
    path = Path(str(db) + LOCK_SUFFIX)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd = os.open(path, os.O_RDWR | os.O_CREAT | os.O_CLOEXEC, 0o600)
    deadline = time.monotonic() + timeout
    while True:
        try:
            fcntl.flock(fd, (fcntl.LOCK_EX if exclusive else fcntl.LOCK_SH) | fcntl.LOCK_NB)
            return fd
        except BlockingIOError:
            if time.monotonic() >= deadline:
                os.close(fd)
                raise DataFolderBusy(busy or f"{path.parent} is in use") from None
            time.sleep(0.05)


class RevisionConflict(Exception):
    """A write with an expected revision (If-Match) that is no longer the stored one. `current`
    is the stored revision (None: the graph does not exist) and `content` the stored version."""

    def __init__(self, current: int | None, content: Any) -> None:
        super().__init__(f"stored revision is {current}")
        self.current = current
        self.content = content


def valid_graph_name(name: str) -> bool:
    return len(name) <= 80 and bool(GRAPH_NAME.match(name)) and ".." not in name


def valid_file_name(name: str) -> bool:
    return len(name) <= 120 and bool(FILE_NAME.match(name)) and ".." not in name


class Store:
    def __init__(self, path: str | Path, *, lock_timeout: float = 30.0) -> None:
        self.path = Path(path)
        self.path.parent.mkdir(parents=True, exist_ok=True)
        # held while the store is open: `waamflow restore` refuses while any server holds it
        self._folder_lock = lock_file(
            self.path,
            exclusive=False,
            timeout=lock_timeout,
            busy=f"{self.path.parent} is being restored (waamflow restore): start the server when it has finished",
        )
        self._lock = threading.RLock()
        try:
            self._conn = sqlite3.connect(str(self.path), check_same_thread=False, timeout=30)
            self._conn.row_factory = sqlite3.Row
            self._conn.execute("PRAGMA journal_mode=WAL")
            self._conn.executescript(SCHEMA)
            self._migrate()
            self._conn.commit()
        except BaseException:
            os.close(self._folder_lock)
            raise

    def _migrate(self) -> None:
        for table, column, decl in MIGRATIONS:
            have = {r["name"] for r in self._conn.execute(f"PRAGMA table_info({table})")}
            if column not in have:
                self._conn.execute(f"ALTER TABLE {table} ADD COLUMN {column} {decl}")

    def close(self) -> None:
        with self._lock:
            self._conn.close()
            if self._folder_lock >= 0:
                os.close(self._folder_lock)
                self._folder_lock = -1

    def _exec(self, sql: str, args: tuple = ()) -> sqlite3.Cursor:
        with self._lock:
            cur = self._conn.execute(sql, args)
            self._conn.commit()
            return cur

    def _query(self, sql: str, args: tuple = ()) -> list[sqlite3.Row]:
        with self._lock:
            return self._conn.execute(sql, args).fetchall()

    # graphs
    def list_graphs(self) -> list[dict]:
        rows = self._query(
            "SELECT name, recipe, example, updated, coalesce(length(params_xml), 0) > 0 AS has_params, "
            "owner FROM graphs ORDER BY name"
        )
        out = []
        for r in rows:
            rec = json.loads(r["recipe"])
            out.append(
                {
                    "name": r["name"],
                    "description": rec.get("description", ""),
                    "example": bool(r["example"]),
                    "updated": r["updated"],
                    "has_params": bool(r["has_params"]),
                    "owner": r["owner"],
                }
            )
        return out

    def get_graph(self, name: str) -> dict | None:
        rows = self._query("SELECT recipe FROM graphs WHERE name=?", (name,))
        return json.loads(rows[0]["recipe"]) if rows else None

    def is_example(self, name: str) -> bool:
        rows = self._query("SELECT example FROM graphs WHERE name=?", (name,))
        return bool(rows and rows[0]["example"])

    def graph_revision(self, name: str) -> int | None:
        rows = self._query("SELECT revision FROM graphs WHERE name=?", (name,))
        return int(rows[0]["revision"]) if rows else None

    def params_revision(self, name: str) -> int | None:
        rows = self._query("SELECT params_revision FROM graphs WHERE name=?", (name,))
        return int(rows[0]["params_revision"]) if rows else None

    def graph_owner(self, name: str) -> str | None:
        """The token name that created the graph (None: before owners were recorded, or no graph)."""
        rows = self._query("SELECT owner FROM graphs WHERE name=?", (name,))
        return rows[0]["owner"] if rows else None

    def put_graph(
        self,
        name: str,
        recipe: dict,
        *,
        example: bool = False,
        expect: int | None = None,
        user: str | None = None,
        owner: str | None = None,
    ) -> tuple[bool, int]:
        """Insert or replace; returns (created, new revision). `expect`: the revision the writer
        loaded (If-Match); when it is not the stored one → RevisionConflict and nothing changes
        (checked and written under one lock and one transaction)."""
        now = time.time()
        text = json.dumps(recipe)
        with self._lock:
            row = self._conn.execute("SELECT recipe, revision FROM graphs WHERE name=?", (name,)).fetchone()
            if expect is not None and (row is None or int(row["revision"]) != expect):
                raise RevisionConflict(
                    int(row["revision"]) if row else None, json.loads(row["recipe"]) if row else None
                )
            if row is not None:
                rev = int(row["revision"]) + 1
                self._conn.execute(
                    "UPDATE graphs SET recipe=?, updated=?, example=?, revision=? WHERE name=?",
                    (text, now, int(example), rev, name),
                )
            else:
                # a name used before (deleted) continues its history: revisions only grow
                last = self._conn.execute(
                    "SELECT max(revision) FROM graph_revisions WHERE graph=? AND kind='recipe'", (name,)
                ).fetchone()[0]
                rev = int(last or 0) + 1
                # ... and so does its parameter XML's: the first XML saved is the next revision, and
                # those of the deleted graph stay for a restore (`reattach_params`)
                last_params = self._conn.execute(
                    "SELECT max(revision) FROM graph_revisions WHERE graph=? AND kind='params'", (name,)
                ).fetchone()[0]
                self._conn.execute(
                    "INSERT INTO graphs (name, recipe, example, created, updated, revision, owner, "
                    "params_revision) VALUES (?,?,?,?,?,?,?,?)",
                    (name, text, int(example), now, now, rev, owner or user, int(last_params or 0) + 1),
                )
            self._conn.execute(
                "INSERT OR REPLACE INTO graph_revisions (graph, kind, revision, time, user, content) "
                "VALUES (?,?,?,?,?,?)",
                (name, "recipe", rev, now, user, text),
            )
            self._conn.commit()
        return row is None, rev

    def list_revisions(self, name: str, kind: str = "recipe") -> list[dict]:
        rows = self._query(
            "SELECT revision, time, user FROM graph_revisions WHERE graph=? AND kind=? ORDER BY revision DESC",
            (name, kind),
        )
        return [dict(r) for r in rows]

    def get_revision(self, name: str, revision: int, kind: str = "recipe") -> str | None:
        rows = self._query(
            "SELECT content FROM graph_revisions WHERE graph=? AND kind=? AND revision=?", (name, kind, revision)
        )
        return rows[0]["content"] if rows else None

    def delete_graph(self, name: str) -> bool:
        """Delete the graph, its files (their space is freed) and its current parameter XML. Kept for an
        admin's restore: the recipe's and the XML's revisions, and a 'deleted' entry recording the
        owner and the names of the files that went (`deleted_info`)."""
        with self._lock:
            row = self._conn.execute("SELECT revision, owner FROM graphs WHERE name=?", (name,)).fetchone()
            if row is not None:
                files = [
                    r[0]
                    for r in self._conn.execute("SELECT name FROM graph_files WHERE graph=? ORDER BY name", (name,))
                ]
                self._conn.execute(
                    "INSERT OR REPLACE INTO graph_revisions (graph, kind, revision, time, user, content) "
                    "VALUES (?,?,?,?,?,?)",
                    (name, "deleted", int(row["revision"]), time.time(), row["owner"], json.dumps({"files": files})),
                )
            cur = self._conn.execute("DELETE FROM graphs WHERE name=?", (name,))
            self._conn.execute("DELETE FROM graph_files WHERE graph=?", (name,))
            self._conn.execute("DELETE FROM graph_file_versions WHERE graph=?", (name,))
            self._conn.execute("DELETE FROM file_blobs WHERE sha256 NOT IN (SELECT sha256 FROM graph_file_versions)")
            # a graph's history (recipe and parameter XML) outlives it: revisions only grow, and an
            # admin's restore brings the XML back
            self._conn.commit()
            return cur.rowcount > 0

    def deleted_info(self, name: str) -> dict | None:
        """The last delete of `name`: {"owner", "files": names of the files deleted with it, "revision"}."""
        rows = self._query(
            "SELECT revision, user, content FROM graph_revisions WHERE graph=? AND kind='deleted' "
            "ORDER BY revision DESC LIMIT 1",
            (name,),
        )
        if not rows:
            return None
        return {
            "owner": rows[0]["user"],
            "revision": int(rows[0]["revision"]),
            "files": json.loads(rows[0]["content"] or "{}").get("files", []),
        }

    def reattach_params(self, name: str) -> int | None:
        """A restored graph without parameter XML gets its last saved one back (that revision);
        None when it never had one."""
        with self._lock:
            row = self._conn.execute(
                "SELECT revision, content FROM graph_revisions WHERE graph=? AND kind='params' "
                "ORDER BY revision DESC LIMIT 1",
                (name,),
            ).fetchone()
            if row is None:
                return None
            cur = self._conn.execute(
                "UPDATE graphs SET params_xml=?, params_revision=? WHERE name=? AND coalesce(params_xml, '') = ''",
                (row["content"], int(row["revision"]), name),
            )
            self._conn.commit()
            return int(row["revision"]) if cur.rowcount else None

    def get_params_xml(self, name: str) -> str | None:
        rows = self._query("SELECT params_xml FROM graphs WHERE name=?", (name,))
        return rows[0]["params_xml"] if rows else None

    def put_params_xml(self, name: str, xml: str, *, expect: int | None = None, user: str | None = None) -> int:
        """Replace the graph's parameter XML; returns its new revision. The first XML of a graph is
        revision 1; `expect` as in put_graph."""
        now = time.time()
        with self._lock:
            row = self._conn.execute("SELECT params_xml, params_revision FROM graphs WHERE name=?", (name,)).fetchone()
            if row is None:
                raise RevisionConflict(None, None)
            cur = int(row["params_revision"])
            if expect is not None and cur != expect:
                raise RevisionConflict(cur, row["params_xml"])
            rev = cur + 1 if row["params_xml"] else cur
            self._conn.execute(
                "UPDATE graphs SET params_xml=?, updated=?, params_revision=? WHERE name=?", (xml, now, rev, name)
            )
            self._conn.execute(
                "INSERT OR REPLACE INTO graph_revisions (graph, kind, revision, time, user, content) "
                "VALUES (?,?,?,?,?,?)",
                (name, "params", rev, now, user, xml),
            )
            self._conn.commit()
        return rev

    def list_files(self, graph: str) -> list[dict]:
        """name, size, updated and the sha256 of the content the name points at now (computed once
        for files stored before content hashes existed)."""
        rows = self._query(
            "SELECT name, length(data) AS size, updated, sha256 FROM graph_files WHERE graph=? ORDER BY name", (graph,)
        )
        out = [dict(r) for r in rows]
        for f in out:
            if not f["sha256"]:
                data = self._query("SELECT data FROM graph_files WHERE graph=? AND name=?", (graph, f["name"]))[0][
                    "data"
                ]
                f["sha256"] = hashlib.sha256(bytes(data)).hexdigest()
                self._exec("UPDATE graph_files SET sha256=? WHERE graph=? AND name=?", (f["sha256"], graph, f["name"]))
        return out

    def get_files(self, graph: str) -> dict[str, bytes]:
        rows = self._query("SELECT name, data FROM graph_files WHERE graph=?", (graph,))
        return {r["name"]: bytes(r["data"]) for r in rows}

    def put_file(self, graph: str, name: str, data: bytes, user: str | None = None) -> dict:
        """Store `data` under its sha256 and point `name` at it (the graph's current file of that
        name, as before); every content a name pointed at stays readable by hash (a recipe pins the
        exact content it runs with, #25). Returns {sha256, size, version, previous} (previous: the
        sha256 the name pointed at before, None for a new name)."""
        digest = hashlib.sha256(data).hexdigest()
        now = time.time()
        with self._lock:
            prev = self._conn.execute(
                "SELECT sha256, data FROM graph_files WHERE graph=? AND name=?", (graph, name)
            ).fetchone()
            previous = (prev["sha256"] or hashlib.sha256(bytes(prev["data"])).hexdigest()) if prev else None
            last = self._conn.execute(
                "SELECT max(version) FROM graph_file_versions WHERE graph=? AND name=?", (graph, name)
            ).fetchone()[0]
            if previous is not None and last is None:  # a file from before versions: its content is version 1
                self._conn.execute(
                    "INSERT OR IGNORE INTO file_blobs (sha256, data) VALUES (?,?)", (previous, prev["data"])
                )
                self._conn.execute(
                    "INSERT INTO graph_file_versions (graph, name, version, sha256, size, time, user) "
                    "VALUES (?,?,?,?,?,?,?)",
                    (graph, name, 1, previous, len(prev["data"]), now, None),
                )
                last = 1
            version = int(last or 0) + 1
            self._conn.execute("INSERT OR IGNORE INTO file_blobs (sha256, data) VALUES (?,?)", (digest, data))
            self._conn.execute(
                "INSERT INTO graph_file_versions (graph, name, version, sha256, size, time, user) "
                "VALUES (?,?,?,?,?,?,?)",
                (graph, name, version, digest, len(data), now, user),
            )
            self._conn.execute(
                "INSERT OR REPLACE INTO graph_files (graph, name, data, updated, sha256) VALUES (?,?,?,?,?)",
                (graph, name, data, now, digest),
            )
            self._conn.commit()
        return {"sha256": digest, "size": len(data), "version": version, "previous": previous}

    def list_file_versions(self, graph: str, name: str) -> list[dict]:
        """Every content the graph's file `name` pointed at, newest first."""
        rows = self._query(
            "SELECT version, sha256, size, time, user FROM graph_file_versions WHERE graph=? AND name=? "
            "ORDER BY version DESC",
            (graph, name),
        )
        if not rows:  # a file from before versions
            return [
                {"version": 1, "sha256": f["sha256"], "size": f["size"], "time": f["updated"], "user": None}
                for f in self.list_files(graph)
                if f["name"] == name
            ]
        return [dict(r) for r in rows]

    def get_file_content(self, graph: str, sha256: str) -> bytes | None:
        """Content with this sha256 that one of the graph's files held (another graph's uploads stay
        out of reach, whatever hash is asked for)."""
        rows = self._query(
            "SELECT b.data FROM file_blobs b JOIN graph_file_versions v ON v.sha256=b.sha256 "
            "WHERE v.graph=? AND b.sha256=? LIMIT 1",
            (graph, sha256),
        )
        if rows:
            return bytes(rows[0]["data"])
        for f in self.get_files(graph).values():  # a file from before versions
            if hashlib.sha256(f).hexdigest() == sha256:
                return f
        return None

    # runs
    def create_run(
        self, run_id: str, graph: str | None, recipe: dict, inputs: dict | None, params_xml: str | None = None
    ) -> None:
        """`params_xml`: the draft parameter XML the run used instead of the graph's saved one (kept
        with the run, never as the graph's XML, so the run can be rebuilt exactly)."""
        with self._lock:
            self._conn.execute(
                "INSERT INTO runs (id, graph, recipe, inputs, status, created) VALUES (?,?,?,?,?,?)",
                (run_id, graph, json.dumps(recipe), json.dumps(inputs or {}), "queued", time.time()),
            )
            if params_xml is not None:
                self._conn.execute("INSERT OR REPLACE INTO run_params (run, xml) VALUES (?,?)", (run_id, params_xml))
            self._conn.commit()

    def get_run_params_xml(self, run_id: str) -> str | None:
        """The draft parameter XML a run used, or None when it used the graph's saved XML."""
        rows = self._query("SELECT xml FROM run_params WHERE run=?", (run_id,))
        return rows[0]["xml"] if rows else None

    def latest_finished_run(self, key: str) -> dict | None:
        """The newest run that finished ('done') of the graph named `key`, else the run with id
        `key` if it finished (an unsaved recipe's runs are known by their id)."""
        rows = self._query(
            "SELECT id FROM runs WHERE graph=? AND status='done' ORDER BY finished DESC, created DESC LIMIT 1", (key,)
        )
        if not rows:
            rows = self._query("SELECT id FROM runs WHERE id=? AND status='done'", (key,))
        return self.get_run(rows[0]["id"]) if rows else None

    def update_run(self, run_id: str, **fields: Any) -> None:
        cols, vals = [], []
        for k, v in fields.items():
            cols.append(f"{k}=?")
            vals.append(json.dumps(v) if k in ("error", "summary") and v is not None else v)
        self._exec(f"UPDATE runs SET {', '.join(cols)} WHERE id=?", (*vals, run_id))

    def get_run(self, run_id: str) -> dict | None:
        rows = self._query("SELECT * FROM runs WHERE id=?", (run_id,))
        if not rows:
            return None
        r = dict(rows[0])
        for k in ("error", "summary", "recipe", "inputs"):
            if r.get(k):
                r[k] = json.loads(r[k])
        return r

    def list_runs(self, limit: int = 50, graph: str | None = None) -> list[dict]:
        where, args = ("WHERE graph=? ", (graph,)) if graph is not None else ("", ())
        rows = self._query(
            f"SELECT id, graph, status, progress, created, finished FROM runs {where}ORDER BY created DESC LIMIT ?",
            (*args, limit),
        )
        return [dict(r) for r in rows]

    def add_events(self, run_id: str, events: list[dict]) -> None:
        with self._lock:
            self._conn.executemany(
                "INSERT OR REPLACE INTO events (run, seq, data) VALUES (?,?,?)",
                [(run_id, e["seq"], json.dumps(e)) for e in events],
            )
            self._conn.commit()

    def get_events(self, run_id: str, after: int = 0) -> list[dict]:
        rows = self._query("SELECT data FROM events WHERE run=? AND seq>? ORDER BY seq", (run_id, after))
        return [json.loads(r["data"]) for r in rows]

    def mark_interrupted(self) -> int:
        """At start-up: runs left queued/running by a crash or restart become 'interrupted'."""
        err = json.dumps(
            {
                "kind": "interrupted",
                "message": "the server stopped before the run finished",
                "node": None,
                "layer": None,
                "section": None,
                "field": None,
                "text": "the server stopped before the run finished",
            }
        )
        cur = self._exec(
            "UPDATE runs SET status='interrupted', error=?, finished=? WHERE status IN ('queued','running')",
            (err, time.time()),
        )
        return cur.rowcount

    # audit log: who (token name) did what, when
    def audit(self, who: str | None, action: str, target: str | None = None, detail: dict | None = None) -> None:
        self._exec(
            "INSERT INTO audit (time, who, action, target, detail) VALUES (?,?,?,?,?)",
            (time.time(), who, action, target, json.dumps(detail) if detail else None),
        )

    def list_audit(
        self, limit: int = 100, before: int | None = None, who: str | None = None, action: str | None = None
    ) -> list[dict]:
        where: list[str] = []
        args: list[int | str] = []
        if before is not None:
            where.append("id < ?")
            args.append(before)
        if who is not None:
            where.append("who = ?")
            args.append(who)
        if action is not None:
            where.append("action = ?")
            args.append(action)
        sql = "SELECT * FROM audit" + (f" WHERE {' AND '.join(where)}" if where else "") + " ORDER BY id DESC LIMIT ?"
        rows = self._query(sql, (*args, limit))
        return [{**dict(r), "detail": json.loads(r["detail"]) if r["detail"] else None} for r in rows]
