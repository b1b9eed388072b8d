/**
 * The 3D panel's state, one hook per concern: its own choices per recipe (kept while the tab is
 * left), the viewer's state on the server (shown recipe, polling, optimistic view changes), the
 * layer range that follows the canvas layer, and playback.
 */
import { useCallback, useEffect, useMemo, useRef, useState } from "react";
import { viewerShow, viewerState, viewerView, type ViewSettings, type ViewerState } from "./api";
import { layerRange } from "./legend";

export type RangeMode = "all" | "upto" | "only" | "custom";

/** The panel's own choices, per recipe, kept while the tab is left (the panel unmounts). */
interface PanelChoices { rangeMode: RangeMode; custom: [number, number] }
const PANEL = new Map<string, PanelChoices>();

/** The layer-range choices of the open recipe (`key`): its own when it was shown before, else the defaults. */
export function usePanelChoices(key: string | null) {
  const saved = PANEL.get(key ?? "");
  const [rangeMode, setRangeMode] = useState<RangeMode>(saved?.rangeMode ?? "all");
  const [custom, setCustom] = useState<[number, number]>(saved?.custom ?? [0, 0]);
  const shownKey = useRef(key);
  useEffect(() => {
    // another recipe opened: its own choices (or the defaults)
    if (shownKey.current === key) return;
    shownKey.current = key;
    const c = PANEL.get(key ?? "");
    setRangeMode(c?.rangeMode ?? "all");
    setCustom(c?.custom ?? [0, 0]);
  }, [key]);
  useEffect(() => {
    if (key && shownKey.current === key) PANEL.set(key, { rangeMode, custom });
  }, [key, rangeMode, custom]);
  return { rangeMode, setRangeMode, custom, setCustom };
}

/**
 * The viewer's state for the open recipe: `send` changes the view (optimistic: the panel shows the
 * change at once; the state read back confirms it). The recipe's scene is asked for again after
 * each run; the state is polled every second until the scene is the open recipe's, then every 5 s.
 */
export function useViewerState(url: string | null, key: string | null, graph: string | null, runId: string | null, runPhase: string, onMessage: (m: string) => void) {
  const [st, setSt] = useState<ViewerState | null>(null);
  const refresh = useCallback(() => viewerState().then(setSt).catch(() => undefined), []);
  const send = useCallback(
    (v: ViewSettings) => {
      const { fit: _fit, ...patch } = v;
      setSt((cur) => (cur?.view ? { ...cur, view: { ...cur.view, ...(patch as Partial<NonNullable<ViewerState["view"]>>) } } : cur));
      return viewerView(v).then(refresh).catch((e: Error) => onMessage(`3D view: ${e.message}`));
    },
    [refresh, onMessage],
  );
  // Show the open recipe's scene (again after each run: the viewer publishes it when the run ends).
  useEffect(() => {
    if (!url || !key) return;
    void viewerShow(graph, graph ? null : runId).then(refresh).catch(() => undefined);
  }, [url, key, graph, runId, runPhase, refresh]);
  // Poll while the shown scene is not the open recipe's yet (publishing runs beside the run, or
  // a run from before a server restart being rebuilt).
  useEffect(() => {
    if (!url) return;
    const t = setInterval(refresh, st && st.key === key && (st.nodes?.length ?? 0) > 0 && !st.loading ? 5000 : 1000);
    return () => clearInterval(t);
  }, [url, refresh, st, key]);
  return { st, send };
}

/** The layer range shown: all, up to / only the canvas layer, or the chosen range; sent to the viewer when it changes. */
export function useLayerSync(st: ViewerState | null, rangeMode: RangeMode, layer: number, custom: [number, number], send: (v: ViewSettings) => Promise<unknown>) {
  const extent = st?.layers ?? null;
  const [lo, hi] = useMemo((): [number, number] => {
    if (!extent) return [0, 0];
    if (rangeMode === "all") return [extent.lo, extent.hi];
    if (rangeMode === "upto") return [extent.lo, layerRange(true, layer, [0, 0], extent)[1]];
    return layerRange(rangeMode === "only", layer, custom, extent);
  }, [extent, rangeMode, layer, custom]);
  useEffect(() => {
    if (!extent || !st?.view) return;
    if (st.view.layer_lo !== lo || st.view.layer_hi !== hi) void send({ layer_lo: lo, layer_hi: hi });
  }, [lo, hi, extent, st?.view, send]);
  return { extent, lo, hi };
}

/** Playback: advance the time on the server (robot and torch follow), 10 steps per second, to the end. */
export function usePlayback(st: ViewerState | null, send: (v: ViewSettings) => Promise<unknown>) {
  const [playing, setPlaying] = useState(false);
  useEffect(() => {
    if (!playing || !st?.duration_s) return;
    const dur = st.duration_s;
    const t = setInterval(() => {
      const now = (st.view?.time_s ?? 0) + 0.1;
      if (now >= dur) setPlaying(false);
      void send({ time_s: Math.min(now, dur) });
    }, 100);
    return () => clearInterval(t);
  }, [playing, st, send]);
  return [playing, setPlaying] as const;
}
