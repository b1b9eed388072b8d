"""Soak: a real `waamflow serve` (with a token file) under 50 concurrent clients and the hostile
inputs of issue 26 at the same time; reports server RSS (its whole process tree) and latency,
and checks that /api/health answered throughout.

Clients: each loops over health, the node catalog, the graph list, a shipped recipe, saving and
reading back its own graph, and now and then a one-layer preview or a run (429 when the queue is
full counts as an answer, not an error). Hostile, all at once: 10 GB Content-Length uploads,
a chunked 300 MB recipe, a tall part over max_layers (estimate → 422), a 3MF zip bomb (80 MB declared; the soak server's max_uncompressed_mb is 64), previews
abandoned by their client, wrong tokens from another address (throttled → 429), 1,500 half-open
connections and slowloris heads.

`make soak` runs it for 60 s (`python bench/bench_soak.py [SECONDS] [CLIENTS]`); `make bench`
includes it (bench/run.py) with the same defaults. Results: `soak_p99_ms` (legitimate requests),
`soak_peak_rss_mb`, `soak_5xx`, `soak_health_failures`, `soak_requests`.
"""

from __future__ import annotations

import io
import json
import os
import socket
import struct
import subprocess
import sys
import tempfile
import threading
import time
import zipfile
from pathlib import Path

import httpx
import numpy as np
import psutil

ROOT = Path(__file__).resolve().parents[1]
TOKEN = "soak-" + os.urandom(12).hex()
BAD = "wrong-" + os.urandom(12).hex()


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def _box_stl(height: float, size: float = 20.0) -> bytes:
    v = np.array([[x, y, z] for x in (0, size) for y in (0, size) for z in (0, height)], dtype=np.float32)
    faces = [
        (0, 1, 3),
        (0, 3, 2),
        (4, 6, 7),
        (4, 7, 5),
        (0, 4, 5),
        (0, 5, 1),
        (2, 3, 7),
        (2, 7, 6),
        (0, 2, 6),
        (0, 6, 4),
        (1, 5, 7),
        (1, 7, 3),
    ]
    out = io.BytesIO()
    out.write(b"\0" * 80 + struct.pack("<I", len(faces)))
    for f in faces:
        out.write(struct.pack("<3f", 0, 0, 0) + v[list(f)].tobytes() + b"\0\0")
    return out.getvalue()


def _sliced(path: str) -> dict:
    return {
        "format": "waamflow/1",
        "name": "soak",
        "nodes": [
            {"id": "part", "type": "mesh", "params": {"path": path}},
            {"id": "layers", "type": "slice", "params": {"layer_height": 1.5}},
        ],
        "edges": [{"from": "part.mesh", "to": "layers.mesh"}],
    }


def start_server(tmp: Path, port: int) -> subprocess.Popen:
    tf = tmp / "tokens.txt"
    tf.write_text(f"soak:{TOKEN}\n")
    tf.chmod(0o600)
    env = {
        **os.environ,
        "WAAMFLOW_START_VIEWER": "false",
        "WAAMFLOW_MAX_LAYERS": "2000",
        "WAAMFLOW_LAYER_WORKERS": "1",
        "WAAMFLOW_MAX_UNCOMPRESSED_MB": "64",
    }
    return subprocess.Popen(
        [
            sys.executable,
            "-m",
            "waamflow.cli",
            "serve",
            "--port",
            str(port),
            "--data",
            str(tmp / "data"),
            "--viewer-port",
            "0",
            "--token-file",
            str(tf),
            "--graphs",
            str(ROOT / "graphs"),
            "--header-timeout",
            "5",
        ],
        env=env,
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
    )


