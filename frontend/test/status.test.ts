import { describe, expect, it } from "vitest";
import type { RunEvent } from "../src/api/types";
import { badgeText, reduceEvent, startedRun } from "../src/run/status";

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
    expect(s.phase).toBe("done");
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
