"""Slicing benchmark: our mesh load + slice kernels vs bare trimesh, side by side in one run.

Entries (contract `out/bench/results.json`):
- `slice_ratio_vs_trimesh`: time(ours) / time(peer) on a generated ribbed, twisted hollow tube
  (≥ 0.5 M triangles, binary STL in a temp dir) cut into ≥ 500 mid-layer planes. Ours =
  `geometry.load_mesh_bytes` (parse + weld + closedness check) + `slicing.slice_part` (sections +
  polygons with holes), the functions the `mesh` and `slice` nodes call. Peer = `trimesh.load` +
  `section_multiplane` + `Path2D.polygons_full` (shapely polygons with holes) per layer.
- `mesh_load_50mb_s`: seconds to load a ~50 MB binary STL (1 M triangles) with our loader; peer
  `trimesh.load` of the same file.
- `slice_area_error`: relative difference of total section area, ours vs trimesh (agreement).

Method, the same for us and the peer: both are warmed up on a small mesh (lazy imports and
caches not timed), both read their input from the same file on disk inside the timed call, and
each time is the median of `REPEATS` runs. Run alone: `.venv/bin/python bench/bench_slice.py`.
"""

from __future__ import annotations

import json
import os
import statistics
import tempfile
import time

import numpy as np

REPEATS = 3


def ribbed_tube(
    n_theta: int,
    n_z: int,
    *,
    radius: float = 60.0,
    wall: float = 6.0,
    height: float = 100.0,
    ribs: int = 24,
    rib_depth: float = 3.0,
    twist_deg: float = 90.0,
    inner_follows: bool = False,
) -> np.ndarray:
    """Triangle corners (4·n_theta·(n_z + 1), 3, 3) float32, mm, of a closed hollow tube.

    Outer wall carries `ribs` sinusoidal ribs of depth `rib_depth` twisting by `twist_deg` over
    the height; the inner wall is a plain cylinder of radius − wall (or, `inner_follows`, the
    outer wall moved in by `wall`: a rippled thin wall), so every section is one ring with one
    hole. Faces are wound outwards.
    """
    th = np.linspace(0.0, 2 * np.pi, n_theta, endpoint=False)
    z = np.linspace(0.0, height, n_z + 1)
    T, Z = np.meshgrid(th, z, indexing="ij")  # (n_theta, n_z + 1)
    phase = T + np.radians(twist_deg) * Z / height
    r_out = radius + rib_depth * np.sin(ribs * phase)
    r_in = r_out - wall if inner_follows else np.full_like(T, radius - wall)
    outer = np.stack([r_out * np.cos(T), r_out * np.sin(T), Z], axis=-1)
    inner = np.stack([r_in * np.cos(T), r_in * np.sin(T), Z], axis=-1)
    j1 = np.roll(np.arange(n_theta), -1)

    def quads(s, a_j, b_j, k0, k1):
        return s[a_j][:, k0], s[b_j][:, k0], s[b_j][:, k1], s[a_j][:, k1]

    j = np.arange(n_theta)
    k0, k1 = np.arange(n_z), np.arange(1, n_z + 1)
    tris = []
    a, b, c, d = quads(outer, j, j1, k0, k1)  # outward
    tris += [np.stack([a, b, c], -2), np.stack([a, c, d], -2)]
    a, b, c, d = quads(inner, j, j1, k0, k1)  # inward-facing wall: reversed
    tris += [np.stack([a, c, b], -2), np.stack([a, d, c], -2)]
    for k, down in ((0, True), (n_z, False)):
        o0, o1, i0, i1 = outer[j, k], outer[j1, k], inner[j, k], inner[j1, k]
        if down:
            tris += [np.stack([o0, i0, i1], -2), np.stack([o0, i1, o1], -2)]
        else:
            tris += [np.stack([o0, i1, i0], -2), np.stack([o0, o1, i1], -2)]
    return np.concatenate([t.reshape(-1, 3, 3) for t in tris]).astype(np.float32)


def write_binary_stl(path: str, corners: np.ndarray) -> int:
    """Write (m, 3, 3) corners as binary STL; returns the file size in bytes."""
    from waamflow.geometry.mesh_io import STL_RECORD

    rec = np.zeros(len(corners), dtype=STL_RECORD)
    rec["corners"] = corners
    n = np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0])
    rec["normal"] = n / np.maximum(np.linalg.norm(n, axis=1, keepdims=True), 1e-30)
    with open(path, "wb") as fh:
        fh.write(b"waamflow bench".ljust(80, b" "))
        fh.write(np.uint32(len(corners)).tobytes())
        fh.write(rec.tobytes())
    return os.path.getsize(path)


