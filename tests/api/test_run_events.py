"""A run's terminal event (run_finished / run_failed / run_cancelled) is streamed only once its
record is stored: whoever sees it finds GET /api/runs/{id} ended, with its summary (the engine's
run_finished came first, seconds before the summary when the post-run work took long)."""

import threading
import time

import pytest
from fastapi.testclient import TestClient

import toy_nodes as toy
from api_util import wait_for_run as wait
from waamflow.api.app import create_app
from waamflow.engine.events import TERMINAL_KINDS
from waamflow.settings import Settings


@pytest.mark.parametrize("run_memory_mb", [0, 2048])  # in the server process, and in a process of its own
def test_terminal_event_after_the_record(tmp_path, run_memory_mb):
    s = Settings(
        data_dir=tmp_path / "data",
        graphs_dir=None,
        start_viewer=False,
        static_dir=None,
        workers=1,
        layer_workers=1,
        run_memory_mb=run_memory_mb,
    )
    with TestClient(create_app(s)) as c:
        runs = c.app.state.services.runs
        hook = runs.on_done

        def slow_hook(*args):  # the post-run work (viewer, parameter store) taking its time
            time.sleep(1.0)
            if hook is not None:
                hook(*args)

        runs.on_done = slow_hook
        seen: list[tuple[str, object, object]] = []
        stop = threading.Event()
        rid = c.post("/api/runs", json={"recipe": toy.chain(stack={"count": 3})}).json()["id"]

        def watch():
            while not stop.is_set():
                live = runs.live.get(rid)
                for e in list(live.events) if live is not None else []:
                    if e.get("kind") in TERMINAL_KINDS:
                        rec = runs.store.get_run(rid)
                        seen.append((e["kind"], rec["status"], rec["summary"]))
                        return
                time.sleep(0.005)

        t = threading.Thread(target=watch)
        t.start()
        run = wait(c, rid)
        stop.set()
        t.join()
        assert run["status"] == "done" and run["summary"]["layer_count"] == 3
        for kind, status, summary in seen:  # empty when the event came after `live` was dropped: fine too
            assert kind == "run_finished" and status == "done" and summary is not None, seen
        events = c.get(f"/api/runs/{rid}/events", headers={"Accept": "text/event-stream"}).text
        assert events.count("run_finished") == 1
