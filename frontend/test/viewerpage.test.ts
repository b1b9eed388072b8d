import { describe, expect, it } from "vitest";
import { viewerPage, viewerUrl } from "../src/api/client";
import type { Health } from "../src/api/types";

const health = (over: Partial<Health>): Health => ({ status: "ok", version: "x", viewer_url: null, viewer_port: null, workers: 1, auth_required: false, ...over }) as Health;
const loc = { protocol: "http:", host: "cam.local:8000" };

describe("the 3D view's page (#25 fault 11: cached like the hashed assets)", () => {
  it("loads viser's page from this origin's hashed URL, told where viser's websocket is", () => {
    const h = health({ viewer_port: 8081, viewer_page: "/viewer-client/0123456789abcdef/index.html" });
    const src = viewerPage(h, "http://cam.local:8081", loc);
    expect(src).toBe("/viewer-client/0123456789abcdef/index.html?embedded&websocket=ws%3A%2F%2Fcam.local%3A8081");
  });
  it("behind tokens the websocket is this origin's /viewer relay (wss under https)", () => {
    const h = health({ viewer_url: "/viewer/", viewer_page: "/viewer-client/0123456789abcdef/index.html", auth_required: true });
    const src = viewerPage(h, "/viewer/", { protocol: "https:", host: "cam.example" });
    expect(decodeURIComponent(src.split("websocket=")[1])).toBe("wss://cam.example/viewer");
  });
  it("a server without the hashed page: viser's own page, as before", () => {
    expect(viewerPage(health({ viewer_port: 8081 }), "http://cam.local:8081", loc)).toBe("http://cam.local:8081/?embedded");
  });
  it("the 3D view is always this origin's /viewer/ proxy, never viser's own port (#26)", () => {
    expect(viewerUrl(health({ viewer_url: "/viewer/" }))).toBe("/viewer/");
    expect(viewerUrl(health({ viewer_url: "/viewer/", viewer_port: 8081 }))).toBe("/viewer/");
    expect(viewerUrl(health({}))).toBeNull();
  });
});
