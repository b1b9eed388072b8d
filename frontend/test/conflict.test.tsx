// @vitest-environment jsdom
// Concurrent editing (#25 fault 4): a save sends the revision it loaded as If-Match; a 409 becomes
// the conflict dialog's state; "overwrite" saves again with their revision; nothing is silent.
import { act } from "react";
import { createRoot } from "react-dom/client";
import { beforeAll, beforeEach, describe, expect, it, vi } from "vitest";

(globalThis as { IS_REACT_ACT_ENVIRONMENT?: boolean }).IS_REACT_ACT_ENVIRONMENT = true;

type Sent = { method: string; url: string; ifMatch: string | null; body: string };
const sent: Sent[] = [];
let answers: Response[] = [];
const stub = vi.fn(async (input: RequestInfo | URL, init?: RequestInit) => {
  const req = input instanceof Request ? input : new Request(new URL(String(input), "http://localhost/"), init);
  sent.push({ method: req.method, url: new URL(req.url).pathname, ifMatch: req.headers.get("If-Match"), body: await req.clone().text() });
  return answers.shift() ?? new Response("{}", { status: 500 });
});
const json = (body: unknown, status = 200, etag?: string) =>
  new Response(JSON.stringify(body), { status, headers: { "Content-Type": "application/json", ...(etag ? { ETag: etag } : {}) } });

let API: typeof import("../src/api/client");
let CD: typeof import("../src/components/ConflictDialog");
const recipe = (description: string) =>
  ({ format: "waamflow/1", name: "shared", description, inputs: {}, nodes: [], edges: [] }) as never;

beforeAll(async () => {
  // openapi-fetch builds a Request from the relative "/api/..." URL: resolve it as a page would
  const Base = globalThis.Request;
  globalThis.Request = class extends Base {
    constructor(input: RequestInfo | URL, init?: RequestInit) {
      super(typeof input === "string" ? new URL(input, "http://localhost/") : input, init);
    }
  } as typeof Request;
  globalThis.fetch = stub as unknown as typeof fetch;
  window.fetch = stub as unknown as typeof fetch;
  API = await import("../src/api/client");
  CD = await import("../src/components/ConflictDialog");
});
beforeEach(() => {
  sent.length = 0;
  answers = [];
});

describe("save with the loaded revision", () => {
  it("sends If-Match, turns a stale save into the dialog's state, and overwrite sends their revision", async () => {
    answers.push(json(recipe("mine"), 200, '"1"'));
    await API.getGraph("shared");
    expect(API.loadedRevision("recipe", "shared")).toBe('"1"');

    const conflictBody = {
      detail: { kind: "conflict", message: "Someone saved this recipe since you opened it", text: "x", node: null, layer: null,
        section: null, field: null, yours: recipe("mine"), theirs: { revision: 2, recipe: recipe("theirs") } },
    };
    answers.push(json(conflictBody, 409, '"2"'));
    const err = await API.putGraph("shared", recipe("mine")).catch((e: unknown) => e);
    expect(sent.at(-1)).toMatchObject({ method: "PUT", url: "/api/graphs/shared", ifMatch: '"1"' });
    expect(err).toBeInstanceOf(API.ConflictError);
    const c = CD.conflictOf(err)!;
    expect(c).toEqual({ kind: "recipe", name: "shared", theirsRevision: 2, message: "Someone saved this recipe since you opened it" });
    // a 409 is never remembered as loaded: the next plain save would still be refused
    expect(API.loadedRevision("recipe", "shared")).toBe('"1"');

    // overwrite: save again on their revision; the saved revision is remembered
    CD.overwriteWith(c);
    answers.push(json({ name: "shared", created: false, problems: [], revision: 3 }, 200, '"3"'));
    const res = await API.putGraph("shared", recipe("mine"));
    expect(sent.at(-1)!.ifMatch).toBe('"2"');
    expect(JSON.parse(sent.at(-1)!.body).description).toBe("mine");
    expect(res.revision).toBe(3);
    expect(API.loadedRevision("recipe", "shared")).toBe('"3"');
  });

  it("the parameter XML has its own revision", async () => {
    answers.push(new Response("<parameters/>", { status: 200, headers: { ETag: '"4"' } }));
    expect(await API.getParams("shared")).toBe("<parameters/>");
    const body = { detail: { kind: "conflict", message: "m", text: "m", node: null, layer: null, section: null, field: null,
      yours: "<parameters><!-- B --></parameters>", theirs: { revision: 5, xml: "<parameters><!-- A --></parameters>" } } };
    answers.push(json(body, 409, '"5"'));
    const err = await API.putParams("shared", "<parameters><!-- B --></parameters>").catch((e: unknown) => e);
    expect(sent.at(-1)).toMatchObject({ method: "PUT", url: "/api/graphs/shared/params", ifMatch: '"4"' });
    expect(CD.conflictOf(err)).toMatchObject({ kind: "params", theirsRevision: 5 });
    CD.overwriteWith(CD.conflictOf(err)!);
    answers.push(new Response(null, { status: 204, headers: { ETag: '"6"' } }));
    await API.putParams("shared", "<parameters><!-- B --></parameters>");
    expect(sent.at(-1)!.ifMatch).toBe('"5"');
    expect(API.loadedRevision("params", "shared")).toBe('"6"');
  });

  it("a graph never loaded saves without If-Match; other errors are no conflict", async () => {
    answers.push(json({ name: "fresh", created: true, problems: [], revision: 1 }, 201, '"1"'));
    await API.putGraph("fresh", recipe("new"));
    expect(sent.at(-1)!.ifMatch).toBeNull();
    expect(API.loadedRevision("recipe", "fresh")).toBe('"1"');
    answers.push(json({ detail: { kind: "conflict", message: "'example' is a shipped example and read-only" } }, 409));
    const err = await API.putGraph("example", recipe("x")).catch((e: unknown) => e);
    expect(err).toBeInstanceOf(API.ApiError);
    expect(CD.conflictOf(err)).toBeNull();
  });
});

describe("conflict dialog", () => {
  it("says what happened and offers reload / overwrite / save as", async () => {
    const host = document.createElement("div");
    document.body.appendChild(host);
    const calls: string[] = [];
    const c = { kind: "recipe" as const, name: "shared", theirsRevision: 2, message: "m" };
    const root = createRoot(host);
    await act(async () => root.render(
      <CD.ConflictDialog conflict={c} onReload={() => calls.push("reload")} onOverwrite={() => calls.push("overwrite")}
        onSaveAs={() => calls.push("saveas")} onCancel={() => calls.push("cancel")} />,
    ));
    expect(host.querySelector("h2")!.textContent).toBe("Someone saved this recipe since you opened it");
    expect(host.querySelector("[role=dialog]")!.getAttribute("aria-modal")).toBe("true");
    const buttons = [...host.querySelectorAll("button")];
    expect(buttons.map((b) => b.textContent)).toEqual(["Reload theirs (discard mine)", "Overwrite with mine", "Save mine as…", "Cancel"]);
    for (const b of buttons) await act(async () => b.click());
    expect(calls).toEqual(["reload", "overwrite", "saveas", "cancel"]);
    await act(async () => root.unmount());
  });
});
