// @vitest-environment jsdom
import { act } from "react";
import { createRoot } from "react-dom/client";
import { describe, expect, it } from "vitest";
import type { JSONSchema } from "../src/api/types";
import { ParamForm } from "../src/forms/ParamForm";

(globalThis as { IS_REACT_ACT_ENVIRONMENT?: boolean }).IS_REACT_ACT_ENVIRONMENT = true;

// as the catalog serves simulate-robot's params (titles and shipped names from the backend)
const schema = {
  type: "object",
  properties: {
    cell: { type: "string", default: "", title: "Robot cell", "x-shipped": "cells", examples: ["irb4600_tilt_rotate", "kr150_tilt", "kr150_tilt_rotate"] },
    robot_profile: { type: "string", default: "kuka_kr100ha_krc2", title: "Robot profile", "x-shipped": "robots", examples: ["abb_irb4600_irc5", "kuka_kr100ha_krc2"] },
    ik_step_mm: { type: "number", default: 5, title: "IK sample spacing", unit: "mm" },
  },
} as unknown as JSONSchema;

function render(params: Record<string, unknown>, onChange: (p: Record<string, unknown>) => void) {
  const host = document.createElement("div");
  document.body.appendChild(host);
  act(() => createRoot(host).render(<ParamForm schema={schema} params={params} onChange={onChange} onUpload={async (f) => f.name} />));
  return host;
}

describe("pickers for shipped cells and robots, labels from schema titles", () => {
  it("the cell is a picker of the shipped cells (plus a custom file)", () => {
    let got: Record<string, unknown> = {};
    const host = render({}, (p) => (got = p));
    const sel = host.querySelector<HTMLSelectElement>('[data-field="cell"] select')!;
    expect(sel).not.toBeNull();
    expect([...sel.options].map((o) => o.textContent)).toEqual(["— none —", "irb4600_tilt_rotate", "kr150_tilt", "kr150_tilt_rotate", "other…"]);
    act(() => {
      sel.value = "kr150_tilt";
      sel.dispatchEvent(new Event("change", { bubbles: true }));
    });
    expect(got).toEqual({ cell: "kr150_tilt" });
  });
  it("a value that is not shipped shows as 'other' with its text", () => {
    const host = render({ cell: "cells/my_cell.json" }, () => {});
    expect(host.querySelector<HTMLSelectElement>('[data-field="cell"] select')!.selectedOptions[0].textContent).toBe("other…");
    expect(host.querySelector<HTMLInputElement>('[data-field="cell"] input[type=text]')!.value).toBe("cells/my_cell.json");
  });
  it("the robot profile picker names its default; labels are the schema titles", () => {
    const host = render({}, () => {});
    const sel = host.querySelector<HTMLSelectElement>('[data-field="robot_profile"] select')!;
    expect(sel.options[0].textContent).toBe("default (kuka_kr100ha_krc2)");
    expect(host.querySelector('[data-field="ik_step_mm"] label')!.textContent).toBe("IK sample spacing [mm]");
  });
});
