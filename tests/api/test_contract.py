"""The OpenAPI schema is the contract. schemathesis' engine (what `schemathesis run` runs) generates
requests from it against the ASGI app in all its phases: examples, coverage, fuzzing (schema-valid
and schema-invalid data) and stateful (sequences that follow the schema's OpenAPI links: save a
graph → read, re-save, upload to, run and delete it; list graphs → run one; start a run → its
status, events, log, artifacts, cancel), and runs all its checks on every answer: no 5xx, every
status declared, every body (also each Server-Sent Event) matching its declared schema (one
ErrorResponse model for all 4xx), content types declared, schema-valid requests accepted and
schema-invalid ones rejected, authentication enforced where declared.

Two servers: one with a bearer token (every request carries it; the `ignored_auth` check re-sends
each operation without a token and with a wrong one and expects the declared 401 with the
ErrorResponse body) and one without tokens (a desktop server on loopback).

One documented exception: a recipe is a program. Its JSON Schema (Recipe) says what a recipe looks
like; whether its node types exist, its edges join existing ports of matching types and each node's
params are valid for that type is checked by the engine (422 naming node and field). Likewise a
zone-parameter XML file (root element, numbers, units, ranges; 422 naming layer, section and zone)
and a layer scan (PLY / XYZ / heights CSV of the layer the build expects; 422 with the reason).
So for the operations that take a recipe, a parameter file or a scan, 422 is an accepted answer to
schema-valid data; so are 404 (a graph name that is not saved) and 409 (writing a shipped example).
And `DELETE /api/runs/{id}` is the contract's cancel, not a removal: the run stays readable, so the
`use_after_free` check is off for the run's read operations (it stays on for graphs).

Bounded: a few examples per operation and a few dozen short scenarios (see the constants): about
1,500 cases with the token in ~30 s; `WAAMFLOW_CONTRACT_EXAMPLES=50` generates more."""

import json
import os
from collections import Counter
from pathlib import Path

import pytest
import schemathesis
from fastapi.testclient import TestClient
from schemathesis.engine import Status, events, from_schema

import toy_nodes as toy
from api_util import wait_for_run
from waamflow.api.app import create_app
from waamflow.settings import Settings

DOCUMENT_OPS = r"^/api/(runs|preview|graphs/\{name\}|graphs/\{name\}/params|builds/\{build_id\}/scans)$"
# DELETE /api/runs/{id} cancels a run (CONTRACT.md): the run stays readable afterwards (status
# "cancelled", its log and artifacts), so "deleted resource still available" does not apply to it;
# nor to a deleted graph's revisions: they stay readable so an admin can restore one (#26)
RUN_READS = r"^/api/runs/\{run_id\}(/.*)?$"
KEPT_HISTORY = r"^/api/graphs/\{name\}/revisions(/.*)?$"
TOKEN = "contract-token-0123456789abcdef"
ALL_PHASES = ("examples", "coverage", "fuzzing", "stateful")
AUTH = {"Authorization": f"Bearer {TOKEN}"}
EXAMPLES = int(os.environ.get("WAAMFLOW_CONTRACT_EXAMPLES", "8"))  # per operation and phase


def _config(phases, examples: int, scenarios: int, headers: dict | None = None) -> schemathesis.Config:
    cfg = {
        "phases": {p: {"enabled": p in phases} for p in ALL_PHASES},
        "generation": {"max-examples": examples, "mode": "all"},
        "checks": {"enabled": True},
        "operations": [
            {
                "include-path-regex": DOCUMENT_OPS,
                "checks": {
                    "positive_data_acceptance": {"expected-statuses": ["2xx", "401", "404", "409", "422", "429"]}
                },
            },
            {"include-path-regex": RUN_READS, "checks": {"use_after_free": {"enabled": False}}},
            {"include-path-regex": KEPT_HISTORY, "checks": {"use_after_free": {"enabled": False}}},
        ],
        "seed": 13,
    }
    cfg["phases"]["stateful"].update({"max-steps": 6, "generation": {"max-examples": scenarios}})
    if headers:
        cfg["headers"] = headers
    return schemathesis.Config.from_dict(cfg)


