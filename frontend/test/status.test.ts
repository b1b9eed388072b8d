import { describe, expect, it } from "vitest";
import type { RunEvent } from "../src/api/types";
import { badgeText, computeText, reduceEvent, startedRun } from "../src/run/status";

const ev = (seq: number, kind: RunEvent["kind"], extra: Partial<RunEvent> = {}): RunEvent => ({ seq, kind, time: seq, progress: 0, ...extra });

describe("run events → badges", () => {
  it("follows nodes through cached, running and done, with monotone progress", () => {
    let s = startedRun("r1");
    for (const e of [
      ev(1, "run_started"),
      ev(2, "node_cached", { node: "part", progress: 0.2 }),
      ev(3, "node_started", { node: "slice", progress: 0.2 }),
      ev(4, "node_progress", { node: "slice", layer: 3, progress: 0.5 }),
      ev(5, "node_progress", { node: "slice", layer: 4, progress: 0.4 }),
    ])
      s = reduceEvent(s, e);
    expect(s.nodes.part.state).toBe("cached");
    expect(badgeText(s.nodes.slice)).toBe("layer 4");
    expect(s.progress).toBe(0.5);
    s = reduceEvent(s, ev(6, "node_finished", { node: "slice", seconds: 0.25 }));
    s = reduceEvent(s, ev(7, "run_finished", { progress: 1 }));
    expect(badgeText(s.nodes.slice)).toBe("done 250 ms");
    expect(computeText(s.nodes.slice)).toBeNull(); // a whole-part node: its wall time is its cost
    expect(s.phase).toBe("done");
  });
  it("says where a chained layer node's time went", () => {
    let s = startedRun("r3");
    s = reduceEvent(s, ev(1, "node_finished", { node: "mask", seconds: 1.787, compute_seconds: 0.182 }));
    s = reduceEvent(s, ev(2, "node_finished", { node: "strategy", seconds: 0.006, compute_seconds: 1.407 }));
    expect(badgeText(s.nodes.mask)).toBe("done 1.8 s");
    expect(computeText(s.nodes.mask)).toBe("layers computed in 182 ms (all processes); 1.8 s of the run");
    expect(computeText(s.nodes.strategy)).toBe("layers computed in 1.4 s (all processes); 6 ms of the run");
  });
  it("keeps the failing node's layer and section and ignores replayed events", () => {
    let s = startedRun("r2");
    s = reduceEvent(s, ev(1, "node_error", { node: "mask", error: { message: "2 regions", node: "mask", layer: 24, section: "bs1/A" } }));
    s = reduceEvent(s, ev(2, "run_failed"));
    expect(badgeText(s.nodes.mask)).toBe("error · layer 24 · bs1/A");
    expect(s.error).toMatchObject({ node: "mask", layer: 24, section: "bs1/A" });
    expect(s.phase).toBe("failed");
    expect(reduceEvent(s, ev(1, "node_started", { node: "mask" }))).toBe(s);
  });
});
