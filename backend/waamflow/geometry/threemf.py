"""3MF archives rewritten where trimesh's reader falls short (read by `mesh_io.read_triangles`)."""

from __future__ import annotations

import io

PRODUCTION_NS = "http://schemas.microsoft.com/3dmanufacturing/production/2015/06"


def items_as_components(data: bytes) -> bytes | None:
    """The 3MF archive `data` with the objects that build items take from other model parts (the
    production extension's `p:path`) copied into the root model under new ids, the items pointing
    at the copies: trimesh follows `p:path` on components only, and keys objects by id across parts
    (3MF Consortium's cube_gears_prod_req.3mf, 17 items each naming object 1 of its own part, read
    as no triangles). None when no item names another part or the archive is not one to rewrite."""
    import zipfile
    from xml.etree import ElementTree as ET

    import defusedxml.ElementTree as DET

    try:
        zin = zipfile.ZipFile(io.BytesIO(data))
        names = {n.lower().lstrip("/"): n for n in zin.namelist()}
        root_name = names.get("3d/3dmodel.model")
        if root_name is None:
            return None
        root = DET.fromstring(zin.read(root_name))
        core = root.tag[1 : root.tag.index("}")] if root.tag.startswith("{") else ""
        q = (lambda t: f"{{{core}}}{t}") if core else (lambda t: t)
        path_key = f"{{{PRODUCTION_NS}}}path"
        build, resources = root.find(q("build")), root.find(q("resources"))
        items = [i for i in (build.findall(q("item")) if build is not None else []) if i.get(path_key)]
        if not items or resources is None:
            return None
        ids = [int(o.get("id", "0")) for o in resources.iter(q("object")) if o.get("id", "").isdigit()]
        base = max(ids, default=0) + 1
        offsets: dict[str, int] = {}
        for item in items:
            part = item.get(path_key, "").lower().lstrip("/")
            if part not in offsets:
                if part not in names:
                    return None
                objects = DET.fromstring(zin.read(names[part])).iter(q("object"))
                offsets[part], top = base, 0
                for obj in objects:  # copied under id + offset; their own components too
                    top = max(top, int(obj.get("id", "0")))
                    obj.set("id", str(int(obj.get("id", "0")) + base))
                    for comp in obj.iter(q("component")):
                        if not comp.get(path_key):
                            comp.set("objectid", str(int(comp.get("objectid", "0")) + base))
                    resources.append(obj)
                base += top + 1
            item.set("objectid", str(int(item.get("objectid", "0")) + offsets[part]))
            del item.attrib[path_key]
    except (zipfile.BadZipFile, ET.ParseError, KeyError, OSError, ValueError):
        return None
    out = io.BytesIO()
    with zipfile.ZipFile(out, "w", zipfile.ZIP_DEFLATED) as zout:
        for name in zin.namelist():
            zout.writestr(name, ET.tostring(root, encoding="utf-8") if name == root_name else zin.read(name))
    return out.getvalue()
