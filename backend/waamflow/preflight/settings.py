"""The preflight's thresholds: a recipe's optional top-level `"preflight": {...}` block.

Defaults are what a WAAM engineer would sign off: the top within half a layer, at most 2 % of the
part without a bead (fail above 5 %), wire ending in the part 0.9–1.2× the part's volume (fail
outside 0.75–1.5×: machining stock is wanted, three times the metal is not), no arc-ON run shorter
than two bead widths, no ignition within one bead width of one on the layer below, weld data
commanded for every arc-ON move, a sequence node that welds exactly what it was given, and no
weld clear of the part beyond a run end's machining stock (fail: a centre line more than a bead
width off the part over more than two bead widths; warn: a bead clear of it over one).
"""

from __future__ import annotations

from typing import Literal

from pydantic import BaseModel, ConfigDict, Field, model_validator

from ..core.process import BEAD_SHAPE_FACTOR, DEPOSITION_EFFICIENCY, WIRE_DIAMETER_MM


_WARN_FAIL = (  # (warning threshold, failure threshold) pairs: a warning never lies beyond its failure
    ("uncovered_warn", "uncovered_fail"),
    ("hole_warn_widths", "hole_fail_widths"),
    ("layer_gap_warn_layers", "layer_gap_fail_layers"),
    ("dwell_warn_widths", "dwell_fail_widths"),
    ("torch_axis_warn_deg", "torch_axis_fail_deg"),
    ("weld_position_warn_deg", "weld_position_fail_deg"),
)


