// @vitest-environment jsdom
// The run view hook (#27: App.tsx split): a finished run's results, merged XML and preflight
// report appear together (trust fault 8 read the badge as "no preflight" beside the results).
import { beforeEach, describe, expect, it, vi } from "vitest";
import type { Artifact } from "../src/api/types";
import { emptyRecipe } from "../src/graph/recipe";
import { act, renderHook } from "./renderHook";

const deferred = <T,>() => {
  let resolve!: (v: T) => void;
  const promise = new Promise<T>((r) => (resolve = r));
  return { promise, resolve };
};
let preflightText = deferred<string | null>();
// what the run's record says, one answer per ask (the last one stays)
let statuses: string[] = ["done"];
const arts = [{ name: "preflight.json" }, { name: "zone.params.xml" }, { name: "post.gcode" }] as Artifact[];
vi.mock("../src/api/client", () => ({
  ApiError: class extends Error {},
  startRun: vi.fn(async () => ({ id: "r1" })),
  getRun: vi.fn(async () => ({ status: statuses.length > 1 ? statuses.shift() : statuses[0], error: null })),
  cancelRun: vi.fn(),
  runsOf: vi.fn(async () => []),
  eventsUrl: (id: string) => `/api/runs/${id}/events`,
  listArtifacts: vi.fn(async () => arts),
  artifactText: vi.fn(async (_id: string, name: string) => (name === "preflight.json" ? preflightText.promise : "<params/>")),
}));

class FakeEventSource {
  static last: FakeEventSource | null = null;
  static CLOSED = 2;
  readyState = 1;
  onmessage: ((m: { data: string }) => void) | null = null;
  onerror: (() => void) | null = null;
  constructor(public url: string) {
    FakeEventSource.last = this;
  }
  close() {
    this.readyState = 2;
  }
}
(globalThis as { EventSource?: unknown }).EventSource = FakeEventSource;

const { useRunView } = await import("../src/run/useRunView");
const { storedEnd, END_POLLS, STALL_POLL_MS } = await import("../src/run/useRun");
const client = await import("../src/api/client");

describe("useRunView", () => {
  beforeEach(() => {
    preflightText = deferred<string | null>();
    statuses = ["done"];
    vi.mocked(client.getRun).mockClear();
  });
  it("shows the end, the artifacts and the preflight report together; the end of the run is told once", async () => {
    const message = vi.fn();
    const { result } = renderHook(() => useRunView({ message, fail: vi.fn(), toMask: vi.fn() }), undefined);
    await act(async () => void (await result.current.start({ recipe: emptyRecipe("r"), xml: null }, "r")));
    expect(result.current.run).toMatchObject({ id: "r1", phase: "running" });
    expect(FakeEventSource.last?.url).toBe("/api/runs/r1/events");
    await act(async () => FakeEventSource.last!.onmessage!({ data: JSON.stringify({ seq: 1, kind: "run_finished", time: 1, progress: 1 }) }));
    // the artifacts are listed, the preflight report is still being read: nothing shown yet, the
    // end included (a "done" toolbar beside "no preflight" was the badge of no report)
    expect(result.current.run.phase).toBe("running");
    expect(result.current.artifacts).toEqual([]);
    expect(result.current.preflight).toBeNull();
    await act(async () => preflightText.resolve(JSON.stringify({ verdict: "ok", programs: [], layers: [], problems: [] })));
    expect(result.current.run.phase).toBe("done");
    expect(result.current.artifacts.length).toBe(3);
    expect(result.current.preflight?.verdict).toBe("ok");
    expect(result.current.runXml).toBe("<params/>");
    expect(message.mock.calls).toEqual([["run finished"]]);
  });
  it("clear forgets what the last run left", async () => {
    const { result } = renderHook(() => useRunView({ message: vi.fn(), fail: vi.fn(), toMask: vi.fn() }), undefined);
    await act(async () => void (await result.current.start({ recipe: emptyRecipe("r"), xml: null }, "r")));
    await act(async () => FakeEventSource.last!.onmessage!({ data: JSON.stringify({ seq: 1, kind: "run_finished", time: 1, progress: 1 }) }));
    await act(async () => preflightText.resolve(JSON.stringify({ verdict: "ok", programs: [], layers: [], problems: [] })));
    expect(result.current.artifacts.length).toBe(3);
    act(() => result.current.clear("other"));
    expect([result.current.artifacts, result.current.preflight, result.current.runXml, result.current.run.phase]).toEqual([[], null, null, "idle"]);
  });
});

