/**
 * The 2D mask canvas (SVG): the active layer with holes, neighbouring layers ghosted, the mask's
 * closed segmentation curves, guides with their boundary crossings, zone split points and
 * start/end lengths, and the section paths coloured by zone as re-planned by the server.
 * Drawing is in layer mm; SVG y = −y so the part is seen from above with y up.
 */
import { memo, useCallback, useEffect, useMemo, useRef, useState, type PointerEvent as RPointerEvent } from "react";
import { DeviationOverlay } from "../builds/DeviationOverlay";
import { CoverageLayer } from "./CoverageLayer";
import type { LayerJson, Preview, PreviewPath } from "../api/types";
import {
  boundaryCrossings, closestOnPolyline, dist, pointAtLength, polygonPathD, polygonVertices, ringPathD, snapPoint,
  translate, type Pt,
} from "./geom";
import { sectionKey, type GuideParams, type KeyedParams, type Mask } from "./edits";
import { canvasLegend, dropVertex, measure, mm, nudge, nudgeStep, pathRuns, speedRange, type ColorBy } from "./canvasTools";
import { useSvgView, type View } from "./useSvgView";

export type Tool = "select" | "curve" | "guide" | "split" | "measure";

export const SECTION_COLORS = ["#e76f51", "#2a9d8f", "#e9c46a", "#8e7dbe", "#f4a261", "#457b9d", "#b5838d", "#6a994e"];

export interface CanvasEdits {
  addCurve: (curve: Pt[]) => void;
  setCurve: (key: string, curve: Pt[]) => void;
  setGuide: (key: string, guide: Pt[]) => void;
  addSplit: (key: string, p: Pt) => void;
  removeSplit: (key: string, index: number) => void;
  removeSection: (key: string) => void;
}

export interface MaskCanvasProps {
  preview: Preview | null;
  ghosts: { prev: LayerJson | null; next: LayerJson | null };
  mask: Mask | undefined;
  guides: GuideParams;
  zone: KeyedParams;
  tool: Tool;
  setTool: (t: Tool) => void;
  grid: number;
  snapVertices: boolean;
  selected: string | null;
  setSelected: (k: string | null) => void;
  highlight: string | null;
  edits: CanvasEdits;
  replanMs: number | null;
  /** Path colours: by zone, programmed speed or arc state. */
  colorBy: ColorBy;
  /** Bead width (mm) of a section's paths, drawn under them; null = not drawn. */
  beadWidthOf: (key: string) => number | null;
  /** Move the shown layer by ±1 (PageUp / PageDown). */
  onLayerStep: (delta: number) => void;
  /** The last run's ignition points (preflight, layer mm) of this layer and the one below;
   * `stacked[i]`: start i lies within a bead width of one below. */
  starts?: { here: number[][]; below: number[][]; stops?: number[][]; stacked: boolean[] } | null;
  /** A point a picked preflight problem names (layer mm), marked with a crosshair. */
  mark?: number[] | null;
}

type Drag =
  | { kind: "pan" }
  | { kind: "vertex"; key: string; index: number; curve: Pt[] }
  | { kind: "curve"; key: string; start: Pt; curve: Pt[] };

// Stable empty lists: a fresh `[]` each render would recompute every memo that depends on them.
const NO_SECTIONS: Preview["sections"] = [];
const NO_PATHS: PreviewPath[] = [];
const num = (v: unknown, d = 0) => (typeof v === "number" && Number.isFinite(v) ? v : d);

