/**
 * Robust limits for charts and colour maps: the 2nd–98th percentile of the data, so one outlier
 * (an ignition spike of 48,500 mm³/mm among values of 5) does not squeeze every ordinary value
 * into one colour or one pixel row. Values beyond the limits are clamped (drawn at the edge) and
 * the range says how many were, so a legend or an axis can mark them. The backend's colour maps
 * use the same percentiles (`waamflow.viewer.colors.robust_range`).
 */

export const ROBUST_PERCENTILES: readonly [number, number] = [2, 98];

/** The p-th percentile (0–100) of the finite values, linear interpolation (numpy's default); NaN if none. */
export function percentile(values: ArrayLike<number>, p: number): number {
  const v = Array.from(values).filter(Number.isFinite).sort((a, b) => a - b);
  if (!v.length) return NaN;
  const x = (Math.min(Math.max(p, 0), 100) / 100) * (v.length - 1);
  const i = Math.floor(x);
  return i + 1 < v.length ? v[i] + (x - i) * (v[i + 1] - v[i]) : v[i];
}

export interface RobustRange {
  /** the limits: drawn range (percentiles) */
  lo: number;
  hi: number;
  /** the data's full extent */
  min: number;
  max: number;
  /** how many values lie below lo / above hi (clamped when drawn) */
  below: number;
  above: number;
  clamped: boolean;
}

/** Robust limits over one or more series (their finite values pooled); {0, 1} without data. */
export function robustRange(...series: ArrayLike<number>[]): RobustRange {
  const all: number[] = [];
  for (const s of series) for (let i = 0; i < s.length; i++) if (Number.isFinite(s[i])) all.push(s[i]);
  if (!all.length) return { lo: 0, hi: 1, min: 0, max: 1, below: 0, above: 0, clamped: false };
  const [pl, ph] = ROBUST_PERCENTILES;
  const lo = percentile(all, pl);
  const hi = percentile(all, ph);
  let below = 0, above = 0, min = Infinity, max = -Infinity;
  for (const v of all) {
    if (v < lo) below++;
    if (v > hi) above++;
    min = Math.min(min, v);
    max = Math.max(max, v);
  }
  return { lo, hi, min, max, below, above, clamped: below + above > 0 };
}