class Soak:
    def __init__(self, base: str, port: int, seconds: float, clients: int, server: psutil.Process) -> None:
        self.base, self.port, self.seconds, self.clients, self.server = base, port, seconds, clients, server
        self.stop = threading.Event()
        self.lat: list[float] = []
        self.codes: dict[int, int] = {}
        self.hostile: dict[str, dict[int | str, int]] = {}
        self.lock = threading.Lock()
        self.rss: list[float] = []
        self.health_fail = 0
        self.health_n = 0
        self.auth = {"Authorization": f"Bearer {TOKEN}"}

    def note(self, kind: str, code) -> None:
        with self.lock:
            d = self.hostile.setdefault(kind, {})
            d[code] = d.get(code, 0) + 1

    # ---- legitimate clients -------------------------------------------------------------------
    def client(self, k: int) -> None:
        rng = np.random.default_rng(k)
        name = f"soak-{k}"
        recipe = json.loads((ROOT / "graphs" / "rectangle-study.json").read_text())
        with httpx.Client(base_url=self.base, headers=self.auth, timeout=60) as c:
            i = 0
            while not self.stop.is_set():
                i += 1
                r = rng.random()
                t0 = time.perf_counter()
                try:
                    if r < 0.25:
                        resp = c.get("/api/health")
                    elif r < 0.45:
                        resp = c.get("/api/graphs")
                    elif r < 0.6:
                        resp = c.get("/api/graphs/rectangle-study")
                    elif r < 0.7:
                        resp = c.get("/api/nodes")
                    elif r < 0.85:
                        resp = c.put(f"/api/graphs/{name}", json=recipe)
                    elif r < 0.985:
                        resp = c.get("/api/runs")
                    elif r < 0.995:
                        resp = c.post("/api/preview", json={"recipe": recipe, "node": "simulate", "layer": 0})
                    else:
                        resp = c.post("/api/runs", json={"graph": "rectangle-study"})
                    code = resp.status_code
                except httpx.HTTPError:
                    code = -1
                dt = time.perf_counter() - t0
                with self.lock:
                    self.lat.append(dt)
                    self.codes[code] = self.codes.get(code, 0) + 1

    # ---- hostile inputs -----------------------------------------------------------------------
    def big_uploads(self) -> None:
        with httpx.Client(base_url=self.base, headers=self.auth, timeout=30) as c:
            c.put("/api/graphs/target", json=_sliced("tall.stl"))
        while not self.stop.wait(1.0):
            with httpx.Client(base_url=self.base, headers=self.auth, timeout=30) as c:  # a new connection each time

                def body():
                    for _ in range(10 * 1024):
                        yield b"x" * 2**20

                try:
                    r = c.put(
                        "/api/graphs/target/files/big.stl", content=body(), headers={"Content-Length": str(10 * 2**30)}
                    )
                    self.note("10 GB Content-Length", r.status_code)
                except httpx.HTTPError as e:
                    self.note("10 GB Content-Length", type(e).__name__)
                try:
                    chunks = (b"y" * 2**20 for _ in range(300))
                    r = c.put("/api/graphs/huge", content=chunks, headers={"Content-Type": "application/json"})
                    self.note("chunked 300 MB recipe", r.status_code)
                except httpx.HTTPError as e:
                    self.note("chunked 300 MB recipe", type(e).__name__)

    def estimates(self) -> None:
        bomb = io.BytesIO()
        with zipfile.ZipFile(bomb, "w", zipfile.ZIP_DEFLATED) as z:
            z.writestr("3D/3dmodel.model", bytes(80 * 2**20))  # 80 MB of zeros: ~80 kB compressed
        with httpx.Client(base_url=self.base, headers=self.auth, timeout=30) as c:
            c.put("/api/graphs/target", json=_sliced("tall.stl"))
            c.put("/api/graphs/target/files/tall.stl", content=_box_stl(30_000.0))  # 20,000 layers
            c.put("/api/graphs/target/files/bomb.3mf", content=bomb.getvalue())
            while not self.stop.wait(0.5):
                r = c.post("/api/runs", json={"graph": "target"})
                self.note("20,000-layer part (estimate)", r.status_code)
                r = c.post("/api/runs", json={"recipe": _sliced("bomb.3mf"), "graph": "target"})
                self.note("3MF zip bomb (80 MB declared, limit 64 MB)", r.status_code)
                r = c.post(
                    "/api/preview",
                    json={"recipe": _sliced("tall.stl"), "graph": "target", "node": "layers", "layer": 0},
                )
                self.note("preview of the 20,000-layer part", r.status_code)

    def abandoned_previews(self) -> None:
        recipe = json.loads((ROOT / "graphs" / "mpp-cross.json").read_text())
        while not self.stop.wait(0.5):
            try:
                with httpx.Client(base_url=self.base, headers=self.auth, timeout=0.2) as c:
                    c.post("/api/preview", json={"recipe": recipe, "node": recipe["nodes"][-1]["id"], "layer": 3})
                self.note("abandoned preview", "answered")
            except httpx.HTTPError:
                self.note("abandoned preview", "left")

    def wrong_tokens(self) -> None:
        transport = httpx.HTTPTransport(local_address="127.0.0.2")
        with httpx.Client(
            base_url=f"http://127.0.0.1:{self.port}",
            transport=transport,
            timeout=10,
            headers={"Authorization": f"Bearer {BAD}"},
        ) as c:
            while not self.stop.is_set():
                try:
                    self.note("wrong tokens (127.0.0.2)", c.get("/api/graphs").status_code)
                except httpx.HTTPError as e:
                    self.note("wrong tokens (127.0.0.2)", type(e).__name__)

    def half_open(self) -> None:
        socks = []
        while not self.stop.is_set():
            while len(socks) < 1500 and not self.stop.is_set():
                try:
                    s = socket.create_connection(("127.0.0.1", self.port), timeout=2, source_address=("127.0.0.3", 0))
                    if len(socks) % 3 == 0:
                        s.sendall(b"GET /api/health HTTP/1.1\r\nHost: x\r\n")  # slowloris: head never ends
                    socks.append(s)
                except OSError:
                    self.note("half-open connections", "refused")
                    break
            self.stop.wait(1.0)
            alive = []
            for s in socks:
                s.setblocking(False)
                try:
                    closed = s.recv(1) == b""
                except BlockingIOError:
                    closed = False
                except OSError:
                    closed = True
                if closed:
                    self.note("half-open connections", "closed by server")
                    s.close()
                else:
                    alive.append(s)
            socks = alive
        for s in socks:
            s.close()

    # ---- watchers -----------------------------------------------------------------------------
    def watch(self) -> None:
        with httpx.Client(base_url=self.base, timeout=5) as c:
            while not self.stop.wait(0.5):
                try:
                    rss = self.server.memory_info().rss + sum(
                        p.memory_info().rss for p in self.server.children(recursive=True)
                    )
                    self.rss.append(rss / 2**20)
                except psutil.Error:
                    self.rss.append(float("nan"))
                self.health_n += 1
                try:
                    if c.get("/api/health").status_code != 200:
                        self.health_fail += 1
                except httpx.HTTPError:
                    self.health_fail += 1

    def run(self) -> dict:
        threads = [threading.Thread(target=self.client, args=(k,), daemon=True) for k in range(self.clients)]
        threads += [
            threading.Thread(target=f, daemon=True)
            for f in (
                self.big_uploads,
                self.estimates,
                self.abandoned_previews,
                self.wrong_tokens,
                self.half_open,
                self.watch,
            )
        ]
        for t in threads:
            t.start()
        time.sleep(self.seconds)
        self.stop.set()
        for t in threads:
            t.join(timeout=70)
        lat = np.array(self.lat) * 1000
        return {
            "requests": len(lat),
            "p50_ms": float(np.percentile(lat, 50)) if len(lat) else None,
            "p95_ms": float(np.percentile(lat, 95)) if len(lat) else None,
            "p99_ms": float(np.percentile(lat, 99)) if len(lat) else None,
            "codes": {str(k): v for k, v in sorted(self.codes.items())},
            "hostile": {k: {str(c): n for c, n in v.items()} for k, v in self.hostile.items()},
            "peak_rss_mb": float(np.nanmax(self.rss)) if self.rss else None,
            "start_rss_mb": float(self.rss[0]) if self.rss else None,
            "health_checks": self.health_n,
            "health_failures": self.health_fail,
        }


