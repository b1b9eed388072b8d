/**
 * The zone parameter file (contract: `<parameters>` > `<layer index= z=>` > `<section id=>` >
 * `<zone id= color=>` > one element per parameter with a `unit` attribute) as a plain tree, with
 * the edits the parameter editor makes. Serialising writes the values back into the original
 * document, so attributes and elements the GUI does not know survive untouched.
 */
import type { ProcessParameter } from "../api/types";

export interface ParamValue {
  name: string;
  unit: string;
  value: string; // as written in the file; "" = not filled in
}
export interface ZoneNode {
  id: string;
  color: string;
  params: ParamValue[];
}
export interface SectionNode {
  id: string;
  zones: ZoneNode[];
}
export interface LayerNode {
  index: number;
  z: string;
  sections: SectionNode[];
}
export interface ParamDoc {
  layers: LayerNode[];
}

/** Sanity bounds of a parameter: an entry of the server's table (GET /api/process-parameters). */
export type Bounds = Pick<ProcessParameter, "minimum" | "maximum"> & Partial<Omit<ProcessParameter, "minimum" | "maximum">>;

/** The server's parameter table by name. */
export function boundsByName(params: readonly ProcessParameter[]): Record<string, Bounds> {
  return Object.fromEntries(params.map((p) => [p.name, p]));
}

const fmt = (v: number) => String(Number(v.toPrecision(12)));

/** "0…1000 A": the allowed range of a parameter with its unit. */
export function rangeText(bounds: Bounds): string {
  return `${fmt(bounds.minimum)}…${fmt(bounds.maximum)}${bounds.unit ? " " + bounds.unit : ""}`;
}

const children = (el: Element, tag: string) => Array.from(el.children).filter((c) => c.tagName === tag);

export function parseParams(text: string): ParamDoc {
  const doc = new DOMParser().parseFromString(text, "application/xml");
  const err = doc.getElementsByTagName("parsererror")[0];
  if (err) throw new Error(`not well-formed XML: ${(err.textContent ?? "").split("\n")[0]}`);
  const root = doc.documentElement;
  if (root.tagName !== "parameters") throw new Error(`root element is <${root.tagName}>, expected <parameters>`);
  return {
    layers: children(root, "layer").map((l) => ({
      index: Number(l.getAttribute("index")),
      z: l.getAttribute("z") ?? "",
      sections: children(l, "section").map((s) => ({
        id: s.getAttribute("id") ?? "",
        zones: children(s, "zone").map((z) => ({
          id: z.getAttribute("id") ?? "",
          color: z.getAttribute("color") ?? "#888888",
          params: Array.from(z.children).map((p) => ({
            name: p.tagName,
            unit: p.getAttribute("unit") ?? "",
            value: (p.textContent ?? "").trim(),
          })),
        })),
      })),
    })),
  };
}

/** Write the values of `doc` into `original` (same structure) and return the XML text. */
export function serializeParams(original: string, doc: ParamDoc): string {
  const xml = new DOMParser().parseFromString(original, "application/xml");
  const root = xml.documentElement;
  const byKey = new Map<string, string>();
  for (const l of doc.layers)
    for (const s of l.sections) for (const z of s.zones) for (const p of z.params) byKey.set(`${l.index}|${s.id}|${z.id}|${p.name}`, p.value);
  for (const l of children(root, "layer"))
    for (const s of children(l, "section"))
      for (const z of children(s, "zone"))
        for (const p of Array.from(z.children)) {
          const v = byKey.get(`${l.getAttribute("index")}|${s.getAttribute("id")}|${z.getAttribute("id")}|${p.tagName}`);
          if (v !== undefined) p.textContent = v;
        }
  let out = new XMLSerializer().serializeToString(xml);
  if (!out.startsWith("<?xml")) out = '<?xml version="1.0" encoding="utf-8"?>\n' + out;
  return out;
}

/**
 * Why a value is invalid, or null, checked as the server will: a number within the parameter's
 * bounds, and the file's `unit` attribute (when given) the table's unit. Empty is allowed (the
 * strategy's value then applies).
 */
export function validateValue(value: string, bounds?: Bounds, fileUnit?: string): string | null {
  if (bounds?.unit !== undefined && fileUnit && fileUnit.trim() !== bounds.unit)
    return `unit is "${fileUnit}", expected "${bounds.unit}"`;
  const t = value.trim();
  if (t === "") return null;
  const v = Number(t);
  if (!Number.isFinite(v)) return "not a number";
  if (bounds && (v < bounds.minimum || v > bounds.maximum)) return `outside ${rangeText(bounds)}`;
  return null;
}

