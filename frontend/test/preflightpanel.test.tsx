// @vitest-environment jsdom
import { act } from "react";
import { createRoot } from "react-dom/client";
import { describe, expect, it } from "vitest";
import { PreflightBadge } from "../src/preflight/PreflightBadge";
import { coarseCoverage, preflightBadge, type Preflight, type PreflightProblem } from "../src/preflight/preflight";
import { ProblemsPanel } from "../src/problems/ProblemsPanel";

(globalThis as { IS_REACT_ACT_ENVIRONMENT?: boolean }).IS_REACT_ACT_ENVIRONMENT = true;

const report: Preflight = {
  verdict: "warn", accepted: false, top_gap_mm: 0, uncovered_share: 0.04, wire_part_volume_ratio: 1.1, min_arc_run_mm: 9, start_spread_mm: 3, weld_data_missing: 0,
  layers: [], programs: [],
  problems: [
    { check: "uncovered", severity: "warn", node: "post", layer: 3, section: "bs1/A", message: "layer 3, bs1/A: 12 mm² gets no bead", value: 0.04, limit: 0.02, point: [10, 2, 6] },
    { check: "stacked_starts", severity: "warn", node: "post", layer: 4, section: null, message: "layer 4 ignites on layer 3's start", value: 1, limit: 6, point: null },
  ],
};

function render(el: React.ReactElement) {
  const host = document.createElement("div");
  document.body.appendChild(host);
  const root = createRoot(host);
  act(() => root.render(el));
  return host;
}

