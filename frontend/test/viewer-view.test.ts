import { describe, expect, it } from "vitest";
import { VIEW_ID, withView } from "../src/viewer/api";

describe("withView: the 3D page's websocket names this tab's view", () => {
  it("adds the view to viser's own page", () => {
    expect(withView("http://127.0.0.1:8081/?embedded", "tab-1")).toBe("http://127.0.0.1:8081/?embedded&view=tab-1");
  });
  it("adds the view to the websocket of a cached page", () => {
    const src = withView(`/viewer-client/abc/index.html?embedded&websocket=${encodeURIComponent("ws://h:8000/viewer")}`, "tab-2");
    const q = new URLSearchParams(src.split("?")[1]);
    expect(q.get("websocket")).toBe("ws://h:8000/viewer/?view=tab-2");
    expect(q.get("view")).toBe("tab-2");
    expect(q.has("embedded")).toBe(true);
  });
  it("replaces a view already there", () => {
    const src = withView(withView(`/p?websocket=${encodeURIComponent("ws://h/x/")}`, "a"), "b");
    const q = new URLSearchParams(src.split("?")[1]);
    expect([q.get("websocket"), q.getAll("view")]).toEqual(["ws://h/x/?view=b", ["b"]]);
  });
  it("one id per page load, usable in a URL", () => {
    expect(VIEW_ID).toMatch(/^[A-Za-z0-9._-]{8,64}$/);
  });
});
