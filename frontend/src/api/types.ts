/**
 * Domain types used across the GUI. Every shape the REST API declares comes from the generated
 * OpenAPI types (`schema.d.ts`, `npm run gen:api`) and is only named here. What the API returns
 * as a free-form JSON object (the node catalog entries, the recipe, run events, the preview's
 * layer/sections/paths) is typed below after the contract (CONTRACT.md) and engine/events.py.
 */
import type { components } from "./schema";

type S = components["schemas"];
export type Health = S["Health"];
export type GraphInfo = S["GraphInfo"];
export type SaveResult = S["SaveResult"];
export type FileInfo = S["FileInfo"];
export type Artifact = S["ArtifactInfo"];
export type RunCreated = S["RunCreated"];
export type RunRequest = S["RunRequest"];
export type PreviewRequest = S["PreviewRequest"];
export type RunInfo = Omit<S["RunStatus"], "error"> & { error?: RunError | null };
export type RunStatus = S["RunStatus"]["status"];
export type Json = null | boolean | number | string | Json[] | { [k: string]: Json };

export interface PortSpec {
  name: string;
  type: string;
  description: string;
  optional: boolean;
  color: string;
}

export interface NodeSpec {
  type: string;
  title: string;
  category: string;
  description: string;
  version?: string;
  per_layer: boolean;
  inputs: PortSpec[];
  outputs: PortSpec[];
  params_schema: JSONSchema;
}

export interface JSONSchema {
  type?: string | string[];
  title?: string;
  description?: string;
  default?: unknown;
  enum?: unknown[];
  const?: unknown;
  properties?: Record<string, JSONSchema>;
  required?: string[];
  items?: JSONSchema;
  additionalProperties?: boolean | JSONSchema;
  anyOf?: JSONSchema[];
  oneOf?: JSONSchema[];
  allOf?: JSONSchema[];
  $ref?: string;
  $defs?: Record<string, JSONSchema>;
  minimum?: number;
  maximum?: number;
  exclusiveMinimum?: number;
  exclusiveMaximum?: number;
  minLength?: number;
  maxLength?: number;
  minItems?: number;
  maxItems?: number;
  unit?: string;
  "x-file"?: boolean;
  [k: string]: unknown;
}

export interface RecipeNode {
  id: string;
  type: string;
  params: Record<string, unknown>;
  label?: string | null;
}

export interface RecipeEdge {
  from: string;
  to: string;
}

export interface Recipe {
  format: string;
  name: string;
  description: string;
  inputs: Record<string, unknown>;
  nodes: RecipeNode[];
  edges: RecipeEdge[];
  ui?: { positions?: Record<string, [number, number]>; [k: string]: unknown } | null;
}

export interface RunError {
  message: string;
  node?: string | null;
  layer?: number | null;
  section?: string | null;
  text?: string | null;
}

export type EventKind =
  | "run_started"
  | "node_started"
  | "node_cached"
  | "node_progress"
  | "node_finished"
  | "node_error"
  | "warning"
  | "run_finished"
  | "run_failed"
  | "run_cancelled";

export interface RunEvent {
  seq: number;
  kind: EventKind;
  node?: string | null;
  layer?: number | null;
  section?: string | null;
  progress?: number;
  message?: string;
  seconds?: number | null;
  cached?: boolean | null;
  error?: RunError | null;
}

export interface PolygonJson {
  exterior: number[][];
  holes: number[][][];
}

export interface LayerJson {
  index: number;
  z: number;
  thickness: number;
  area_mm2: number;
  polygons: PolygonJson[];
  curves: number[][][];
  /** (4, 4) layer-local (x, y, 0) → world, for non-horizontal layers; absent = horizontal. */
  frame?: number[][];
}

export interface PreviewSection {
  key: string;
  polygon: PolygonJson | null;
  guide: number[][] | null;
  start: number[] | null;
  stop: number[] | null;
}

export interface PreviewPath {
  key: string;
  strategy: string;
  points: number[][];
  zone: string[];
  arc: boolean[];
  speed: (number | null)[];
  zone_colors?: Record<string, string>;
}

export interface Preview extends Omit<S["PreviewResponse"], "layer" | "sections" | "paths" | "error"> {
  layer: LayerJson | null;
  sections: PreviewSection[];
  paths: PreviewPath[];
  error: RunError | null;
}
