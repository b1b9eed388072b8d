import { describe, expect, it } from "vitest";
import {
  boundaryCrossings, closestOnPolyline, cumulativeLengths, pointAtLength, pointInPolygon, polygonArea,
  polygonPathD, polygonVertices, ringArea, ringSelfIntersects, snapPoint, worldToLayer,
} from "../src/mask/geom";

const square = (x0: number, y0: number, s: number) => [[x0, y0], [x0 + s, y0], [x0 + s, y0 + s], [x0, y0 + s], [x0, y0]];
const frame = { exterior: square(0, 0, 10), holes: [square(3, 3, 4)] };

describe("areas and containment", () => {
  it("computes signed ring and polygon-with-hole areas", () => {
    expect(ringArea(square(0, 0, 10))).toBeCloseTo(100, 9);
    expect(ringArea([...square(0, 0, 10)].reverse())).toBeCloseTo(-100, 9);
    expect(polygonArea(frame)).toBeCloseTo(84, 9);
  });
  it("treats holes as outside", () => {
    expect(pointInPolygon([1, 1], frame)).toBe(true);
    expect(pointInPolygon([5, 5], frame)).toBe(false);
    expect(pointInPolygon([11, 5], frame)).toBe(false);
  });
  it("writes evenodd path data with y flipped", () => {
    expect(polygonPathD({ exterior: [[0, 0], [2, 0], [2, 1]], holes: [] })).toBe("M0 0 L2 0 L2 -1 Z");
  });
});

describe("guide crossings", () => {
  it("finds exactly two crossings for a guide through a solid square", () => {
    const c = boundaryCrossings([[-5, 5], [15, 5]], { exterior: square(0, 0, 10), holes: [] });
    expect(c).toHaveLength(2);
    expect(c[0][0]).toBeCloseTo(0, 9);
    expect(c[1][0]).toBeCloseTo(10, 9);
  });
  it("counts the hole's boundary too (four crossings → invalid guide)", () => {
    expect(boundaryCrossings([[-5, 5], [15, 5]], frame)).toHaveLength(4);
  });
  it("counts a crossing through a vertex once", () => {
    expect(boundaryCrossings([[-5, -5], [15, 15]], { exterior: square(0, 0, 10), holes: [] })).toHaveLength(2);
  });
});

describe("lengths along a path", () => {
  const line = [[0, 0], [3, 4], [3, 10]];
  it("accumulates segment lengths", () => {
    expect(cumulativeLengths(line)).toEqual([0, 5, 11]);
  });
  it("interpolates and clamps points at a length", () => {
    expect(pointAtLength(line, 2.5)).toEqual([1.5, 2]);
    expect(pointAtLength(line, 8)).toEqual([3, 7]);
    expect(pointAtLength(line, 99)).toEqual([3, 10]);
  });
  it("projects onto the closest segment with its arc length", () => {
    const c = closestOnPolyline([5, 8], line);
    expect(c.point).toEqual([3, 8]);
    expect(c.distance).toBeCloseTo(2, 9);
    expect(c.s).toBeCloseTo(9, 9);
    expect(c.segment).toBe(1);
  });
});

describe("snapping", () => {
  const vertices = polygonVertices([frame]);
  it("collects vertices of exterior and holes without closing duplicates", () => {
    expect(vertices).toHaveLength(8);
  });
  it("prefers a layer vertex within the radius", () => {
    expect(snapPoint([2.8, 3.3], { vertices, radius: 0.6, grid: 1 })).toEqual({ point: [3, 3], kind: "vertex" });
  });
  it("falls back to the grid, then to the raw point", () => {
    expect(snapPoint([1.26, 8.74], { vertices, radius: 0.5, grid: 0.5 })).toEqual({ point: [1.5, 8.5], kind: "grid" });
    expect(snapPoint([1.26, 8.74], { vertices, radius: 0.5, grid: 0 })).toEqual({ point: [1.26, 8.74], kind: "none" });
  });
});

it("detects a self-intersecting (bow-tie) curve", () => {
  expect(ringSelfIntersects([[0, 0], [10, 10], [10, 0], [0, 10]])).toBe(true);
  expect(ringSelfIntersects(square(0, 0, 10))).toBe(false);
});

describe("layer frames", () => {
  it("maps world points into a tilted layer's plane (rigid frame)", () => {
    // Layer plane tilted 90° about y (layer x → world −z, layer z → world x), origin at (10, 0, 5).
    const frame = [[0, 0, 1, 10], [0, 1, 0, 0], [-1, 0, 0, 5], [0, 0, 0, 1]];
    const world = [[10, 2, 5], [10, 0, 2], [11, 0, 5]];
    const local = worldToLayer(world, frame).map((p) => p.map((v) => Math.round(v * 1e9) / 1e9 + 0));
    expect(local).toEqual([[0, 2, 0], [3, 0, 0], [0, 0, 1]]);
  });
  it("leaves points alone without a frame", () => {
    const pts = [[1, 2, 3]];
    expect(worldToLayer(pts, undefined)).toBe(pts);
  });
});
