// @vitest-environment jsdom
import { act } from "react";
import { createRoot } from "react-dom/client";
import { afterEach, describe, expect, it } from "vitest";
import type { JSONSchema } from "../src/api/types";
import { ParamForm } from "../src/forms/ParamForm";

(globalThis as { IS_REACT_ACT_ENVIRONMENT?: boolean }).IS_REACT_ACT_ENVIRONMENT = true;

const schema: JSONSchema = {
  type: "object",
  properties: {
    layer_height: { type: "number", exclusiveMinimum: 0, maximum: 50, default: 1.5, unit: "mm", title: "Layer Height" },
    pattern: { enum: ["raster", "spiral"], type: "string", default: "raster", title: "Pattern" },
    path: { type: "string", "x-file": true, title: "Path" },
  },
  required: ["path"],
};

let host: HTMLDivElement;
afterEach(() => host?.remove());

function render(params: Record<string, unknown>, onChange: (p: Record<string, unknown>) => void = () => {}) {
  host = document.createElement("div");
  document.body.append(host);
  const root = createRoot(host);
  act(() => root.render(<ParamForm schema={schema} params={params} onChange={onChange} onUpload={async (f) => f.name} />));
  return host;
}

describe("ParamForm", () => {
  it("renders one row per field with units, bounds and the default as placeholder", () => {
    const el = render({ path: "a.stl" });
    expect([...el.querySelectorAll(".field > label")].map((l) => l.textContent)).toEqual(["Layer Height [mm]", "Pattern", "Path"]);
    expect(el.querySelector('[data-field="layer_height"] .hint')?.textContent).toBe("0 < x ≤ 50 mm");
    expect((el.querySelector('[data-field="layer_height"] input') as HTMLInputElement).placeholder).toBe("1.5");
    expect(el.querySelectorAll('[data-field="pattern"] option')).toHaveLength(3);
    expect(el.querySelector('[data-field="path"] input[type=file]')).not.toBeNull();
  });
  it("shows a bound violation and a missing required value inline", () => {
    const el = render({ layer_height: 60 });
    expect(el.querySelector('[data-field="layer_height"] .error')?.textContent).toBe("must be ≤ 50 mm");
    expect(el.querySelector('[data-field="path"] .error')?.textContent).toBe("required");
  });
  it("writes typed numbers and input references, and drops cleared fields", () => {
    const seen: Record<string, unknown>[] = [];
    const el = render({ path: "a.stl", layer_height: 2 }, (p) => seen.push(p));
    const input = el.querySelector('[data-field="layer_height"] input') as HTMLInputElement;
    const type = (v: string) => {
      const setter = Object.getOwnPropertyDescriptor(HTMLInputElement.prototype, "value")!.set!;
      act(() => {
        setter.call(input, v);
        input.dispatchEvent(new Event("input", { bubbles: true }));
      });
    };
    type("2.5");
    type("$h");
    type("");
    expect(seen).toEqual([{ path: "a.stl", layer_height: 2.5 }, { path: "a.stl", layer_height: "$h" }, { path: "a.stl" }]);
  });
});
