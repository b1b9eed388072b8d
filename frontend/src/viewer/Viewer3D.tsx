import { useCallback, useEffect, useMemo, useRef, useState } from "react";
import { viewerPage, viewerUrl } from "../api/client";
import type { Health } from "../api/types";
import { VIEW_ID, viewerShow, viewerState, viewerView, withView, type ViewSettings, type ViewerState } from "./api";
import { layerRange, legendBlocks } from "./legend";

export interface Viewer3DProps {
  health: Health | null;
  /** The open recipe: a saved graph's name (its runs are published under it) … */
  graph: string | null;
  /** … or, unsaved, the id of its latest run. */
  runId: string | null;
  /** Changes when a run ends, so the panel reloads what the viewer shows. */
  runPhase: string;
  layer: number;
  setLayer: (layer: number) => void;
  onMessage: (m: string) => void;
}

type RangeMode = "all" | "upto" | "only" | "custom";
const RANGE_MODES: [RangeMode, string][] = [["all", "all layers"], ["upto", "up to the canvas layer"], ["only", "only the canvas layer"], ["custom", "range"]];
const PATH_LABELS: Record<string, string> = { zone: "zone", speed: "speed", arc: "arc on/off", section: "section" };
const SIM_LABELS: Record<string, string> = { deviation: "deviation", speed: "speed", deposit: "deposit per mm" };

/** The panel's own choices, per recipe, kept while the tab is left (the panel unmounts). */
interface PanelChoices { rangeMode: RangeMode; custom: [number, number] }
const PANEL = new Map<string, PanelChoices>();

/** The line under the panel's title: which run is shown, or why none is. */
function runLine(key: string | null, st: ViewerState | null, shownOther: boolean): string {
  if (!key) return "Save or run the recipe to see it in 3D.";
  if (st?.loading && st.loading.key === key) return `Rebuilding the scene of run ${st.loading.run}…`;
  if (!st || st.wanted !== key) return `Loading the scene of ${key}…`; // the select request is on its way
  if (st.rebuild_error) return `The scene of run ${st.rebuild_error.run ?? "?"} could not be rebuilt: ${st.rebuild_error.message}. Press Run.`;
  if (!st.nodes?.length) return `No run of ${key} yet: press Run.`;
  if (shownOther) return `loading ${key}…`;
  return `Latest run of ${key}${st.run ? ` (run ${st.run})` : ""}`;
}

/**
 * The 3D workspace tab: viser's scene in an iframe filling the tab, and beside it (never over it)
 * what to show — per-node visibility, the layer range (synced with the mask canvas layer),
 * programmed / simulated / robot, colour modes with their legend, playback — driving the viewer
 * through /api/viewer. It shows the open recipe's latest run, not whatever ran last on the server.
 */
