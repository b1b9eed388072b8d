"""Issue 26 fault 8: half-open connections must not exhaust the server. `waamflow serve` closes a
connection that sends no request head within --header-timeout and connections beyond
--max-connections; /api/health answers throughout."""

import os
import socket
import subprocess
import sys
import time

import httpx
import pytest


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


@pytest.fixture(scope="module")
def server(tmp_path_factory):
    tmp_path = tmp_path_factory.mktemp("serve")
    port = _free_port()
    env = {
        **os.environ,
        "WAAMFLOW_START_VIEWER": "false",
        "WAAMFLOW_GRAPHS_DIR": str(tmp_path / "none"),
        "WAAMFLOW_MAX_CONNECTIONS_PER_CLIENT": "10",
    }
    proc = subprocess.Popen(
        [
            sys.executable,
            "-m",
            "waamflow.cli",
            "serve",
            "--port",
            str(port),
            "--data",
            str(tmp_path / "data"),
            "--viewer-port",
            "0",
            "--header-timeout",
            "1",
            "--max-connections",
            "30",
        ],
        env=env,
        stdout=subprocess.DEVNULL,
        stderr=subprocess.PIPE,
    )
    base = f"http://127.0.0.1:{port}"
    for _ in range(300):
        try:
            if httpx.get(base + "/api/health", timeout=1).status_code == 200:
                break
        except httpx.HTTPError:
            time.sleep(0.05)
    else:
        proc.kill()
        raise AssertionError(proc.stderr.read().decode()[-2000:])
    yield port, base
    proc.terminate()
    proc.wait(10)


def _closed(sock: socket.socket, within: float) -> bool:
    sock.settimeout(within)
    try:
        return sock.recv(1) == b""
    except (socket.timeout, TimeoutError):
        return False
    except ConnectionResetError:
        return True


def test_half_open_and_slow_heads_are_closed(server):
    port, base = server
    idle = socket.create_connection(("127.0.0.1", port))
    slow = socket.create_connection(("127.0.0.1", port))
    slow.sendall(b"GET /api/health HTTP/1.1\r\nHost: 127.0.0.1\r\n")  # head never finished
    t0 = time.monotonic()
    assert _closed(idle, 3.0) and _closed(slow, 3.0)
    assert 0.8 <= time.monotonic() - t0 < 3.0
    # a slowloris that trickles bytes does not restart the clock
    drip = socket.create_connection(("127.0.0.1", port))
    t0 = time.monotonic()
    closed = False
    for b in b"GET /api/health HTTP/1.1\r\nX-A: " + b"a" * 40:
        try:
            drip.sendall(bytes([b]))
        except OSError:
            closed = True
            break
        if _closed(drip, 0.1):
            closed = True
            break
    assert closed and time.monotonic() - t0 < 3.0
    assert httpx.get(base + "/api/health").status_code == 200


def _open(port, addr, n):
    """n connections from `addr`; each sends one request and waits for its answer (then it idles as
    keep-alive, past the 1 s head timeout); one the server closed at once has no answer."""
    out = [socket.create_connection(("127.0.0.1", port), source_address=(addr, 0)) for _ in range(n)]
    answered = []
    for s in out:
        try:
            s.sendall(b"GET /api/health HTTP/1.1\r\nHost: 127.0.0.1\r\n\r\n")
            s.settimeout(2)
            answered.append(s.recv(4096).startswith(b"HTTP/1.1 200"))
        except OSError:
            answered.append(False)
    return out, answered


def test_connections_over_the_caps_are_closed_and_health_answers(server):
    port, base = server
    one, ok = _open(port, "127.0.0.3", 25)  # one address: 10 kept, 15 closed at once
    assert sum(ok) == 10
    assert httpx.get(base + "/api/health").status_code == 200  # others still get in
    more, ok4 = _open(port, "127.0.0.4", 10)
    more5, ok5 = _open(port, "127.0.0.5", 10)  # 30 held: the server's cap
    assert 15 <= sum(ok4) + sum(ok5) <= 20  # (closing connections count until the server sees them go)
    late, ok6 = _open(port, "127.0.0.6", 10)  # within its own cap, but the server is full
    assert sum(ok6) <= 30 - 10 - sum(ok4) - sum(ok5) and sum(ok6) <= 5
    more += more5
    for s in one + more + late:
        s.close()
    time.sleep(0.3)
    assert httpx.get(base + "/api/health").status_code == 200
