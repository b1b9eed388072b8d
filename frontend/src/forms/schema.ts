/**
 * Parameter forms generated from a node's pydantic JSON Schema: which widget, unit, bounds,
 * and validation of a value against them. Nothing about any particular node lives here.
 */
import type { JSONSchema } from "../api/types";

/**
 * Widget kinds. Scalars: number, integer, string, boolean, enum, file. Structures:
 * object (nested model → sub-form), map (section key → value: section picker + form for it),
 * vector (fixed-length number tuple, e.g. x/y/z), points (list of vectors → editable table),
 * list (list of anything else → rows with add/remove). json only for what none of these fits.
 */
export type FieldKind =
  | "number" | "integer" | "string" | "boolean" | "enum" | "file"
  | "object" | "map" | "vector" | "points" | "list" | "json";

export interface FieldSpec {
  name: string;
  title: string;
  description: string;
  kind: FieldKind;
  unit?: string;
  minimum?: number;
  maximum?: number;
  exclusiveMinimum?: number;
  exclusiveMaximum?: number;
  options?: unknown[];
  /** Names to pick from (the catalog's `examples`: shipped cells, robots, machine profiles,
   * materials); the field still takes another value. */
  suggestions?: string[];
  default?: unknown;
  hasDefault: boolean;
  nullable: boolean;
  required: boolean;
  schema: JSONSchema;
}

