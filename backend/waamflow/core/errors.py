"""Errors that carry *where* they happened: node id, layer index, section key.

`RecipeError` → CLI exit 2 / HTTP 422 (the graph itself is wrong).
`PlanningError` → CLI exit 3 / run failed (the graph is valid but cannot plan this geometry).
Kernels raise them with whatever location they know (layer, section); the engine fills in the
node id. `str(err)` is the one-line message the CLI prints after `error:`.
"""

from __future__ import annotations

from typing import Any, Self


class WaamflowError(Exception):
    exit_code = 1
    kind = "error"
    debug_traceback: str | None = None  # the traceback of the bug it stands for (executor), `--debug` prints it

    def __init__(
        self,
        message: str,
        *,
        node: str | None = None,
        layer: int | None = None,
        section: str | None = None,
        field: str | None = None,
    ) -> None:
        super().__init__(message)
        self.message = message
        self.node = node
        self.layer = layer
        self.section = section
        self.field = field

    def located(self, *, node: str | None = None, layer: int | None = None, section: str | None = None) -> Self:
        """Fill in location fields that are not set yet; returns self for `raise err.located(...)`."""
        if self.node is None and node is not None:
            self.node = node
        if self.layer is None and layer is not None:
            self.layer = layer
        if self.section is None and section is not None:
            self.section = section
        return self

    def location(self) -> str:
        parts = []
        if self.node is not None:
            parts.append(f"node '{self.node}'")
        if self.layer is not None:
            parts.append(f"layer {self.layer}")
        if self.section is not None:
            parts.append(f"section '{self.section}'")
        if self.field is not None:
            parts.append(f"field '{self.field}'")
        return ", ".join(parts)

    def __str__(self) -> str:
        loc = self.location()
        return f"{loc}: {self.message}" if loc else self.message

    def to_dict(self) -> dict[str, Any]:
        return {
            "kind": self.kind,
            "message": self.message,
            "node": self.node,
            "layer": self.layer,
            "section": self.section,
            "field": self.field,
            "text": str(self),
        }


class RecipeError(WaamflowError):
    """The recipe/graph is invalid: schema, unknown type/port/input, type mismatch, cycle."""

    exit_code = 2
    kind = "invalid_recipe"


class InputFileError(RecipeError):
    """An input file (mesh, sketch, XML) is missing, too large or malformed."""

    kind = "invalid_input"


class PlanningError(WaamflowError):
    """The graph is valid but the geometry cannot be planned (e.g. a mask that does not fit)."""

    exit_code = 3
    kind = "planning_failed"


class CancelledError(WaamflowError):
    exit_code = 130
    kind = "cancelled"


def layer_ranges(indices: list[int]) -> str:
    """Layer indices as the messages name them: [0, 1, 2, 5, 7, 8] → "0-2, 5, 7-8"."""
    out: list[str] = []
    run: list[int] = []
    for i in sorted(indices):
        if run and i == run[-1] + 1:
            run.append(i)
            continue
        if run:
            out.append(f"{run[0]}-{run[-1]}" if len(run) > 1 else str(run[0]))
        run = [i]
    if run:
        out.append(f"{run[0]}-{run[-1]}" if len(run) > 1 else str(run[0]))
    return ", ".join(out)
