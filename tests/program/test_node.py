"""The post-process node: params → writer settings, artifacts by format, clear errors."""

import pytest
from pydantic import ValidationError

from waamflow.core.errors import RecipeError
from waamflow.core.model import Layered
from waamflow.engine.node import load_nodes

from conftest import PostCtx, build_toolpath


def _run(**params):
    node_cls = load_nodes()["post-process"]
    node = node_cls()
    p = node_cls.Params(**params)
    out = node.run(PostCtx(), p, {"toolpath": build_toolpath(2)})
    return out["program"], node.artifacts(PostCtx(), p, out)


def test_catalog_entry():
    d = load_nodes()["post-process"].describe()
    assert [p["name"] for p in d["inputs"]] == ["toolpath"] and d["inputs"][0]["type"] == "toolpath"
    assert [p["type"] for p in d["outputs"]] == ["program"]
    props = d["params_schema"]["properties"]
    assert props["format"]["enum"] == ["gcode", "krl", "rapid", "inform", "tp", "csv", "printpoints"]
    assert props["ignition_dwell"]["unit"] == "s" and props["arc_tolerance"]["unit"] == "mm"
    assert props["arc_on"]["default"] == "M3" and props["arc_off"]["default"] == "M5"


# KRL / RAPID files are named after the program ("/<name>.<ext>": not `<node id>.<ext>`), G-code and CSV after the node
@pytest.mark.parametrize(
    "fmt, suffixes",
    [("gcode", {"gcode"}), ("krl", {"/part.src", "/part.dat"}), ("rapid", {"/part.mod"}), ("csv", {"csv"})],
)
def test_artifacts_by_format(fmt, suffixes):
    program, files = _run(format=fmt, program_name="part")
    assert set(files) == suffixes and program.format == fmt
    assert program.stats["points"] == 94 and program.stats["arc_on_count"] == 10
    assert program.stats["layers"] == 2


def test_krl_split_artifacts_and_gcode_params():
    _, files = _run(format="krl", split_per_layer=True)
    assert set(files) == {"src", "dat", "/post_L000.src", "/post_L000.dat", "/post_L001.src", "/post_L001.dat"}
    _, files = _run(
        format="gcode",
        arc_on="M7",
        arc_off="M9",
        dwell_units="ms",
        ignition_dwell=2,
        process_codes={"job": "M101 P{value:.0f}"},
    )
    g = files["gcode"]
    assert "M7 ; arc on" in g and "M9 ; arc off" in g and "G4 P2000" in g and "M101 P12" in g


def test_invalid_params():
    cls = load_nodes()["post-process"].Params
    with pytest.raises(ValidationError):
        cls(format="fanuc")
    with pytest.raises(ValidationError):
        cls(program_name="bad name")
    with pytest.raises(ValidationError):
        cls(process_codes={"current": "M1 {nope}"})
    with pytest.raises(ValidationError):  # the field itself (it was found only when the node ran)
        cls(arc_on="M3 ; comment")
    with pytest.raises(RecipeError):
        _run(format="krl", program_name="a_long_program_name_x", split_per_layer=True)


def test_empty_toolpath_warns():
    node_cls = load_nodes()["post-process"]
    ctx = PostCtx()
    out = node_cls().run(ctx, node_cls.Params(format="krl"), {"toolpath": Layered(())})
    assert out["program"].stats["motions"] == 0 and ctx.warnings
    assert "DEF post( )" in out["program"].files["src"]  # named after the node (PostCtx.node_id)


def test_gcode_warns_about_tilted_torch():
    from dataclasses import replace

    import numpy as np

    from waamflow.core.model import LayerPaths

    tp = build_toolpath(1)
    lp = tp[0]
    sp = lp.sections[0]
    axis = np.tile([0.0, np.sin(np.radians(10)), -np.cos(np.radians(10))], (len(sp.points), 1))
    tp = Layered((LayerPaths(lp.layer, (replace(sp, tool_axis=axis),)),))
    node_cls = load_nodes()["post-process"]
    ctx = PostCtx()
    out = node_cls().run(ctx, node_cls.Params(format="gcode"), {"toolpath": tp})
    assert out["program"].stats["max_tool_tilt_deg"] == pytest.approx(10.0)
    assert len(ctx.warnings) == 1 and "10.0°" in ctx.warnings[0]
    ctx = PostCtx()
    node_cls().run(ctx, node_cls.Params(format="krl"), {"toolpath": tp})
    # no tilt warning for a robot; the default KRL analog outputs have no job command (issue 23): reported
    assert ctx.warnings == [
        "KRL weld commands of zone start (section bs1/A, layer 0): job 12 not commanded: the "
        "program has no command for it (give it a KRL statement in process_codes)"
    ]


@pytest.mark.parametrize("fmt, profile", [("krl", "kuka_krc4"), ("inform", ""), ("tp", "")])
def test_weld_data_warnings_of_unzoned_paths_name_no_empty_zone(fmt, profile):
    """A recipe without a zone node (mesh → slice → mask → strategy → sequence → post, compas_slicer's
    coin to INFORM): "weld data of zone  (section region0, ...)" named a zone with an empty id, or
    TP's "zone -". Such paths are "the unzoned paths"."""
    from dataclasses import replace

    tp = build_toolpath(1)
    lp = tp[0]
    bare = tuple(replace(sp, zone=(), zone_colors={}, zone_params={}) for sp in lp.sections)
    tp = Layered((replace(lp, sections=bare),))
    node_cls = load_nodes()["post-process"]
    ctx = PostCtx()
    params = node_cls.Params(format=fmt, profile=profile, weld_values={"wire_feed_speed": 4.0})
    node_cls().run(ctx, params, {"toolpath": tp})
    weld = [w for w in ctx.warnings if " of the unzoned paths (section bs1/A, layer 0" in w]
    assert weld and not [w for w in ctx.warnings if "of zone  (" in w or "of zone - (" in w], ctx.warnings
