// @vitest-environment jsdom
// The parameter editor checks values against GET /api/process-parameters in the browser: the
// error (with the unit) shows in the cell as it is typed, and saving sends nothing while one is invalid.
// The editor edits a draft held by its host (the App); the host's save checks with saveBlocker.
import { act, useState } from "react";
import { createRoot } from "react-dom/client";
import { afterEach, describe, expect, it, vi } from "vitest";
import type { ProcessParameter } from "../src/api/types";
import { ParamsEditor } from "../src/xml/ParamsEditor";
import { boundsByName, saveBlocker } from "../src/xml/params";

(globalThis as { IS_REACT_ACT_ENVIRONMENT?: boolean }).IS_REACT_ACT_ENVIRONMENT = true;

const TABLE: ProcessParameter[] = [
  { name: "current", unit: "A", label: "Current", minimum: 0, maximum: 1000, description: "Welding current." },
  { name: "travel_speed", unit: "mm/s", label: "Travel speed", minimum: 0.1, maximum: 500, description: "Torch travel speed." },
];
const XML = `<?xml version="1.0" encoding="utf-8"?><parameters version="1"><layer index="0" z="1.5"><section id="bs1/A">${["start", "end"]
  .map((z) => `<zone id="${z}" color="#ff0000"><current unit="A">200</current><travel_speed unit="mm/s"/></zone>`)
  .join("")}</section></layer></parameters>`;

let host: HTMLDivElement;
afterEach(() => {
  host?.remove();
  vi.unstubAllGlobals();
});

/** The App's part: holds saved text and draft, saves both through the API (fetch stubbed). */
function Host() {
  const [saved, setSaved] = useState(XML);
  const [draft, setDraft] = useState<string | null>(null);
  const [error, setError] = useState<{ message: string } | null>(null);
  const save = async () => {
    const text = draft ?? saved;
    const blocked = saveBlocker(text, boundsByName(TABLE));
    if (blocked) return setError({ message: blocked });
    await fetch("/api/graphs/g/params", { method: "PUT", body: text });
    setSaved(text);
    setDraft(null);
    setError(null);
  };
  return (
    <ParamsEditor
      graph="g" text={draft ?? saved} unsaved={draft !== null && draft !== saved} loadError={null} serverError={error}
      onChange={setDraft} onSave={() => void save()} onDiscard={() => setDraft(null)}
      runId={null} runParamsArtifacts={[]} runWarnings={[]} parameters={TABLE} dirtyRecipe={false} onMessage={() => {}}
    />
  );
}

async function render() {
  const calls: { method: string; url: string }[] = [];
  vi.stubGlobal("fetch", async (url: string, init?: RequestInit) => {
    calls.push({ method: init?.method ?? "GET", url });
    return new Response(init?.method === "PUT" ? null : XML, { status: init?.method === "PUT" ? 204 : 200 });
  });
  host = document.createElement("div");
  document.body.append(host);
  const root = createRoot(host);
  await act(async () => root.render(<Host />));
  await act(async () => {
    await new Promise((r) => setTimeout(r, 0));
  });
  return { el: host, calls };
}

function type(input: HTMLInputElement, v: string) {
  const setter = Object.getOwnPropertyDescriptor(HTMLInputElement.prototype, "value")!.set!;
  act(() => {
    setter.call(input, v);
    input.dispatchEvent(new Event("input", { bubbles: true }));
  });
}

describe("ParamsEditor bounds", () => {
  it("labels rows from the server's table with unit and range", async () => {
    const { el } = await render();
    const rows = [...el.querySelectorAll("[data-testid=zone-table] tbody tr td:first-child")].map((td) => td.textContent);
    expect(rows).toEqual(["Current [A]0…1000 A", "Travel speed [mm/s]0.1…500 mm/s"]);
  });
  it("marks an out-of-range value inline, with its unit, and the save sends nothing", async () => {
    const { el, calls } = await render();
    const cell = el.querySelector('[data-cell="start.current"]') as HTMLInputElement;
    type(cell, "5000");
    expect(el.querySelector('[data-cell-error="start.current"]')?.textContent).toBe("outside 0…1000 A");
    expect(cell.closest("td")?.dataset.err).toBe("1");
    expect(el.querySelector("[data-testid=params-unsaved]")).not.toBeNull();
    await act(async () => (el.querySelector("[data-testid=params-save]") as HTMLButtonElement).click());
    expect(el.querySelector("[data-testid=params-error]")?.textContent).toMatch(/not saved: 1 invalid value\(s\), e\.g\. layer 0 · bs1\/A · start · current: outside 0…1000 A/);
    // Only the invalid cell is marked.
    expect([...el.querySelectorAll("td[data-err] input")].map((i) => i.getAttribute("data-cell"))).toEqual(["start.current"]);
    expect(calls.filter((c) => c.method === "PUT")).toEqual([]);
    type(el.querySelector('[data-cell="end.travel_speed"]') as HTMLInputElement, "0.05");
    expect(el.querySelector('[data-cell-error="end.travel_speed"]')?.textContent).toBe("outside 0.1…500 mm/s");
  });
  it("saves once every value is within bounds", async () => {
    const { el, calls } = await render();
    type(el.querySelector('[data-cell="start.current"]') as HTMLInputElement, "1000");
    type(el.querySelector('[data-cell="end.travel_speed"]') as HTMLInputElement, "0.1");
    expect(el.querySelector("[data-cell-error]")).toBeNull();
    await act(async () => (el.querySelector("[data-testid=params-save]") as HTMLButtonElement).click());
    expect(calls.filter((c) => c.method === "PUT").map((c) => c.url)).toEqual(["/api/graphs/g/params"]);
    expect(el.querySelector("[data-testid=params-saved]")).not.toBeNull();
  });
});
