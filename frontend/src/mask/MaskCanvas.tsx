/**
 * The 2D mask canvas (SVG): the active layer with holes, neighbouring layers ghosted, the mask's
 * closed segmentation curves, guides with their boundary crossings, zone split points and
 * start/end lengths, and the section paths coloured by zone as re-planned by the server.
 * Drawing is in layer mm; SVG y = −y so the part is seen from above with y up. The tool state is
 * in useCanvasTools / useCanvasKeys, the drawing's pieces in CanvasParts.
 */
import { memo, useCallback, useEffect, useMemo, useRef } from "react";
import { DeviationOverlay } from "../builds/DeviationOverlay";
import { CoverageLayer } from "./CoverageLayer";
import type { LayerJson, Preview, PreviewPath } from "../api/types";
import { polygonPathD, ringPathD, type Pt } from "./geom";
import { sectionKey, type GuideParams, type KeyedParams, type Mask } from "./edits";
import { canvasLegend, speedRange, type ColorBy } from "./canvasTools";
import { useSvgView } from "./useSvgView";
import {
  useCanvasPointer, useCurveDrag, useDraft, useMeasure, useSnap, useVertexSel, type CanvasEdits, type Tool,
} from "./useCanvasTools";
import { useCanvasKeys } from "./useCanvasKeys";
import { CanvasHud, CanvasLegend, Curves, Draft, Grid, Guides, MeasureMark, PathView, ProblemMark, StartMarkers } from "./CanvasParts";

export type { CanvasEdits, Tool } from "./useCanvasTools";

export const SECTION_COLORS = ["#e76f51", "#2a9d8f", "#e9c46a", "#8e7dbe", "#f4a261", "#457b9d", "#b5838d", "#6a994e"];

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

// Stable empty lists: a fresh `[]` each render would recompute every memo that depends on them.
const NO_SECTIONS: Preview["sections"] = [];
const NO_PATHS: PreviewPath[] = [];

/** Fit the view to the layer the first time one arrives (and on demand: the returned function). */
function useFitLayer(fitTo: (pts: readonly number[][]) => void, p: MaskCanvasProps, hasView: boolean) {
  const layer = p.preview?.layer ?? null;
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
    if (!hasView && layer) fit();
  }, [layer, hasView, fit]);
  return fit;
}

/** Section colours: by the order of the mask's sections, then the preview's. */
function useColorOf(mask: Mask | undefined, sections: Preview["sections"]) {
  return useMemo(() => {
    const keys = [...new Set([...(mask?.sections.map((s) => sectionKey(mask!.id, s.id)) ?? []), ...sections.map((s) => s.key)])];
    return (k: string) => SECTION_COLORS[Math.max(0, keys.indexOf(k)) % SECTION_COLORS.length];
  }, [mask, sections]);
}

export const MaskCanvas = memo(function MaskCanvas(p: MaskCanvasProps) {
  const svgRef = useRef<SVGSVGElement>(null);
  const sv = useSvgView(svgRef);
  const { view } = sv;
  const layer = p.preview?.layer ?? null;
  const fit = useFitLayer(sv.fitTo, p, view !== null);
  const snap = useSnap(p, layer, sv.pxSize);
  const sections = p.preview?.sections ?? NO_SECTIONS;
  const paths = p.preview?.paths ?? NO_PATHS;
  const colorOf = useColorOf(p.mask, sections);
  const draft = useDraft(p);
  const meas = useMeasure(p.tool);
  const [vertexSel, setVertexSel] = useVertexSel(p.selected);
  const curves = useCurveDrag(p);
  useCanvasKeys(p, { draft, meas, vertexSel, setVertexSel, fit });
  const ptr = useCanvasPointer(p, sv, svgRef, { draft, meas, setVertexSel, curves }, snap, paths);

  const px = sv.pxSize();
  const r = 4 * px;
  const speed = useMemo(() => speedRange(paths), [paths]);
  const legend = useMemo(() => canvasLegend(paths, p.colorBy), [paths, p.colorBy]);
  const shownCurves = (p.mask?.sections ?? []).map((s) => {
    const key = sectionKey(p.mask!.id, s.id);
    return { key, curve: curves.dragged?.key === key ? curves.dragged.curve : (s.curve as Pt[]) };
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
        onPointerDown={ptr.onPointerDown}
        onPointerMove={ptr.onPointerMove}
        onPointerUp={ptr.onPointerUp}
        onPointerLeave={ptr.onPointerLeave}
        tabIndex={0}
        role="application"
        aria-label={`mask canvas, layer ${layer?.index ?? "?"}: tools V C G S M, PageUp/PageDown change layer, [ ] pick a vertex, arrows nudge it, Delete removes, Esc cancels`}
        onWheel={sv.onWheel}
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
        <Guides sections={sections} guides={p.guides} r={r} px={px} />
        {p.starts && <StartMarkers starts={p.starts} size={r * 2.4} />}
        <Curves curves={shownCurves} selected={p.selected} highlight={p.highlight} tool={p.tool} vertexSel={vertexSel} colorOf={colorOf} r={r} px={px} />
        <Draft draft={draft.draft} cursor={ptr.cursor?.p ?? null} tool={p.tool} r={r} />
        {meas.ab && <MeasureMark a={meas.ab.a} b={meas.b} meas={meas.result} r={r} px={px} />}
        {p.mark && <ProblemMark mark={p.mark} r={r} />}
        {ptr.cursor && <circle className={`cursor snap-${ptr.cursor.kind}`} cx={ptr.cursor.p[0]} cy={-ptr.cursor.p[1]} r={r * 1.5} />}
      </svg>
      <CanvasLegend legend={legend} starts={p.starts} />
      <CanvasHud tool={p.tool} selected={p.selected} meas={meas.result} fit={fit} coordsRef={ptr.coordsRef} replanMs={p.replanMs} />
    </div>
  );
});