export const MaskCanvas = memo(function MaskCanvas(p: MaskCanvasProps) {
  const svgRef = useRef<SVGSVGElement>(null);
  const { view, fitTo, pxSize, toWorld, onWheel, startPan, movePan, endPan } = useSvgView(svgRef);
  const [draft, setDraft] = useState<Pt[]>([]);
  const [cursor, setCursor] = useState<{ p: Pt; kind: string } | null>(null);
  const [dragCurve, setDragCurve] = useState<{ key: string; curve: Pt[] } | null>(null);
  const drag = useRef<Drag | null>(null);
  const layer = p.preview?.layer ?? null;
  const [vertexSel, setVertexSel] = useState<{ key: string; index: number } | null>(null);
  const [measureAB, setMeasureAB] = useState<{ a: Pt; b: Pt | null } | null>(null);
  const [measureHover, setMeasureHover] = useState<Pt | null>(null);
  const coordsRef = useRef<HTMLSpanElement>(null);

  // Fit the view to the layer the first time one arrives (and on demand).
  const fit = useCallback(
    () =>
      fitTo([
        ...(layer?.polygons.flatMap((q) => q.exterior) ?? []),
        ...(layer?.curves.flat() ?? []),
        ...(p.preview?.paths.flatMap((q) => q.points) ?? []),
        ...(p.ghosts.prev?.polygons.flatMap((q) => q.exterior) ?? []),
        ...(p.mask?.sections.flatMap((s) => s.curve) ?? []),
      ]),
    [fitTo, layer, p.preview, p.ghosts.prev, p.mask],
  );
  useEffect(() => {
    if (!view && layer) fit();
  }, [layer, view, fit]);

  const snapVerts = useMemo(() => {
    const v = p.snapVertices ? polygonVertices(layer?.polygons ?? []) : [];
    const curves = p.snapVertices ? (p.mask?.sections.flatMap((s) => s.curve) ?? []) : [];
    return [...v, ...curves];
  }, [layer, p.mask, p.snapVertices]);

  const snap = (w: Pt) => snapPoint(w, { vertices: snapVerts, radius: 8 * pxSize(), grid: p.grid });

  const sections = p.preview?.sections ?? NO_SECTIONS;
  const colorOf = useMemo(() => {
    const keys = [...new Set([...(p.mask?.sections.map((s) => sectionKey(p.mask!.id, s.id)) ?? []), ...sections.map((s) => s.key)])];
    return (k: string) => SECTION_COLORS[Math.max(0, keys.indexOf(k)) % SECTION_COLORS.length];
  }, [p.mask, sections]);

  const finishDraft = () => {
    if (p.tool === "curve" && draft.length >= 3) p.edits.addCurve(draft);
    if (p.tool === "guide" && p.selected && draft.length >= 2) p.edits.setGuide(p.selected, draft);
    setDraft([]);
  };

  useEffect(() => {
    setDraft([]);
    if (p.tool !== "measure") setMeasureAB(null);
  }, [p.tool]);
  useEffect(() => setVertexSel((v) => (v && v.key === p.selected ? v : null)), [p.selected]);

  const curveOf = (key: string) => p.mask?.sections.find((x) => sectionKey(p.mask!.id, x.id) === key)?.curve as Pt[] | undefined;

  // Keyboard alternatives for the canvas actions (documented in frontend/README.md).
  useEffect(() => {
    const onKey = (e: KeyboardEvent) => {
      const t = e.target as HTMLElement;
      if (t && (t.tagName === "INPUT" || t.tagName === "TEXTAREA" || t.tagName === "SELECT")) return;
      if (e.ctrlKey || e.metaKey || e.altKey) return;
      const keys = (p.mask?.sections ?? []).map((x) => sectionKey(p.mask!.id, x.id));
      const arrows: Record<string, Pt> = { ArrowLeft: [-1, 0], ArrowRight: [1, 0], ArrowUp: [0, 1], ArrowDown: [0, -1] };
      if (e.key === "Escape") {
        setDraft([]);
        setMeasureAB(null);
        if (vertexSel) setVertexSel(null);
        else if (!draft.length) p.setSelected(null);
      } else if (e.key === "Enter") finishDraft();
      else if (arrows[e.key] && vertexSel) {
        const curve = curveOf(vertexSel.key);
        if (!curve) return;
        const st = nudgeStep(p.grid, e.shiftKey);
        p.edits.setCurve(vertexSel.key, nudge(curve, vertexSel.index, arrows[e.key][0] * st, arrows[e.key][1] * st));
      } else if ((e.key === "Delete" || e.key === "Backspace") && vertexSel && !draft.length) {
        const curve = curveOf(vertexSel.key);
        const next = curve ? dropVertex(curve, vertexSel.index) : null;
        if (next) {
          p.edits.setCurve(vertexSel.key, next);
          setVertexSel({ key: vertexSel.key, index: Math.min(vertexSel.index, next.length - 1) });
        }
      } else if ((e.key === "Delete" || e.key === "Backspace") && p.selected && !draft.length) {
        p.edits.removeSection(p.selected);
        p.setSelected(null);
      } else if (e.key === "PageUp") p.onLayerStep(1);
      else if (e.key === "PageDown") p.onLayerStep(-1);
      else if ((e.key === "]" || e.key === "[") && p.selected) {
        const curve = curveOf(p.selected);
        if (!curve?.length) return;
        const cur = vertexSel?.key === p.selected ? vertexSel.index : e.key === "]" ? -1 : 0;
        setVertexSel({ key: p.selected, index: (cur + (e.key === "]" ? 1 : -1) + curve.length) % curve.length });
        p.setTool("select");
      } else if ((e.key === "}" || e.key === "{") && keys.length) {
        const i = p.selected ? keys.indexOf(p.selected) : -1;
        p.setSelected(keys[(i + (e.key === "}" ? 1 : -1) + keys.length + (i < 0 && e.key === "{" ? 1 : 0)) % keys.length]);
      } else if (e.key === "v") p.setTool("select");
      else if (e.key === "c") p.setTool("curve");
      else if (e.key === "g") p.setTool("guide");
      else if (e.key === "s") p.setTool("split");
      else if (e.key === "m") p.setTool("measure");
      else if (e.key === "f") fit();
      else return;
      e.preventDefault();
    };
    window.addEventListener("keydown", onKey);
    return () => window.removeEventListener("keydown", onKey);
  });

  const paths = p.preview?.paths ?? NO_PATHS;

  const onPointerDown = (e: RPointerEvent<SVGSVGElement>) => {
    if (!view) return;
    const w = toWorld(e);
    const target = e.target as SVGElement;
    const vtx = target.getAttribute("data-vertex");
    const curveKey = target.getAttribute("data-curve");
    const split = target.getAttribute("data-split");
    const section = target.getAttribute("data-section");
    svgRef.current!.setPointerCapture(e.pointerId);
    if (e.button === 1 || e.button === 2 || (p.tool === "select" && !vtx && !curveKey && !split && !section)) {
      drag.current = { kind: "pan" };
      startPan(e);
      if (p.tool === "select" && e.button === 0) p.setSelected(null);
      return;
    }
    if (e.button !== 0) return;
    if (p.tool === "measure") {
      const q = snap(w).point;
      setMeasureAB((m) => (!m || m.b ? { a: q, b: null } : { a: m.a, b: q }));
      return;
    }
    if (p.tool === "select") {
      if (vtx) {
        const [key, i] = [vtx.slice(0, vtx.lastIndexOf(":")), Number(vtx.slice(vtx.lastIndexOf(":") + 1))];
        setVertexSel({ key, index: i });
        const s = p.mask?.sections.find((x) => sectionKey(p.mask!.id, x.id) === key);
        if (s) drag.current = { kind: "vertex", key, index: i, curve: s.curve.map((q) => [q[0], q[1]] as Pt) };
        p.setSelected(key);
      } else if (curveKey) {
        const s = p.mask?.sections.find((x) => sectionKey(p.mask!.id, x.id) === curveKey);
        if (s) drag.current = { kind: "curve", key: curveKey, start: w, curve: s.curve.map((q) => [q[0], q[1]] as Pt) };
        p.setSelected(curveKey);
      } else if (split) {
        p.setSelected(split.slice(0, split.lastIndexOf(":")));
      } else if (section) p.setSelected(section);
      return;
    }
    if (p.tool === "split") {
      if (split) {
        const i = split.lastIndexOf(":");
        p.edits.removeSplit(split.slice(0, i), Number(split.slice(i + 1)));
        return;
      }
      // The path clicked on (within 12 px), else the selected section's path.
      const near = nearestPath(paths, w);
      const onNear = near && closestOnPolyline(w, near.points).distance <= 12 * pxSize();
      const path = onNear ? near : paths.find((q) => q.key === (p.selected ?? section));
      if (!path) return;
      const c = closestOnPolyline(w, path.points);
      p.setSelected(path.key);
      p.edits.addSplit(path.key, [round3(c.point[0]), round3(c.point[1])]);
      return;
    }
    // curve / guide drawing
    if (p.tool === "guide" && !p.selected) {
      if (section) p.setSelected(section);
      return;
    }
    const s = snap(w).point;
    if (p.tool === "curve" && draft.length >= 3 && dist(s, draft[0]) <= 8 * pxSize()) {
      p.edits.addCurve(draft);
      setDraft([]);
      return;
    }
    if (e.detail >= 2) {
      finishDraft();
      return;
    }
    setDraft((d) => [...d, [round3(s[0]), round3(s[1])]]);
  };

  const onPointerMove = (e: RPointerEvent<SVGSVGElement>) => {
    const w = toWorld(e);
    // Cursor coordinates in layer mm, written straight into the HUD (no re-render per move).
    if (coordsRef.current) coordsRef.current.textContent = `x ${mm(w[0])}  y ${mm(w[1])} mm`;
    const d = drag.current;
    if (d?.kind === "pan") {
      movePan(e);
      return;
    }
    if (d?.kind === "vertex") {
      const s = snap(w).point;
      const curve = d.curve.map((q, i) => (i === d.index ? ([round3(s[0]), round3(s[1])] as Pt) : q));
      setDragCurve({ key: d.key, curve });
      return;
    }
    if (d?.kind === "curve") {
      const s = snap(w).point;
      const dx = p.grid > 0 ? Math.round((s[0] - d.start[0]) / p.grid) * p.grid : w[0] - d.start[0];
      const dy = p.grid > 0 ? Math.round((s[1] - d.start[1]) / p.grid) * p.grid : w[1] - d.start[1];
      setDragCurve({ key: d.key, curve: translate(d.curve, dx, dy).map((q) => [round3(q[0]), round3(q[1])] as Pt) });
      return;
    }
    if (p.tool === "curve" || p.tool === "guide" || p.tool === "measure") {
      const s = snap(w);
      setCursor({ p: s.point, kind: s.kind });
      if (p.tool === "measure" && measureAB && !measureAB.b) setMeasureHover(s.point);
    } else setCursor(null);
  };

  const onPointerUp = () => {
    const d = drag.current;
    drag.current = null;
    endPan();
    if ((d?.kind === "vertex" || d?.kind === "curve") && dragCurve) {
      const orig = d.curve;
      if (dragCurve.curve.some((q, i) => q[0] !== orig[i][0] || q[1] !== orig[i][1])) p.edits.setCurve(dragCurve.key, dragCurve.curve);
    }
    setDragCurve(null);
  };

  // Keep the dragged curve on screen until the recipe has it (no flicker back to the old one).
  useEffect(() => setDragCurve(null), [p.mask]);

  const px = pxSize();
  const r = 4 * px;
  const speed = useMemo(() => speedRange(paths), [paths]);
  const legend = useMemo(() => canvasLegend(paths, p.colorBy), [paths, p.colorBy]);
  const mB = measureAB ? measureAB.b ?? measureHover : null;
  const meas = measureAB && mB ? measure(measureAB.a, mB) : null;

  const curves = (p.mask?.sections ?? []).map((s) => {
    const key = sectionKey(p.mask!.id, s.id);
    return { key, curve: dragCurve?.key === key ? dragCurve.curve : (s.curve as Pt[]) };
  });

  return (
    <div className="mask-canvas-wrap">
      <svg
        ref={svgRef}
        className={`mask-canvas tool-${p.tool}`}
        data-testid="mask-canvas"
        data-replan-ms={p.replanMs ?? ""}
        data-paths={paths.length}
        data-path-points={paths.reduce((a, q) => a + q.points.length, 0)}
        viewBox={view ? `${view.x} ${view.y} ${view.w} ${view.h}` : "0 0 100 100"}
        onPointerDown={onPointerDown}
        onPointerMove={onPointerMove}
        onPointerUp={onPointerUp}
        onPointerLeave={() => {
          setCursor(null);
          if (coordsRef.current) coordsRef.current.textContent = "";
        }}
        tabIndex={0}
        role="application"
        aria-label={`mask canvas, layer ${layer?.index ?? "?"}: tools V C G S M, PageUp/PageDown change layer, [ ] pick a vertex, arrows nudge it, Delete removes, Esc cancels`}
        onWheel={onWheel}
        onContextMenu={(e) => e.preventDefault()}
      >
        {view && p.grid > 0 && view.w / p.grid < 400 && <Grid view={view} pitch={p.grid} />}
        {[p.ghosts.prev, p.ghosts.next].map((g, gi) =>
          g?.polygons.map((q, i) => <path key={`g${gi}-${i}`} d={polygonPathD(q)} className={`ghost ghost-${gi ? "next" : "prev"}`} fillRule="evenodd" />),
        )}
        {layer?.polygons.map((q, i) => <path key={`l${i}`} d={polygonPathD(q)} className="layer-poly" fillRule="evenodd" />)}
        {layer?.curves.map((c, i) => <path key={`mc${i}`} d={ringPathD(c, false)} className="layer-curve" />)}
        {sections.map((s) =>
          s.polygon ? (
            <path
              key={`s-${s.key}`}
              d={polygonPathD(s.polygon)}
              fillRule="evenodd"
              data-section={s.key}
              className={`section-region ${s.key === p.selected ? "selected" : ""} ${s.key === p.highlight ? "failing" : ""}`}
              style={{ fill: colorOf(s.key) }}
            />
          ) : null,
        )}
        <CoverageLayer coverage={p.preview?.coverage} />
        {paths.map((q) => (
          <PathView key={`p-${q.key}`} path={q} zone={p.zone} r={r} colorBy={p.colorBy} speed={speed} bead={p.beadWidthOf(q.key)} />
        ))}
        <DeviationOverlay layer={layer?.index ?? null} r={r} />
        {sections.map((s) => {
          const own = p.guides.guides?.[s.key];
          const g = own ?? s.guide;
          if (!g || !s.polygon) return null;
          const xs = boundaryCrossings(g, s.polygon);
          const ok = xs.length === 2;
          return (
            <g key={`gd-${s.key}`} className={`guide ${own ? "own" : "auto"} ${ok ? "" : "bad"}`} data-guide={s.key} data-crossings={xs.length}>
              <path d={ringPathD(g, false)} />
              {xs.map((x, i) => (
                <circle key={i} cx={x[0]} cy={-x[1]} r={r * 1.3} className="crossing" />
              ))}
              {!ok && (
                <text x={g[0][0]} y={-g[0][1]} fontSize={12 * px} className="bad-text">
                  {xs.length} crossings (needs 2)
                </text>
              )}
            </g>
          );
        })}
        {p.starts && <StartMarkers starts={p.starts} size={r * 2.4} />}
        {curves.map(({ key, curve }) => (
          <g key={`c-${key}`} className={`mask-curve ${key === p.selected ? "selected" : ""} ${key === p.highlight ? "failing" : ""}`}>
            <path d={ringPathD(curve, true)} data-curve={key} style={{ stroke: colorOf(key) }} />
            <text x={curve[0][0]} y={-curve[0][1]} fontSize={11 * px} className="curve-label">
              {key}
            </text>
            {p.tool === "select" &&
              key === p.selected &&
              curve.map((q, i) => (
                <circle key={i} cx={q[0]} cy={-q[1]} r={r * (vertexSel?.index === i && vertexSel.key === key ? 1.8 : 1.2)} data-vertex={`${key}:${i}`} className={`vertex ${vertexSel?.index === i && vertexSel.key === key ? "picked" : ""}`} />
              ))}
          </g>
        ))}
        {draft.length > 0 && (
          <g className={`draft draft-${p.tool}`}>
            <path d={ringPathD(cursor ? [...draft, cursor.p] : draft, false)} />
            {draft.map((q, i) => (
              <circle key={i} cx={q[0]} cy={-q[1]} r={r} />
            ))}
          </g>
        )}
        {measureAB && (
          <g className="measure" data-testid="measure">
            <circle cx={measureAB.a[0]} cy={-measureAB.a[1]} r={r} />
            {mB && <path d={`M${measureAB.a[0]} ${-measureAB.a[1]}L${mB[0]} ${-mB[1]}`} />}
            {mB && <circle cx={mB[0]} cy={-mB[1]} r={r} />}
            {meas && mB && (
              <text x={(measureAB.a[0] + mB[0]) / 2} y={-(measureAB.a[1] + mB[1]) / 2 - 6 * px} fontSize={12 * px}>
                {mm(meas.distance)} mm, {meas.angleDeg.toFixed(1)}°
              </text>
            )}
          </g>
        )}
        {p.mark && (
          <g className="pf-mark" data-testid="pf-mark" data-x={p.mark[0].toFixed(2)} data-y={p.mark[1].toFixed(2)} pointerEvents="none">
            <circle cx={p.mark[0]} cy={-p.mark[1]} r={r * 4} />
            <path d={`M${p.mark[0] - r * 6} ${-p.mark[1]}H${p.mark[0] - r * 2}M${p.mark[0] + r * 2} ${-p.mark[1]}H${p.mark[0] + r * 6}M${p.mark[0]} ${-p.mark[1] - r * 6}V${-p.mark[1] - r * 2}M${p.mark[0]} ${-p.mark[1] + r * 2}V${-p.mark[1] + r * 6}`} />
          </g>
        )}
        {cursor && <circle className={`cursor snap-${cursor.kind}`} cx={cursor.p[0]} cy={-cursor.p[1]} r={r * 1.5} />}
      </svg>
      <div className="canvas-legend" data-testid="canvas-legend" aria-label="path colours">
        {legend.gradient && (
          <span className="legend-bar">
            <span className="bar" style={{ background: `linear-gradient(to right, ${legend.gradient.stops.join(", ")})` }} aria-hidden="true" />
            <span className="ends">
              <span>{legend.gradient.lo.toPrecision(3)}</span>
              <span>{legend.gradient.hi.toPrecision(3)} {legend.gradient.unit}</span>
            </span>
          </span>
        )}
        {legend.swatches.map((s) => (
          <span className="legend-swatch" key={s.label}>
            <i style={{ background: s.color }} aria-hidden="true" />
            {s.label}
          </span>
        ))}
        {p.starts && (
          <span className="legend-swatch pf-legend" title="arc ignition points read back from the program (preflight); red: within a bead width of one on the layer below">
            <span aria-hidden="true" className="pf-tri">▲</span> arc starts <span aria-hidden="true" className="pf-tri below">△</span> layer below{" "}
            <span aria-hidden="true" className="pf-tri">■</span> arc stops
            {p.starts.stacked.some(Boolean) && (
              <>
                {" "}
                <span aria-hidden="true" className="pf-tri stacked">▲</span> stacked ({p.starts.stacked.filter(Boolean).length})
              </>
            )}
          </span>
        )}
      </div>
      <div className="canvas-hud">
        <button onClick={fit} title="fit view (F)">fit</button>
        {p.tool === "curve" && <span>click to add points (snapped), click the first point or double-click / Enter to close, Esc cancels</span>}
        {p.tool === "guide" && <span>{p.selected ? `guide for ${p.selected}: click points, double-click / Enter to finish` : "pick a section first"}</span>}
        {p.tool === "split" && <span>click on a section path to add a zone split point; click a split point to remove it</span>}
        {p.tool === "select" && <span>drag a curve or its vertices ([ ] picks one, arrows nudge it); Delete removes; drag empty space to pan, wheel zooms</span>}
        {p.tool === "measure" && (
          <span data-testid="measure-readout">
            {meas ? `distance ${mm(meas.distance)} mm · angle ${meas.angleDeg.toFixed(1)}° · dx ${mm(meas.dx)} dy ${mm(meas.dy)}` : "click two points to measure distance and angle; Esc clears"}
          </span>
        )}
        <span className="coords" ref={coordsRef} data-testid="cursor-coords" aria-live="off" />
        {p.replanMs !== null && <span className="replan" data-testid="replan-ms">re-plan {p.replanMs.toFixed(0)} ms</span>}
      </div>
    </div>
  );
});

