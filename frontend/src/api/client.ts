/**
 * The REST client: typed by the generated OpenAPI paths (openapi-fetch), so a route or field the
 * server renames breaks the build instead of the GUI.
 */
import createClient from "openapi-fetch";
import type { paths } from "./schema";
import type {
  Artifact, FileInfo, GraphInfo, Health, NodeSpec, Preview, PreviewRequest, ProcessParameter, Recipe, RunCreated, RunError, RunInfo, RunListItem, RunRequest,
  RevisionInfo, SaveResult, WireRecipe,
} from "./types";

export const api = createClient<paths>({ baseUrl: "" });

/** An error answer of the API ({"detail": {"message", "node", "layer", "section", ...}}). */
export class ApiError extends Error {
  constructor(public status: number, public detail: RunError & Record<string, unknown>) {
    super(detail.message);
  }
}

function toDetail(status: number, body: unknown): RunError & Record<string, unknown> {
  const d = (body as { detail?: unknown } | undefined)?.detail;
  if (d && typeof d === "object" && !Array.isArray(d) && "message" in d) return d as RunError & Record<string, unknown>;
  if (typeof d === "string") return { message: d };
  if (Array.isArray(d)) return { message: d.map((e) => e?.msg ?? String(e)).join("; ") };
  return { message: `HTTP ${status}` };
}

async function unwrap<T>(p: Promise<{ data?: unknown; error?: unknown; response: Response }>): Promise<T> {
  const { data, error, response } = await p;
  if (!response.ok) throw new ApiError(response.status, toDetail(response.status, error));
  return data as T;
}

export const health = () => unwrap<Health>(api.GET("/api/health"));
export const nodes = () => unwrap<NodeSpec[]>(api.GET("/api/nodes"));
/** The zone parameters of the XML file: names, units, labels and sanity bounds. */
export const processParameters = () => unwrap<ProcessParameter[]>(api.GET("/api/process-parameters"));
export const listGraphs = () => unwrap<GraphInfo[]>(api.GET("/api/graphs"));
/** The API's recipe with its defaulted collections filled in: the shape the GUI edits. */
export function normalizeRecipe(r: WireRecipe): Recipe {
  return {
    ...r,
    inputs: r.inputs ?? {},
    nodes: (r.nodes ?? []).map((n) => ({ ...n, params: n.params ?? {} })),
    edges: r.edges ?? [],
    ui: r.ui as Recipe["ui"],
  };
}

// ---- revisions (#25): every save sends the revision it loaded (If-Match) ----------------------
/** What was saved: the recipe or its parameter XML (each has its own revision). */
export type Saved = "recipe" | "params";
/** The ETag (quoted revision) last loaded or saved per graph and kind; a save sends it as If-Match. */
const loaded = new Map<string, string>();
const key = (kind: Saved, name: string) => `${kind}:${name}`;
export const loadedRevision = (kind: Saved, name: string) => loaded.get(key(kind, name)) ?? null;
/** Remember a revision (after a load or save); `null` forgets it (the next save is unconditional). */
export function setLoadedRevision(kind: Saved, name: string, etag: string | null): void {
  if (etag) loaded.set(key(kind, name), etag);
  else loaded.delete(key(kind, name));
}
function remember(kind: Saved, name: string, res: Response): void {
  const etag = res.headers.get("ETag");
  if (etag) loaded.set(key(kind, name), etag);
}

/** A save refused because someone saved since this client loaded (409 on a stale If-Match). */
export class ConflictError extends ApiError {
  constructor(
    status: number,
    detail: RunError & Record<string, unknown>,
    public kind: Saved,
    public name: string,
    /** Their stored revision, or null when the graph was deleted meanwhile. */
    public theirs: { revision: number; recipe?: WireRecipe; xml?: string } | null,
  ) {
    super(status, detail);
  }
}

function conflictOr(kind: Saved, name: string, status: number, body: unknown): ApiError {
  const detail = toDetail(status, body);
  if (status === 409 && "theirs" in detail)
    return new ConflictError(status, detail, kind, name, (detail.theirs as ConflictError["theirs"]) ?? null);
  return new ApiError(status, detail);
}

export async function getGraph(name: string): Promise<Recipe> {
  const { data, error, response } = await api.GET("/api/graphs/{name}", { params: { path: { name } } });
  if (!response.ok) throw new ApiError(response.status, toDetail(response.status, error));
  remember("recipe", name, response);
  return normalizeRecipe(data as WireRecipe);
}

/** Save a recipe with If-Match = the revision this client loaded (none known: unconditional). A
 * stale revision → ConflictError (nothing was saved). */
export async function putGraph(name: string, recipe: Recipe): Promise<SaveResult> {
  const ifMatch = loadedRevision("recipe", name);
  const { data, error, response } = await api.PUT("/api/graphs/{name}", {
    params: { path: { name }, header: ifMatch ? { "If-Match": ifMatch } : undefined },
    body: recipe,
  });
  if (!response.ok) throw conflictOr("recipe", name, response.status, error);
  remember("recipe", name, response);
  return data as SaveResult;
}
/** The recipe's saved revisions, newest first (revision, time in epoch seconds, user). */
export const listRevisions = (name: string) => unwrap<RevisionInfo[]>(api.GET("/api/graphs/{name}/revisions", { params: { path: { name } } }));
/** One earlier revision of the recipe, as saved then. Does not touch the loaded revision (If-Match). */
export async function getRevision(name: string, rev: number): Promise<Recipe> {
  const { data, error, response } = await api.GET("/api/graphs/{name}/revisions/{rev}", { params: { path: { name, rev } } });
  if (!response.ok) throw new ApiError(response.status, toDetail(response.status, error));
  return normalizeRecipe(data as WireRecipe);
}
export const deleteGraph = (name: string) => unwrap<void>(api.DELETE("/api/graphs/{name}", { params: { path: { name } }, parseAs: "text" }));
export const listFiles = (name: string) => unwrap<FileInfo[]>(api.GET("/api/graphs/{name}/files", { params: { path: { name } } }));

