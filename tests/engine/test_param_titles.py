"""Every parameter in the node catalog has a human title (issue 25, fault 10): the GUI labels its
forms from the schema, so a field without one showed its name ("Ik Step Mm [mm]", "Wire Feed Mm3
S [mm³/s]"). Titles are declared with the params (`Field(title=...)`); units live in `unit`."""

import re

from pydantic import BaseModel

from waamflow.engine.node import catalog, load_nodes


def _fields(schema: dict, where: str):
    for name, prop in (schema.get("properties") or {}).items():
        yield where, name, prop
    for dname, d in (schema.get("$defs") or {}).items():
        for name, prop in (d.get("properties") or {}).items():
            yield f"{where}#{dname}", name, prop


def _models(model, seen):
    if model in seen:
        return
    seen.add(model)
    for f in model.model_fields.values():
        stack = [f.annotation]
        while stack:
            a = stack.pop()
            if isinstance(a, type) and issubclass(a, BaseModel):
                _models(a, seen)
            stack += list(getattr(a, "__args__", ()) or ())


def test_every_param_in_the_catalog_has_a_human_title():
    bad, count = [], 0
    shipped = {t for t, cls in load_nodes().items() if cls.__module__.startswith("waamflow.")}  # not test toys
    for node in (n for n in catalog() if n["type"] in shipped):
        for where, name, prop in _fields(node["params_schema"], node["type"]):
            count += 1
            title = prop.get("title", "")
            if not title or (title == name.replace("_", " ").title() and "_" in name.strip("_")):
                bad.append(f"{where}.{name}: {title!r}")
            elif re.search(r"\b(mm|deg|mm3|s|m/min|mm/s)\s*$", title) or "[" in title:
                bad.append(f"{where}.{name}: unit in the title {title!r}")
    assert count >= 250
    assert bad == [], f"{len(bad)} of {count} params without a human title:\n" + "\n".join(bad)


def test_titles_are_declared_with_the_params():
    """Single-word names ("material") title-case to a fine label: the declaration must still say it."""
    seen: set = set()
    for cls in load_nodes().values():
        if cls.__module__.startswith("waamflow."):
            _models(cls.Params, seen)
    missing = [f"{m.__qualname__}.{n}" for m in seen for n, f in m.model_fields.items() if not f.title]
    assert len(seen) >= 25 and missing == []


def _prop(node_type: str, name: str) -> dict:
    node = next(n for n in catalog() if n["type"] == node_type)
    return node["params_schema"]["properties"][name]


def test_shipped_cells_robots_machines_and_materials_are_listed():
    """The GUI's pickers come from the catalog: a `x-shipped` field lists the shipped names as
    `examples` (the files in waamflow/data), a material field common materials."""
    from pathlib import Path

    import waamflow

    data = Path(waamflow.__file__).parent / "data"
    cells = sorted(p.stem for p in (data / "cells").glob("*.json"))
    assert len(cells) >= 3
    assert _prop("simulate-robot", "cell")["examples"] == cells
    assert _prop("post-process", "cell")["examples"] == cells
    machines = _prop("post-process", "profile")["examples"]
    assert machines == sorted(p.stem for p in (data / "machines").glob("*.json")) and {"marlin", "kuka_krc4"} <= set(
        machines
    )
    profiles = _prop("simulate-robot", "robot_profile")["examples"]
    assert "kuka_kr100ha_krc2" in profiles and not any(p.endswith(".urdf") for p in profiles)
    urdfs = _prop("simulate-robot", "robot_description")["examples"]
    assert "kuka_kr150_2.urdf" in urdfs and all(u.endswith(".urdf") for u in urdfs)
    assert len(_prop("bead-fit", "material")["examples"]) >= 4