describe("the end of a run is shown once the server has stored it", () => {
  beforeEach(() => {
    preflightText = deferred<string | null>();
    vi.mocked(client.getRun).mockClear();
  });
  it("storedEnd asks until the record has ended, at most END_POLLS times", async () => {
    statuses = ["running", "running", "done"];
    const waits: number[] = [];
    expect((await storedEnd("r1", async (ms) => void waits.push(ms))).status).toBe("done");
    expect(waits).toEqual([250, 250]);
    statuses = ["running"];
    vi.mocked(client.getRun).mockClear();
    expect((await storedEnd("r1", async () => {})).status).toBe("running");
    expect(vi.mocked(client.getRun).mock.calls.length).toBe(END_POLLS);
  });
  it("the stream's last event before the record: the run shows running until the record says done", async () => {
    statuses = ["running", "done"];
    const { result } = renderHook(() => useRunView({ message: vi.fn(), fail: vi.fn(), toMask: vi.fn() }), undefined);
    await act(async () => void (await result.current.start({ recipe: emptyRecipe("r"), xml: null }, "r")));
    await act(async () => FakeEventSource.last!.onmessage!({ data: JSON.stringify({ seq: 1, kind: "run_finished", time: 1, progress: 1 }) }));
    expect(result.current.run.phase).toBe("running");
    preflightText.resolve(JSON.stringify({ verdict: "ok", programs: [], layers: [], problems: [] }));
    await act(async () => void (await new Promise((r) => setTimeout(r, 400))));
    expect(result.current.run.phase).toBe("done");
    expect(result.current.artifacts.length).toBe(3);
  });
  it("a stream that stays open without its terminal event: the record's end is shown after STALL_POLL_MS", async () => {
    statuses = ["done"]; // the record has ended; the stream never says so
    const { result } = renderHook(() => useRunView({ message: vi.fn(), fail: vi.fn(), toMask: vi.fn() }), undefined);
    await act(async () => void (await result.current.start({ recipe: emptyRecipe("r"), xml: null }, "r")));
    await act(async () => FakeEventSource.last!.onmessage!({ data: JSON.stringify({ seq: 1, kind: "node_finished", node: "a", time: 1, progress: 1 }) }));
    expect(result.current.run.phase).toBe("running");
    preflightText.resolve(JSON.stringify({ verdict: "ok", programs: [], layers: [], problems: [] }));
    await act(async () => void (await new Promise((r) => setTimeout(r, STALL_POLL_MS - 500))));
    expect(result.current.run.phase).toBe("running"); // the first ask comes after STALL_POLL_MS
    await act(async () => void (await new Promise((r) => setTimeout(r, 1500))));
    expect(result.current.run.phase).toBe("done");
    expect(FakeEventSource.last!.readyState).toBe(2); // the stream is closed
  }, 10_000);
  it("a run followed meanwhile is not overwritten by the older run's late end", async () => {
    statuses = ["running", "done"];
    const { result } = renderHook(() => useRunView({ message: vi.fn(), fail: vi.fn(), toMask: vi.fn() }), undefined);
    await act(async () => void (await result.current.start({ recipe: emptyRecipe("r"), xml: null }, "r")));
    await act(async () => FakeEventSource.last!.onmessage!({ data: JSON.stringify({ seq: 1, kind: "run_finished", time: 1, progress: 1 }) }));
    act(() => result.current.clear("other"));
    await act(async () => void (await new Promise((r) => setTimeout(r, 400))));
    expect(result.current.run.phase).toBe("idle");
    expect(result.current.artifacts).toEqual([]);
  });
});
