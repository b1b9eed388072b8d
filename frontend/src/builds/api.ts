/**
 * The builds REST calls (#29), typed by the generated OpenAPI paths (`api` of ../api/client).
 */
import { ApiError, api } from "../api/client";
import type { RunListItem } from "../api/types";
import type { BuildDetail, BuildInfo, LayerProgram, Surface } from "./data";

async function unwrap<T>(p: Promise<{ data?: unknown; error?: unknown; response: Response }>): Promise<T> {
  const { data, error, response } = await p;
  if (!response.ok) {
    const d = (error as { detail?: unknown } | undefined)?.detail;
    const detail = d && typeof d === "object" && "message" in d ? (d as { message: string }) : { message: typeof d === "string" ? d : `HTTP ${response.status}` };
    throw new ApiError(response.status, detail as ConstructorParameters<typeof ApiError>[1]);
  }
  return data as T;
}

const path = (id: string) => ({ params: { path: { build_id: id } } });

export const listBuilds = () => unwrap<BuildInfo[]>(api.GET("/api/builds"));
export const getBuild = (id: string) => unwrap<BuildDetail>(api.GET("/api/builds/{build_id}", path(id)));
export const startBuild = (run: string, interpass_c?: number | null) =>
  unwrap<BuildDetail>(api.POST("/api/builds", { body: { run, ...(interpass_c != null ? { interpass_c } : {}) } as never }));
export const nextProgram = (id: string) => unwrap<LayerProgram>(api.GET("/api/builds/{build_id}/program", path(id)));
export const getSurface = (id: string, layer?: number) =>
  unwrap<Surface>(api.GET("/api/builds/{build_id}/surface", { params: { path: { build_id: id }, query: layer === undefined ? {} : { layer } } }));
/** Draw (or remove) the build's as-built surface in a 3D view; the legend comes back. */
export const showIn3d = (id: string, view: string | null, show = true) =>
  unwrap<{ build: string; shown: boolean; legend: Record<string, unknown> | null }>(
    api.POST("/api/builds/{build_id}/view", { params: { path: { build_id: id } }, body: { view, show } }),
  );
/** The finished runs of a graph, newest first (a build starts from one). */
export const finishedRuns = async (graph: string | null) =>
  (await unwrap<RunListItem[]>(api.GET("/api/runs", { params: { query: graph ? { graph, limit: 20 } : { limit: 20 } } }))).filter((r) => r.status === "done");

export interface ScanOptions {
  layer: number;
  kind: "cloud" | "heights";
  register: boolean;
  /** part temperature measured after the layer (°C) */
  interpassC: number | null;
}

/** Post a scan file (the bytes as they are) of the layer just built. */
export const postScan = (id: string, body: Blob | ArrayBuffer, o: ScanOptions) =>
  unwrap<{ layer: Record<string, unknown>; next: LayerProgram | null }>(
    api.POST("/api/builds/{build_id}/scans", {
      params: {
        path: { build_id: id },
        query: { layer: o.layer, kind: o.kind, register: o.register, ...(o.interpassC !== null ? { interpass_temp_c: o.interpassC } : {}) },
      },
      body: body as never,
      bodySerializer: (b: unknown) => b as BodyInit,
      headers: { "content-type": "application/octet-stream" },
    }),
  );