def soak(seconds: float = 60.0, clients: int = 50) -> dict:
    with tempfile.TemporaryDirectory(prefix="waamflow-soak-") as d:
        tmp = Path(d)
        port = _free_port()
        proc = start_server(tmp, port)
        base = f"http://127.0.0.1:{port}"
        try:
            for _ in range(600):
                try:
                    if httpx.get(base + "/api/health", timeout=1).status_code == 200:
                        break
                except httpx.HTTPError:
                    time.sleep(0.05)
                if proc.poll() is not None:
                    raise RuntimeError(f"server exited with {proc.returncode}")
            out = Soak(base, port, seconds, clients, psutil.Process(proc.pid)).run()
            out["server_alive"] = proc.poll() is None
            return out
        finally:
            proc.terminate()
            try:
                proc.wait(15)
            except subprocess.TimeoutExpired:
                proc.kill()


def run(seconds: float = 60.0, clients: int = 50) -> list[dict]:
    r = soak(seconds, clients)
    notes = json.dumps(
        {k: r[k] for k in ("codes", "hostile", "p50_ms", "p95_ms", "start_rss_mb", "health_checks", "server_alive")}
    )
    return [
        {
            "name": "soak_p99_ms",
            "value": round(r["p99_ms"], 1),
            "unit": "ms",
            "notes": f"{clients} clients + hostile inputs, {seconds:g} s: {notes}",
        },
        {
            "name": "soak_peak_rss_mb",
            "value": round(r["peak_rss_mb"], 1),
            "unit": "MB",
            "notes": "server process tree (layer workers included)",
        },
        {"name": "soak_5xx", "value": sum(v for k, v in r["codes"].items() if k.startswith("5")), "unit": "count"},
        {
            "name": "soak_health_failures",
            "value": r["health_failures"],
            "unit": "count",
            "notes": f"of {r['health_checks']} checks every 0.5 s; server alive at the end: {r['server_alive']}",
        },
        {"name": "soak_requests", "value": r["requests"], "unit": "count"},
    ]


if __name__ == "__main__":
    secs = float(sys.argv[1]) if len(sys.argv) > 1 else 60.0
    n = int(sys.argv[2]) if len(sys.argv) > 2 else 50
    result = soak(secs, n)
    print(json.dumps(result, indent=1))
    ok = (
        result["server_alive"]
        and result["health_failures"] == 0
        and not any(k.startswith("5") for k in result["codes"])
    )
    sys.exit(0 if ok else 1)
