import { memo } from "react";
import { ticks } from "../plots/data";

export interface LayerSeries {
  label: string;
  x: number[];
  y: number[];
  color: string;
  dashed?: boolean;
}

/** A per-layer SVG chart: every planned layer on the x axis (integer ticks), each series as
 * points joined by lines (one scanned layer is a point, not nothing), a zero line, a legend. */
export const LayerChart = memo(function LayerChart({ title, yLabel, series, layers, height = 200, zero = false }: {
  title: string; yLabel: string; series: LayerSeries[]; layers: number; height?: number; zero?: boolean;
}) {
  const W = 560, H = height, L = 52, R = 10, T = 22, B = 34;
  const x0 = -0.5, x1 = Math.max(layers - 1, 1) + 0.5;
  let y0 = Infinity, y1 = -Infinity;
  for (const s of series)
    for (const v of s.y)
      if (Number.isFinite(v)) {
        y0 = Math.min(y0, v);
        y1 = Math.max(y1, v);
      }
  const has = Number.isFinite(y0);
  if (!has) {
    y0 = -1;
    y1 = 1;
  }
  if (zero) {
    y0 = Math.min(y0, 0);
    y1 = Math.max(y1, 0);
  }
  if (y1 - y0 < 1e-9) {
    y0 -= 0.5;
    y1 += 0.5;
  }
  const pad = (y1 - y0) * 0.08;
  y0 -= pad;
  y1 += pad;
  const sx = (v: number) => L + ((v - x0) / (x1 - x0)) * (W - L - R);
  const sy = (v: number) => T + (1 - (v - y0) / (y1 - y0)) * (H - T - B);
  const step = Math.max(1, Math.ceil(layers / 12));
  const xt: number[] = [];
  for (let k = 0; k < Math.max(layers, 1); k += step) xt.push(k);
  const f = (v: number) => Number(v.toPrecision(3)).toString();
  return (
    <svg className="chart layer-chart" viewBox={`0 0 ${W} ${H}`} data-chart={title} role="img" aria-label={title}>
      <text x={L} y={14} className="chart-title">{title}</text>
      {xt.map((t) => (
        <g key={`x${t}`}>
          <line x1={sx(t)} x2={sx(t)} y1={T} y2={H - B} className="gridline" />
          <text x={sx(t)} y={H - B + 13} textAnchor="middle" className="tick">{t}</text>
        </g>
      ))}
      {ticks(y0, y1, 4).map((t) => (
        <g key={`y${t}`}>
          <line x1={L} x2={W - R} y1={sy(t)} y2={sy(t)} className="gridline" />
          <text x={L - 4} y={sy(t) + 3} textAnchor="end" className="tick">{f(t)}</text>
        </g>
      ))}
      {zero && <line x1={L} x2={W - R} y1={sy(0)} y2={sy(0)} stroke="#9aa5b1" />}
      <text x={(L + W - R) / 2} y={H - 4} textAnchor="middle" className="axis-label">layer</text>
      <text x={12} y={(T + H - B) / 2} textAnchor="middle" transform={`rotate(-90 12 ${(T + H - B) / 2})`} className="axis-label">{yLabel}</text>
      {!has && <text x={(L + W - R) / 2} y={(T + H - B) / 2} textAnchor="middle" className="tick">no layer scanned yet</text>}
      {series.map((s) => {
        const pts = s.x.map((x, i) => [x, s.y[i]] as const).filter(([, y]) => Number.isFinite(y));
        const d = pts.map(([x, y], i) => `${i ? "L" : "M"}${sx(x).toFixed(1)} ${sy(y).toFixed(1)}`).join("");
        return (
          <g key={s.label} data-series={s.label} data-points={pts.length}>
            <path d={d} fill="none" stroke={s.color} strokeWidth={1.4} strokeDasharray={s.dashed ? "5 3" : undefined} />
            {pts.map(([x, y]) => (
              <circle key={x} cx={sx(x)} cy={sy(y)} r={3} fill={s.dashed ? "#fff" : s.color} stroke={s.color} strokeWidth={1.4}>
                <title>{`${s.label}, layer ${x}: ${y.toFixed(3)} mm`}</title>
              </circle>
            ))}
          </g>
        );
      })}
      {series.map((s, i) => (
        <g key={`lg${s.label}`} transform={`translate(${W - R - 150} ${T + 4 + i * 13})`}>
          <line x1={0} x2={16} y1={0} y2={0} stroke={s.color} strokeDasharray={s.dashed ? "5 3" : undefined} strokeWidth={2} />
          <text x={20} y={3} className="tick">{s.label}</text>
        </g>
      ))}
    </svg>
  );
});
