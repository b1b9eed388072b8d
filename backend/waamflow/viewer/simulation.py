"""Scene adapter of a simulated robot motion (another engineer's `SimulationResult`, by duck
typing: `trace` dict, `programmed` (n, 3), optional `corners`, `section_keys`, `profile`).

    /graph/<node>/simulation/L0007/programmed    programmed path (grey)
    /graph/<node>/simulation/L0007/simulated     simulated path (by deviation or speed; arc OFF pale)
    /graph/<node>/simulation/L0007/corners       blended corners (by corner error), pickable
    /graph/<node>/simulation/torch               playback marker at the slider's time
    /graph/<node>/simulation/robot/links         the arm (stick figure) at the slider's time
    /graph/<node>/simulation/robot/body          the arm's link geometry (tubes, torch) at that time

With a cell (simulate-robot `cell`), the cell is drawn in the world and replayed from the
simulation's own joint and positioner angles (`robot.cell_motion`):

    /cell/<node>/arm/body, /arm/links            the arm's link tubes and stick figure
    /cell/<node>/torch/<shape>                   the torch shapes on the flange
    /cell/<node>/positioner/<shape>              table, tilt frame (turning with the positioner)
    /cell/<node>/fixtures/<shape>                pedestals, floor, clamps (world or positioner link)
    /graph/<node>/simulation/flags/unreachable   unreachable stretches of the path (red, thick)
    /graph/<node>/simulation/flags/collisions    collision points (red spheres, on the part)

and the whole `/graph` tree (part, layers, toolpath, simulated path) is placed at the work
frame's pose at the playback time: the part turns with the positioner.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from . import colors as C
from . import geometry as G
from .scene import PROGRAMMED_PX, SIM_PX, Part, Pick, layer_name
from .signature import digest


class SimulationPart(Part):
    """Programmed vs simulated path per layer, simulated coloured by deviation or speed, and a
    torch marker placed on the trace at the playback time."""

    kind = "simulation"

    def __init__(self, *a, **k) -> None:
        super().__init__(*a, **k)
        self.sig: str | None = None
        self.entries: dict[int, dict[str, Any]] = {}
        self.trace: dict[str, np.ndarray] = {}
        self.section_keys: tuple[str, ...] = ()
        self.points = np.zeros((0, 3))
        self.torch = None
        self.ranges: dict[str, tuple[float, float]] = {}  # colour-map limits (robust)
        self.full_ranges: dict[str, tuple[float, float]] = {}  # the data's full extent
        self.mode = "deviation"
        self.node_params: dict[str, Any] = {}  # the simulate node's params (cell set-up for the robot)
        self.robot: Any = None  # RobotMotion (arm only) or CellMotion (cell), or None
        self.robot_note = ""  # why there is no robot, if there is none
        self.robot_handles: dict[str, Any] = {}
        self.cell_handles: dict[str, tuple[Any, str | None]] = {}  # name → (handle, link: None still, "" flange…)
        self.graph_frame = None  # the service's /graph frame (moved with the positioner)
        self.corner_points = np.zeros((0, 3))
        self.corner_layer = np.zeros(0, np.int64)
        self.corner_table: dict[str, np.ndarray] = {}
        self.offset = 0.0  # current sim_offset_mm (the torch rides on the drawn path)
        self.lift = 0.0  # display lift of the lines above the toolpath (mm)
        self.deposit: dict[str, np.ndarray] = {}
        self.programmed = np.zeros((0, 3))
        self._deposit_samples: np.ndarray | None = None

    def duration(self) -> float:
        t = self.trace.get("t")
        return float(t[-1]) if t is not None and len(t) else 0.0

    def deposit_per_sample(self) -> np.ndarray:
        """(n,) actual deposit per mm (mm³/mm) of the programmed segment each trace sample lies
        on (nearest programmed segment of the same layer); NaN without deposit data."""
        if self._deposit_samples is None:
            self._deposit_samples = np.full(len(self.points), np.nan)
            dep = np.asarray(self.deposit.get("actual_mm3_per_mm", ()), float)
            prog = self.programmed
            if len(dep) and len(prog) == len(dep) + 1 and len(self.points):
                from scipy.spatial import cKDTree

                a, b = prog[:-1], prog[1:]
                k = min(8, len(dep))
                _, cand = cKDTree((a + b) / 2).query(self.points, k=k)  # candidates, then exact
                cand = np.asarray(cand).reshape(len(self.points), k)
                ab = b[cand] - a[cand]
                u = np.clip(
                    np.einsum("nkj,nkj->nk", self.points[:, None] - a[cand], ab)
                    / np.maximum(np.einsum("nkj,nkj->nk", ab, ab), 1e-12),
                    0.0,
                    1.0,
                )
                d = np.linalg.norm(a[cand] + u[..., None] * ab - self.points[:, None], axis=2)
                self._deposit_samples = dep[cand[np.arange(len(cand)), d.argmin(axis=1)]]
        return self._deposit_samples

    def _sim_colors(self, first: np.ndarray, mode: str) -> np.ndarray:
        if mode == "deposit":
            vals = self.deposit_per_sample()[first]
            key = "deposit"
        else:
            key = "deviation" if mode == "deviation" else "speed"
            vals = np.asarray(self.trace.get(key, np.full(len(self.points), np.nan)), float)[first]
        rgb = C.colormap(vals, *self.ranges.get(key, (0.0, 1.0)))
        if "arc" in self.trace:
            rgb[~np.asarray(self.trace["arc"], bool)[first]] = C.TRAVEL_RGB
        return np.repeat(rgb[:, None, :], 2, axis=1)

    def sync(self, value, view) -> int:
        sig = digest((value.trace, getattr(value, "programmed", None), self.node_params))
        if sig == self.sig:
            return 0
        for e in self.entries.values():
            e["handle"].remove()
        self.entries.clear()
        trace = {k: np.asarray(v) for k, v in value.trace.items()}
        self.trace = trace
        self.section_keys = tuple(getattr(value, "section_keys", ()) or ())
        self.points = G.trace_points(trace)
        n = len(self.points)
        self.ranges = {k: C.robust_range(trace[k]) for k in ("deviation", "speed") if k in trace}
        self.full_ranges = {k: C.finite_range(trace[k]) for k in ("deviation", "speed") if k in trace}
        self.deposit = {k: np.asarray(v) for k, v in (getattr(value, "deposit", None) or {}).items()}
        self._deposit_samples = None
        if "actual_mm3_per_mm" in self.deposit:
            dep = np.asarray(self.deposit["actual_mm3_per_mm"], float)
            arc = np.asarray(self.deposit.get("arc", np.ones(len(dep), bool)), bool)
            self.ranges["deposit"] = C.robust_range(dep[arc] if arc.any() else dep)
            self.full_ranges["deposit"] = C.finite_range(dep[arc] if arc.any() else dep)
        layer = np.asarray(trace.get("layer", np.zeros(n)), np.int64)
        chunks = G.split_by_layer(layer)
        budget = max(self.max_segments // max(len(chunks), 1) // 2, 64)
        programmed = getattr(value, "programmed", None)
        prog = np.zeros((0, 3)) if programmed is None else np.asarray(programmed, float).reshape(-1, 3)
        self.programmed = prog
        # Display only: where simulated and programmed paths coincide with the (wider) toolpath, the
        # thinner lines are lifted a hair (1e-3 of the part's size) so they draw on top of it seen
        # from above: toolpath band → simulated line inside it → programmed hairline in the middle.
        extent = np.ptp(self.points, axis=0) if n else np.zeros(3)
        self.lift = 1e-3 * float(np.linalg.norm(extent))
        prog_layer = self._programmed_layers(prog, layer)
        prog_chunks = G.split_by_layer(prog_layer) if len(prog) else {}
        added = 0
        for index in sorted(set(chunks) | set(prog_chunks)):
            name = f"{self.root}/{layer_name(index)}"
            frame = self.scene.add_frame(name, show_axes=False)
            entry: dict[str, Any] = {"handle": frame, "bounds": None}
            if index in prog_chunks:
                segs, _ = G.chunk_segments(prog, prog_chunks[index], budget)
                entry["prog"] = self.scene.add_line_segments(
                    f"{name}/programmed",
                    segs,
                    C.PROGRAMMED_RGB,
                    thickness=PROGRAMMED_PX,
                    thickness_units="screen",
                    position=(0.0, 0.0, 2 * self.lift),
                    visible=view.show_programmed,
                )
                entry["programmed"] = len(segs)
            if index in chunks:
                arc_flags = np.asarray(trace["arc"], np.int64) if "arc" in trace else None
                segs, first = G.chunk_segments(self.points, chunks[index], budget, arc_flags)
                entry["sim"] = self.scene.add_line_segments(
                    f"{name}/simulated",
                    segs,
                    self._sim_colors(first, view.sim_color),
                    thickness=SIM_PX,
                    thickness_units="screen",
                    position=(0.0, 0.0, view.sim_offset_mm + self.lift),
                    visible=view.show_simulated,
                )
                entry["first"] = first
                entry["bounds"] = G.layers_bounds([segs])
            frame.visible = view.shows_layer(index)
            self.entries[index] = entry
            added += 1
        self._add_corners(value, prog, prog_layer)
        self.mode = view.sim_color
        pos, _ = G.interpolate_trace(trace, view.time_s) if n else (np.zeros(3), 0)
        b = self.bounds()
        radius = 0.01 * float(np.linalg.norm(b[1] - b[0])) if b is not None else 1.0
        self.torch = self.scene.add_icosphere(
            f"{self.root}/torch", radius=max(radius, 0.5), color=(255, 183, 3), position=tuple(pos), visible=n > 0
        )
        self._add_robot(value, view)
        self.sig = sig
        return added + 1

    def _add_corners(self, value, prog: np.ndarray, prog_layer: np.ndarray) -> None:
        """Blended corners as points on their layer, coloured by corner error (the study's closest
        approach of the actual path to the programmed vertex); picked for error, angle, speed."""
        corners = getattr(value, "corners", None) or {}
        vertex = np.asarray(corners.get("vertex", ()), np.int64).reshape(-1)
        ok = (vertex >= 0) & (vertex < len(prog))
        self.corner_table = {k: np.asarray(v)[ok] for k, v in corners.items() if len(np.asarray(v)) == len(vertex)}
        vertex = vertex[ok]
        self.corner_points = prog[vertex] if len(vertex) else np.zeros((0, 3))
        self.corner_layer = prog_layer[vertex] if len(vertex) else np.zeros(0, np.int64)
        if not len(vertex):
            return
        err = np.asarray(self.corner_table.get("error_mm", np.full(len(vertex), np.nan)), float)
        rgb = C.colormap(err, *C.finite_range(err))
        b = self.bounds()
        size = 0.006 * float(np.linalg.norm(b[1] - b[0])) if b is not None else 0.5
        for index in np.unique(self.corner_layer):
            m = self.corner_layer == index
            if int(index) in self.entries:
                self.scene.add_point_cloud(
                    f"{self.root}/{layer_name(int(index))}/corners",
                    self.corner_points[m].astype(np.float32),
                    rgb[m],
                    point_size=max(size, 0.2),
                    point_shape="diamond",
                )

    def _add_robot(self, value, view) -> None:
        """The arm (link geometry + stick figure) at the playback time, if its URDF loads (see `robot`)."""
        from .robot import cell_setup, robot_motion

        for h in self.robot_handles.values():
            h.remove()
        self.robot_handles = {}
        self._remove_cell()
        self.robot, self.robot_note = None, ""
        if len(self.points) < 2 or "t" not in self.trace:
            return
        if (getattr(value, "kinematics", None) or {}).get("motion"):
            self._add_cell(value, view)
            return
        try:
            setup = cell_setup(self.node_params, dict(getattr(value, "profile", {}) or {}))
            self.robot = robot_motion(self.trace, setup)
        except Exception as e:  # no URDF, no Pinocchio, unreachable: the preview goes on without the arm
            self.robot_note = f"robot not shown: {e}"
            return
        segs = self.robot.segments(view.time_s)
        self.robot_handles["links"] = self.scene.add_line_segments(
            f"{self.root}/robot/links",
            segs,
            C.ROBOT_RGB,
            thickness=4.0,
            thickness_units="screen",
            visible=view.show_robot,
        )
        verts, faces = self.robot.body(view.time_s)
        self.robot_handles["body"] = self.scene.add_mesh_simple(
            f"{self.root}/robot/body",
            verts,
            faces,
            color=tuple(int(c) for c in C.ROBOT_RGB),
            opacity=0.45,
            side="double",
            visible=view.show_robot,
        )

    def _add_cell(self, value, view) -> None:
        """The cell in the world (see the module doc), the flags on the part."""
        from .robot import cell_motion, shape_arrays

        self._remove_cell()
        try:
            self.robot = cell_motion(value)
        except Exception as e:  # a cell whose URDF/meshes cannot be loaded here: path only
            self.robot, self.robot_note = None, f"cell not shown: {e}"
            return
        m, cell = self.robot, self.robot.cell
        root = f"/cell/{self.node}"
        segs = m.segments(view.time_s)
        self.robot_handles["links"] = self.scene.add_line_segments(
            f"{root}/arm/links", segs, C.ROBOT_RGB, thickness=4.0, thickness_units="screen", visible=view.show_robot
        )
        verts, faces = m.body(view.time_s)
        self.robot_handles["body"] = self.scene.add_mesh_simple(
            f"{root}/arm/body",
            verts,
            faces,
            color=tuple(int(c) for c in C.ROBOT_RGB),
            opacity=0.55,
            side="double",
            visible=view.show_robot,
        )
        groups = [
            ("torch", cell.tool.shapes, "tool0", (230, 120, 30)),
            ("positioner", cell.positioner.shapes if cell.positioner else [], "", (90, 110, 140)),
            ("fixtures", cell.fixtures, None, (150, 150, 150)),
        ]
        for group, shapes, default, rgb in groups:
            for sh in shapes:
                link = default if default is not None and not sh.link else (sh.link or None)
                if group == "fixtures" and sh.name == "floor":
                    continue  # the grid stands for the floor
                try:
                    v, f = shape_arrays(cell, sh)
                except Exception:  # a user's mesh not readable here: skip that body
                    continue
                h = self.scene.add_mesh_simple(
                    f"{root}/{group}/{sh.name}",
                    v,
                    f,
                    color=rgb,
                    opacity=0.9 if group != "fixtures" else 0.6,
                    side="double",
                    visible=view.show_robot,
                )
                self.cell_handles[f"{group}/{sh.name}"] = (h, link)
        self._add_flags(value, m)
        self._place_cell(view.time_s)

    def _add_flags(self, value, m) -> None:
        """Unreachable stretches (thick red on the programmed path) and collision points (red),
        in the part frame so they turn with the part."""
        from .robot import programmed_s

        kin = getattr(value, "kinematics", None) or {}
        prog = np.asarray(getattr(value, "programmed", np.zeros((0, 3))), float)
        if len(prog) >= 2:
            s_prog = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(prog, axis=0), axis=1))])
            segs = []
            for it in kin.get("issues", []):
                if it.get("kind") != "unreachable":
                    continue
                k = np.flatnonzero((s_prog >= it["s_from"] - 1e-6) & (s_prog <= it["s_to"] + 1e-6))
                k = k[k < len(prog) - 1]
                segs += [prog[[i, i + 1]] for i in k]
            if segs:
                self.robot_handles["unreachable"] = self.scene.add_line_segments(
                    f"{self.root}/flags/unreachable",
                    np.asarray(segs, np.float32),
                    (230, 30, 30),
                    thickness=6.0,
                    thickness_units="screen",
                )
        cols = list(getattr(value, "collisions", ()) or ())
        if cols and m is not None:
            s_tr = programmed_s(value)
            pts = []
            for c in cols:
                i = m.index(float(np.interp(c.s_mm, s_tr, self.trace["t"])))
                R, t = m.work[0][i], m.work[1][i]
                pts.append(R.T @ (np.asarray(c.point_mm, float) - t))  # world → part frame
            b = self.bounds()
            size = 0.015 * float(np.linalg.norm(b[1] - b[0])) if b is not None else 2.0
            self.robot_handles["collisions"] = self.scene.add_point_cloud(
                f"{self.root}/flags/collisions",
                np.asarray(pts, np.float32),
                (255, 0, 0),
                point_size=max(size, 1.0),
                point_shape="circle",
            )

    def _place_cell(self, t: float) -> None:
        """Arm, torch, positioner and the part at time t."""
        from .robot import wxyz

        m = self.robot
        i = m.index(t)
        for name, (h, link) in self.cell_handles.items():
            if link is None:
                continue
            if link == "tool0":
                R, p = m.tool[0][i], m.tool[1][i]
            else:
                R, p = (m.links[link][0][i], m.links[link][1][i])
            h.wxyz, h.position = wxyz(R), tuple(float(v) for v in p)
        if self.graph_frame is not None:
            self.graph_frame.wxyz = wxyz(m.work[0][i])
            self.graph_frame.position = tuple(float(v) for v in m.work[1][i])

    def work_pose(self, t: float) -> tuple[np.ndarray, np.ndarray] | None:
        """(R (3, 3), translation (3,) mm) of the part frame in the world at time t — where the
        positioner holds the part — or None without a cell (the part frame is the world)."""
        m = self.robot
        if m is None or not hasattr(m, "work"):
            return None
        i = m.index(t)
        return np.asarray(m.work[0][i], float), np.asarray(m.work[1][i], float)

    def cell_points(self, t: float) -> list[np.ndarray]:
        """World points (mm) of what stands in the cell at time t: the arm, and the torch,
        positioner and fixtures as placed then (the floor left out, as when drawn)."""
        m = self.robot
        if m is None:
            return []
        pts = [np.asarray(m.body(t)[0], float).reshape(-1, 3)]
        if not self.cell_handles:
            return pts
        from .robot import shape_arrays

        i = m.index(t)
        cell = m.cell
        for group, shapes, default in (
            ("torch", cell.tool.shapes, "tool0"),
            ("positioner", cell.positioner.shapes if cell.positioner else [], ""),
            ("fixtures", cell.fixtures, None),
        ):
            for sh in shapes:
                if f"{group}/{sh.name}" not in self.cell_handles:
                    continue
                link = default if default is not None and not sh.link else (sh.link or None)
                try:
                    v = np.asarray(shape_arrays(cell, sh)[0], float).reshape(-1, 3)
                except Exception:
                    continue
                if link == "tool0":
                    R, p = m.tool[0][i], m.tool[1][i]
                    v = v @ np.asarray(R).T + p
                elif link:
                    R, p = m.links[link][0][i], m.links[link][1][i]
                    v = v @ np.asarray(R).T + p
                pts.append(v)
        return pts

    def robot_base(self) -> np.ndarray | None:
        """World position (mm) of the arm's base, or None without an arm."""
        m = self.robot
        if m is None:
            return None
        chain = getattr(m, "chain", None)
        if chain is None:
            chain = getattr(m, "joints", None)
        return None if chain is None or not len(chain) else np.asarray(chain[0][0], float)

    def _remove_cell(self) -> None:
        for h, _ in self.cell_handles.values():
            h.remove()
        self.cell_handles = {}
        if self.graph_frame is not None:
            self.graph_frame.wxyz, self.graph_frame.position = (1.0, 0.0, 0.0, 0.0), (0.0, 0.0, 0.0)

    def remove(self) -> None:
        self._remove_cell()
        for h in self.robot_handles.values():
            h.remove()
        self.robot_handles = {}
        super().remove()

    def _programmed_layers(self, prog: np.ndarray, trace_layer: np.ndarray) -> np.ndarray:
        """Layer of each programmed point: the trace's own when sampled 1:1, else the layer of
        the nearest simulated sample."""
        if len(prog) == len(trace_layer):
            return trace_layer
        if len(prog) == 0 or len(self.points) == 0:
            return np.zeros(len(prog), np.int64)
        from scipy.spatial import cKDTree

        _, idx = cKDTree(self.points).query(prog)
        return trace_layer[idx]

    def apply(self, view):
        for index, e in self.entries.items():
            e["handle"].visible = view.shows_layer(index)
            if "sim" in e:
                e["sim"].position = (0.0, 0.0, view.sim_offset_mm + self.lift)
                e["sim"].visible = view.show_simulated
            if "prog" in e:
                e["prog"].visible = view.show_programmed
        self.offset = view.sim_offset_mm
        if view.sim_color != self.mode:
            for e in self.entries.values():
                if "sim" in e:
                    e["sim"].colors = self._sim_colors(e["first"], view.sim_color)
            self.mode = view.sim_color
        for key in ("links", "body"):
            if key in self.robot_handles:
                self.robot_handles[key].visible = view.show_robot
        for h, _ in self.cell_handles.values():
            h.visible = view.show_robot
        self.set_time(view.time_s)

    def set_time(self, t: float) -> dict[str, Any] | None:
        """Move the torch marker to time t (s); returns the sample readout at t."""
        if self.torch is None or not len(self.points):
            return None
        pos, i = G.interpolate_trace(self.trace, t)
        self.torch.position = (float(pos[0]), float(pos[1]), float(pos[2]) + self.offset)
        if self.robot is not None and self.robot_handles:
            self.robot_handles["links"].points = self.robot.segments(t)
            self.robot_handles["body"].vertices = self.robot.body(t)[0]
            if self.cell_handles or hasattr(self.robot, "work"):
                self._place_cell(t)
        return self.sample_info(i)

    def sample_info(self, i: int) -> dict[str, Any]:
        """Readout of trace sample i: time, layer, section key, actual speed, deviation, arc."""
        tr = self.trace
        info: dict[str, Any] = {}
        if "t" in tr:
            info["t_s"] = round(float(tr["t"][i]), 4)
        if "layer" in tr:
            info["layer"] = int(tr["layer"][i])
        if "section" in tr:
            sec = tr["section"][i]
            keys = self.section_keys
            info["section"] = (
                keys[int(sec)]
                if np.issubdtype(np.asarray(sec).dtype, np.integer) and 0 <= int(sec) < len(keys)
                else str(sec)
            )
        if "speed" in tr:
            info["actual_speed_mm_s"] = round(float(tr["speed"][i]), 4)
        if "deviation" in tr:
            info["deviation_mm"] = round(float(tr["deviation"][i]), 4)
        if "arc" in tr:
            info["arc"] = bool(tr["arc"][i])
        return info

    def layer_indices(self):
        return sorted(self.entries)

    def bounds(self):
        return G.layers_bounds([e["bounds"] for e in self.entries.values() if e.get("bounds") is not None])

    def pick(self, origin, direction, tol, view):
        if not len(self.points):
            return None
        corner = self._pick_corner(origin, direction, tol, view)
        if corner is not None:
            return corner
        mask = np.ones(len(self.points), bool)
        if "layer" in self.trace:
            lay = np.asarray(self.trace["layer"], np.int64)
            mask = (lay >= view.layer_lo) & (lay <= view.layer_hi)
        idx = np.flatnonzero(mask)
        lift = np.array([0.0, 0.0, self.offset])  # picked where it is drawn
        i = G.ray_pick(self.points[idx] + lift, origin, direction, tol)
        if i is None:
            return None
        j = int(idx[i])
        d = np.asarray(direction, float) / np.linalg.norm(direction)
        p = self.points[j] + lift
        return Pick(float((p - np.asarray(origin, float)) @ d), p, self.sample_info(j))

    def _pick_corner(self, origin, direction, tol, view) -> Pick | None:
        vis = np.flatnonzero((self.corner_layer >= view.layer_lo) & (self.corner_layer <= view.layer_hi))
        i = G.ray_pick(self.corner_points[vis], origin, direction, tol) if len(vis) else None
        if i is None:
            return None
        j = int(vis[i])
        d = np.asarray(direction, float) / np.linalg.norm(direction)
        info: dict[str, Any] = {"corner": True, "layer": int(self.corner_layer[j])}
        for key in ("interior_deg", "error_mm", "min_speed_mm_s"):
            if key in self.corner_table:
                info[f"corner_{key}"] = round(float(self.corner_table[key][j]), 4)
        return Pick(float((self.corner_points[j] - np.asarray(origin, float)) @ d), self.corner_points[j], info)

    def nearest_sample(self, point: np.ndarray, layer: int | None) -> dict[str, Any] | None:
        """Readout of the simulated sample nearest to a world point (same layer when known)."""
        if not len(self.points):
            return None
        idx = np.arange(len(self.points))
        if layer is not None and "layer" in self.trace:
            same = np.flatnonzero(np.asarray(self.trace["layer"], np.int64) == layer)
            idx = same if len(same) else idx
        j = int(idx[np.argmin(np.linalg.norm(self.points[idx] - point, axis=1))])
        return self.sample_info(j)
