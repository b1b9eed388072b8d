// @vitest-environment jsdom
// DOMParser/XMLSerializer come from jsdom here, from the browser in the app.
import { describe, expect, it } from "vitest";
import type { ProcessParameter } from "../src/api/types";
import {
  boundsByName, bulkSet, invalidEntries, orphans, parseParams, rangeText, serializeParams, setValue, validateValue, vocabulary,
} from "../src/xml/params";

/** As GET /api/process-parameters answers (core/process.py). */
const TABLE: ProcessParameter[] = [
  { name: "current", unit: "A", label: "Current", minimum: 0, maximum: 1000, description: "Welding current." },
  { name: "travel_speed", unit: "mm/s", label: "Travel speed", minimum: 0.1, maximum: 500, description: "Torch travel speed." },
];

const layer = (i: number, sections: string[]) => `<layer index="${i}" z="${(i + 1) * 1.5}">${sections
  .map((s) => `<section id="${s}">${["start", "z1", "end"].map((z) => `<zone id="${z}" color="#${z === "z1" ? "00ff00" : "ff0000"}"><current unit="A">${i === 0 && z === "start" ? "200" : ""}</current><travel_speed unit="mm/s"/></zone>`).join("")}</section>`)
  .join("")}</layer>`;
const xml = `<?xml version="1.0" encoding="utf-8"?><parameters version="1">${layer(0, ["bs1/A", "bs1/B"])}${layer(1, ["bs1/A", "bs1/B"])}${layer(2, ["bs1/A"])}</parameters>`;

describe("zone parameter XML", () => {
  const doc = parseParams(xml);
  it("parses the layer > section > zone tree", () => {
    expect(doc.layers.map((l) => l.sections.length)).toEqual([2, 2, 1]);
    expect(doc.layers[0].sections[0].zones.map((z) => z.id)).toEqual(["start", "z1", "end"]);
    expect(doc.layers[0].sections[0].zones[0].params).toEqual([{ name: "current", unit: "A", value: "200" }, { name: "travel_speed", unit: "mm/s", value: "" }]);
    expect(vocabulary(doc).params).toEqual([{ name: "current", unit: "A" }, { name: "travel_speed", unit: "mm/s" }]);
  });
  it("rejects malformed XML and a wrong root", () => {
    expect(() => parseParams("<parameters><layer>")).toThrow(/well-formed/);
    expect(() => parseParams("<params/>")).toThrow(/root element/);
  });
  it("bulk-edits a section across a layer range, or a zone id everywhere", () => {
    const a = bulkSet(doc, { layers: [1, 2], section: "bs1/A" }, "travel_speed", "6");
    expect(a.count).toBe(6);
    const b = bulkSet(doc, { zone: "z1" }, "current", "180");
    expect(b.count).toBe(5);
  });
  it("round-trips values and keeps unknown attributes", () => {
    const edited = setValue(doc, 2, "bs1/A", "end", "current", "150");
    const text = serializeParams(xml, edited);
    expect(text).toContain('version="1"');
    const back = parseParams(text);
    expect(back.layers[2].sections[0].zones[2].params[0].value).toBe("150");
    expect(back.layers[0].sections[0].zones[0].params[0].value).toBe("200");
  });
  it("validates numbers against bounds", () => {
    expect(validateValue("", { minimum: 0, maximum: 1000 })).toBeNull();
    expect(validateValue("abc")).toBe("not a number");
    expect(validateValue("1200", { minimum: 0, maximum: 1000, unit: "A" })).toBe("outside 0…1000 A");
    const bad = setValue(doc, 1, "bs1/B", "z1", "current", "-5");
    expect(invalidEntries(bad, { current: { minimum: 0, maximum: 1000 } })).toEqual([
      { layer: 1, section: "bs1/B", zone: "z1", name: "current", message: "outside 0…1000" },
    ]);
  });
  it("validates against the server's parameter table: bounds with the unit, and the file's unit", () => {
    const b = boundsByName(TABLE);
    expect(rangeText(b.travel_speed)).toBe("0.1…500 mm/s");
    expect(validateValue("0.1", b.travel_speed, "mm/s")).toBeNull();
    expect(validateValue("500", b.travel_speed, "mm/s")).toBeNull();
    expect(validateValue("0.05", b.travel_speed, "mm/s")).toBe("outside 0.1…500 mm/s");
    expect(validateValue("1000.5", b.current, "A")).toBe("outside 0…1000 A");
    expect(validateValue(" 12 ", b.current)).toBeNull();
    expect(validateValue("", b.current, "A")).toBeNull();
    expect(validateValue("Infinity", b.current)).toBe("not a number");
    expect(validateValue("8", b.travel_speed, "mm/min")).toBe('unit is "mm/min", expected "mm/s"');
    let bad = setValue(doc, 0, "bs1/A", "z1", "travel_speed", "0");
    bad = setValue(bad, 2, "bs1/A", "end", "current", "1001");
    expect(invalidEntries(bad, b)).toEqual([
      { layer: 0, section: "bs1/A", zone: "z1", name: "travel_speed", message: "outside 0.1…500 mm/s" },
      { layer: 2, section: "bs1/A", zone: "end", name: "current", message: "outside 0…1000 A" },
    ]);
    expect(invalidEntries(doc, b)).toEqual([]);
    // A parameter the table does not know is left to the server.
    expect(invalidEntries(setValue(doc, 0, "bs1/A", "z1", "current", "5"), boundsByName([]))).toEqual([]);
  });
  it("reports filled values whose zone disappeared as orphans", () => {
    const saved = setValue(doc, 1, "bs1/B", "end", "current", "190");
    const current = parseParams(`<parameters>${layer(0, ["bs1/A", "bs1/B"])}${layer(1, ["bs1/A"])}</parameters>`);
    expect(orphans(saved, current).map((o) => [o.layer, o.section, o.zone, o.values[0].value])).toEqual([[1, "bs1/B", "end", "190"]]);
  });
});
