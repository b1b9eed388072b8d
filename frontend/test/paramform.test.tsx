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

describe("ParamForm for nested models (strategy and zone shapes)", () => {
  const pt = { type: "array", minItems: 2, maxItems: 2, prefixItems: [{ type: "number" }, { type: "number" }] } as JSONSchema;
  const strategy: JSONSchema = {
    type: "object",
    $defs: {
      SectionStrategy: { title: "SectionStrategy", type: "object", properties: { pattern: { enum: ["oscillate", "spiral"], type: "string", default: "oscillate", title: "Pattern" }, speed: { type: "number", exclusiveMinimum: 0, maximum: 500, unit: "mm/s", default: 10, title: "Speed" } } },
      Over: { title: "SectionStrategyOverride", type: "object", properties: { pattern: { anyOf: [{ type: "string" }, { type: "null" }], default: null, title: "Pattern" }, speed: { anyOf: [{ type: "number" }, { type: "null" }], default: null, title: "Speed" }, split_points: { type: "array", items: pt, title: "Split Points" } } },
    },
    properties: {
      default: { $ref: "#/$defs/SectionStrategy", description: "Spec for every section" },
      sections: { type: "object", additionalProperties: { $ref: "#/$defs/Over" }, title: "Sections" },
    },
  };
  function renderS(params: Record<string, unknown>, onChange: (p: Record<string, unknown>) => void) {
    host = document.createElement("div");
    document.body.append(host);
    const root = createRoot(host);
    act(() => root.render(<ParamForm schema={strategy} params={params} onChange={onChange} idPrefix="st" />));
    return host;
  }
  const type = (el: Element, v: string) => {
    const input = el as HTMLInputElement;
    const setter = Object.getOwnPropertyDescriptor(HTMLInputElement.prototype, "value")!.set!;
    act(() => {
      setter.call(input, v);
      input.dispatchEvent(new Event("input", { bubbles: true }));
    });
  };
  it("renders sub-forms and a section picker, no JSON textarea, no class names", () => {
    const el = renderS({ sections: { "bs1/A": { speed: 6 } } }, () => {});
    expect(el.querySelectorAll("textarea")).toHaveLength(0);
    expect(el.textContent).not.toMatch(/SectionStrategy/);
    expect([...el.querySelectorAll("legend")].map((l) => l.textContent?.replace(/JSON$/, ""))).toEqual(["Default", "Sections", "Split Points"]);
    const picker = el.querySelector("#st-sections-key") as HTMLSelectElement;
    expect([...picker.options].map((o) => o.value)).toEqual(["bs1/A"]);
    // the override's pattern became a select with the default's enum
    expect(el.querySelectorAll('.map-value [data-field="pattern"] option')).toHaveLength(3);
    expect((el.querySelector('.map-value [data-field="speed"] input') as HTMLInputElement).value).toBe("6");
  });
  it("edits a section's value and its point table", () => {
    const seen: Record<string, unknown>[] = [];
    const el = renderS({ sections: { "bs1/A": { speed: 6, split_points: [[1, 2]] } } }, (p) => seen.push(p));
    type(el.querySelector('.map-value [data-field="speed"] input')!, "7.5");
    expect(seen.at(-1)).toEqual({ sections: { "bs1/A": { speed: 7.5, split_points: [[1, 2]] } } });
    type(el.querySelector('[aria-label="Split Points point 1 y"]')!, "4");
    expect(seen.at(-1)).toEqual({ sections: { "bs1/A": { speed: 6, split_points: [[1, 4]] } } });
    act(() => (el.querySelector('[aria-label="add a point to Split Points"]') as HTMLButtonElement).click());
    expect(seen.at(-1)).toEqual({ sections: { "bs1/A": { speed: 6, split_points: [[1, 2], [1, 2]] } } });
    type(el.querySelector("#st-default-speed")!, "12");
    expect(seen.at(-1)).toEqual({ default: { speed: 12 }, sections: { "bs1/A": { speed: 6, split_points: [[1, 2]] } } });
  });
});