describe("preflight in the GUI", () => {
  it("the badge is a labelled button with its figures in the tooltip; a click opens the list", () => {
    let opened = 0;
    const host = render(<PreflightBadge view={preflightBadge({ phase: "done", report, stale: false })} onOpen={() => opened++} />);
    const b = host.querySelector("[data-testid=preflight-badge]") as HTMLButtonElement;
    expect(b.textContent).toBe("preflight ⚠ 2");
    expect(b.getAttribute("aria-label")).toBe("preflight ⚠ 2: preflight warnings, 2 problems; open the list");
    expect(b.title).toMatch(/uncovered: 4.0 %/);
    act(() => b.click());
    expect(opened).toBe(1);
  });
  it("the problems panel lists each preflight problem; an uncovered one offers 'new mask here'", () => {
    const picked: PreflightProblem[] = [], masked: PreflightProblem[] = [];
    const host = render(
      <ProblemsPanel problems={[]} onPick={() => {}} onClose={() => {}} preflight={report} onPickPreflight={(p) => picked.push(p)} onMaskHere={(p) => masked.push(p)} />,
    );
    const rows = [...host.querySelectorAll(".pf-problem")];
    expect(rows.map((r) => r.querySelector(".where")!.textContent)).toEqual(["uncovered area · post · layer 3 · bs1/A", "stacked starts · post · layer 4"]);
    expect(host.querySelectorAll("[data-testid=pf-mask-here]")).toHaveLength(1);
    act(() => (rows[1] as HTMLButtonElement).click());
    act(() => (host.querySelector("[data-testid=pf-mask-here]") as HTMLButtonElement).click());
    expect(picked.map((p) => p.check)).toEqual(["stacked_starts"]);
    expect(masked.map((p) => p.layer)).toEqual([3]);
    expect(host.querySelector("[data-testid=preflight-section] h3")!.textContent).toMatch(/Preflight\s*warn/);
  });
  it("a failed preflight comes before the run's warnings, and the badge's click brings it into view", () => {
    const warns = Array.from({ length: 33 }, (_, i) => ({ key: `w${i}`, severity: "warning" as const, node: "zone", layer: 5, section: "bs1/A", field: null, message: `params.xml value ${i} dropped` }));
    const failed: Preflight = { ...report, verdict: "fail", problems: [{ check: "bottom_gap", severity: "fail", node: "post", layer: 0, section: "bs1/A", message: "the deposit starts 4.50 mm above the part's bottom", value: 4.5, limit: 0.75, point: null }] };
    let scrolled = 0;
    const proto = Element.prototype as unknown as { scrollIntoView?: () => void };
    const before = proto.scrollIntoView;
    proto.scrollIntoView = function () { scrolled++; };
    try {
      const host = render(<ProblemsPanel problems={warns} onPick={() => {}} onClose={() => {}} preflight={failed} focusPreflight />);
      const body = host.querySelector(".problems-body")!;
      expect(body.firstElementChild!.getAttribute("data-testid")).toBe("preflight-section");
      expect(host.querySelector(".pf-problem .where")!.textContent).toBe("bottom not built · post · layer 0 · bs1/A");
      expect(scrolled).toBe(1);
      // a passing (or warning) preflight stays below the run's own problems, and is not scrolled to unless asked
      const ok = render(<ProblemsPanel problems={warns} onPick={() => {}} onClose={() => {}} preflight={report} />);
      expect(ok.querySelector(".problems-body")!.lastElementChild!.getAttribute("data-testid")).toBe("preflight-section");
      expect(scrolled).toBe(1);
    } finally {
      proto.scrollIntoView = before;
    }
  });
  it("shows what the check did not judge (the programs' notes), each once, named by node when there are several", () => {
    const torch = "3 arc-ON targets in 1 layer neither flat nor laid on a bead (or the plate) within 5.0 mm below: the torch axis is not judged there";
    const angles = "2 arc-ON runs state no positioner angles on cell kr150_tilt_rotate: the positioner stands where the controller left it, its welding position is not judged there";
    const prog = (node: string, notes: string[]) => ({ node, format: "krl", files: [], verdict: "ok" as const, notes });
    const one = render(<ProblemsPanel problems={[]} onPick={() => {}} onClose={() => {}} preflight={{ ...report, problems: [], programs: [prog("post", [torch, angles, torch])] }} />);
    expect([...one.querySelectorAll("[data-testid=pf-note]")].map((e) => e.textContent)).toEqual([torch, angles]);
    const two = render(<ProblemsPanel problems={[]} onPick={() => {}} onClose={() => {}} preflight={{ ...report, problems: [], programs: [prog("post", [torch]), prog("post2", [angles])] }} />);
    expect([...two.querySelectorAll("[data-testid=pf-note]")].map((e) => e.textContent)).toEqual([`post: ${torch}`, `post2: ${angles}`]);
    expect(render(<ProblemsPanel problems={[]} onPick={() => {}} onClose={() => {}} preflight={report} />).querySelectorAll("[data-testid=pf-note]")).toHaveLength(0);
  });
  it("says what passed: the program, or the toolpath when no program is emitted (it had said 'the program' then too)", () => {
    const prog = (node: string, format: string) => ({ node, format, files: [], verdict: "ok" as const, notes: [] });
    const clean = (programs: ReturnType<typeof prog>[]) =>
      render(<ProblemsPanel problems={[]} onPick={() => {}} onClose={() => {}} preflight={{ ...report, verdict: "ok", problems: [], programs }} />).querySelector("[data-testid=pf-clean]")?.textContent;
    expect(clean([prog("post", "gcode")])).toBe("The program builds the part: no preflight problems.");
    expect(clean([prog("post", "krl"), prog("post2", "rapid")])).toBe("The programs build the part: no preflight problems.");
    expect(clean([prog("sequence", "toolpath")])).toBe("The toolpath builds the part: no preflight problems. No program is emitted: add a post-process node to write one (its weld data and wire are checked then).");
    const warned = render(<ProblemsPanel problems={[]} onPick={() => {}} onClose={() => {}} preflight={{ ...report, programs: [prog("post", "gcode")] }} />);
    expect(warned.querySelector("[data-testid=pf-clean]")).toBeNull();
  });
  it("says where the 3D coverage was sampled coarser than asked (a large part), and only there", () => {
    const prog = (node: string, used: number, asked: number | null = 1.0) => ({ node, format: "gcode", files: [], verdict: "ok" as const, bead_width_mm: 4, coverage_sample_mm: used, coverage_sample_asked_mm: asked });
    const big: Preflight = { ...report, problems: [], programs: [prog("post", 5.3), prog("post2", 1.0), prog("post3", 1.04)] };
    expect(coarseCoverage(big)).toEqual([["post", 5.3, 1.0]]);
    expect(coarseCoverage({ ...big, programs: [prog("post", 5.3, 6.0)] })).toEqual([]); // asked coarser still
    expect(coarseCoverage({ ...big, programs: [prog("post", 0.52, 0.5)] })).toEqual([]); // within 5 %
    expect(coarseCoverage({ ...big, programs: [prog("post", 5.3, null)] })).toEqual([]); // an older report: no claim
    const host = render(<ProblemsPanel problems={[]} onPick={() => {}} onClose={() => {}} preflight={big} />);
    const lines = [...host.querySelectorAll("[data-testid=pf-coarse]")].map((e) => e.textContent);
    expect(lines).toEqual(["coverage of post sampled every 5.30 mm, not 1.00: a large part (at most 1,000,000 samples of a wall, 200,000 of a mesh)"]);
    const plain = render(<ProblemsPanel problems={[]} onPick={() => {}} onClose={() => {}} preflight={report} />);
    expect(plain.querySelectorAll("[data-testid=pf-coarse]").length).toBe(0);
  });
});
