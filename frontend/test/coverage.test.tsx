// @vitest-environment jsdom
import { act } from "react";
import { createRoot } from "react-dom/client";
import { describe, expect, it } from "vitest";
import { CoverageLayer, type SectionCoverage } from "../src/mask/CoverageLayer";

(globalThis as { IS_REACT_ACT_ENVIRONMENT?: boolean }).IS_REACT_ACT_ENVIRONMENT = true;

const sq = (x0: number, y0: number, s: number) => ({
  exterior: [[x0, y0], [x0 + s, y0], [x0 + s, y0 + s], [x0, y0 + s], [x0, y0]],
  holes: [],
});

const cov: SectionCoverage = {
  key: "bs1/A", region_area_mm2: 100, footprint_area_mm2: 90, void_area_mm2: 10, overlap_area_mm2: 4,
  over_deposit_area_mm2: 0, void_share: 0.1, overlap_share: 0.04, bead_width_mm: 6, cell_mm: 0.3,
  void: [sq(0, 0, 2), sq(5, 5, 2)], overlap: [sq(1, 1, 2)],
};

describe("CoverageLayer", () => {
  it("draws voids red and overlaps dark, one group per section", () => {
    const host = document.createElement("div");
    const root = createRoot(host);
    act(() => root.render(<svg><CoverageLayer coverage={[cov]} /></svg>));
    const g = host.querySelector('[data-coverage="bs1/A"]')!;
    expect(g.getAttribute("data-void-mm2")).toBe("10.00");
    expect(g.querySelectorAll(".coverage-void")).toHaveLength(2);
    expect(g.querySelectorAll(".coverage-overlap")).toHaveLength(1);
    expect((g.querySelector(".coverage-void") as SVGPathElement).style.fill).toContain("214");
    act(() => root.render(<svg><CoverageLayer coverage={null} /></svg>));
    expect(host.querySelector(".coverage")).toBeNull();
    act(() => root.unmount());
  });
});
