// The pure parts behind MaskCanvas / MaskView that had no test (#27): ring and segment geometry,
// SVG path data, bounding boxes; section keys, mask order and the mask edits.
import { describe, expect, it } from "vitest";
import { bbox, dist, openRing, pointInRing, polygonSegments, ringPathD, segmentIntersection, type Pt } from "../src/mask/geom";
import {
  findSection, forgetKey, governingMask, removeMask, sectionKey, setMaskFrom, sortedMasks, splitKey, type MaskParams,
} from "../src/mask/edits";

const square: Pt[] = [[0, 0], [10, 0], [10, 10], [0, 10], [0, 0]];

describe("geom", () => {
  it("dist is the plane distance; openRing drops only a repeated closing vertex", () => {
    expect(dist([0, 0], [3, 4])).toBe(5);
    expect(openRing(square).length).toBe(4);
    expect(openRing(square.slice(0, 4)).length).toBe(4);
    expect(openRing([[1, 1]])).toEqual([[1, 1]]);
  });
  it("pointInRing: inside, outside, and a concave notch", () => {
    expect(pointInRing([5, 5], square)).toBe(true);
    expect(pointInRing([15, 5], square)).toBe(false);
    const u: Pt[] = [[0, 0], [30, 0], [30, 20], [20, 20], [20, 5], [10, 5], [10, 20], [0, 20]];
    expect(pointInRing([15, 10], u)).toBe(false); // in the notch
    expect(pointInRing([5, 10], u)).toBe(true);
    expect(pointInRing([25, 10], u)).toBe(true);
  });
  it("segmentIntersection: the crossing point, null for parallel or missing segments, ends count", () => {
    expect(segmentIntersection([0, 0], [10, 10], [0, 10], [10, 0])).toEqual([5, 5]);
    expect(segmentIntersection([0, 0], [10, 0], [0, 1], [10, 1])).toBeNull();
    expect(segmentIntersection([0, 0], [4, 4], [0, 10], [10, 0])).toBeNull(); // would meet at 5,5: past its end
    expect(segmentIntersection([0, 0], [10, 0], [10, -5], [10, 5])).toEqual([10, 0]);
  });
  it("polygonSegments: every ring closed, holes included", () => {
    const segs = polygonSegments({ exterior: square, holes: [[[2, 2], [4, 2], [4, 4]]] });
    expect(segs.length).toBe(4 + 3);
    expect(segs[3]).toEqual([[0, 10], [0, 0]]);
    expect(segs[6]).toEqual([[4, 4], [2, 2]]);
  });
  it("ringPathD: y negated (SVG y points down), µm rounding, Z only when closed", () => {
    expect(ringPathD([[0, 0], [1.23456, 2]], false)).toBe("M0 0 L1.235 -2");
    expect(ringPathD(square, true)).toBe("M0 0 L10 0 L10 -10 L0 -10 Z");
    expect(ringPathD([], true)).toBe("");
  });
  it("bbox: the extent with padding; none for no points", () => {
    expect(bbox([[1, 5], [-3, 2], [4, -1]], 1)).toEqual({ minX: -4, minY: -2, maxX: 5, maxY: 6 });
    expect(bbox([])).toBeNull();
  });
});

describe("mask edits", () => {
  const p: MaskParams = {
    masks: [
      { id: "bs2", from_layer: 5, sections: [{ id: "A", curve: square }] },
      { id: "bs1", from_layer: 0, sections: [{ id: "A", curve: square }, { id: "B", curve: square }] },
    ],
  };
  it("section keys are mask/section; a section id may itself hold a slash", () => {
    expect(sectionKey("bs1", "A")).toBe("bs1/A");
    expect(splitKey("bs1/A")).toEqual({ mask: "bs1", section: "A" });
    expect(splitKey("bs1/A/2")).toEqual({ mask: "bs1", section: "A/2" });
  });
  it("masks in layer order; the governing mask is the last starting at or below the layer (the backend's rule)", () => {
    expect(sortedMasks(p).map((m) => m.id)).toEqual(["bs1", "bs2"]);
    expect(governingMask(p, 4)?.id).toBe("bs1");
    expect(governingMask(p, 5)?.id).toBe("bs2");
    expect(governingMask({ masks: [{ id: "m", from_layer: 2, sections: [] }] }, 1)).toBeUndefined();
  });
  it("findSection by key; removeMask; setMaskFrom rounds and clamps at layer 0", () => {
    expect(findSection(p, "bs1/B")?.id).toBe("B");
    expect(findSection(p, "bs2/B")).toBeUndefined();
    expect(removeMask(p, "bs2").masks!.map((m) => m.id)).toEqual(["bs1"]);
    expect(setMaskFrom(p, "bs2", 7.6).masks![0].from_layer).toBe(8);
    expect(setMaskFrom(p, "bs2", -3).masks![0].from_layer).toBe(0);
    expect(p.masks![0].from_layer).toBe(5); // the params given are not changed
  });
  it("forgetKey drops a removed section's entries and guide, the same object otherwise untouched", () => {
    const strategy = { default: { pattern: "raster" }, sections: { "bs1/A": { pattern: "spiral" }, "bs1/B": {} } };
    const out = forgetKey(strategy, "bs1/A");
    expect(Object.keys(out.sections)).toEqual(["bs1/B"]);
    expect(out.default).toBe(strategy.default);
    expect(Object.keys(strategy.sections)).toEqual(["bs1/A", "bs1/B"]);
    const guide = { guides: { "bs1/A": [[0, 0], [1, 1]] } };
    expect(forgetKey(guide, "bs1/A").guides).toEqual({});
    expect(forgetKey(guide, "bs9/Z")).toEqual(guide);
  });
});
