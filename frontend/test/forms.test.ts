import { describe, expect, it } from "vitest";
import type { JSONSchema } from "../src/api/types";
import { allProperties, boundsText, describeFields, enrichFromRoot, fieldKind, humanize, labelOf, vectorDims, findEnum, findProperty, inputField, schemaAt, parseNumberInput, validateField, validateParams } from "../src/forms/schema";

// The shape pydantic v2 emits for a node's Params model.
const schema: JSONSchema = {
  type: "object",
  additionalProperties: false,
  $defs: {
    Pattern: { enum: ["raster", "oscillate", "parallel"], type: "string", title: "Pattern" },
    SectionStrategy: { type: "object", properties: { pattern: { $ref: "#/$defs/Pattern" } } },
  },
  properties: {
    layer_height: { type: "number", exclusiveMinimum: 0, maximum: 50, default: 1.5, unit: "mm", description: "Layer height" },
    layer_count: { anyOf: [{ type: "integer", minimum: 1 }, { type: "null" }], default: null },
    pattern: { $ref: "#/$defs/Pattern", default: "raster" },
    path: { type: "string", "x-file": true },
    kinematics: { type: "boolean", default: true },
    sections: { type: "object", additionalProperties: { $ref: "#/$defs/SectionStrategy" }, default: {} },
  },
  required: ["path"],
};

describe("fields from a pydantic schema", () => {
  const f = Object.fromEntries(describeFields(schema).map((x) => [x.name, x]));
  it("picks a widget per field", () => {
    expect(Object.values(f).map((x) => x.kind)).toEqual(["number", "integer", "enum", "file", "boolean", "map"]);
  });
  it("carries unit, bounds, nullability and enum options", () => {
    expect(f.layer_height.unit).toBe("mm");
    expect(f.layer_height.exclusiveMinimum).toBe(0);
    expect(boundsText(f.layer_height)).toBe("0 < x ≤ 50 mm");
    expect(f.layer_count.nullable).toBe(true);
    expect(f.layer_count.minimum).toBe(1);
    expect(f.pattern.options).toEqual(["raster", "oscillate", "parallel"]);
    expect(f.path.required).toBe(true);
  });
  it("enforces bounds and types", () => {
    expect(validateField(f.layer_height, 0)).toBe("must be > 0 mm");
    expect(validateField(f.layer_height, 51)).toBe("must be ≤ 50 mm");
    expect(validateField(f.layer_height, 2)).toBeNull();
    expect(validateField(f.layer_count, 2.5)).toBe("must be a whole number");
    expect(validateField(f.layer_count, null)).toBeNull();
    expect(validateField(f.pattern, "zigzag")).toMatch(/one of/);
    expect(validateField(f.layer_height, "$speed")).toBeNull();
  });
  it("validates a whole params object, including unknown keys and missing required ones", () => {
    expect(validateParams(schema, { layer_height: -1, typo: 1 })).toEqual({ layer_height: "must be > 0 mm", path: "required", typo: "unknown parameter" });
  });
  it("parses numeric input text", () => {
    expect(parseNumberInput(" 2.5 ")).toBe(2.5);
    expect(parseNumberInput("")).toBeUndefined();
    expect(parseNumberInput("$speed")).toBe("$speed");
    expect(parseNumberInput("abc")).toEqual({ error: "not a number" });
  });
  it("finds a nested enum by property name", () => {
    expect(findEnum({ type: "object", properties: { sections: schema.properties!.sections }, $defs: schema.$defs }, "pattern"))
      .toEqual(["raster", "oscillate", "parallel"]);
    expect(findProperty(schema, "layer_count")).toMatchObject({ type: "integer", minimum: 1 });
    expect(findProperty(schema, "nope")).toBeUndefined();
  });
});

describe("recipe inputs typed by the parameters that use them", () => {
  const strategy: JSONSchema = {
    type: "object",
    $defs: { S: { type: "object", properties: { pattern: { enum: ["raster", "spiral"], type: "string" }, speed: { type: "number", minimum: 0.1, maximum: 500, unit: "mm/s" } } } },
    properties: {
      default: { $ref: "#/$defs/S" },
      sections: { type: "object", additionalProperties: { $ref: "#/$defs/S" } },
      compare: { anyOf: [{ type: "array", items: { type: "string" } }, { type: "null" }] },
    },
  };
  const nodes = [{ type: "strategy", params: { default: { pattern: "$pattern" }, sections: { "bs1/A": { speed: "$speed" } }, compare: ["$first"] } }];
  const of = (t: string) => (t === "strategy" ? strategy : undefined);
  it("finds the enum of a nested parameter", () => {
    expect(inputField(nodes, of, "pattern")).toMatchObject({ kind: "enum", options: ["raster", "spiral"] });
  });
  it("finds bounds and unit through dict and list entries", () => {
    expect(inputField(nodes, of, "speed")).toMatchObject({ kind: "number", minimum: 0.1, maximum: 500, unit: "mm/s" });
    expect(inputField(nodes, of, "first")).toMatchObject({ kind: "string" });
    expect(inputField(nodes, of, "unused")).toBeUndefined();
  });
  it("keeps an optional parameter optional: an input set to null is valid and not required", () => {
    const f = inputField([{ type: "slice", params: { layer_count: "$n", layer_height: "$h" } }], (t) => (t === "slice" ? schema : undefined), "n");
    expect(f).toMatchObject({ kind: "integer", minimum: 1, nullable: true, required: false, default: null });
    expect(validateField(f!, null)).toBeNull();
    expect(validateField(f!, 0)).toBe("must be ≥ 1");
    const h = inputField([{ type: "slice", params: { layer_height: "$h" } }], (t) => (t === "slice" ? schema : undefined), "h");
    expect(h).toMatchObject({ kind: "number", nullable: false, required: true, unit: "mm" });
    expect(validateField(h!, null)).toBe("required");
  });
  it("resolves a schema at a path", () => {
    expect(schemaAt(strategy, ["sections", "x", "pattern"])?.enum).toEqual(["raster", "spiral"]);
    expect(schemaAt(strategy, ["nope"])).toBeUndefined();
  });
});