def _median(fn, repeats=REPEATS):
    """(median wall seconds of `repeats` calls of fn, the last call's result)."""
    times, out = [], None
    for _ in range(repeats):
        t = time.perf_counter()
        out = fn()
        times.append(time.perf_counter() - t)
    return statistics.median(times), out


def load_ours(path: str):
    """Our loader as the `mesh` node runs it: the file's bytes, then parse + weld + closedness check."""
    from waamflow.geometry import load_mesh_bytes

    with open(path, "rb") as fh:
        data = fh.read()
    return load_mesh_bytes(data, os.path.basename(path))


def ours(path: str, layer_height: float):
    from waamflow.slicing import slice_part

    return slice_part(load_ours(path), layer_height=layer_height)


def peer(path: str, heights: np.ndarray):
    """Bare trimesh: load, one multiplane section call, shapely polygons with holes per layer."""
    import trimesh

    mesh = trimesh.load(path, force="mesh")
    z0 = float(mesh.bounds[0][2])
    paths = mesh.section_multiplane(plane_origin=[0, 0, z0], plane_normal=[0, 0, 1], heights=list(heights - z0))
    return [list(p.polygons_full) if p is not None else [] for p in paths]


def run() -> list[dict]:
    import trimesh

    results = []
    with tempfile.TemporaryDirectory() as tmp:
        # ---- warm-up, both sides: imports, caches -----------------------------------------
        small = os.path.join(tmp, "small.stl")
        write_binary_stl(small, ribbed_tube(64, 8))
        ours(small, 10.0)
        peer(small, np.array([10.0, 50.0]))
        # ---- slicing: ≥ 0.5 M triangles, ≥ 500 layers ------------------------------------
        path = os.path.join(tmp, "ribbed_tube.stl")
        corners = ribbed_tube(1000, 125)
        write_binary_stl(path, corners)
        layer_height = 0.2  # 100 mm / 0.2 mm = 500 layers
        t_ours, layers = _median(lambda: ours(path, layer_height))
        cuts = np.array([l.z - l.thickness / 2 for l in layers])
        t_peer, polys = _median(lambda: peer(path, cuts))
        a_ours = sum(l.area for l in layers)
        a_peer = sum(p.area for ps in polys for p in ps)
        results.append(
            {
                "name": "slice_ratio_vs_trimesh",
                "value": round(t_ours / t_peer, 4),
                "unit": "ratio",
                "peer": "trimesh.load + section_multiplane + Path2D.polygons_full",
                "ratio": round(t_ours / t_peer, 4),
                "notes": f"{len(corners)} triangles, {len(layers)} layers; ours {t_ours:.3f} s, peer {t_peer:.3f} s "
                f"(each the median of {REPEATS} runs from the same file, both warmed up)",
            }
        )
        results.append(
            {
                "name": "slice_area_error",
                "value": abs(a_ours - a_peer) / a_peer,
                "unit": "ratio",
                "peer": "trimesh section areas",
                "ratio": abs(a_ours - a_peer) / a_peer,
                "notes": f"total section area ours {a_ours:.1f} mm², trimesh {a_peer:.1f} mm²",
            }
        )
        # ---- loading a 50 MB binary STL ---------------------------------------------------
        big = os.path.join(tmp, "big.stl")
        size = write_binary_stl(big, ribbed_tube(2000, 124))
        t_load, mesh = _median(lambda: load_ours(big))
        t_tm, _ = _median(lambda: trimesh.load(big, force="mesh"))
        results.append(
            {
                "name": "mesh_load_50mb_s",
                "value": round(t_load, 4),
                "unit": "s",
                "peer": "trimesh.load",
                "ratio": round(t_load / t_tm, 4),
                "notes": f"{size / 1e6:.1f} MB, {len(mesh.faces)} triangles, {len(mesh.vertices)} vertices after welding; trimesh {t_tm:.3f} s (both read the file from disk "
                f"in the timed call, median of {REPEATS} runs each)",
            }
        )
    return results


if __name__ == "__main__":
    print(json.dumps({"results": run()}, indent=2))
