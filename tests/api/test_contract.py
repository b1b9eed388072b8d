"""The OpenAPI schema is the contract: schemathesis generates requests from it (examples, coverage
and fuzzing phases; schema-valid and schema-invalid data) against the ASGI app and checks every
answer: no 5xx, every status declared, every body matching its declared schema (one ErrorResponse
model for all 4xx), schema-valid requests accepted and schema-invalid ones rejected.

One documented exception: a recipe is a program. Its JSON Schema (Recipe) says what a recipe looks
like; whether its node types exist, its edges join existing ports of matching types and each node's
params are valid for that type is checked by the engine (422 naming node and field). So for the
operations that take a recipe, 422 is an accepted answer to schema-valid data."""

import json
import shutil
import tempfile
from pathlib import Path

import pytest
import schemathesis
from fastapi.testclient import TestClient
from hypothesis import HealthCheck, settings

import toy_nodes as toy
from waamflow.api.app import create_app
from waamflow.settings import Settings

RECIPE_OPS = r"^/api/(runs|preview|graphs/\{name\})$"


def _app():
    tmp = Path(tempfile.mkdtemp(prefix="waamflow-contract-"))
    gdir = tmp / "graphs"
    gdir.mkdir()
    (gdir / "example.json").write_text(json.dumps(toy.chain(stack={"count": 2})))
    s = Settings(data_dir=tmp / "data", graphs_dir=gdir, start_viewer=False, static_dir=None, workers=1,
                 max_queued_runs=1000, run_timeout_s=5)
    return create_app(s), tmp


APP, TMP = _app()
_LIFESPAN = TestClient(APP)


@pytest.fixture(scope="module", autouse=True)
def _services():
    with _LIFESPAN:  # runs the lifespan (services, workers) around the module's cases
        yield
    shutil.rmtree(TMP, ignore_errors=True)


CONFIG = schemathesis.Config.from_dict({
    "phases": {"examples": {"enabled": True}, "coverage": {"enabled": True}, "fuzzing": {"enabled": True},
               "stateful": {"enabled": False}},
    "generation": {"max-examples": 30, "mode": "all"},
    "operations": [{"include-path-regex": RECIPE_OPS, "checks": {"positive_data_acceptance": {
        "expected-statuses": ["2xx", "401", "404", "409", "422", "429"]}}}],
})

schema = schemathesis.openapi.from_asgi("/openapi.json", APP, config=CONFIG)


@schema.parametrize()
@settings(deadline=None, suppress_health_check=list(HealthCheck), max_examples=30)
def test_api_contract(case):
    case.call_and_validate()
