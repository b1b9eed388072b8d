// @vitest-environment jsdom
// The editor's small state hooks (#27: App.tsx split): messages, selection, view, URL place, catalog.
import { afterEach, describe, expect, it, vi } from "vitest";
import type { GraphInfo, Recipe } from "../src/api/types";
import { ApiError } from "../src/api/client";
import { asTab } from "../src/app/tabs";
import { isExampleGraph } from "../src/app/useCatalog";
import { failureText, MAX_MESSAGES, MESSAGE_MS, pushMessage, useMessages } from "../src/app/useMessages";
import { placeRequest, usePlace } from "../src/app/usePlace";
import { pruneSelection, singleSelected, useSelection } from "../src/app/useSelection";
import { togglePreview, useView } from "../src/app/useView";
import { emptyRecipe } from "../src/graph/recipe";
import { act, renderHook } from "./renderHook";

const recipe = (...ids: string[]): Recipe => ({ ...emptyRecipe("r"), nodes: ids.map((id) => ({ id, type: "t", params: {} })) });

describe("messages", () => {
  afterEach(() => vi.useRealTimers());
  it("keeps the last MAX_MESSAGES, oldest dropped", () => {
    let list = [] as ReturnType<typeof pushMessage>;
    for (let i = 0; i < 6; i++) list = pushMessage(list, { id: i, text: `m${i}` });
    expect(MAX_MESSAGES).toBe(4);
    expect(list.map((m) => m.text)).toEqual(["m2", "m3", "m4", "m5"]);
  });
  it("a toast goes after MESSAGE_MS; a failed request shows the server's message", () => {
    vi.useFakeTimers();
    const { result } = renderHook(() => useMessages(), undefined);
    act(() => result.current.message("saved r"));
    act(() => result.current.fail(new ApiError(409, { message: "someone saved since" })));
    act(() => result.current.fail(new Error("offline")));
    expect(result.current.messages.map((m) => m.text)).toEqual(["saved r", "someone saved since", "Error: offline"]);
    act(() => void vi.advanceTimersByTime(MESSAGE_MS - 1));
    expect(result.current.messages.length).toBe(3);
    act(() => void vi.advanceTimersByTime(1));
    expect(result.current.messages.length).toBe(0);
    expect(failureText("x")).toBe("x");
  });
});

describe("selection", () => {
  it("prunes ids the recipe no longer has, the same set when none go", () => {
    const sel = new Set(["a", "b"]);
    expect(pruneSelection(sel, recipe("a", "b", "c"))).toBe(sel);
    expect([...pruneSelection(sel, recipe("b"))]).toEqual(["b"]);
    expect(singleSelected(new Set(["b"]), recipe("a", "b"))?.id).toBe("b");
    expect(singleSelected(sel, recipe("a", "b"))).toBeNull();
  });
  it("the hook drops deleted nodes from the selection when the recipe changes", () => {
    const h = renderHook((r: Recipe) => useSelection(r), recipe("a", "b", "c"));
    act(() => h.result.current.select(["a", "c"]));
    expect(h.result.current.single).toBeNull();
    h.rerender(recipe("a", "b"));
    expect([...h.result.current.selected]).toEqual(["a"]);
    expect(h.result.current.single?.id).toBe("a");
  });
});

describe("view", () => {
  it("the preview toggle hides the node previewed, else previews the clicked one; clear resets layer and preview", () => {
    expect(togglePreview("a", "a")).toBeNull();
    expect(togglePreview("a", "b")).toBe("b");
    const { result } = renderHook(() => useView(), undefined);
    act(() => result.current.onPreview("n"));
    act(() => result.current.setLayer(7));
    expect([result.current.previewNode, result.current.layer]).toEqual(["n", 7]);
    act(() => result.current.clear());
    expect([result.current.previewNode, result.current.layer, result.current.tab]).toEqual([null, 0, "graph"]);
  });
  it("a tab from outside is one of the tabs, else the graph", () => {
    expect(asTab("mask")).toBe("mask");
    expect(asTab("nope")).toBe("graph");
    expect(asTab(null)).toBe("graph");
  });
});

describe("the URL names the open recipe and tab", () => {
  it("placeRequest: a recipe other than the one shown is opened; the tab defaults to the graph", () => {
    expect(placeRequest("?graph=a&tab=mask", "b")).toEqual({ open: "a", tab: "mask" });
    expect(placeRequest("?graph=a&tab=mask", "a")).toEqual({ open: null, tab: "mask" });
    expect(placeRequest("", "a")).toEqual({ open: null, tab: "graph" });
  });
  it("opens the recipe the URL names at start, pushes a history entry per change, follows back", async () => {
    window.history.replaceState(null, "", "/?graph=cross&tab=params");
    const open = vi.fn(async () => {});
    const setTab = vi.fn();
    const h = renderHook((p: { g: string | null; t: "graph" | "mask" }) => usePlace(p.g, p.t, setTab, open), { g: null, t: "graph" });
    expect(open).toHaveBeenCalledWith("cross", "params");
    await act(async () => {});
    h.rerender({ g: "cross", t: "mask" });
    expect(location.search).toBe("?graph=cross&tab=mask");
    const before = window.history.length;
    h.rerender({ g: "other", t: "graph" });
    expect(location.search).toBe("?graph=other");
    expect(window.history.length).toBe(before + 1);
    // back: the URL names "cross" again while "other" is shown: it is opened
    window.history.replaceState(null, "", "/?graph=cross&tab=mask");
    await act(async () => void window.dispatchEvent(new PopStateEvent("popstate")));
    expect(open).toHaveBeenLastCalledWith("cross", "mask");
    expect(setTab).toHaveBeenLastCalledWith("mask");
    h.unmount();
  });
});

describe("catalog", () => {
  it("a shipped example is read-only by name", () => {
    const graphs = [{ name: "cross", example: true }, { name: "mine", example: false }] as GraphInfo[];
    expect(isExampleGraph(graphs, "cross")).toBe(true);
    expect(isExampleGraph(graphs, "mine")).toBe(false);
    expect(isExampleGraph(graphs, null)).toBe(false);
  });
});
