/**
 * The 3D view's REST side: which recipe it shows, view settings, and state + legend data.
 * Every call names this page's view (`VIEW_ID`): the server keeps one scene, camera, playback and
 * colour state per view, so two tabs — or two users — on one server see their own recipes.
 */
import { api, ApiError } from "../api/client";
import type { components } from "../api/schema";

export type ViewSettings = Omit<Partial<components["schemas"]["ViewSettings"]>, "view">;

/** This page's 3D view id: one per page load (a reload starts a fresh view; a duplicated tab
 * gets its own), kept while the user moves between tabs of the app. */
export const VIEW_ID = `v${Date.now().toString(36)}${Math.random().toString(36).slice(2, 10)}`;

/**
 * The iframe address of viser's page for view `view`: the page's websocket must carry `?view=`
 * (the server binds the browser client to the view by it). Takes the page as built elsewhere —
 * `<viewer>/?embedded` or a cached page with `websocket=` — and adds the view to both.
 */
export function withView(src: string, view: string = VIEW_ID): string {
  const [page, query = ""] = src.split("?", 2);
  const parts = query.split("&").filter((p) => p && !p.startsWith("view="));
  const v = encodeURIComponent(view);
  const out = parts.map((p) => {
    if (!p.startsWith("websocket=")) return p;
    const ws = decodeURIComponent(p.slice("websocket=".length)).replace(/[?&]view=[^&]*/, "");
    return `websocket=${encodeURIComponent(`${ws}${ws.includes("?") ? "&" : ws.endsWith("/") ? "?" : "/?"}view=${v}`)}`;
  });
  return `${page}?${[...out, `view=${v}`].join("&")}`;
}

export interface ViewerNode { id: string; type: string; kinds: string[]; visible: boolean }
/** A colour-map range: `lo`–`hi` the map's ends (robust: 2nd–98th percentile); `min`/`max` the
 * data's extent; `clamped`: values beyond lo/hi are drawn in the end colours. */
export interface Range { lo: number; hi: number; unit: string; min?: number; max?: number; clamped?: boolean }
export interface LegendEntry {
  node: string;
  kind: "toolpath" | "simulation";
  mode: string;
  zones?: { zone: string; color: string }[];
  ranges: Record<string, Range>;
  arc?: { on: string; off: string };
  travel?: string;
  programmed?: string;
  robot?: string | null;
  robot_note?: string;
}
export interface ViewerState {
  running: boolean;
  view_id?: string;
  /** a browser client (this page's iframe) is attached to the view */
  attached?: boolean;
  /** the shown run has a robot cell (arm, torch, positioner): "fit cell" applies */
  has_cell?: boolean;
  key?: string | null;
  wanted?: string | null;
  published?: string[];
  /** id of the run whose scene is shown */
  run?: string | null;
  /** the selected recipe's latest finished run, being rebuilt (its scene was not in memory) */
  loading?: { key: string; run: string; since: number } | null;
  rebuild_error?: { run: string | null; message: string } | null;
  nodes?: ViewerNode[];
  layers?: { lo: number; hi: number } | null;
  duration_s?: number;
  view?: {
    layer_lo: number; layer_hi: number; path_color: string; sim_color: string; time_s: number; show_robot: boolean;
    sim_offset_mm: number; show_programmed: boolean; show_simulated: boolean; hidden: string[];
  };
  path_color_modes?: string[];
  sim_color_modes?: string[];
  colormap?: string[];
  legend?: LegendEntry[];
  bounds?: number[][] | null;
}

async function ok(p: Promise<{ data?: unknown; error?: unknown; response: Response }>) {
  const { data, error, response } = await p;
  if (!response.ok) {
    const d = (error as { detail?: { message?: string } | string } | undefined)?.detail;
    throw new ApiError(response.status, { message: typeof d === "string" ? d : d?.message ?? `HTTP ${response.status}` });
  }
  return data;
}

export const viewerState = async (view: string = VIEW_ID) =>
  (await ok(api.GET("/api/viewer/state", { params: { query: { view } } }))) as ViewerState;
export const viewerView = (body: ViewSettings, view: string = VIEW_ID) =>
  ok(api.POST("/api/viewer/view", { body: { fit: false, ...body, view }, parseAs: "text" }));
/** Show the latest run of the open recipe: a saved graph by name, an unsaved one by its run id. */
export const viewerShow = (graph: string | null, run: string | null, view: string = VIEW_ID) =>
  ok(api.POST("/api/viewer/select", { body: graph ? { graph, view } : { run, view }, parseAs: "text" }));