class PreflightSettings(BaseModel):
    model_config = ConfigDict(extra="forbid")

    enabled: bool = Field(True, description="Run the preflight after every full run")
    bead_width_mm: float | None = Field(
        None,
        gt=0.1,
        le=100,
        description="Bead width, mm; empty = the recipe's strategy/wall-path bead_width, else 6 mm",
    )
    top_gap_max_layers: float = Field(
        0.5,
        ge=0,
        le=10,
        description="Fail when the highest deposited layer ends more than this many layer heights below the part's top",
    )
    bottom_gap_max_layers: float = Field(
        0.5,
        ge=0,
        le=100,
        description="Fail when the lowest deposited layer lies more than this many layer heights above where a "
        "first layer on the part's bottom would (layers missing below: the first bead laid on nothing)",
    )
    plate: Literal["off", "warn", "fail"] = Field(
        "fail",
        description="A program that goes below z = 0 (the plate: the substrate's top in the program's frame) or a "
        "part whose lowest point is more than bottom_gap_max_layers layer heights above it; off when the "
        "program's z = 0 is not the substrate's top (a build on an existing part)",
    )
    overshoot_warn_layers: float = Field(
        1.0,
        ge=0,
        le=100,
        description="Warn when the deposit ends more than this many layer heights above the part's top",
    )
    layer_gap_warn_layers: float = Field(
        1.8,
        gt=1,
        le=100,
        description="Warn when a deposited layer lies more than this many typical layer heights above the "
        "deposited layer below it, where the part has metal between (skipped layers)",
    )
    layer_gap_fail_layers: float = Field(
        2.5,
        gt=1,
        le=100,
        description="Fail when a deposited layer lies more than this many typical layer heights above the "
        "deposited layer below it, where the part has metal between (skipped layers)",
    )
    uncovered_warn: float = Field(0.02, ge=0, le=1, description="Warn above this share of the part with no bead")
    uncovered_fail: float = Field(0.05, ge=0, le=1, description="Fail above this share of the part with no bead")
    hole: Literal["off", "warn", "fail"] = Field(
        "fail",
        description="One place of one layer with no bead, at least half a bead wide, larger than hole_fail_widths "
        "bead widths of bead (warn beyond hole_warn_widths), however small a share of the part it is",
    )
    hole_warn_widths: float = Field(
        2.0,
        ge=1,
        le=10000,
        description="Warn when a layer's largest place with no bead would take more than this many bead widths of "
        "bead to cover (its area over a bead width squared; a wall's over bead width × layer height)",
    )
    hole_fail_widths: float = Field(
        6.0,
        ge=1,
        le=10000,
        description="Fail when a layer's largest place with no bead would take more than this many bead widths of "
        "bead to cover",
    )
    volume_ratio_ok: tuple[float, float] = Field(
        (0.9, 1.2), description="Wire ending in the part / part volume: no remark inside this band"
    )
    volume_ratio_fail: tuple[float, float] = Field((0.75, 1.5), description="Fail outside this band (warn between)")
    layer_volume_ratio: Literal["off", "warn", "fail"] = Field(
        "fail",
        description="A layer that lays far less or more metal for its slab of the part than the program's typical "
        "layer (layer_volume_ratio_fail; warn outside layer_volume_ratio_ok), however the whole part balances; "
        "layers needing under ten bead widths of bead are not judged",
    )
    layer_volume_ratio_ok: tuple[float, float] = Field(
        (0.6, 1.8),
        description="One layer's wire / its slab's part volume, over the typical layer's: no remark inside this band",
    )
    layer_volume_ratio_fail: tuple[float, float] = Field(
        (0.5, 2.5),
        description="One layer's wire / its slab's part volume, over the typical layer's: fail outside this band (warn "
        "between)",
    )
    min_arc_run_mm: float | None = Field(
        None, ge=0, le=1000, description="Warn for arc-ON runs shorter than this, mm; empty = two bead widths"
    )
    stacked_starts: Literal["off", "warn", "fail"] = Field(
        "warn", description="Ignitions within one bead width of an ignition on the layer below"
    )
    weld_data: Literal["off", "warn", "fail"] = Field(
        "fail", description="Arc-ON moves with no weld parameter commanded (comments do not count)"
    )
    layer_order: Literal["off", "warn", "fail"] = Field(
        "fail",
        description="A layer welded below, or at the height of, metal welded before it at the same place "
        "(planar programs): the torch would weld into it",
    )
    retrace: Literal["off", "warn", "fail"] = Field(
        "fail",
        description="An arc-ON run that welds more than retrace_max_share of its length over beads earlier runs "
        "of its layer laid, running the same way or back (a section or layer sent twice)",
    )
    retrace_max_share: float = Field(
        0.5,
        gt=0,
        le=1,
        description="Largest share of a run's length that may lie on earlier runs' beads of its layer (the "
        "shipped examples: 0.016 at most; mpp-cross with triangular weaves at 9 mm spacing 0.16)",
    )
    dwell_metal: Literal["off", "warn", "fail"] = Field(
        "fail",
        description="A dwell with the arc on that lays as much metal in one spot as more than dwell_fail_widths "
        "bead widths of the program's bead (warn beyond dwell_warn_widths)",
    )
    dwell_warn_widths: float = Field(
        3.0,
        gt=0,
        le=1000,
        description="Warn when one arc-on dwell lays the metal of more than this many bead widths of bead "
        "(the shipped 0.5 s ignition dwells: 0.5)",
    )
    dwell_fail_widths: float = Field(
        8.0, gt=0, le=1000, description="Fail (setting dwell_metal) beyond this many bead widths of bead in one dwell"
    )
    travel_collision: Literal["off", "warn", "fail"] = Field(
        "fail",
        description="Planar programs: a travel move (arc off) that passes more than half a layer below the top of "
        "metal welded before it, where that metal stands (the torch driven into the part)",
    )
    torch_axis: Literal["off", "warn", "fail"] = Field(
        "fail",
        description="Robot programs: an arc-ON target whose torch (the orientation the program states) points more "
        "than torch_axis_fail_deg away from the way its layer grows",
    )
    torch_axis_warn_deg: float = Field(
        30.0, ge=0, le=180, description="Warn when the torch points more than this away from the build direction, deg"
    )
    torch_axis_fail_deg: float = Field(
        60.0,
        ge=0,
        le=180,
        description="Fail (setting torch_axis) when the torch points more than this away from the build direction, deg",
    )
    weld_position: Literal["off", "warn", "fail"] = Field(
        "fail",
        description="Programs written for a cell: a layer deposited more than weld_position_fail_deg off the flat "
        "position (its build direction in the world, under the positioner angles the program states, against up), "
        "or positioner angles outside the axis limits",
    )
    weld_position_warn_deg: float = Field(
        20.0,
        ge=0,
        le=180,
        description="Warn when a layer's build direction in the world lies more than this off up, deg",
    )
    weld_position_fail_deg: float = Field(
        45.0,
        ge=0,
        le=180,
        description="Fail (setting weld_position) when a layer's build direction in the world lies more than this "
        "off up, deg",
    )
    z_jump: Literal["off", "warn", "fail"] = Field(
        "fail",
        description="An arc-ON move of a planar layer that climbs or drops more than half a layer height "
        "(at least 1 mm) off the layer's plane",
    )
    local_deposit: Literal["off", "warn", "fail"] = Field(
        "fail",
        description="A stretch longer than a bead width laying far less or more metal per mm (wire feed / speed) "
        "than the program's median: warn outside local_deposit_ok, this outside local_deposit_fail",
    )
    local_deposit_ok: tuple[float, float] = Field(
        (0.25, 4.0), description="Metal per mm of a stretch / the program's median: no remark inside this band"
    )
    local_deposit_fail: tuple[float, float] = Field(
        (0.1, 8.0), description="Metal per mm of a stretch / the program's median: fail outside this band"
    )
    unreadable: Literal["off", "warn", "fail"] = Field(
        "fail",
        description="Motions the preflight cannot place (RAPID RelTool, KRL LIN_REL, a G53 move, a target not "
        "declared) and frames changed after the program has moved (work offset, work object, base, tool)",
    )
    weld_speed: Literal["off", "warn", "fail"] = Field(
        "fail",
        description="Arc-ON moves with no travel speed to weld at: a rapid (G0) with the arc on, or a zero feed",
    )
    wire_feed_min: Literal["off", "warn", "fail"] = Field(
        "fail",
        description="Arc-ON moves commanded less wire feed than `wire_feed_min_m_min`: the arc burns without wire",
    )
    wire_feed_min_m_min: float = Field(
        0.5,
        ge=0,
        le=10,
        description="Least wire feed an arc-ON move may command, m/min (power sources feed from about 1 m/min; "
        "0 is an arc with no wire)",
    )
    deposit_changed: Literal["off", "warn", "fail"] = Field(
        "fail",
        description="A sequence node whose output "
        "welds another arc-ON length in a section than its "
        "input (short-run fixes aside)",
    )
    outside: Literal["off", "warn", "fail"] = Field(
        "fail",
        description="Arc-ON centre lines that leave the "
        "part by more than outside_margin_mm over more than "
        "outside_fail_mm (shorter stretches clear of the part warn)",
    )
    outside_margin_mm: float | None = Field(
        None,
        ge=0,
        le=1000,
        description="How far off the part a centre line must be to count towards a fail, mm; empty = one bead width",
    )
    outside_fail_mm: float | None = Field(
        None,
        ge=0,
        le=10000,
        description="Fail above this contiguous length more than the margin off the part, mm; empty = two bead widths",
    )
    outside_warn_mm: float | None = Field(
        None,
        ge=0,
        le=10000,
        description="Warn above this contiguous length of bead clear of the part, mm; empty = one bead width",
    )
    outside_share_warn: float = Field(
        0.02,
        ge=0,
        le=1,
        description="Warn above this share of the arc-ON length clear of the part (stock at run ends aside)",
    )
    outside_stock_mm: float | None = Field(
        None,
        ge=0,
        le=1000,
        description="Machining stock allowed beyond the "
        "part at a run's ends, mm; empty = the recipe's longest extension "
        "(extension_before/after, free_end_extension) + one bead width",
    )
    wire_diameter_mm: float = Field(WIRE_DIAMETER_MM, gt=0.1, le=10)
    deposition_efficiency: float = Field(
        DEPOSITION_EFFICIENCY, gt=0.1, le=1.0, description="Share of the wire fed that ends in the part"
    )
    bead_shape_factor: float = Field(
        BEAD_SHAPE_FACTOR,
        gt=0.3,
        le=1.0,
        description="k in bead area = k·w·h (stated for the report; a stacked layer "
        "adds w·h, so the balance uses the part's volume)",
    )
    sample_mm: float | None = Field(
        None,
        gt=0.1,
        le=50,
        description="Sample spacing of the 3D coverage check, "
        "mm; empty = a quarter bead width; coarsened on a large part to at most 200,000 samples "
        "of a mesh, 1,000,000 of a midsurface (the spacing used: coverage_sample_mm)",
    )

    @model_validator(mode="after")
    def _bands(self) -> "PreflightSettings":
        lo, hi = self.volume_ratio_ok
        flo, fhi = self.volume_ratio_fail
        if not (0 < flo <= lo <= hi <= fhi):
            raise ValueError("volume bands must nest: 0 < fail low ≤ ok low ≤ ok high ≤ fail high")
        lo, hi = self.layer_volume_ratio_ok
        flo, fhi = self.layer_volume_ratio_fail
        if not (0 < flo <= lo <= hi <= fhi):
            raise ValueError("layer volume bands must nest: 0 < fail low ≤ ok low ≤ ok high ≤ fail high")
        lo, hi = self.local_deposit_ok
        flo, fhi = self.local_deposit_fail
        if not (0 < flo <= lo <= 1 <= hi <= fhi):
            raise ValueError("local deposit bands must nest around 1: 0 < fail low ≤ ok low ≤ 1 ≤ ok high ≤ fail high")
        for warn, fail in _WARN_FAIL:
            if getattr(self, warn) > getattr(self, fail):
                raise ValueError(f"{warn} must not exceed {fail}")
        return self
