"""Helpers shared by the API tests."""

import time


def wait_for_run(client, run_id: str, timeout: float = 30.0) -> dict:
    """Poll GET /api/runs/{id} until the run has ended; returns its status body."""
    t0 = time.time()
    while time.time() - t0 < timeout:
        r = client.get(f"/api/runs/{run_id}").json()
        if r["status"] in ("done", "failed", "cancelled"):
            return r
        time.sleep(0.05)
    raise AssertionError(f"run {run_id} did not finish within {timeout} s")
