/**
 * The 2D canvas's drawing, piece by piece (presentational: props in, SVG / HTML out): grid, section
 * paths with zone marks, guides with their boundary crossings, mask curves with their vertices,
 * the draft, the measure, the preflight's marks, the legend and the HUD under the canvas.
 * Drawing is in layer mm; SVG y = −y.
 */
import { memo, type RefObject } from "react";
import type { Preview, PreviewPath } from "../api/types";
import { boundaryCrossings, closestOnPolyline, dist, pointAtLength, ringPathD, type Pt } from "./geom";
import type { GuideParams, KeyedParams } from "./edits";
import { mm, pathRuns, type ColorBy, type Legend } from "./canvasTools";
import type { View } from "./canvasModel";
import type { Tool, VertexSel } from "./useCanvasTools";

const num = (v: unknown, d = 0) => (typeof v === "number" && Number.isFinite(v) ? v : d);

export type Starts = { here: number[][]; below: number[][]; stops?: number[][]; stacked: boolean[] };

/** The grid (memo: re-drawn when the view or pitch changes, not on every re-plan). */
export const Grid = memo(function Grid({ view, pitch }: { view: View; pitch: number }) {
  const xs: number[] = [], ys: number[] = [];
  for (let x = Math.ceil(view.x / pitch) * pitch; x <= view.x + view.w; x += pitch) xs.push(x);
  for (let y = Math.ceil(view.y / pitch) * pitch; y <= view.y + view.h; y += pitch) ys.push(y);
  const d = [...xs.map((x) => `M${x} ${view.y}V${view.y + view.h}`), ...ys.map((y) => `M${view.x} ${y}H${view.x + view.w}`)].join("");
  return <path d={d} className="grid" />;
});

/** A section path: consecutive segments of one colour and arc state drawn as one polyline, over
 * its bead (the path stroked at the bead width, in mm) when known. */
export const PathView = memo(function PathView({ path, zone, r, colorBy, speed, bead }: { path: PreviewPath; zone: KeyedParams; r: number; colorBy: ColorBy; speed: { lo: number; hi: number } | null; bead: number | null }) {
  const runs = pathRuns(path, colorBy, speed);
  const pts = path.points;
  const spec = zone.sections?.[path.key] ?? zone.default ?? {};
  const splits = (spec.split_points as number[][] | undefined) ?? [];
  const xy = pts.map((q) => [q[0], q[1]]);
  let total = 0;
  for (let i = 1; i < xy.length; i++) total += dist(xy[i - 1], xy[i]);
  const sLen = num(spec.start_length), eLen = num(spec.end_length);
  const marks = [sLen > 0 ? pointAtLength(xy, sLen) : null, eLen > 0 ? pointAtLength(xy, total - eLen) : null];
  const climbs = path.climbs ?? null;
  return (
    <g className={`section-path${climbs ? " climbing" : ""}`} data-path={path.key} data-zones={[...new Set(path.zone)].join(",")} data-length={total.toFixed(3)} data-bead={bead ?? ""} data-climbs={climbs ? climbs.from_layer : undefined}>
      {climbs && <title>{climbNote(path.key, climbs)}</title>}
      {bead !== null &&
        runs.filter((q) => q.arc).map((q, i) => <path key={`b${i}`} d={q.d} className="bead" style={{ stroke: q.color, strokeWidth: bead }} />)}
      {runs.map((q, i) => (
        <path key={i} d={q.d} className={q.arc ? "arc-on" : "arc-off"} style={{ stroke: q.arc ? q.color : undefined }} data-zone={q.zone} />
      ))}
      {pts.length > 0 && !(climbs && Math.abs(pts[0][2] - climbs.z_from) > 1e-6) && <circle cx={pts[0][0]} cy={-pts[0][1]} r={r * 1.1} className="path-start" />}
      {marks.map((m, i) => (m ? <rect key={i} x={m[0] - r} y={-m[1] - r} width={2 * r} height={2 * r} className="zone-mark" transform={`rotate(45 ${m[0]} ${-m[1]})`} /> : null))}
      {splits.map((s, i) => {
        const c = xy.length > 1 ? closestOnPolyline(s, xy).point : (s as Pt);
        return <circle key={`sp${i}`} cx={c[0]} cy={-c[1]} r={r * 1.6} className="split-point" data-split={`${path.key}:${i}`} />;
      })}
    </g>
  );
});

/** A helix's lap: which helix, where it is laid and how far it climbs (its one ignition is on its first lap). */
export function climbNote(key: string, c: NonNullable<PreviewPath["climbs"]>): string {
  return `${key}: a lap of the helix laid in layer ${c.from_layer} (${c.laps} laps, z ${c.z_from.toFixed(1)}–${c.z_to.toFixed(1)} mm, one ignition on its first lap)`;
}

