"""What the robot nodes share: the robot params (`RobotParams`: profile, cell and the positioner
plan's limits) and their fields, the cell file named by a param and the files it reads, the robot
profile of a node's params and the moves of its toolpath input. Used by simulate-robot,
estimate-time, calibrate-robot (`nodes.robot`), post-process (`nodes.post`) and the process
nodes that simulate (`nodes.process`).

Split from `nodes.robot` (issue 27): that module declares the nodes; every name stays importable
from there.
"""

from __future__ import annotations

from typing import Literal

from pydantic import Field

from ..core.errors import PlanningError
from ..core.files import SHIPPED_NAME, ShippedName, shipped
from ..core.moves import flatten
from ..engine.node import FileRef, NodeParams, unit
from ..trajectory.cell import load_cell
from ..trajectory.profile import RobotProfile, load_profile
from ..trajectory.simulate import SimOptions


class RobotParams(NodeParams):
    """Parameters shared by the robot nodes: which robot and how it is set up in the cell."""

    robot_profile: ShippedName = shipped(
        "robots",
        default="kuka_kr100ha_krc2",
        min_length=1,
        max_length=64,
        description="Shipped robot profile (controller constants, data/robots/<name>.json)",
        title="Robot profile",
    )
    profile_file: FileRef = Field(
        "", description="Optional robot profile JSON file; overrides robot_profile", title="Robot profile file"
    )
    cdis: float = Field(
        5.0,
        ge=0,
        le=200,
        json_schema_extra=unit("mm"),
        description="Blend distance: KUKA $APO.CDIS (blend=cdis) or ABB zone radius (blend=zone); 0 = exact stops",
        title="Blend distance",
    )
    blend: Literal["cdis", "zone"] = Field(
        "cdis", description="Corner blending: KUKA C_DIS-like arc or ABB zone-like parabola", title="Corner blending"
    )
    speed_override: float | None = Field(
        None,
        gt=0,
        le=2000,
        json_schema_extra=unit("mm/s"),
        description="Replace the programmed speed of arc-ON moves (empty = as programmed)",
        title="Weld speed override",
    )
    speed: float | None = Field(
        None,
        gt=0,
        le=2000,
        json_schema_extra=unit("mm/s"),
        description="Same as speed_override (the contract's example recipe sets `speed` here)",
        title="Speed",
    )
    travel_speed: float | None = Field(
        None,
        gt=0,
        le=2000,
        json_schema_extra=unit("mm/s"),
        description="Speed of arc-OFF moves that carry no speed (empty = the profile's)",
        title="Travel speed",
    )
    interpolation_cycle_s: float = Field(
        0.012,
        gt=0.0005,
        le=0.1,
        json_schema_extra=unit("s"),
        description="Controller interpolation cycle (KRC2: 12 ms); trace sampling period",
        title="Interpolation cycle",
    )
    ignition_dwell_s: float = Field(
        0.0,
        ge=0,
        le=60,
        json_schema_extra=unit("s"),
        description="Standstill after each arc ignition when the zone has no `dwell` parameter",
        title="Ignition dwell",
    )
    wire_feed_mm3_s: float = Field(
        94.25,
        gt=0,
        le=10000,
        json_schema_extra=unit("mm³/s"),
        description="Constant wire volume feed while the arc is ON (1.2 mm wire at 83.34 mm/s = 94.25)",
        title="Wire feed volume rate",
    )
    wire_diameter_mm: float | None = Field(
        None,
        gt=0.1,
        le=10,
        json_schema_extra=unit("mm"),
        description="Wire diameter: when set, zones with a wire_feed_speed parameter "
        "feed WFS·π·d²/4 instead of wire_feed_mm3_s",
        title="Wire diameter",
    )

    def sim_options(self) -> SimOptions:
        return SimOptions(
            cdis=self.cdis,
            blend=self.blend,
            wire_feed_mm3_s=self.wire_feed_mm3_s,
            speed_override=self.speed_override if self.speed_override is not None else self.speed,
            interpolation_cycle_s=self.interpolation_cycle_s,
            travel_speed=self.travel_speed,
            ignition_dwell_s=self.ignition_dwell_s,
            wire_diameter_mm=self.wire_diameter_mm,
        )


POSITIONER_PLAN_KEYS = ("positioner_policy", "max_tilt_deg", "max_lean_deg", "flat_tol_deg")


def max_tilt_field():
    return Field(
        30.0,
        ge=0,
        le=90,
        json_schema_extra=unit("deg"),
        description="positioner_policy min-motion: torch lean from vertical tolerated "
        "before the positioner turns the next layer",
        title="Largest torch lean",
    )


def max_lean_field():
    return Field(
        15.0,
        ge=0,
        le=15,
        json_schema_extra=unit("deg"),
        description="positioner_policy auto: largest torch lean from the layer normal the process allows",
        title="Largest torch lean (auto)",
    )


def flat_tol_field():
    return Field(
        5.0,
        ge=0,
        le=30,
        json_schema_extra=unit("deg"),
        description="positioner_policy auto: how far a layer's normal may stay off vertical (flat-position tolerance)",
        title="Flat-position tolerance (auto)",
    )


def cell_files(cell: str, read_bytes) -> list[str]:
    """A node's `read_files` for a cell parameter: a user's cell file and the mesh files its
    shapes name (shipped cells are part of the code version)."""
    if not cell.endswith(".json"):
        return []
    data = read_bytes(cell)
    try:
        c = load_cell(cell, text=data.decode("utf-8")) if data is not None else None
    except Exception:  # unreadable or invalid: the run reports it; its text is in the key
        c = None
    meshes = sorted({sh.mesh for sh in c.all_shapes() if sh.kind == "mesh"}) if c else []
    return [cell, *(_beside(cell, m) for m in meshes)]


def cell_from_param(ctx, cell: str, meshes: bool = True):
    """The `Cell` a node's cell parameter names, with its meshes loaded when `meshes` (the
    collision checks need them): a user's cell .json (read through the engine's file gate, its
    meshes beside it) or a shipped cell by name."""
    if cell.endswith(".json"):
        c = load_cell(cell, text=ctx.read_text(cell, max_bytes=1_000_000))
        return c.load_meshes(lambda name: ctx.read_bytes(_beside(cell, name), max_bytes=200_000_000)) if meshes else c
    return load_cell(cell).load_meshes() if meshes else load_cell(cell)


def check_cell_param(v: str) -> str:
    """A cell parameter: a user's cell is a .json file (read through the engine's file gate);
    anything else is the name of a shipped cell, never a path."""
    if v and not v.endswith(".json") and not SHIPPED_NAME.match(v):
        raise ValueError("a shipped cell name (letters, digits, _ - .) or a cell .json file")
    return v


def _beside(cell_path: str, name: str) -> str:
    """A file named in a cell file, next to it."""
    folder = cell_path.replace("\\", "/").rpartition("/")[0]
    return f"{folder}/{name}" if folder else name


def _profile(ctx, params: RobotParams) -> RobotProfile:
    if params.profile_file:
        return load_profile(params.profile_file, text=ctx.read_text(params.profile_file, max_bytes=1_000_000))
    return load_profile(params.robot_profile)


def _toolpath_moves(inputs):
    moves = flatten(inputs["toolpath"])
    if len(moves.points) < 2:
        raise PlanningError("the toolpath has no motion to simulate")
    return moves
