import { describe, expect, it } from "vitest";
import { collectProblems, currentProblems, problemsByNode } from "../src/problems/problems";

describe("stale problems (#25 fault 11)", () => {
  const refused = collectProblems([], [{ message: "layer_height: must be > 0", node: "layers", layer: null, section: null, field: "layer_height" } as never]);
  it("keeps a refused run's problems while the document is the one it ran", () => {
    const shown = currentProblems(refused, { recipe: "R1", xml: null }, { recipe: "R1", xml: null });
    expect(shown).toHaveLength(1);
    expect(problemsByNode(shown).get("layers")?.errors).toBe(1);
  });
  it("drops them once the recipe or the XML changes, and shows them again after an undo back", () => {
    expect(currentProblems(refused, { recipe: "R1", xml: null }, { recipe: "R2", xml: null })).toHaveLength(0);
    expect(currentProblems(refused, { recipe: "R1", xml: "<a/>" }, { recipe: "R1", xml: "<b/>" })).toHaveLength(0);
    expect(currentProblems(refused, { recipe: "R1", xml: "<a/>" }, { recipe: "R1", xml: "<a/>" })).toHaveLength(1);
    expect(currentProblems(refused, null, { recipe: "R9", xml: null })).toHaveLength(1);
  });
});
