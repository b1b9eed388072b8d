/** The 3D view's REST side: which recipe it shows, view settings, and state + legend data. */
import { api, ApiError } from "../api/client";
import type { components } from "../api/schema";

export type ViewSettings = Partial<components["schemas"]["ViewSettings"]>;

export interface ViewerNode { id: string; type: string; kinds: string[]; visible: boolean }
export interface Range { lo: number; hi: number; unit: string }
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

export const viewerState = async () => (await ok(api.GET("/api/viewer/state"))) as ViewerState;
export const viewerView = (body: ViewSettings) => ok(api.POST("/api/viewer/view", { body: { fit: false, ...body }, parseAs: "text" }));
/** Show the latest run of the open recipe: a saved graph by name, an unsaved one by its run id. */
export const viewerShow = (graph: string | null, run: string | null) =>
  ok(api.POST("/api/viewer/select", { body: graph ? { graph } : { run }, parseAs: "text" }));
