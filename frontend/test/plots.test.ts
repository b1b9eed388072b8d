import { describe, expect, it } from "vitest";
import { decimate, parseCsv, pathLength, programmedProfile, programmedSpeed, ticks } from "../src/plots/data";
import { tableRows } from "../src/plots/Results";

describe("simulation artifacts", () => {
  const c = parseCsv("t,x,y,z,speed,arc,deviation\n0,0,0,1.5,0,false,0\n0.5,3,4,1.5,10,true,0.2\n1.0,3,10,1.5,12,1,0.1\n");
  it("parses a numeric CSV with boolean cells", () => {
    expect(Object.keys(c)).toEqual(["t", "x", "y", "z", "speed", "arc", "deviation"]);
    expect(Array.from(c.arc)).toEqual([0, 1, 1]);
    expect(c.speed[2]).toBe(12);
  });
  it("derives the path length from x, y, z when there is no s column", () => {
    expect(Array.from(pathLength(c)!)).toEqual([0, 5, 11]);
    expect(programmedSpeed(c)).toBeNull();
    expect(programmedSpeed(parseCsv("t,speed,programmed_speed\n0,1,2\n"))?.name).toBe("programmed_speed");
  });
  it("builds the programmed speed profile of a toolpath as steps", () => {
    const p = programmedProfile({ layers: [{ sections: [{ points: [[0, 0, 0], [10, 0, 0], [10, 5, 0]], speed: [6, 8] }] }] });
    expect(p.s).toEqual([0, 10, 10, 15]);
    expect(p.speed).toEqual([6, 6, 8, 8]);
  });
  it("decimates keeping each bucket's extremes", () => {
    const x = Array.from({ length: 10000 }, (_, i) => i);
    const y = x.map((i) => (i === 5000 ? 100 : Math.sin(i / 100)));
    const [dx, dy] = decimate(x, y, 1000);
    expect(dx.length).toBeLessThanOrEqual(1000);
    expect(Math.max(...dy)).toBe(100);
  });
  it("picks nice ticks", () => {
    expect(ticks(0, 10, 5)).toEqual([0, 2, 4, 6, 8, 10]);
    expect(ticks(0.13, 0.61, 4)).toEqual([0.2, 0.4, 0.6]);
    expect(ticks(-1, 1, 4)).toEqual([-1, -0.5, 0, 0.5, 1]);
  });
  it("reads comparison JSON rows from a list or a keyed object", () => {
    expect(tableRows({ sections: 1, patterns: [{ pattern: "raster", time_s: 38.8 }, { pattern: "spiral", time_s: 20 }] })).toHaveLength(2);
    expect(tableRows({ raster: { time_s: 1 }, spiral: { time_s: 2 } })).toEqual([{ name: "raster", time_s: 1 }, { name: "spiral", time_s: 2 }]);
  });
});
