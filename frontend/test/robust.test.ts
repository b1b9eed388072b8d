import { describe, expect, it } from "vitest";
import { percentile, robustRange } from "../src/plots/robust";

describe("robust limits (2nd–98th percentile): one outlier does not flatten a chart or a colour map", () => {
  it("percentile interpolates linearly like numpy", () => {
    expect(percentile([1, 2, 3, 4], 50)).toBeCloseTo(2.5);
    expect(percentile([10, 0, 5], 0)).toBe(0);
    expect(percentile([10, 0, 5], 100)).toBe(10);
    expect(percentile([0, 10], 2)).toBeCloseTo(0.2);
    expect(Number.isNaN(percentile([], 50))).toBe(true);
  });
  it("clamps the deposit outlier (0–48,500 mm³/mm) and says so", () => {
    const v = Array.from({ length: 999 }, (_, i) => 1 + (2 * i) / 998);
    v.push(48_500);
    const r = robustRange(v);
    expect(r.lo).toBeGreaterThanOrEqual(1);
    expect(r.lo).toBeLessThan(1.1);
    expect(r.hi).toBeGreaterThan(2.9);
    expect(r.hi).toBeLessThan(3);
    expect([r.min, r.max, r.clamped, r.above, r.below]).toEqual([1, 48_500, true, 20, 20]);
  });
  it("ignores NaN and infinities; a flat series is not clamped", () => {
    const r = robustRange([5, 5, NaN, Infinity, 5]);
    expect([r.lo, r.hi, r.clamped, r.above]).toEqual([5, 5, false, 0]);
    expect(robustRange([])).toMatchObject({ lo: 0, hi: 1, clamped: false });
  });
  it("several series share one range", () => {
    const r = robustRange([0, 1, 2], [3, 4, 100]);
    expect(r.min).toBe(0);
    expect(r.max).toBe(100);
    expect(r.hi).toBeLessThan(100);
  });
});
