import { memo, useMemo } from "react";
import { decimate, ticks } from "./data";
import { robustRange } from "./robust";

/** Clamp the y axis to robust limits (2nd–98th percentile) when the outliers would squeeze the
 * ordinary values into less than this share of the axis. */
const OUTLIER_SQUEEZE = 1 / 3;

export interface Series {
  label: string;
  x: ArrayLike<number>;
  y: ArrayLike<number>;
  color: string;
  dashed?: boolean;
  /** Draw as steps (state signals such as arc on/off). */
  step?: boolean;
}

/** A small SVG line chart (no runtime dependency): axes with ticks, several series, a legend. */
export const LineChart = memo(function LineChart({ title, xLabel, yLabel, series, height = 190 }: { title: string; xLabel: string; yLabel: string; series: Series[]; height?: number }) {
  const W = 560, H = height, L = 52, R = 10, T = 22, B = 34;
  const data = useMemo(() => series.map((s) => ({ ...s, pts: decimate(s.x, s.y) })), [series]);
  const robust = useMemo(() => robustRange(...series.map((s) => s.y)), [series]);
  let x0 = Infinity, x1 = -Infinity, y0 = Infinity, y1 = -Infinity;
  for (const s of data) {
    s.pts[0].forEach((v) => Number.isFinite(v) && ((x0 = Math.min(x0, v)), (x1 = Math.max(x1, v))));
    s.pts[1].forEach((v) => Number.isFinite(v) && ((y0 = Math.min(y0, v)), (y1 = Math.max(y1, v))));
  }
  if (!Number.isFinite(x0)) return <div className="chart empty">{title}: no data</div>;
  // One outlier must not flatten the chart: clamp to the robust limits, mark what was clamped.
  const clamp = robust.clamped && robust.hi > robust.lo && (robust.hi - robust.lo) < OUTLIER_SQUEEZE * (robust.max - robust.min);
  if (clamp) {
    y0 = robust.lo;
    y1 = robust.hi;
  }
  if (y1 === y0) {
    y0 -= 1;
    y1 += 1;
  }
  const pad = (y1 - y0) * 0.05;
  y0 -= pad;
  y1 += pad;
  if (x1 === x0) x1 = x0 + 1;
  let beyond = 0;
  if (clamp) for (const sr of series) for (let i = 0; i < sr.y.length; i++) if (sr.y[i] < y0 || sr.y[i] > y1) beyond++;
  const sx = (v: number) => L + ((v - x0) / (x1 - x0)) * (W - L - R);
  const sy = (v: number) => T + (1 - (Math.min(Math.max(v, y0), y1) - y0) / (y1 - y0)) * (H - T - B);
  const fmt = (v: number) => (Math.abs(v) >= 1000 ? v.toFixed(0) : Number(v.toPrecision(3)).toString());
  return (
    <svg className="chart" viewBox={`0 0 ${W} ${H}`} data-chart={title}>
      <text x={L} y={14} className="chart-title">{title}</text>
      {ticks(x0, x1).map((t) => (
        <g key={`x${t}`}>
          <line x1={sx(t)} x2={sx(t)} y1={T} y2={H - B} className="gridline" />
          <text x={sx(t)} y={H - B + 13} textAnchor="middle" className="tick">{fmt(t)}</text>
        </g>
      ))}
      {ticks(y0, y1, 4).map((t) => (
        <g key={`y${t}`}>
          <line x1={L} x2={W - R} y1={sy(t)} y2={sy(t)} className="gridline" />
          <text x={L - 4} y={sy(t) + 3} textAnchor="end" className="tick">{fmt(t)}</text>
        </g>
      ))}
      <text x={(L + W - R) / 2} y={H - 4} textAnchor="middle" className="axis-label">{xLabel}</text>
      <text x={12} y={(T + H - B) / 2} textAnchor="middle" transform={`rotate(-90 12 ${(T + H - B) / 2})`} className="axis-label">{yLabel}</text>
      {data.map((s) => {
        let d = "";
        const [xs, ys] = s.pts;
        let pen = false;
        for (let i = 0; i < xs.length; i++) {
          if (!Number.isFinite(xs[i]) || !Number.isFinite(ys[i])) {
            pen = false;
            continue;
          }
          if (s.step && pen) d += `H${sx(xs[i]).toFixed(1)}`;
          d += `${pen ? "L" : "M"}${sx(xs[i]).toFixed(1)} ${sy(ys[i]).toFixed(1)}`;
          pen = true;
        }
        return <path key={s.label} d={d} fill="none" stroke={s.color} strokeWidth={1.3} strokeDasharray={s.dashed ? "5 3" : undefined} />;
      })}
      {clamp && beyond > 0 && (
        <text x={W - R} y={14} textAnchor="end" className="chart-note" style={{ fontSize: 10, fill: "#9b2226" }} data-clamped={beyond}>
          <title>{`${beyond} value${beyond === 1 ? "" : "s"} beyond the axis (2nd–98th percentile) drawn at its edge; data ${fmt(robust.min)}…${fmt(robust.max)}`}</title>
          {`⇕ ${beyond} clamped (data ${fmt(robust.min)}…${fmt(robust.max)})`}
        </text>
      )}
      {data.map((s, i) => (
        <g key={`lg${s.label}`} transform={`translate(${W - R - 150} ${T + 4 + i * 13})`}>
          <line x1={0} x2={16} y1={0} y2={0} stroke={s.color} strokeDasharray={s.dashed ? "5 3" : undefined} strokeWidth={2} />
          <text x={20} y={3} className="tick">{s.label}</text>
        </g>
      ))}
    </svg>
  );
});