/** Follow a local `$ref` (`#/$defs/Name`) against the root schema. */
export function deref(root: JSONSchema, s: JSONSchema | undefined): JSONSchema {
  let cur = s ?? {};
  for (let guard = 0; cur.$ref && guard < 32; guard++) {
    const path = cur.$ref.replace(/^#\//, "").split("/");
    let target: unknown = root;
    for (const p of path) target = (target as Record<string, unknown> | undefined)?.[p];
    const { $ref: _r, ...rest } = cur;
    cur = { ...((target as JSONSchema) ?? {}), ...rest };
  }
  if (cur.allOf && cur.allOf.length === 1) {
    const { allOf, ...rest } = cur;
    cur = { ...deref(root, allOf[0]), ...rest };
  }
  return cur;
}

function typesOf(s: JSONSchema): string[] {
  if (Array.isArray(s.type)) return s.type;
  return s.type ? [s.type] : [];
}

/** Split `anyOf: [X, {type: null}]` into X and nullable. */
export function unwrapNullable(root: JSONSchema, s: JSONSchema): { schema: JSONSchema; nullable: boolean } {
  const d = deref(root, s);
  const alts = d.anyOf ?? d.oneOf;
  if (alts) {
    const nonNull = alts.filter((a) => !typesOf(deref(root, a)).includes("null"));
    const nullable = nonNull.length < alts.length;
    if (nonNull.length === 1) {
      const { anyOf: _a, oneOf: _o, ...outer } = d;
      return { schema: { ...deref(root, nonNull[0]), ...outer }, nullable };
    }
    return { schema: d, nullable };
  }
  const t = typesOf(d);
  if (t.includes("null") && t.length === 2) return { schema: { ...d, type: t.find((x) => x !== "null") }, nullable: true };
  return { schema: d, nullable: false };
}

/** The dimension of a fixed-length number tuple (`prefixItems` of numbers, min = max items), else 0. */
export function vectorDims(root: JSONSchema, s: JSONSchema | undefined): number {
  if (!s) return 0;
  const d = deref(root, s);
  const pre = d.prefixItems as JSONSchema[] | undefined;
  if (!typesOf(d).includes("array") || !pre?.length) return 0;
  if (!pre.every((p) => ["number", "integer"].includes(typesOf(deref(root, p))[0] ?? ""))) return 0;
  if (d.minItems !== undefined && d.minItems !== pre.length) return 0;
  return pre.length;
}

export function fieldKind(s: JSONSchema, root: JSONSchema = s): FieldKind {
  if (s["x-file"]) return "file";
  if (s.enum) return "enum";
  if (s.const !== undefined) return "enum";
  const t = typesOf(s);
  if (t.length === 1) {
    if (t[0] === "number") return "number";
    if (t[0] === "integer") return "integer";
    if (t[0] === "boolean") return "boolean";
    if (t[0] === "string") return "string";
    if (t[0] === "object") {
      if (s.properties && Object.keys(s.properties).length) return "object";
      if (typeof s.additionalProperties === "object") return "map";
      return "json";
    }
    if (t[0] === "array") {
      if (vectorDims(root, s)) return "vector";
      if (s.items && vectorDims(root, s.items)) return "points";
      if (s.items) return "list";
      return "json";
    }
  }
  const alts = s.anyOf ?? s.oneOf;
  if (alts && alts.every((a) => a.const !== undefined || a.enum)) return "enum";
  return "json";
}

function options(s: JSONSchema): unknown[] | undefined {
  if (s.enum) return s.enum;
  if (s.const !== undefined) return [s.const];
  const alts = s.anyOf ?? s.oneOf;
  if (alts && alts.every((a) => a.const !== undefined || a.enum)) return alts.flatMap((a) => a.enum ?? [a.const]);
  return undefined;
}

/** The catalog's `examples` of a string field (shipped names, common values), if any. */
function suggestions(s: JSONSchema): string[] | undefined {
  const ex = (s as { examples?: unknown }).examples;
  return Array.isArray(ex) && ex.length && ex.every((e) => typeof e === "string") ? (ex as string[]) : undefined;
}

/** "bead_width" → "Bead width", "angle_deg" → "Angle (deg)". */
export function humanize(name: string): string {
  const words = name.replace(/([a-z])([A-Z])/g, "$1 $2").split(/[_\s]+/).filter(Boolean);
  if (words.length > 1 && ["deg", "mm", "s", "mb"].includes(words[words.length - 1].toLowerCase())) words.pop();
  const t = words.join(" ").toLowerCase();
  return t ? t[0].toUpperCase() + t.slice(1) : name;
}

/** A model class name (pydantic puts it in `title` of `$defs` entries) is never a label. */
const looksLikeClassName = (t: string) => /^[A-Z][a-z0-9]+(?:[A-Z][a-z0-9]*)+$/.test(t);

/** A field's human label: its own title, else the property name made readable; never a class name. */
export function labelOf(name: string, raw: JSONSchema): string {
  const t = raw.title;
  if (t && !looksLikeClassName(t) && t !== "Params") return t;
  return humanize(name);
}

/** Fields of an object schema (a node's params model, or `obj` nested in it), in declaration order. */
export function describeFields(root: JSONSchema, objSchema?: JSONSchema): FieldSpec[] {
  const obj = deref(root, objSchema ?? root);
  const required = new Set(obj.required ?? []);
  return Object.entries(obj.properties ?? {}).map(([name, raw]) => {
    const { schema, nullable } = unwrapNullable(root, raw);
    const kind = fieldKind(schema, root);
    return {
      name,
      title: labelOf(name, raw),
      description: (raw.description ?? schema.description ?? "") as string,
      kind,
      unit: (raw.unit ?? schema.unit) as string | undefined,
      minimum: schema.minimum,
      maximum: schema.maximum,
      exclusiveMinimum: schema.exclusiveMinimum,
      exclusiveMaximum: schema.exclusiveMaximum,
      options: options(schema),
      suggestions: suggestions(raw) ?? suggestions(schema),
      default: raw.default ?? schema.default,
      hasDefault: "default" in raw || "default" in schema,
      nullable,
      required: required.has(name),
      schema,
    };
  });
}

/** A "$name" recipe-input reference is always accepted: it is checked when the run substitutes it. */
export const isInputRef = (v: unknown): v is string => typeof v === "string" && /^\$[A-Za-z_][A-Za-z0-9_]*$/.test(v);

/** Why `value` is not acceptable for `f`, or null. `undefined` means "not set" (the default applies). */
export function validateField(f: FieldSpec, value: unknown): string | null {
  if (value === undefined) return f.required && !f.hasDefault ? "required" : null;
  if (value === null) return f.nullable ? null : "required";
  if (isInputRef(value)) return null;
  switch (f.kind) {
    case "number":
    case "integer": {
      if (typeof value !== "number" || !Number.isFinite(value)) return "not a number";
      if (f.kind === "integer" && !Number.isInteger(value)) return "must be a whole number";
      const u = f.unit ? ` ${f.unit}` : "";
      if (f.minimum !== undefined && value < f.minimum) return `must be ≥ ${f.minimum}${u}`;
      if (f.maximum !== undefined && value > f.maximum) return `must be ≤ ${f.maximum}${u}`;
      if (f.exclusiveMinimum !== undefined && value <= f.exclusiveMinimum) return `must be > ${f.exclusiveMinimum}${u}`;
      if (f.exclusiveMaximum !== undefined && value >= f.exclusiveMaximum) return `must be < ${f.exclusiveMaximum}${u}`;
      return null;
    }
    case "boolean":
      return typeof value === "boolean" ? null : "must be true or false";
    case "enum":
      return f.options?.some((o) => o === value) ? null : `one of ${f.options?.map(String).join(", ")}`;
    case "string":
    case "file": {
      if (typeof value !== "string") return "must be text";
      if (f.schema.minLength !== undefined && value.length < f.schema.minLength) return `at least ${f.schema.minLength} characters`;
      if (f.schema.maxLength !== undefined && value.length > f.schema.maxLength) return `at most ${f.schema.maxLength} characters`;
      return null;
    }
    default:
      return null;
  }
}

/** Parse what the user typed into a number/integer field: a number, a "$input" reference, or unset. */
export function parseNumberInput(text: string): number | string | undefined | { error: string } {
  const t = text.trim();
  if (t === "") return undefined;
  if (isInputRef(t)) return t;
  const v = Number(t);
  if (!Number.isFinite(v)) return { error: "not a number" };
  return v;
}

/** Human text of a field's bounds with unit, e.g. "0 < x ≤ 50 mm". */
export function boundsText(f: FieldSpec): string {
  const lo = f.exclusiveMinimum !== undefined ? `${f.exclusiveMinimum} <` : f.minimum !== undefined ? `${f.minimum} ≤` : "";
  const hi = f.exclusiveMaximum !== undefined ? `< ${f.exclusiveMaximum}` : f.maximum !== undefined ? `≤ ${f.maximum}` : "";
  if (!lo && !hi) return "";
  return `${lo} x ${hi}`.trim() + (f.unit ? ` ${f.unit}` : "");
}

/** Validate a whole params object: {field name: message}. Unknown keys are errors (the engine forbids them). */
export function validateParams(root: JSONSchema, params: Record<string, unknown>): Record<string, string> {
  const fields = describeFields(root);
  const errors: Record<string, string> = {};
  for (const f of fields) {
    const e = validateField(f, params[f.name]);
    if (e) errors[f.name] = e;
  }
  const known = new Set(fields.map((f) => f.name));
  for (const k of Object.keys(params)) if (!known.has(k)) errors[k] = "unknown parameter";
  return errors;
}

/** The first property named `name` anywhere in a schema (e.g. a strategy's per-section `pattern`), unwrapped. */
export function findProperty(root: JSONSchema, name: string): JSONSchema | undefined {
  const seen = new Set<JSONSchema>();
  const walk = (s: JSONSchema | undefined): JSONSchema | undefined => {
    if (!s || typeof s !== "object" || seen.has(s)) return undefined;
    seen.add(s);
    const d = deref(root, s);
    const p = d.properties?.[name];
    if (p) return unwrapNullable(root, p).schema;
    const kids: (JSONSchema | undefined)[] = [
      ...Object.values(d.properties ?? {}),
      d.items,
      typeof d.additionalProperties === "object" ? d.additionalProperties : undefined,
      ...(d.anyOf ?? []),
      ...(d.oneOf ?? []),
      ...(d.allOf ?? []),
      ...Object.values(root.$defs ?? {}),
    ];
    for (const k of kids) {
      const r = walk(k);
      if (r) return r;
    }
    return undefined;
  };
  return walk(root);
}

/** The enum of a property named `name` anywhere in a schema. */
export function findEnum(root: JSONSchema, name: string): unknown[] | undefined {
  const p = findProperty(root, name);
  return p ? options(p) : undefined;
}

/** The (unwrapped) schema at a params path, e.g. ["default", "pattern"] or ["sections", "bs1/A", "speed"]. */
export function schemaAt(root: JSONSchema, path: readonly (string | number)[]): JSONSchema | undefined {
  const cur = rawSchemaAt(root, path);
  return cur ? unwrapNullable(root, cur).schema : undefined;
}

/** The schema at a params path as declared (an optional value keeps its `anyOf: [X, null]`). */
function rawSchemaAt(root: JSONSchema, path: readonly (string | number)[]): JSONSchema | undefined {
  let cur: JSONSchema | undefined = deref(root, root);
  for (const key of path) {
    if (!cur) return undefined;
    const d: JSONSchema = unwrapNullable(root, cur).schema;
    if (typeof key === "number") cur = d.items ? deref(root, d.items) : undefined;
    else if (d.properties?.[key]) cur = deref(root, d.properties[key]);
    else if (typeof d.additionalProperties === "object") cur = deref(root, d.additionalProperties);
    else cur = undefined;
  }
  return cur;
}

/**
 * What a recipe input ("$name" in params) must be, from the first parameter that references it:
 * its field (kind, unit, bounds, options). Undefined when no node parameter references it.
 */
export function inputField(
  nodes: readonly { type: string; params: Record<string, unknown> }[],
  schemaOf: (type: string) => JSONSchema | undefined,
  name: string,
): FieldSpec | undefined {
  const ref = `$${name}`;
  for (const n of nodes) {
    const root = schemaOf(n.type);
    if (!root) continue;
    const found: (string | number)[][] = [];
    const walk = (v: unknown, path: (string | number)[]) => {
      if (v === ref) found.push(path);
      else if (Array.isArray(v)) v.forEach((x, i) => walk(x, [...path, i]));
      else if (v && typeof v === "object") Object.entries(v).forEach(([k, x]) => walk(x, [...path, k]));
    };
    walk(n.params, []);
    for (const path of found) {
      const raw = rawSchemaAt(root, path);
      if (!raw) continue;
      const { schema: sch, nullable } = unwrapNullable(root, raw);
      const kind = fieldKind(sch, root);
      return {
        name, title: sch.title ?? name, description: sch.description ?? "", kind, unit: sch.unit,
        minimum: sch.minimum, maximum: sch.maximum, exclusiveMinimum: sch.exclusiveMinimum, exclusiveMaximum: sch.exclusiveMaximum,
        options: options(sch), default: sch.default, hasDefault: "default" in sch, nullable, required: !nullable, schema: sch,
      };
    }
  }
  return undefined;
}

/**
 * Fill what an "override" model leaves out from the same-named property elsewhere in the schema:
 * a section override's `pattern` is a plain optional string, the default's is an enum with bounds.
 */
export function enrichFromRoot(root: JSONSchema, f: FieldSpec): FieldSpec {
  if (f.kind !== "string" && f.kind !== "number" && f.kind !== "integer") return f;
  const twins = allProperties(root, f.name);
  const twin = twins.find((t) => options(t) || t.minimum !== undefined || t.exclusiveMinimum !== undefined || t.maximum !== undefined) ?? twins[0];
  if (!twin) return f;
  const out = { ...f };
  const opts = options(twin);
  if (f.kind === "string" && !f.options && opts) {
    out.kind = "enum";
    out.options = opts;
  }
  if (f.kind !== "string") {
    out.unit ??= twin.unit;
    if (f.minimum === undefined && f.exclusiveMinimum === undefined) {
      out.minimum = twin.minimum;
      out.exclusiveMinimum = twin.exclusiveMinimum;
    }
    if (f.maximum === undefined && f.exclusiveMaximum === undefined) {
      out.maximum = twin.maximum;
      out.exclusiveMaximum = twin.exclusiveMaximum;
    }
  }
  return out;
}

/** Every property named `name` anywhere in a schema, unwrapped (each `$defs` entry visited once). */
export function allProperties(root: JSONSchema, name: string): JSONSchema[] {
  const out: JSONSchema[] = [];
  const seen = new Set<JSONSchema>();
  const walk = (s: JSONSchema | undefined) => {
    if (!s || typeof s !== "object" || seen.has(s)) return;
    seen.add(s);
    if (s.$ref) return; // its target is walked with the $defs
    const d = s;
    const p = d.properties?.[name];
    if (p) out.push(unwrapNullable(root, p).schema);
    [...Object.values(d.properties ?? {}), d.items, typeof d.additionalProperties === "object" ? d.additionalProperties : undefined, ...(d.anyOf ?? []), ...(d.oneOf ?? []), ...(d.allOf ?? [])].forEach(walk);
  };
  walk(root);
  Object.values(root.$defs ?? {}).forEach(walk);
  return out;
}