def _server(tmp: Path, token: str | None):
    gdir = tmp / "graphs"
    gdir.mkdir()
    # a shipped example under the name the schema's examples use (read-only, runnable)
    example = toy.chain(stack={"count": 2}, inputs={"pattern": "swiping", "speed": 40})
    (gdir / "rectangle-study.json").write_text(json.dumps(example))
    s = Settings(
        data_dir=tmp / "data",
        graphs_dir=gdir,
        start_viewer=False,
        static_dir=None,
        workers=1,
        max_queued_runs=1000,
        run_timeout_s=5,
        token=token,
    )
    return create_app(s)


def run_schemathesis(app, config) -> tuple[list[str], Counter]:
    """All failures the engine found (one line each, with a curl to reproduce) and, per phase,
    operation and status, how many requests it sent."""
    schema = schemathesis.openapi.from_asgi("/openapi.json", app, config=config)
    calls: Counter = Counter()

    @schema.hook
    def after_call(context, case, response):
        phase = case.meta.phase.name.value if case.meta is not None else "?"
        calls[(phase, case.method, case.path, response.status_code)] += 1

    found: list[str] = []
    with TestClient(app):  # the lifespan: services and run workers
        for ev in from_schema(schema).execute():
            if isinstance(ev, (events.ScenarioFinished, events.FuzzScenarioFinished)):
                for checks in ev.recorder.checks.values():
                    for ch in checks:
                        if ch.failure_info is not None:
                            f = ch.failure_info.failure
                            found.append(f"{ch.name}: {f.title}: {f.message[:400]}\n  {ch.failure_info.code_sample}")
            elif isinstance(ev, events.NonFatalError):
                found.append(f"error in {ev.label}: {ev.info.message}")
            elif isinstance(ev, events.FatalError):
                found.append(f"fatal: {ev.exception!r}")
            elif isinstance(ev, events.PhaseFinished) and ev.status == Status.ERROR:
                found.append(f"phase {ev.phase.name.value} ended with an error")
    return sorted(set(found)), calls


def _phase_calls(calls: Counter, phase: str) -> Counter:
    out: Counter = Counter()
    for (p, method, path, status), n in calls.items():
        if p == phase:
            out[(method, path, status)] += n
    return out


@pytest.fixture()
def save_is_a_root(monkeypatch):
    """schemathesis starts scenarios only at operations that look like creators (POST, or GET of a
    list); this API creates a graph with PUT /api/graphs/{name} (create or replace by name), so that
    operation is made a scenario root too, and the save → read/re-save/upload/run/delete links run."""
    from schemathesis.specs.openapi import stateful

    likely = stateful.is_likely_root_transition

    def is_root(operation, node, produced_anywhere):
        if operation.path.startswith("/api/builds"):  # a build needs a finished run: the run links cover it
            return False
        return (operation.method == "put" and operation.path == "/api/graphs/{name}") or likely(
            operation, node, produced_anywhere
        )

    monkeypatch.setattr(stateful, "is_likely_root_transition", is_root)


def test_contract_with_token(tmp_path):
    found, calls = run_schemathesis(
        _server(tmp_path, TOKEN),
        _config(("examples", "coverage", "fuzzing"), examples=EXAMPLES, scenarios=1, headers=AUTH),
    )
    assert not found, "\n\n".join(found)
    examples = _phase_calls(calls, "examples")
    assert examples[("POST", "/api/runs", 202)] >= 1 and examples[("GET", "/api/graphs/{name}", 200)] >= 1, examples
    for phase in ("coverage", "fuzzing"):
        assert sum(_phase_calls(calls, phase).values()) > 100, (phase, calls)
    # #26: at least 1,000 cases with the token in CI (~30 s); WAAMFLOW_CONTRACT_EXAMPLES=50 for a longer run
    assert sum(calls.values()) >= 1000, {p: sum(_phase_calls(calls, p).values()) for p in ALL_PHASES}