export function Viewer3D({ health, graph, runId, runPhase, layer, setLayer, onMessage }: Viewer3DProps) {
  const key = graph ?? runId;
  const saved = PANEL.get(key ?? "");
  const [st, setSt] = useState<ViewerState | null>(null);
  const [rangeMode, setRangeMode] = useState<RangeMode>(saved?.rangeMode ?? "all");
  const [custom, setCustom] = useState<[number, number]>(saved?.custom ?? [0, 0]);
  const [playing, setPlaying] = useState(false);
  const url = health ? viewerUrl(health) : null;
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

  const refresh = useCallback(() => viewerState().then(setSt).catch(() => undefined), []);
  const send = useCallback(
    (v: ViewSettings) => {
      // Optimistic: the panel shows the change at once; the state read back confirms it.
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

  // The layer range follows the canvas layer (or the chosen range).
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

  // Playback: advance the time on the server (robot and torch follow), 10 steps per second.
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

  if (!url) return <div className="empty">3D view not available{health ? " (the server runs without the viewer: serve with --viewer-port)" : ""}</div>;
  const view = st?.view;
  const hidden = new Set(view?.hidden ?? []);
  const blocks = legendBlocks(st?.legend ?? [], st?.colormap ?? []);
  const hasSim = (st?.nodes ?? []).some((n) => n.kinds.includes("simulation"));
  const hasPath = (st?.nodes ?? []).some((n) => n.kinds.includes("toolpath"));
  const shownOther = st?.key && key && st.key !== key;

  return (
    <div className="viewer3d" data-testid="viewer3d" data-view={VIEW_ID}>
      <div className="viewer3d-scene">
        <iframe title="3D view of the open recipe's latest run" src={withView(viewerPage(health!, url))} data-testid="viewer" />
      </div>
      <aside className="viewer3d-panel" aria-label="3D view settings">
        <h2 className="panel-title">3D view</h2>
        <div className="muted" data-testid="viewer-run" role="status" data-run={st?.run ?? ""} data-loading={st?.loading?.run ?? ""}>
          {runLine(key, st, !!shownOther)}
        </div>
        <div className="row" role="group" aria-label="camera">
          <button type="button" data-testid="fit-part" onClick={() => void send({ fit: "part" })} disabled={!st?.bounds} title="Frame the part as the positioner holds it at the playback time">
            Fit part
          </button>
          <button type="button" data-testid="fit-cell" onClick={() => void send({ fit: "cell" })} disabled={!st?.bounds || !st?.has_cell} title="Frame the part with the robot, torch and positioner at the playback time">
            Fit cell
          </button>
        </div>

        <section aria-labelledby="v3d-nodes">
          <h3 id="v3d-nodes">Nodes</h3>
          {(st?.nodes ?? []).map((n) => (
            <label key={n.id} className="check" data-node={n.id}>
              <input
                type="checkbox"
                checked={!hidden.has(n.id)}
                onChange={(e) => {
                  const next = new Set(hidden);
                  if (e.target.checked) next.delete(n.id);
                  else next.add(n.id);
                  void send({ hidden: [...next] });
                }}
              />
              {n.id} <span className="muted">{n.type}</span>
            </label>
          ))}
        </section>

        <section aria-labelledby="v3d-layers">
          <h3 id="v3d-layers">Layers</h3>
          <label className="row">
            show
            <select data-testid="layer-mode" value={rangeMode} onChange={(e) => setRangeMode(e.target.value as RangeMode)}>
              {RANGE_MODES.map(([m, l]) => (
                <option key={m} value={m}>
                  {l}
                </option>
              ))}
            </select>
          </label>
          {(rangeMode === "upto" || rangeMode === "only") && (
            <label className="row">
              canvas layer
              <input type="number" min={extent?.lo ?? 0} max={extent?.hi ?? undefined} value={layer} onChange={(e) => setLayer(Math.max(0, Number(e.target.value) || 0))} />
            </label>
          )}
          {rangeMode === "custom" && (
            <div className="row">
              <label>
                from <input type="number" data-testid="layer-from" min={extent?.lo ?? 0} max={extent?.hi ?? undefined} value={custom[0]} onChange={(e) => setCustom([Number(e.target.value) || 0, custom[1]])} />
              </label>
              <label>
                to <input type="number" data-testid="layer-to" min={extent?.lo ?? 0} max={extent?.hi ?? undefined} value={custom[1]} onChange={(e) => setCustom([custom[0], Number(e.target.value) || 0])} />
              </label>
            </div>
          )}
          <div className="muted" data-testid="viewer-layers">
            {extent ? `layers ${lo}–${hi} of ${extent.lo}–${extent.hi}` : "no layers"}
          </div>
        </section>

        <section aria-labelledby="v3d-colour">
          <h3 id="v3d-colour">Colour</h3>
          {hasPath && (
            <label className="row">
              toolpath by
              <select data-testid="path-color" value={view?.path_color ?? "zone"} onChange={(e) => void send({ path_color: e.target.value as ViewSettings["path_color"] })}>
                {(st?.path_color_modes ?? []).map((m) => (
                  <option key={m} value={m}>
                    {PATH_LABELS[m] ?? m}
                  </option>
                ))}
              </select>
            </label>
          )}
          {hasSim && (
            <label className="row">
              simulated by
              <select data-testid="sim-color" value={view?.sim_color ?? "deviation"} onChange={(e) => void send({ sim_color: e.target.value as ViewSettings["sim_color"] })}>
                {(st?.sim_color_modes ?? []).map((m) => (
                  <option key={m} value={m}>
                    {SIM_LABELS[m] ?? m}
                  </option>
                ))}
              </select>
            </label>
          )}
          <div className="legend" data-testid="viewer-legend">
            {blocks.map((b) => (
              <div className="legend-block" key={b.title}>
                <div className="legend-title">{b.title}</div>
                {b.bar && (
                  <div className="legend-bar">
                    <span className="bar" style={{ background: b.bar.gradient }} aria-hidden="true" />
                    <span className="ends">
                      <span>{b.bar.lo}</span>
                      <span>
                        {b.bar.hi} {b.bar.unit}
                      </span>
                    </span>
                  </div>
                )}
                {b.swatches.map((s) => (
                  <span className="legend-swatch" key={s.label}>
                    <i style={{ background: s.color }} aria-hidden="true" />
                    {s.label}
                  </span>
                ))}
                {b.note && <div className="muted">{b.note}</div>}
              </div>
            ))}
          </div>
        </section>

        {hasSim && view && (
          <section aria-labelledby="v3d-sim">
            <h3 id="v3d-sim">Programmed vs simulated</h3>
            <label className="check">
              <input type="checkbox" checked={view.show_programmed} onChange={(e) => void send({ show_programmed: e.target.checked })} />
              programmed path
            </label>
            <label className="check">
              <input type="checkbox" checked={view.show_simulated} onChange={(e) => void send({ show_simulated: e.target.checked })} />
              simulated path
            </label>
            <label className="check">
              <input type="checkbox" checked={view.show_robot} onChange={(e) => void send({ show_robot: e.target.checked })} />
              robot
            </label>
            <label className="row">
              lift simulated [mm]
              <input type="number" min={0} max={1000} step={0.5} value={view.sim_offset_mm} onChange={(e) => void send({ sim_offset_mm: Math.max(0, Number(e.target.value) || 0) })} />
            </label>
            <div className="row">
              <button type="button" onClick={() => setPlaying(!playing)} aria-pressed={playing}>
                {playing ? "pause" : "play"}
              </button>
              <label className="grow">
                <span className="sr-only">playback time</span>
                <input type="range" data-testid="viewer-time" min={0} max={st?.duration_s ?? 0} step={Math.max((st?.duration_s ?? 1) / 500, 0.01)} value={view.time_s} onChange={(e) => void send({ time_s: Number(e.target.value) })} />
              </label>
              <span className="muted">{view.time_s.toFixed(1)} s</span>
            </div>
          </section>
        )}
      </aside>
    </div>
  );
}
