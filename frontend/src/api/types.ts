/**
 * Domain types used across the GUI. Every shape the REST API declares comes from the generated
 * OpenAPI types (`schema.d.ts`, `npm run gen:api`) and is only named here, at most narrowed where
 * the API passes free-form JSON through: a node's `params_schema` (JSONSchema below), the recipe's
 * editor-only `ui`, and the contract's error object (RunError) in events, run status and preview.
 */
import type { components } from "./schema";

type S = components["schemas"];
/** `T` with the keys `K` no longer optional (fields the server always fills, by default). */
type WithRequired<T, K extends keyof T> = Omit<T, K> & Required<Pick<T, K>>;

export type Health = S["Health"];
export type GraphInfo = S["GraphInfo"];
export type SaveResult = S["SaveResult"];
export type RevisionInfo = S["RevisionInfo"];
export type FileInfo = S["FileInfo"];
export type Artifact = S["ArtifactInfo"];
export type RunCreated = S["RunCreated"];
export type RunRequest = S["RunRequest"];
export type PreviewRequest = S["PreviewRequest"];
export type RunInfo = Omit<S["RunStatus"], "error"> & { error?: RunError | null };
export type RunListItem = S["RunListItem"];
export type ProcessParameter = S["ProcessParameterInfo"];
export type Json = null | boolean | number | string | Json[] | { [k: string]: Json };

// ---- node catalog (GET /api/nodes) ---------------------------------------------------------------
export type PortSpec = S["PortInfo"];
/** A catalog entry; its params schema (free-form JSON in the API) read as a JSON Schema. */
export type NodeSpec = Omit<S["NodeInfo"], "params_schema"> & { params_schema: JSONSchema };

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

// ---- recipe (GET/PUT /api/graphs/{name}) ----------------------------------------------------------
/** The recipe as the API declares it (collections defaulted, so optional on the wire). */
export type WireRecipe = S["Recipe"];
/** A node as the GUI holds it: `params` always present (`normalizeRecipe`). */
export type RecipeNode = WithRequired<S["NodeEntry"], "params">;
export type RecipeEdge = S["EdgeEntry"];
/** The editor-only state kept in the recipe's free-form `ui`. */
export type RecipeUi = NonNullable<WireRecipe["ui"]> & { positions?: Record<string, [number, number]> };
/**
 * The recipe as the GUI holds it: the API's Recipe with its defaulted collections filled in
 * (`normalizeRecipe`), so it is still a valid request body as is.
 */
export type Recipe = Omit<WireRecipe, "inputs" | "nodes" | "edges" | "ui"> &
  Required<Pick<WireRecipe, "inputs">> & { nodes: RecipeNode[]; edges: RecipeEdge[]; ui?: RecipeUi | null };

// ---- runs (POST /api/runs, SSE events, GET /api/runs/{id}/log) -----------------------------------
/** The contract's error object (node, layer, section where known); free-form JSON in the API. */
export interface RunError {
  message: string;
  node?: string | null;
  layer?: number | null;
  section?: string | null;
  text?: string | null;
}

export type EventKind = S["RunEvent"]["kind"];
/** One run event; its free-form `error` read as a RunError. */
export type RunEvent = S["RunEvent"] & { error?: RunError | null };

// ---- preview (POST /api/preview) ---------------------------------------------------------------
export type PolygonJson = S["PolygonJSON"];
export type LayerJson = S["LayerJSON"];
export type PreviewSection = S["SectionJSON"];
export type PreviewPath = S["SectionPathJSON"];
export type Preview = Omit<S["PreviewResponse"], "error"> & { error: RunError | null };