def test_stateful_with_token(tmp_path, save_is_a_root):
    """The stateful phase on a fresh server (earlier phases would hand it the names they saw,
    mostly the read-only example)."""
    app = _server(tmp_path, TOKEN)
    with TestClient(app, headers=AUTH) as c:  # a server with history: one finished run
        run_id = c.post("/api/runs", json={"graph": "rectangle-study"}).json()["id"]
        assert wait_for_run(c, run_id)["status"] == "done"
    found, calls = run_schemathesis(app, _config(("stateful",), examples=8, scenarios=60, headers=AUTH))
    assert not found, "\n\n".join(found)
    stateful = _phase_calls(calls, "stateful")
    # The scenarios followed the links with real values: graphs were saved, then deleted (a
    # generated name exists only after its save); the listed run was read with its artifacts.
    # (schemathesis uses a link's value or a generated one by a coin toss from true randomness,
    # so only outcomes that dozens of steps make certain are asserted.)
    print("stateful phase:", sorted(stateful.items(), key=str))
    assert stateful[("PUT", "/api/graphs/{name}", 201)] >= 1, stateful
    assert stateful[("DELETE", "/api/graphs/{name}", 204)] >= 1, stateful
    assert stateful[("GET", "/api/runs/{run_id}", 200)] + stateful[("GET", "/api/runs/{run_id}/artifacts", 200)] >= 1, (
        stateful
    )
    assert sum(n for (m, p, _), n in stateful.items() if (m, p) == ("POST", "/api/runs")) >= 1, stateful
    with TestClient(app, headers=AUTH) as c:
        log = c.get("/api/audit", params={"limit": 1000}).json()
    assert {"save_graph", "delete_graph", "run"} <= {e["action"] for e in log}
    # every accepted write came with the token (a wrong one is audited as a failed login, who unknown)
    assert {e["who"] for e in log if e["action"] != "failed_login"} == {"default"}


def test_contract_without_token(tmp_path, save_is_a_root):
    """The same schema without tokens (security optional): the phases that generate requests
    (coverage ran on the token server above; the schema differs only in `security`)."""
    found, calls = run_schemathesis(
        _server(tmp_path, None), _config(("examples", "fuzzing", "stateful"), examples=5, scenarios=15)
    )
    assert not found, "\n\n".join(found)
    assert sum(_phase_calls(calls, "fuzzing").values()) > 20
    assert sum(_phase_calls(calls, "stateful").values()) > 10


def test_schema_declares_links_and_auth(tmp_path):
    """The links the stateful phase follows are in the schema; the token server requires the token
    on every route behind the check and documents 401 with the ErrorResponse body there."""
    app = _server(tmp_path, TOKEN)
    with TestClient(app) as c:
        doc = c.get("/openapi.json").json()  # the schema itself is public
        r = c.get("/api/graphs")
        assert r.status_code == 401 and r.json()["detail"]["kind"] == "unauthorized"
    put = doc["paths"]["/api/graphs/{name}"]["put"]["responses"]
    assert {"GetGraph", "DeleteGraph", "RunGraph", "UploadFile"} <= set(put["201"]["links"])
    assert put["201"]["links"]["RunGraph"]["requestBody"] == {"graph": "$response.body#/name"}
    assert {"GetRun", "RunEvents", "ListArtifacts", "CancelRun"} <= set(
        doc["paths"]["/api/runs"]["post"]["responses"]["202"]["links"]
    )
    n = 0
    for path, ops in doc["paths"].items():
        for method, op in ops.items():
            if path == "/api/health":
                assert "security" not in op and "401" not in op["responses"]
                continue
            n += 1
            assert op["security"] == [{"bearer": []}], (method, path)
            assert op["responses"]["401"]["content"]["application/json"]["schema"] == {
                "$ref": "#/components/schemas/ErrorResponse"
            }, (method, path)
    assert n >= 24
    (tmp_path / "open").mkdir()
    open_doc = _server(tmp_path / "open", None).openapi()
    assert open_doc["paths"]["/api/graphs"]["get"]["security"] == [{"bearer": []}, {}]  # optional there
