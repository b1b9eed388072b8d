"""Headless Chromium screenshot of a web page over the DevTools protocol (tests and docs).

`--screenshot` alone fires at the load event, before viser's websocket has streamed the scene, and
`--virtual-time-budget` stalls on a live websocket; so we drive Chromium over CDP: open the page,
wait for its WebGL canvas, then capture until `ready(png)` accepts a frame (or time runs out).
WebGL runs on SwiftShader (software), so no GPU is needed.
"""

from __future__ import annotations

import base64
import json
import os
import signal
import subprocess
import tempfile
import time
import urllib.request
from pathlib import Path
from typing import Callable

CHROMIUM = "/usr/bin/chromium"
FLAGS = (
    "--headless",
    "--no-sandbox",
    "--disable-gpu",
    "--use-angle=swiftshader",
    "--enable-unsafe-swiftshader",
    "--disable-background-networking",
    "--disable-component-update",
    "--disable-sync",
    "--no-first-run",
    "--disable-dev-shm-usage",
    "--hide-scrollbars",
    "--mute-audio",
)


class _Cdp:
    """Minimal synchronous CDP client on one page target."""

    def __init__(self, ws_url: str) -> None:
        from websockets.sync.client import connect

        self.ws = connect(ws_url, max_size=None, open_timeout=20)
        self.next_id = 0

    def call(self, method: str, timeout: float = 30.0, **params) -> dict:
        self.next_id += 1
        my_id = self.next_id
        self.ws.send(json.dumps({"id": my_id, "method": method, "params": params}))
        deadline = time.monotonic() + timeout
        while True:
            msg = json.loads(self.ws.recv(timeout=max(deadline - time.monotonic(), 0.01)))
            if msg.get("id") == my_id:
                if "error" in msg:
                    raise RuntimeError(f"CDP {method}: {msg['error']}")
                return msg.get("result", {})

    def close(self) -> None:
        self.ws.close()


def _devtools_port(profile: Path, proc: subprocess.Popen, timeout: float) -> int:
    marker = profile / "DevToolsActivePort"
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        if proc.poll() is not None:
            raise RuntimeError(f"chromium exited with code {proc.returncode}")
        if marker.exists():
            lines = marker.read_text().split()
            if lines:
                return int(lines[0])
        time.sleep(0.1)
    raise TimeoutError("chromium did not open its DevTools port")


def _stop_group(proc: subprocess.Popen) -> None:
    """Terminate Chromium and every helper process it started (its own session/group)."""
    for sig, wait_s in ((signal.SIGTERM, 10), (signal.SIGKILL, 10)):
        try:
            os.killpg(proc.pid, sig)
        except ProcessLookupError:
            return
        try:
            proc.wait(timeout=wait_s)
            time.sleep(0.2)  # helpers leave after the browser process
            return
        except subprocess.TimeoutExpired:
            continue


def capture(
    url: str,
    out_png: str | os.PathLike,
    *,
    width: int = 1280,
    height: int = 800,
    timeout_s: float = 90.0,
    ready: Callable[[bytes], bool] | None = None,
    chromium: str = CHROMIUM,
) -> bytes:
    """Open `url` in headless Chromium, wait for a <canvas>, and save a PNG to `out_png` once
    `ready(png_bytes)` is true (checked twice a second; the last frame is kept on timeout).
    Returns the PNG bytes."""
    out_png = Path(out_png)
    out_png.parent.mkdir(parents=True, exist_ok=True)
    # Chromium's helper processes may still write into the profile while it shuts down: the
    # whole process group is stopped, and what is left of the folder never fails the capture
    with tempfile.TemporaryDirectory(prefix="waamflow-chromium-", ignore_cleanup_errors=True) as tmp:
        profile = Path(tmp)
        proc = subprocess.Popen(
            [
                chromium,
                *FLAGS,
                f"--user-data-dir={profile}",
                "--remote-debugging-port=0",
                f"--window-size={width},{height}",
                "about:blank",
            ],
            stdout=subprocess.DEVNULL,
            stderr=subprocess.DEVNULL,
            start_new_session=True,
        )
        try:
            deadline = time.monotonic() + timeout_s
            port = _devtools_port(profile, proc, timeout=min(30.0, timeout_s))
            with urllib.request.urlopen(f"http://127.0.0.1:{port}/json/list", timeout=10) as r:
                pages = [t for t in json.load(r) if t.get("type") == "page"]
            cdp = _Cdp(pages[0]["webSocketDebuggerUrl"])
            try:
                cdp.call(
                    "Emulation.setDeviceMetricsOverride", width=width, height=height, deviceScaleFactor=1, mobile=False
                )
                cdp.call("Page.enable")
                cdp.call("Page.navigate", url=url)
                png = b""
                while time.monotonic() < deadline:
                    time.sleep(0.5)
                    has_canvas = cdp.call("Runtime.evaluate", expression="document.querySelectorAll('canvas').length")
                    if not has_canvas.get("result", {}).get("value"):
                        continue
                    shot = cdp.call("Page.captureScreenshot", format="png")
                    png = base64.b64decode(shot["data"])
                    if ready is None or ready(png):
                        break
            finally:
                cdp.close()
        finally:
            _stop_group(proc)
    out_png.write_bytes(png)
    return png