describe("schema → widget mapping (the shapes pydantic emits for strategy, zone, mesh, mask)", () => {
  const pt = { type: "array", minItems: 2, maxItems: 2, prefixItems: [{ type: "number" }, { type: "number" }] } as JSONSchema;
  const root: JSONSchema = {
    type: "object",
    $defs: {
      SectionStrategy: { title: "SectionStrategy", type: "object", properties: { pattern: { enum: ["oscillate", "spiral"], type: "string", title: "Pattern" }, speed: { type: "number", exclusiveMinimum: 0, maximum: 500, unit: "mm/s", title: "Speed" } } },
      SectionStrategyOverride: { title: "SectionStrategyOverride", type: "object", properties: { pattern: { anyOf: [{ type: "string" }, { type: "null" }], default: null }, speed: { anyOf: [{ type: "number" }, { type: "null" }], default: null } } },
      ZoneSpecParams: { title: "ZoneSpecParams", type: "object", properties: { split_points: { type: "array", items: pt, unit: "mm", title: "Split Points" } } },
      TransformParams: { title: "TransformParams", type: "object", properties: { translate: { type: "array", minItems: 3, maxItems: 3, prefixItems: [{ type: "number" }, { type: "number" }, { type: "number" }] } } },
    },
    properties: {
      default: { $ref: "#/$defs/SectionStrategy", description: "Spec for every section" },
      sections: { type: "object", additionalProperties: { $ref: "#/$defs/SectionStrategyOverride" }, title: "Sections" },
      zone: { $ref: "#/$defs/ZoneSpecParams" },
      transform: { $ref: "#/$defs/TransformParams" },
      compare: { type: "array", items: { type: "string" }, title: "Compare" },
      guides: { type: "object", additionalProperties: { type: "array", items: pt } },
    },
  };
  const f = Object.fromEntries(describeFields(root).map((x) => [x.name, x]));
  it("maps nested models, section maps, vectors, point lists and lists to widgets", () => {
    expect(Object.fromEntries(Object.entries(f).map(([k, x]) => [k, x.kind]))).toEqual({
      default: "object", sections: "map", zone: "object", transform: "object", compare: "list", guides: "map",
    });
    expect(describeFields(root, f.zone.schema)[0].kind).toBe("points");
    expect(describeFields(root, f.transform.schema)[0].kind).toBe("vector");
    expect(vectorDims(root, describeFields(root, f.transform.schema)[0].schema)).toBe(3);
    expect(fieldKind(f.guides.schema.additionalProperties as JSONSchema, root)).toBe("points");
  });
  it("labels come from titles or property names, never from class names", () => {
    expect(f.default.title).toBe("Default");
    expect(f.zone.title).toBe("Zone");
    expect(f.transform.title).toBe("Transform");
    expect(f.sections.title).toBe("Sections");
    expect(labelOf("x", { title: "ZoneSpecParams" })).toBe("X");
    expect(humanize("bead_width")).toBe("Bead width");
    expect(humanize("angle_deg")).toBe("Angle");
    expect(Object.values(f).map((x) => x.title).join(" ")).not.toMatch(/Section Strategy|SectionStrategy|ZoneSpecParams|TransformParams/);
  });
  it("an override field takes enum, unit and bounds from its same-named twin", () => {
    const ov = describeFields(root, { $ref: "#/$defs/SectionStrategyOverride" });
    const pattern = enrichFromRoot(root, ov[0]);
    expect(pattern.kind).toBe("enum");
    expect(pattern.options).toEqual(["oscillate", "spiral"]);
    const speed = enrichFromRoot(root, ov[1]);
    expect(speed).toMatchObject({ kind: "number", unit: "mm/s", exclusiveMinimum: 0, maximum: 500, nullable: true });
    expect(validateField(speed, 600)).toBe("must be ≤ 500 mm/s");
    expect(allProperties(root, "pattern")).toHaveLength(2);
  });
});
