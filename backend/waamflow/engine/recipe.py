"""Recipes: the one saved-graph format for GUI, API and CLI (`waamflow/1`, see CONTRACT.md).

Loading applies format migrations and legacy type ids, so renames never break saved recipes.
`$name` strings in params are replaced by recipe inputs; `--set` overrides set inputs or node
params by dotted path.
"""

from __future__ import annotations

import copy
import json
import re
from pathlib import Path
from typing import Annotated, Any

from pydantic import BaseModel, ConfigDict, Field, StringConstraints, ValidationError, field_validator

from ..core.errors import InputFileError, RecipeError
from ..preflight.settings import PreflightSettings

FORMAT = "waamflow/1"
OLD_FORMATS = ("waamflow/0", "waamflow")
FORMATS = (FORMAT, *OLD_FORMATS)
NODE_ID = re.compile(r"^[A-Za-z_][A-Za-z0-9_-]{0,63}$")
INPUT_NAME = re.compile(r"^[A-Za-z_][A-Za-z0-9_]{0,63}$")
MAX_RECIPE_BYTES = 5_000_000

# Type ids that were renamed: old → current. Saved recipes keep loading (ryvencore's
# legacy_identifiers idea).
LEGACY_TYPES: dict[str, str] = {
    "simulate": "simulate-robot",
    "postprocess": "post-process",
    "post_process": "post-process",
    "simulate_robot": "simulate-robot",
}


class NodeEntry(BaseModel):
    model_config = ConfigDict(extra="forbid")
    id: str = Field(
        description="Unique node id (letters, digits, _ and -).", json_schema_extra={"pattern": NODE_ID.pattern}
    )
    type: str = Field(description="Node type id from the catalog.")
    params: dict[str, Any] = Field(default_factory=dict)
    label: str | None = None

    @field_validator("id")
    @classmethod
    def _id(cls, v: str) -> str:
        if not NODE_ID.fullmatch(v):
            raise ValueError(f"invalid node id {v!r}: use letters, digits, '_' or '-', start with a letter, ≤ 64 chars")
        return v


class EdgeEntry(BaseModel):
    model_config = ConfigDict(extra="forbid", populate_by_name=True)
    from_: str = Field(alias="from", description='"nodeid.port" of an output')
    to: str = Field(description='"nodeid.port" of an input')


class Recipe(BaseModel):
    """A saved graph. `ui` holds editor-only state (node positions); the engine ignores it."""

    model_config = ConfigDict(extra="forbid", populate_by_name=True)
    format: str = Field(
        FORMAT, json_schema_extra={"enum": list(FORMATS)}, description=f"{FORMAT}; older formats are migrated on load"
    )
    name: str = "recipe"
    description: str = ""
    inputs: dict[str, Any] = Field(
        default_factory=dict,
        json_schema_extra={"propertyNames": {"pattern": INPUT_NAME.pattern}},
        description='named values that node params refer to as "$name"',
    )
    nodes: list[NodeEntry] = Field(default_factory=list)
    edges: list[EdgeEntry] = Field(default_factory=list)
    preflight: PreflightSettings | None = Field(
        None,
        description="thresholds of the check of every emitted "
        "program against its part (README 'Preflight'); empty = defaults",
    )
    files: dict[str, Annotated[str, StringConstraints(pattern=r"^[0-9a-f]{64}$")]] | None = Field(
        None,
        description="uploaded files pinned to their content: file name → sha256 (hex) of the exact content "
        "this recipe runs with on the server; an upload under the same name changes nothing "
        "until the recipe is pinned to it (the GUI asks). Part of the recipe hash.",
    )
    ui: dict[str, Any] | None = None

    @field_validator("inputs")
    @classmethod
    def _inputs(cls, v: dict[str, Any]) -> dict[str, Any]:
        for k in v:
            if not INPUT_NAME.fullmatch(k):
                raise ValueError(f"invalid input name {k!r}")
        return v

    def to_json(self) -> dict[str, Any]:
        return self.model_dump(mode="json", by_alias=True, exclude_none=True)

    def node(self, node_id: str) -> NodeEntry | None:
        return next((n for n in self.nodes if n.id == node_id), None)


def migrate(data: dict[str, Any]) -> dict[str, Any]:
    """Bring an older recipe dict up to the current format (returns a new dict)."""
    data = copy.deepcopy(data)
    fmt = data.get("format", FORMAT)
    if fmt in OLD_FORMATS:
        # waamflow/0 stored edges as {"source": "n.port", "target": "n.port"}.
        data["edges"] = [
            {"from": e.get("from", e.get("source")), "to": e.get("to", e.get("target"))} for e in data.get("edges", [])
        ]
        fmt = FORMAT
    if fmt != FORMAT:
        raise RecipeError(f"unsupported recipe format {fmt!r} (this waamflow reads {FORMAT})", field="format")
    data["format"] = FORMAT
    for n in data.get("nodes", []):
        if isinstance(n, dict) and n.get("type") in LEGACY_TYPES:
            n["type"] = LEGACY_TYPES[n["type"]]
    return data


