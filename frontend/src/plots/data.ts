/**
 * Simulation artifacts → plot series. Column names follow the contract's `<node>.trace.csv`
 * (t, x, y, z, speed, arc, deviation; more columns are kept). Units: s, mm, mm/s.
 */

export type Columns = Record<string, Float64Array>;

/** Parse a numeric CSV with a header row. Non-numeric cells (e.g. "true"/"false") become 1/0 or NaN. */
export function parseCsv(text: string): Columns {
  const lines = text.split(/\r?\n/).filter((l) => l.trim() !== "" && !l.startsWith("#"));
  if (!lines.length) return {};
  const head = lines[0].split(",").map((h) => h.trim());
  const cols = head.map(() => new Float64Array(lines.length - 1));
  for (let r = 1; r < lines.length; r++) {
    const cells = lines[r].split(",");
    for (let c = 0; c < head.length; c++) {
      const t = (cells[c] ?? "").trim();
      cols[c][r - 1] = t === "true" || t === "True" ? 1 : t === "false" || t === "False" ? 0 : t === "" ? NaN : Number(t);
    }
  }
  return Object.fromEntries(head.map((h, i) => [h, cols[i]]));
}

/** Path length s (mm) along the sampled trace: the `s` column if present, else cumulative xyz distance. */
export function pathLength(c: Columns): Float64Array | null {
  if (c.s) return c.s;
  if (!c.x || !c.y) return null;
  const n = c.x.length;
  const s = new Float64Array(n);
  for (let i = 1; i < n; i++) {
    const dz = c.z ? c.z[i] - c.z[i - 1] : 0;
    s[i] = s[i - 1] + Math.hypot(c.x[i] - c.x[i - 1], c.y[i] - c.y[i - 1], dz);
  }
  return s;
}

/** The programmed-speed column, if the trace has one (named like programmed/commanded speed). */
export function programmedSpeed(c: Columns): { name: string; values: Float64Array } | null {
  const name = Object.keys(c).find((k) => /speed/i.test(k) && /(prog|cmd|command|target|nominal)/i.test(k));
  return name ? { name, values: c[name] } : null;
}

/** Decimate to at most `max` points keeping the min and max of every bucket (the shape survives). */
export function decimate(x: ArrayLike<number>, y: ArrayLike<number>, max = 2000): [number[], number[]] {
  const n = Math.min(x.length, y.length);
  if (n <= max) return [Array.from({ length: n }, (_, i) => x[i]), Array.from({ length: n }, (_, i) => y[i])];
  const bucket = Math.ceil(n / (max / 2));
  const xs: number[] = [], ys: number[] = [];
  for (let b = 0; b < n; b += bucket) {
    let lo = b, hi = b;
    for (let i = b; i < Math.min(n, b + bucket); i++) {
      if (y[i] < y[lo]) lo = i;
      if (y[i] > y[hi]) hi = i;
    }
    for (const i of lo < hi ? [lo, hi] : [hi, lo]) {
      xs.push(x[i]);
      ys.push(y[i]);
    }
  }
  return [xs, ys];
}

/** Nice tick values covering [lo, hi]. */
export function ticks(lo: number, hi: number, count = 5): number[] {
  if (!Number.isFinite(lo) || !Number.isFinite(hi)) return [];
  if (hi <= lo) return [lo];
  const raw = (hi - lo) / count;
  const mag = 10 ** Math.floor(Math.log10(raw));
  const step = [1, 2, 2.5, 5, 10].map((m) => m * mag).find((s) => s >= raw) ?? raw;
  const out: number[] = [];
  for (let v = Math.ceil(lo / step) * step; v <= hi + step * 1e-9; v += step) out.push(Number((Math.round(v / step) * step).toPrecision(12)));
  return out;
}

/** Programmed speed (mm/s) against programmed path length (mm), as steps: one value per segment,
 * over every layer and section of a contract toolpath JSON in file order. */
export function programmedProfile(tp: { layers: { sections: { points: number[][]; speed: (number | null)[] }[] }[] }): { s: number[]; speed: number[] } {
  const s: number[] = [], speed: number[] = [];
  let acc = 0;
  for (const l of tp.layers)
    for (const sec of l.sections)
      for (let i = 0; i + 1 < sec.points.length; i++) {
        const a = sec.points[i], b = sec.points[i + 1];
        const v = sec.speed[i];
        s.push(acc);
        speed.push(v ?? NaN);
        acc += Math.hypot(b[0] - a[0], b[1] - a[1], (b[2] ?? 0) - (a[2] ?? 0));
        s.push(acc);
        speed.push(v ?? NaN);
      }
  return { s, speed };
}