/** The graph's zone-parameter XML, or null when it has none yet (404). */
export async function getParams(name: string): Promise<string | null> {
  const res = await fetch(`/api/graphs/${encodeURIComponent(name)}/params`);
  if (res.status === 404) return null;
  if (!res.ok) throw new ApiError(res.status, toDetail(res.status, await res.json().catch(() => undefined)));
  remember("params", name, res);
  return res.text();
}

// XML and binary bodies go through fetch directly: openapi-fetch serialises bodies as JSON.
export async function putParams(name: string, xml: string): Promise<void> {
  const ifMatch = loadedRevision("params", name);
  const res = await fetch(`/api/graphs/${encodeURIComponent(name)}/params`, {
    method: "PUT",
    headers: { "Content-Type": "application/xml", ...(ifMatch ? { "If-Match": ifMatch } : {}) },
    body: xml,
  });
  if (!res.ok) throw conflictOr("params", name, res.status, await res.json().catch(() => undefined));
  remember("params", name, res);
}

/** A graph's file: the content `sha256` it held (a recipe's pin), else what the name holds now. */
export async function getFile(name: string, filename: string, sha256?: string): Promise<Blob> {
  const q = sha256 ? `?sha256=${sha256}` : "";
  const res = await fetch(`/api/graphs/${encodeURIComponent(name)}/files/${encodeURIComponent(filename)}${q}`);
  if (!res.ok) throw new ApiError(res.status, toDetail(res.status, await res.json().catch(() => undefined)));
  return res.blob();
}

/** Upload a graph's file; resolves to the sha256 (hex) the server stored it under (its ETag). */
export async function putFile(name: string, filename: string, body: Blob): Promise<string | null> {
  const res = await fetch(`/api/graphs/${encodeURIComponent(name)}/files/${encodeURIComponent(filename)}`, {
    method: "PUT",
    headers: { "Content-Type": "application/octet-stream" },
    body,
  });
  if (!res.ok) throw new ApiError(res.status, toDetail(res.status, await res.json().catch(() => undefined)));
  return res.headers.get("ETag")?.match(/^"([0-9a-f]{64})"$/)?.[1] ?? null;
}

/**
 * Start a run: `graph` alone runs the saved graph; `recipe` alone an inline recipe; both run the
 * (possibly unsaved) `recipe` with the saved graph's files and parameter XML.
 */
export const startRun = (
  body: Omit<RunRequest, "recipe" | "accept_preflight"> & { recipe?: Recipe | Omit<Recipe, "ui">; accept_preflight?: boolean },
) => unwrap<RunCreated>(api.POST("/api/runs", { body: { ...body, accept_preflight: body.accept_preflight ?? false } }));
/** The newest runs of a saved graph, newest first (`limit` of them). */
export const runsOf = (graph: string, limit = 1) =>
  unwrap<RunListItem[]>(api.GET("/api/runs", { params: { query: { graph, limit } } }));
export const getRun = (id: string) => unwrap<RunInfo>(api.GET("/api/runs/{run_id}", { params: { path: { run_id: id } } }));
export const cancelRun = (id: string) => unwrap<RunInfo>(api.DELETE("/api/runs/{run_id}", { params: { path: { run_id: id } } }));
export const listArtifacts = (id: string) =>
  unwrap<Artifact[]>(api.GET("/api/runs/{run_id}/artifacts", { params: { path: { run_id: id } } }));

export const artifactUrl = (id: string, name: string) => `/api/runs/${encodeURIComponent(id)}/artifacts/${encodeURIComponent(name)}`;

export async function artifactText(id: string, name: string): Promise<string | null> {
  const res = await fetch(artifactUrl(id, name));
  if (res.status === 404) return null;
  if (!res.ok) throw new ApiError(res.status, toDetail(res.status, await res.json().catch(() => undefined)));
  return res.text();
}

/**
 * The 3D view's URL: this origin's /viewer/ proxy, under the API's token and Host/Origin checks
 * (viser listens on the server's loopback only and admits nothing but the proxy, #26).
 */
export function viewerUrl(h: Health): string | null {
  return h.viewer_url ?? null;
}

/**
 * The 3D view's iframe address: viser's page from this origin under its content-hashed URL (cached
 * like the app's assets, #25) told where viser's websocket is; else viser's own page (uncached).
 */
export function viewerPage(h: Health, url: string, loc: { protocol: string; host: string } = location): string {
  if (!h.viewer_page) return `${url}/?embedded`;
  const abs = url.startsWith("/") ? `${loc.protocol}//${loc.host}${url}` : url;
  const ws = abs.replace(/^http/, "ws").replace(/\/+$/, "");
  return `${h.viewer_page}?embedded&websocket=${encodeURIComponent(ws)}`;
}

export const eventsUrl = (id: string) => `/api/runs/${encodeURIComponent(id)}/events`;

export function preview(body: Omit<PreviewRequest, "recipe"> & { recipe: Recipe }, signal?: AbortSignal) {
  return unwrap<Preview>(
    api.POST("/api/preview", { body, signal }),
  );
}
