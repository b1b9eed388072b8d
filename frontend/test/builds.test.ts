import { describe, expect, it } from "vitest";
import { chartSeries, deviationColor, layerRows, overlaySegments, parseRoute, progress, timeline, type BuildDetail } from "../src/builds/data";

// A build of 4 planned layers: 0 and 1 scanned (layer 1 with a measured temperature), layer 2's
// program issued with a 174.57 s dwell, layer 3 not yet.
const detail: BuildDetail = {
  id: "abcdef012345", run: "0123456789ab", graph: "mpp-cross", status: "building", created: "2026-11-25T10:00:00Z",
  layers_planned: 4, layers_scanned: 2, next_layer: 2, plan_layers: [0, 1, 2, 3], layers_added: 0, layers_dropped: 0, skipped: [],
  layers: [
    { layer: 0, coverage: 0.99, planned_top_mm: 1.5, asbuilt_top_mm: 1.2, mean_error_mm: -0.3, rms_error_mm: 0.31, max_error_mm: 0.42 },
    { layer: 1, coverage: 0.98, planned_top_mm: 3.0, asbuilt_top_mm: 2.9, mean_error_mm: -0.1, rms_error_mm: 0.12, max_error_mm: 0.2, interpass_measured_c: 350 },
  ],
  programs: [
    { layer: 0, adapted: false, files: ["post.gcode"] },
    { layer: 1, adapted: true, speed_factor_min: 0.6, speed_factor_max: 0.63, clamped_slow: 480, clamped_fast: 0, files: ["post.gcode"] },
    { layer: 2, adapted: true, speed_factor_min: 0.9, speed_factor_max: 1.1, clamped_slow: 0, clamped_fast: 0, dwell_s: 174.57, dwell_clamped: false, interpass_measured_c: 350, files: ["post.gcode"] },
  ],
  interpass: { target_c: 200 },
  log: [
    { time: "2026-11-25T10:00:00Z", who: "alice", action: "start", layers: 4 },
    { time: "2026-11-25T10:00:01Z", who: "alice", action: "program", layer: 0, adapted: false, files: ["post.gcode"] },
    { time: "2026-11-25T10:03:00Z", who: "cell", action: "scan", layer: 0, coverage: 0.99, mean_error_mm: -0.3, rms_error_mm: 0.31, max_error_mm: 0.42, scan_file: "scan_00000.bin", scan_bytes: 40960, scan_sha256: "0123456789abcdef" },
    { time: "2026-11-25T10:03:01Z", who: "cell", action: "scan_refused", layer: 3, reason: "expected layer 1" },
    { time: "2026-11-25T10:09:02Z", who: "cell", action: "program", layer: 2, adapted: true, speed_factor_min: 0.9, speed_factor_max: 1.1, dwell_s: 174.57, interpass_measured_c: 350, files: ["post.gcode"], sha256: { "post.gcode": "fedcba9876543210" } },
  ],
};

