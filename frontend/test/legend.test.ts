import { describe, expect, it } from "vitest";
import { fmt, gradientCss, layerRange, legendBlocks } from "../src/viewer/legend";
import type { LegendEntry } from "../src/viewer/api";

const stops = ["#440154", "#21908d", "#fde725"];
const toolpath: LegendEntry = {
  node: "zone", kind: "toolpath", mode: "zone", zones: [{ zone: "start", color: "#2ec4b6" }, { zone: "z1", color: "#4e79a7" }],
  ranges: { speed: { lo: 4, hi: 12.5, unit: "mm/s" } }, arc: { on: "#e63946", off: "#457b9d" }, travel: "#cdcdcd",
};
const sim: LegendEntry = {
  node: "simulate", kind: "simulation", mode: "deposit", ranges: { deviation: { lo: 0, hi: 0.42, unit: "mm" }, deposit: { lo: 1.25, hi: 3.5, unit: "mm³/mm" } },
  programmed: "#6e6e6e", travel: "#cdcdcd", robot: null, robot_note: "",
};

describe("3D legend", () => {
  it("a gradient through evenly spaced stops", () => {
    expect(gradientCss(stops)).toBe("linear-gradient(to right, #440154 0.0%, #21908d 50.0%, #fde725 100.0%)");
    expect(gradientCss([])).toBe("none");
  });
  it("formats range ends with 3 significant digits", () => {
    expect([fmt(12.3456), fmt(0.0421234), fmt(0), fmt(250000), fmt(NaN)]).toEqual(["12.3", "0.0421", "0", "2.50e+5", "–"]);
  });
  it("zone mode: one swatch per zone plus travel, no bar", () => {
    const [b] = legendBlocks([toolpath], stops);
    expect(b.swatches.map((s) => s.label)).toEqual(["start", "z1", "travel"]);
    expect(b.bar).toBeNull();
  });
  it("speed mode: a bar with range and unit", () => {
    const [b] = legendBlocks([{ ...toolpath, mode: "speed" }], stops);
    expect(b.bar).toMatchObject({ lo: "4", hi: "12.5", unit: "mm/s" });
    expect(b.title).toBe("zone — toolpath by speed");
  });
  it("arc mode: on/off swatches, travel not repeated", () => {
    const [b] = legendBlocks([{ ...toolpath, mode: "arc" }], stops);
    expect(b.swatches.map((s) => [s.label, s.color])).toEqual([["arc on", "#e63946"], ["arc off", "#457b9d"]]);
  });
  it("deposit mode on the simulation: bar in mm³/mm; a missing range says so", () => {
    const [b] = legendBlocks([sim], stops);
    expect(b.bar).toMatchObject({ lo: "1.25", hi: "3.5", unit: "mm³/mm", label: "deposit per mm" });
    const [c] = legendBlocks([{ ...sim, mode: "speed" }], stops);
    expect(c.bar).toBeNull();
    expect(c.note).toMatch(/no speed data/);
  });
  it("layer range: synced to the canvas layer, or the chosen range, clipped to the part", () => {
    expect(layerRange(true, 3, [0, 0], { lo: 0, hi: 7 })).toEqual([3, 3]);
    expect(layerRange(true, 12, [0, 0], { lo: 0, hi: 7 })).toEqual([7, 7]);
    expect(layerRange(false, 3, [6, 2], { lo: 0, hi: 7 })).toEqual([2, 6]);
    expect(layerRange(false, 3, [-4, 40], { lo: 1, hi: 7 })).toEqual([1, 7]);
  });
});

describe("legend of robust colour ranges", () => {
  it("marks clamped outliers at the bar's ends and gives the data's extent", () => {
    const [b] = legendBlocks(
      [{ node: "sim", kind: "simulation", mode: "deposit", ranges: { deposit: { lo: 4.1, hi: 6.2, unit: "mm³/mm", min: 0, max: 48500, clamped: true } } }],
      ["#440154", "#fde725"],
    );
    expect([b.bar?.lo, b.bar?.hi]).toEqual(["≤ 4.1", "≥ 6.2"]);
    expect(b.note).toMatch(/outliers clamped.*0–48500 mm³\/mm/);
  });
  it("nothing clamped: plain ends", () => {
    const [b] = legendBlocks([{ node: "tp", kind: "toolpath", mode: "speed", ranges: { speed: { lo: 10, hi: 20, unit: "mm/s", min: 10, max: 20, clamped: false } } }], []);
    expect([b.bar?.lo, b.bar?.hi, b.note]).toEqual(["10", "20", undefined]);
  });
});

describe("clamping marks only what matters", () => {
  it("a low end beyond by less than 1 % of the span is not marked (deviation 5e-12 vs 5.6e-10 of 0.098 mm)", () => {
    const [b] = legendBlocks([{ node: "sim", kind: "simulation", mode: "deviation", ranges: { deviation: { lo: 5.64e-10, hi: 0.0981, unit: "mm", min: 5.11e-12, max: 0.2, clamped: true } } }], []);
    expect(b.bar?.lo.startsWith("≤")).toBe(false);
    expect(b.bar?.hi).toBe("≥ 0.0981");
  });
});