const round3 = (v: number) => Math.round(v * 1000) / 1000;

/** An upward triangle of circumradius `s` centred on layer point q (SVG y = −y). */
const triangleD = (q: number[], s: number) =>
  `M${q[0]} ${-q[1] - s}L${q[0] + 0.866 * s} ${-q[1] + 0.5 * s}L${q[0] - 0.866 * s} ${-q[1] + 0.5 * s}Z`;

/** The preflight's arc ignition points: this layer's filled (red when stacked on one below), the layer below's hollow. */
const StartMarkers = memo(function StartMarkers({ starts, size }: { starts: { here: number[][]; below: number[][]; stops?: number[][]; stacked: boolean[] }; size: number }) {
  return (
    <g className="pf-starts" data-testid="pf-starts" data-count={starts.here.length} data-stacked={starts.stacked.filter(Boolean).length} pointerEvents="none">
      {starts.below.map((q, i) => (
        <path key={`b${i}`} d={triangleD(q, size * 1.25)} className="pf-start-below" />
      ))}
      {(starts.stops ?? []).map((q, i) => (
        <rect key={`s${i}`} x={q[0] - size * 0.55} y={-q[1] - size * 0.55} width={size * 1.1} height={size * 1.1}
          className="pf-stop" data-stop={i}>
          <title>{`arc stop ${i + 1}: x ${mm(q[0])} y ${mm(q[1])} mm`}</title>
        </rect>
      ))}
      {starts.here.map((q, i) => (
        <path key={`h${i}`} d={triangleD(q, size)} className={`pf-start ${starts.stacked[i] ? "stacked" : ""}`} data-start={i}>
          <title>{`arc start ${i + 1}: x ${mm(q[0])} y ${mm(q[1])} mm${starts.stacked[i] ? " (stacked on a start of the layer below)" : ""}`}</title>
        </path>
      ))}
    </g>
  );
});