describe("builds page data", () => {
  it("rows: every planned layer, scanned ones with errors, the added error and the program's adaptation", () => {
    const rows = layerRows(detail);
    expect(rows.map((r) => [r.layer, r.state])).toEqual([[0, "scanned"], [1, "scanned"], [2, "next"], [3, "planned"]]);
    expect(rows[0].addedError).toBeCloseTo(-0.3, 9);
    expect(rows[1].addedError).toBeCloseTo(0.2, 9); // −0.1 − (−0.3): layer 1 brought the top back 0.2 mm
    expect(rows[1].meanError).toBe(-0.1);
    expect([rows[1].speedMin, rows[1].speedMax, rows[1].clampedSlow]).toEqual([0.6, 0.63, 480]);
    expect(rows[1].measuredC).toBe(350);
    expect(rows[2].dwellS).toBe(174.57);
    expect(rows[3].meanError).toBeNull();
    expect(rows[0].adapted).toBe(false);
  });

  it("progress: layers done vs planned, the last layer's errors, the dwell and clamped layers", () => {
    const p = progress(detail);
    expect(p).toMatchObject({ done: 2, planned: 4, share: 0.5, lastMean: -0.1, lastMax: 0.2, clampedLayers: 1 });
    expect(p.dwellTotal).toBeCloseTo(174.57, 9);
  });

  it("chart series over the scanned layers only", () => {
    const s = chartSeries(layerRows(detail));
    expect(s.heights[0].y).toEqual([1.5, 3.0]);
    expect(s.heights[1].y).toEqual([1.2, 2.9]);
    expect(s.errors.map((e) => e.label)).toEqual(["mean error (cumulative)", "max |error|", "added by the layer"]);
    expect(s.errors[1].y).toEqual([0.42, 0.2]);
    expect(s.errors[0].x).toEqual([0, 1]);
  });

  it("timeline: seconds since the start, who, and what each step did", () => {
    const t = timeline(detail);
    expect(t.map((e) => e.t)).toEqual([0, 1, 180, 181, 542]);
    expect(t[2].text).toBe("scan of layer 0 measured: mean -0.300 mm, max 0.420 mm, coverage 99.0 % — scan_00000.bin, 40.0 kB, sha256 0123456789abcdef…");
    expect(t[3].text).toBe("scan of layer 3 refused: expected layer 1");
    expect(t[4].text).toBe("program of layer 2 issued (adapted), speed ×0.90…×1.10, wait 174.6 s (part 350 °C) (post.gcode sha256 fedcba9876543210…)");
    expect(t[4].who).toBe("cell");
  });

  it("a layer laid again has a row per pass, a layer left out is marked, the rest follows the plan", () => {
    const d: BuildDetail = {
      ...detail, layers_planned: 5, plan_layers: [0, 1, 2, 3, 4], next_layer: 3, layers_added: 1, layers_dropped: 1, skipped: [2], layers_scanned: 3,
      layers: [
        { layer: 0, pass: 1, mean_error_mm: -1.0, max_error_mm: 1.1, then: "layer 0 laid again (1.00 mm low, more than half the 1.5 mm layer)" },
        { layer: 0, pass: 2, mean_error_mm: 0.0, max_error_mm: 0.1 },
        { layer: 1, pass: 1, mean_error_mm: 0.8, max_error_mm: 0.9, then: "layer 2 left out (0.80 mm high, more than half the 1.5 mm layer)" },
      ],
      programs: [
        { layer: 0, pass: 1, adapted: false }, { layer: 0, pass: 2, adapted: true, speed_factor_min: 0.75, speed_factor_max: 0.75 },
        { layer: 1, pass: 1, adapted: true, speed_factor_min: 1.0, speed_factor_max: 1.1 }, { layer: 3, pass: 1, adapted: true, speed_factor_min: 0.6, speed_factor_max: 0.7 },
      ],
    };
    const rows = layerRows(d);
    expect(rows.map((r) => [r.layer, r.pass, r.state])).toEqual([[0, 1, "scanned"], [0, 2, "scanned"], [1, 1, "scanned"], [2, 1, "dropped"], [3, 1, "next"], [4, 1, "planned"]]);
    expect(rows[1].speedMin).toBe(0.75);
    expect(rows[1].addedError).toBeCloseTo(1.0, 9);
    expect(rows[0].then).toMatch(/laid again/);
    expect(rows[4].speedMin).toBe(0.6);
    expect(progress(d)).toMatchObject({ done: 2, added: 1, dropped: 1, lastMean: 0.8 });
    // the chart takes a repeated layer's last pass
    expect(chartSeries(rows).errors[0].y).toEqual([0.0, 0.8]);
  });

  it("deviation colours: −limit blue, 0 white, +limit red, half way between", () => {
    expect(deviationColor(-1, 0.5)).toBe("rgb(33,102,172)");
    expect(deviationColor(0, 0.5)).toBe("rgb(247,247,247)");
    expect(deviationColor(0.5, 0.5)).toBe("rgb(178,24,43)");
    expect(deviationColor(0.25, 0.5)).toBe("rgb(213,136,145)");
  });

  it("overlay: a segment between neighbouring seen samples, gaps at jumps and unseen samples", () => {
    const o = overlaySegments({ layer: 0, thickness: 1.5, x: [0, 1, 2, 3, 10, 11], y: [0, 0, 0, 0, 0, 0], z: [1, 1, 1, 1, 1, 1], deviation: [-0.2, -0.1, null, 0.1, 0.3, 0.3] });
    expect(o.segs.map((s) => [s.x1, s.x2])).toEqual([[0, 1], [10, 11]]);
    expect(o.segs[0].dev).toBeCloseTo(-0.15, 9);
    expect([o.lo, o.hi, o.limit, o.seen, o.samples]).toEqual([-0.2, 0.3, 0.3, 5, 6]);
    expect(o.segs[1].color).toBe("rgb(178,24,43)");
  });

  it("routes: #/builds and #/builds/<12 hex>, anything else is the editor", () => {
    expect(parseRoute("#/builds")).toEqual({ id: null });
    expect(parseRoute("#/builds/abcdef012345")).toEqual({ id: "abcdef012345" });
    expect(parseRoute("#/builds/xyz")).toBeNull();
    expect(parseRoute("")).toBeNull();
    expect(parseRoute("#/other")).toBeNull();
  });
});
