import { describe, expect, it } from "vitest";
import type { Recipe } from "../src/api/types";
import { change, freeName, isDirty, newDocument, pinStored, runRequest, savedOf, sha256Hex, withPin, withRecipe, withXml, xmlDirty } from "../src/document/document";
import { emptyRecipe, redo, removeNodes, undo } from "../src/graph/recipe";

const recipe: Recipe = {
  ...emptyRecipe("copy"),
  nodes: [
    { id: "mask", type: "mask", params: { masks: [{ id: "bs1", from_layer: 0, sections: [{ id: "A" }, { id: "C" }] }] } },
    { id: "zone", type: "zone", params: {} },
  ],
  edges: [{ from: "mask.sections", to: "zone.sections" }],
  ui: { positions: { mask: [0, 0], zone: [200, 0] } },
} as unknown as Recipe;
// user's own XML: comments and formatting must survive
const XML = `<!-- my notes -->\n<params>\n  <section id="bs1/C"><zone name="start"><travel_speed unit="mm/s">6</travel_speed></zone></section>\n</params>\n`;
const withoutC = XML.replace(/ {2}<section id="bs1\/C">.*\n/, "");

describe("document: recipe and parameter XML in one history", () => {
  it("undo restores the XML together with the recipe (delete section, undo → both as saved)", () => {
    let h = newDocument(recipe, XML);
    const saved = savedOf(h.present);
    // deleting a section changes the recipe and drops its XML values in one step
    h = change(h, { recipe: removeNodes(recipe, new Set(["zone"])), xml: withoutC });
    expect(isDirty(h.present, saved)).toBe(true);
    h = undo(h);
    expect(h.present.recipe).toEqual(recipe);
    expect(h.present.xml).toBe(XML);
    expect(isDirty(h.present, saved)).toBe(false);
    h = redo(h);
    expect(h.present.xml).toBe(withoutC);
  });

  it("an XML edit is its own undo step; typing folds into one", () => {
    let h = newDocument(recipe, XML);
    h = change(h, withXml(h.present, XML.replace(">6<", ">3<")));
    h = change(h, withXml(h.present, XML.replace(">6<", ">35<")), true);
    expect(h.past).toHaveLength(1);
    h = change(h, withRecipe(h.present, { ...recipe, description: "d" }));
    h = undo(h);
    expect(h.present.xml).toBe(XML.replace(">6<", ">35<"));
    expect(h.present.recipe).toBe(recipe);
    h = undo(h);
    expect(h.present.xml).toBe(XML);
  });

  it("the run request is exactly what is on screen: recipe + XML draft, saved or not", () => {
    const h = change(newDocument(recipe, XML), withXml(newDocument(recipe, XML).present, XML.replace(">6<", ">3<")));
    const req = runRequest(h.present, "copy");
    expect(req).toEqual({ graph: "copy", recipe: { ...recipe, ui: undefined }, accept_preflight: false, params_xml: XML.replace(">6<", ">3<") });
    expect("ui" in req.recipe && req.recipe.ui !== undefined).toBe(false);
    // an unsaved recipe sends its draft XML too
    expect(runRequest(h.present, null).params_xml).toBe(XML.replace(">6<", ">3<"));
    // no XML of the user's own: none sent (the server uses the stored one or its template)
    expect("params_xml" in runRequest(newDocument(recipe, null).present, "copy")).toBe(false);
  });

  it("a run changes nothing: the document and its dirty state are the same before and after", () => {
    const h = newDocument(recipe, XML);
    const saved = savedOf(h.present);
    const before = JSON.stringify(h.present);
    runRequest(h.present, "copy");
    expect(JSON.stringify(h.present)).toBe(before);
    expect(isDirty(h.present, saved)).toBe(false);
    // a document without XML of its own is not dirty (the run's template is shown beside it)
    expect(xmlDirty(newDocument(recipe, null).present, savedOf(newDocument(recipe, null).present))).toBe(false);
  });
});

describe("uploads pinned by content (#25 fault 5)", () => {
  const base = { format: "waamflow/1", name: "u", description: "", inputs: {}, nodes: [], edges: [] } as Recipe;
  const A = "a".repeat(64), B = "b".repeat(64);
  it("a replace is one undo step; undo pins the old content, the document clean again", () => {
    const opened = pinStored(base, [{ name: "part.stl", sha256: A }, { name: "old.dxf", sha256: null }]);
    expect(opened.files).toEqual({ "part.stl": A });
    let h = newDocument(opened, null);
    const saved = savedOf(h.present);
    h = change(h, withPin(h.present, "part.stl", B));
    expect(h.present.recipe.files).toEqual({ "part.stl": B });
    expect(isDirty(h.present, saved)).toBe(true);
    expect(runRequest(h.present, "u").recipe.files).toEqual({ "part.stl": B });
    h = undo(h);
    expect(h.present.recipe.files).toEqual({ "part.stl": A });
    expect(isDirty(h.present, saved)).toBe(false);
    expect(withPin(h.present, "part.stl", A)).toBe(h.present); // same content: no change
  });
  it("keeps a pin the recipe has; keep-both names are free; sha256 as the server computes it", async () => {
    expect(pinStored({ ...base, files: { "part.stl": B } }, [{ name: "part.stl", sha256: A }]).files).toEqual({ "part.stl": B });
    expect(freeName("part.stl", ["part.stl", "part-2.stl"])).toBe("part-3.stl");
    expect(freeName("README", ["README"])).toBe("README-2");
    expect(await sha256Hex(new Blob(["abc"]))).toBe("ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad");
  });
});

describe("no empty undo steps", () => {
  it("an edit to the same document is no step", () => {
    const r = { format: "waamflow/1", name: "u", description: "", inputs: {}, nodes: [{ id: "a", type: "mesh", params: { path: "p.stl" } }], edges: [] } as Recipe;
    const h = newDocument(r, null);
    expect(change(h, withRecipe(h.present, structuredClone(r)))).toBe(h);
    expect(change(h, withRecipe(h.present, { ...r, description: "x" })).past).toHaveLength(1);
  });
});