function nearestPath(paths: PreviewPath[], w: Pt): PreviewPath | undefined {
  let best: PreviewPath | undefined, bd = Infinity;
  for (const q of paths) {
    if (q.points.length < 2) continue;
    const c = closestOnPolyline(w, q.points);
    if (c.distance < bd) {
      bd = c.distance;
      best = q;
    }
  }
  return best;
}

function Grid({ view, pitch }: { view: View; pitch: number }) {
  const xs: number[] = [], ys: number[] = [];
  for (let x = Math.ceil(view.x / pitch) * pitch; x <= view.x + view.w; x += pitch) xs.push(x);
  for (let y = Math.ceil(view.y / pitch) * pitch; y <= view.y + view.h; y += pitch) ys.push(y);
  const d = [...xs.map((x) => `M${x} ${view.y}V${view.y + view.h}`), ...ys.map((y) => `M${view.x} ${y}H${view.x + view.w}`)].join("");
  return <path d={d} className="grid" />;
}

/** A section path: consecutive segments of one colour and arc state drawn as one polyline, over
 * its bead (the path stroked at the bead width, in mm) when known. */
const PathView = memo(function PathView({ path, zone, r, colorBy, speed, bead }: { path: PreviewPath; zone: KeyedParams; r: number; colorBy: ColorBy; speed: { lo: number; hi: number } | null; bead: number | null }) {
  const runs = pathRuns(path, colorBy, speed);
  const pts = path.points;
  const spec = zone.sections?.[path.key] ?? zone.default ?? {};
  const splits = (spec.split_points as number[][] | undefined) ?? [];
  const xy = pts.map((q) => [q[0], q[1]]);
  let total = 0;
  for (let i = 1; i < xy.length; i++) total += dist(xy[i - 1], xy[i]);
  const sLen = num(spec.start_length), eLen = num(spec.end_length);
  const marks = [sLen > 0 ? pointAtLength(xy, sLen) : null, eLen > 0 ? pointAtLength(xy, total - eLen) : null];
  return (
    <g className="section-path" data-path={path.key} data-zones={[...new Set(path.zone)].join(",")} data-length={total.toFixed(3)} data-bead={bead ?? ""}>
      {bead !== null &&
        runs.filter((q) => q.arc).map((q, i) => <path key={`b${i}`} d={q.d} className="bead" style={{ stroke: q.color, strokeWidth: bead }} />)}
      {runs.map((q, i) => (
        <path key={i} d={q.d} className={q.arc ? "arc-on" : "arc-off"} style={{ stroke: q.arc ? q.color : undefined }} data-zone={q.zone} />
      ))}
      {pts.length > 0 && <circle cx={pts[0][0]} cy={-pts[0][1]} r={r * 1.1} className="path-start" />}
      {marks.map((m, i) => (m ? <rect key={i} x={m[0] - r} y={-m[1] - r} width={2 * r} height={2 * r} className="zone-mark" transform={`rotate(45 ${m[0]} ${-m[1]})`} /> : null))}
      {splits.map((s, i) => {
        const c = xy.length > 1 ? closestOnPolyline(s, xy).point : (s as Pt);
        return <circle key={`sp${i}`} cx={c[0]} cy={-c[1]} r={r * 1.6} className="split-point" data-split={`${path.key}:${i}`} />;
      })}
    </g>
  );
});