export interface Selector {
  /** Inclusive layer index range; omitted = all layers. */
  layers?: [number, number];
  /** Section id; omitted = all sections. */
  section?: string;
  /** Zone id; omitted = all zones. */
  zone?: string;
}

export function matches(sel: Selector, layer: number, section: string, zone: string): boolean {
  if (sel.layers && (layer < sel.layers[0] || layer > sel.layers[1])) return false;
  if (sel.section !== undefined && sel.section !== section) return false;
  if (sel.zone !== undefined && sel.zone !== zone) return false;
  return true;
}

/** Set parameter `name` to `value` in every zone the selector matches; returns the new doc and the count. */
export function bulkSet(doc: ParamDoc, sel: Selector, name: string, value: string): { doc: ParamDoc; count: number } {
  let count = 0;
  const layers = doc.layers.map((l) => ({
    ...l,
    sections: l.sections.map((s) => ({
      ...s,
      zones: s.zones.map((z) => {
        if (!matches(sel, l.index, s.id, z.id)) return z;
        return {
          ...z,
          params: z.params.map((p) => {
            if (p.name !== name) return p;
            count++;
            return { ...p, value };
          }),
        };
      }),
    })),
  }));
  return { doc: { layers }, count };
}

export function setValue(doc: ParamDoc, layer: number, section: string, zone: string, name: string, value: string): ParamDoc {
  return bulkSet(doc, { layers: [layer, layer], section, zone }, name, value).doc;
}

/** All (layer, section, zone, param) entries that fail validation. */
export function invalidEntries(doc: ParamDoc, bounds: Record<string, Bounds>) {
  const out: { layer: number; section: string; zone: string; name: string; message: string }[] = [];
  for (const l of doc.layers)
    for (const s of l.sections)
      for (const z of s.zones)
        for (const p of z.params) {
          const m = validateValue(p.value, bounds[p.name], p.unit);
          if (m) out.push({ layer: l.index, section: s.id, zone: z.id, name: p.name, message: m });
        }
  return out;
}

/**
 * Values filled in `saved` whose layer/section/zone no longer exists in `current` (e.g. the
 * run's regenerated template after a geometry change): the orphans the user should re-home.
 */
export function orphans(saved: ParamDoc, current: ParamDoc) {
  const exists = new Set<string>();
  for (const l of current.layers) for (const s of l.sections) for (const z of s.zones) exists.add(`${l.index}|${s.id}|${z.id}`);
  const out: { layer: number; section: string; zone: string; values: ParamValue[] }[] = [];
  for (const l of saved.layers)
    for (const s of l.sections)
      for (const z of s.zones) {
        const filled = z.params.filter((p) => p.value !== "");
        if (filled.length && !exists.has(`${l.index}|${s.id}|${z.id}`)) out.push({ layer: l.index, section: s.id, zone: z.id, values: filled });
      }
  return out;
}

/** Distinct section ids, zone ids and parameter names in a doc (for bulk-edit pickers). */
export function vocabulary(doc: ParamDoc) {
  const sections = new Set<string>(), zones = new Set<string>(), names = new Map<string, string>();
  for (const l of doc.layers)
    for (const s of l.sections) {
      sections.add(s.id);
      for (const z of s.zones) {
        zones.add(z.id);
        for (const p of z.params) if (!names.has(p.name)) names.set(p.name, p.unit);
      }
    }
  return { sections: [...sections], zones: [...zones], params: [...names].map(([name, unit]) => ({ name, unit })) };
}

/** Why `text` must not be saved (an invalid value, naming where), or null. */
export function saveBlocker(text: string, bounds: Record<string, Bounds>): string | null {
  let doc: ParamDoc;
  try {
    doc = parseParams(text);
  } catch (e) {
    return `not saved: the parameter XML does not parse: ${(e as Error).message}`;
  }
  const invalid = invalidEntries(doc, bounds);
  if (!invalid.length) return null;
  const [f] = invalid;
  return `not saved: ${invalid.length} invalid value(s), e.g. layer ${f.layer} · ${f.section} · ${f.zone} · ${f.name}: ${f.message}; fix the fields marked in red`;
}