def _pydantic_message(err: ValidationError) -> tuple[str, str | None]:
    e = err.errors()[0]
    loc = ".".join(str(x) for x in e["loc"])
    return f"{e['msg']}" + (f" at '{loc}'" if loc else ""), loc or None


def parse_recipe(data: Any) -> Recipe:
    """Validate a recipe dict (from JSON) into a `Recipe`; RecipeError on any schema problem."""
    if not isinstance(data, dict):
        raise RecipeError("a recipe must be a JSON object")
    data = migrate(data)
    try:
        recipe = Recipe.model_validate(data)
    except ValidationError as err:
        msg, loc = _pydantic_message(err)
        node = None
        if loc and loc.startswith("nodes."):
            idx = loc.split(".")[1]
            try:
                node = data["nodes"][int(idx)].get("id")
            except (ValueError, IndexError, AttributeError, KeyError):
                node = None
        raise RecipeError(f"invalid recipe: {msg}", node=node) from None
    return recipe


def load_recipe(path: str | Path) -> Recipe:
    p = Path(path)
    if not p.is_file():
        raise InputFileError(f"recipe file not found: {p}")
    if p.stat().st_size > MAX_RECIPE_BYTES:
        raise InputFileError(f"recipe file {p} is larger than {MAX_RECIPE_BYTES} bytes")
    try:
        data = json.loads(p.read_text(encoding="utf-8"))
    except (json.JSONDecodeError, UnicodeDecodeError) as e:
        raise RecipeError(f"{p.name} is not valid JSON: {e}") from None
    return parse_recipe(data)


# ---- inputs and overrides -----------------------------------------------------------------------
def parse_value(text: str) -> Any:
    """CLI value: JSON when it parses, else the string itself."""
    try:
        return json.loads(text)
    except (json.JSONDecodeError, ValueError):
        return text


def parse_set(items: list[str]) -> list[tuple[str, Any]]:
    out = []
    for item in items:
        if "=" not in item:
            raise RecipeError(f"--set expects KEY=VALUE, got {item!r}")
        key, value = item.split("=", 1)
        key = key.strip()
        if not key:
            raise RecipeError(f"--set expects KEY=VALUE, got {item!r}")
        out.append((key, parse_value(value)))
    return out


def apply_overrides(recipe: Recipe, sets: list[tuple[str, Any]]) -> Recipe:
    """`name=value` sets recipe input `name` (must exist); `node.param.sub=value` sets a node param."""
    r = recipe.model_copy(deep=True)
    for key, value in sets:
        if "." not in key:
            if key not in r.inputs:
                known = ", ".join(sorted(r.inputs)) or "none"
                raise RecipeError(f"unknown input {key!r} (recipe inputs: {known})", field=key)
            r.inputs[key] = value
            continue
        node_id, *path = key.split(".")
        node = r.node(node_id)
        if node is None:
            raise RecipeError(f"--set {key}: no node with id {node_id!r}", node=node_id)
        target: Any = node.params
        for i, part in enumerate(path[:-1]):
            if isinstance(target, list):
                try:
                    target = target[int(part)]
                    continue
                except (ValueError, IndexError):
                    raise RecipeError(f"--set {key}: no element {part!r}", node=node_id) from None
            if part not in target or not isinstance(target[part], (dict, list)):
                target[part] = {}
            target = target[part]
        last = path[-1]
        if isinstance(target, list):
            try:
                target[int(last)] = value
            except (ValueError, IndexError):
                raise RecipeError(f"--set {key}: no element {last!r}", node=node_id) from None
        else:
            target[last] = value
    return r


def substitute_inputs(params: Any, inputs: dict[str, Any], node_id: str) -> Any:
    """Replace every string "$name" in params by input `name` (keeping its JSON type)."""
    if isinstance(params, dict):
        return {k: substitute_inputs(v, inputs, node_id) for k, v in params.items()}
    if isinstance(params, list):
        return [substitute_inputs(v, inputs, node_id) for v in params]
    if isinstance(params, str) and params.startswith("$") and not params.startswith("$$"):
        name = params[1:]
        if name not in inputs:
            known = ", ".join(sorted(inputs)) or "none"
            raise RecipeError(f"parameter refers to unknown input ${name} (recipe inputs: {known})", node=node_id)
        return copy.deepcopy(inputs[name])
    if isinstance(params, str) and params.startswith("$$"):
        return params[1:]
    return params