/** Each section's guide (its own, else the server's auto guide) with its crossings of the section boundary (2 needed). */
export function Guides({ sections, guides, r, px }: { sections: Preview["sections"]; guides: GuideParams; r: number; px: number }) {
  return (
    <>
      {sections.map((s) => {
        const own = guides.guides?.[s.key];
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
    </>
  );
}

/** The mask's curves, labelled; the selected one's vertices are handles under the select tool. */
export function Curves(p: { curves: { key: string; curve: Pt[] }[]; selected: string | null; highlight: string | null; tool: Tool; vertexSel: VertexSel; colorOf: (k: string) => string; r: number; px: number }) {
  const { r, vertexSel } = p;
  return (
    <>
      {p.curves.map(({ key, curve }) => (
        <g key={`c-${key}`} className={`mask-curve ${key === p.selected ? "selected" : ""} ${key === p.highlight ? "failing" : ""}`}>
          <path d={ringPathD(curve, true)} data-curve={key} style={{ stroke: p.colorOf(key) }} />
          <text x={curve[0][0]} y={-curve[0][1]} fontSize={11 * p.px} className="curve-label">
            {key}
          </text>
          {p.tool === "select" &&
            key === p.selected &&
            curve.map((q, i) => (
              <circle key={i} cx={q[0]} cy={-q[1]} r={r * (vertexSel?.index === i && vertexSel.key === key ? 1.8 : 1.2)} data-vertex={`${key}:${i}`} className={`vertex ${vertexSel?.index === i && vertexSel.key === key ? "picked" : ""}`} />
            ))}
        </g>
      ))}
    </>
  );
}

/** The curve or guide being drawn, to the cursor. */
export function Draft({ draft, cursor, tool, r }: { draft: Pt[]; cursor: Pt | null; tool: Tool; r: number }) {
  if (!draft.length) return null;
  return (
    <g className={`draft draft-${tool}`}>
      <path d={ringPathD(cursor ? [...draft, cursor] : draft, false)} />
      {draft.map((q, i) => (
        <circle key={i} cx={q[0]} cy={-q[1]} r={r} />
      ))}
    </g>
  );
}

/** The measure tool's A, B and the line between with its length and angle. */
export function MeasureMark({ a, b, meas, r, px }: { a: Pt; b: Pt | null; meas: { distance: number; angleDeg: number } | null; r: number; px: number }) {
  return (
    <g className="measure" data-testid="measure">
      <circle cx={a[0]} cy={-a[1]} r={r} />
      {b && <path d={`M${a[0]} ${-a[1]}L${b[0]} ${-b[1]}`} />}
      {b && <circle cx={b[0]} cy={-b[1]} r={r} />}
      {meas && b && (
        <text x={(a[0] + b[0]) / 2} y={-(a[1] + b[1]) / 2 - 6 * px} fontSize={12 * px}>
          {mm(meas.distance)} mm, {meas.angleDeg.toFixed(1)}°
        </text>
      )}
    </g>
  );
}

/** The crosshair on a point a picked preflight problem names. */
export function ProblemMark({ mark, r }: { mark: number[]; r: number }) {
  const [x, y] = [mark[0], -mark[1]];
  return (
    <g className="pf-mark" data-testid="pf-mark" data-x={mark[0].toFixed(2)} data-y={mark[1].toFixed(2)} pointerEvents="none">
      <circle cx={x} cy={y} r={r * 4} />
      <path d={`M${x - r * 6} ${y}H${x - r * 2}M${x + r * 2} ${y}H${x + r * 6}M${x} ${y - r * 6}V${y - r * 2}M${x} ${y + r * 2}V${y + r * 6}`} />
    </g>
  );
}

/** An upward triangle of circumradius `s` centred on layer point q (SVG y = −y). */
const triangleD = (q: number[], s: number) =>
  `M${q[0]} ${-q[1] - s}L${q[0] + 0.866 * s} ${-q[1] + 0.5 * s}L${q[0] - 0.866 * s} ${-q[1] + 0.5 * s}Z`;

/** The preflight's arc ignition points: this layer's filled (red when stacked on one below), the layer below's hollow. */
export const StartMarkers = memo(function StartMarkers({ starts, size }: { starts: Starts; size: number }) {
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

/** What the path colours mean (and, with a preflight, the start / stop markers). */
export function CanvasLegend({ legend, starts }: { legend: Legend; starts: Starts | null | undefined }) {
  return (
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
      {starts && (
        <span className="legend-swatch pf-legend" title="arc ignition points read back from the program (preflight); red: within a bead width of one on the layer below">
          <span aria-hidden="true" className="pf-tri">▲</span> arc starts <span aria-hidden="true" className="pf-tri below">△</span> layer below{" "}
          <span aria-hidden="true" className="pf-tri">■</span> arc stops
          {starts.stacked.some(Boolean) && (
            <>
              {" "}
              <span aria-hidden="true" className="pf-tri stacked">▲</span> stacked ({starts.stacked.filter(Boolean).length})
            </>
          )}
        </span>
      )}
    </div>
  );
}

/** The bar under the canvas: fit, the tool's hint or the measure's readout, cursor mm, re-plan time. */
export function CanvasHud(p: { tool: Tool; selected: string | null; meas: { distance: number; angleDeg: number; dx: number; dy: number } | null; fit: () => void; coordsRef: RefObject<HTMLSpanElement | null>; replanMs: number | null }) {
  const meas = p.meas;
  return (
    <div className="canvas-hud">
      <button onClick={p.fit} title="fit view (F)">fit</button>
      {p.tool === "curve" && <span>click to add points (snapped), click the first point or double-click / Enter to close, Esc cancels</span>}
      {p.tool === "guide" && <span>{p.selected ? `guide for ${p.selected}: click points, double-click / Enter to finish` : "pick a section first"}</span>}
      {p.tool === "split" && <span>click on a section path to add a zone split point; click a split point to remove it</span>}
      {p.tool === "select" && <span>drag a curve or its vertices ([ ] picks one, arrows nudge it); Delete removes; drag empty space to pan, wheel zooms</span>}
      {p.tool === "measure" && (
        <span data-testid="measure-readout">
          {meas ? `distance ${mm(meas.distance)} mm · angle ${meas.angleDeg.toFixed(1)}° · dx ${mm(meas.dx)} dy ${mm(meas.dy)}` : "click two points to measure distance and angle; Esc clears"}
        </span>
      )}
      <span className="coords" ref={p.coordsRef} data-testid="cursor-coords" aria-live="off" />
      {p.replanMs !== null && <span className="replan" data-testid="replan-ms">re-plan {p.replanMs.toFixed(0)} ms</span>}
    </div>
  );
}
