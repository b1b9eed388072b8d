// @vitest-environment jsdom
// The token hook: same-origin requests carry `Authorization: Bearer <token>` from sessionStorage,
// other origins never see it, and the first 401 asks for the token in a dialog.
import { act } from "react";
import { beforeAll, describe, expect, it, vi } from "vitest";

(globalThis as { IS_REACT_ACT_ENVIRONMENT?: boolean }).IS_REACT_ACT_ENVIRONMENT = true;

const seen: Request[] = [];
let status = 200;
const stub = vi.fn(async (req: Request) => {
  seen.push(req);
  return new Response("{}", { status, headers: status === 401 ? { "WWW-Authenticate": 'Bearer realm="waamflow"' } : {} });
});
let auth: typeof import("../src/api/auth");

beforeAll(async () => {
  window.fetch = stub as unknown as typeof fetch;
  auth = await import("../src/api/auth"); // wraps fetch on import
});

describe("bearer token hook", () => {
  it("sends no header without a token", async () => {
    await window.fetch("/api/graphs");
    expect(seen.at(-1)!.headers.get("Authorization")).toBeNull();
  });

  it("adds the session token to same-origin requests only", async () => {
    auth.setToken("lab-secret-0123456789");
    expect(sessionStorage.getItem("waamflow.token")).toBe("lab-secret-0123456789");
    expect(document.cookie).toContain("waamflow_token=lab-secret-0123456789");
    await window.fetch("/api/graphs", { method: "PUT", body: "{}" });
    expect(seen.at(-1)!.headers.get("Authorization")).toBe("Bearer lab-secret-0123456789");
    expect(seen.at(-1)!.method).toBe("PUT");
    await window.fetch("https://elsewhere.example/x");
    expect(stub.mock.calls.at(-1)![0]).toBe("https://elsewhere.example/x"); // passed through untouched
  });

  it("asks for the token on a 401", async () => {
    status = 401;
    await act(async () => {
      await window.fetch("/api/graphs");
    });
    const dialog = document.querySelector('[role="dialog"]');
    expect(dialog).not.toBeNull();
    expect(dialog!.textContent).toContain("not accepted"); // a token was set and refused
    expect(dialog!.querySelector('input[type="password"]')).not.toBeNull();
  });
});
