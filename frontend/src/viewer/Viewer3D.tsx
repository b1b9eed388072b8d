import { viewerPage, viewerUrl } from "../api/client";
import type { Health } from "../api/types";
import { VIEW_ID, withView, type ViewerState } from "./api";
import { useLayerSync, usePanelChoices, usePlayback, useViewerState } from "./useViewer3D";
import { ColourSection, LayersSection, NodesSection, SimSection } from "./ViewerPanels";

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
  const choices = usePanelChoices(key);
  const url = health ? viewerUrl(health) : null;
  const { st, send } = useViewerState(url, key, graph, runId, runPhase, onMessage);
  const { extent, lo, hi } = useLayerSync(st, choices.rangeMode, layer, choices.custom, send);
  const [playing, setPlaying] = usePlayback(st, send);

  if (!url) return <div className="empty">3D view not available{health ? " (the server runs without the viewer: serve with --viewer-port)" : ""}</div>;
  const view = st?.view;
  const hasSim = (st?.nodes ?? []).some((n) => n.kinds.includes("simulation"));
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
        <NodesSection st={st} send={send} />
        <LayersSection {...choices} layer={layer} setLayer={setLayer} extent={extent} lo={lo} hi={hi} />
        <ColourSection st={st} send={send} />
        {hasSim && view && <SimSection st={st} view={view} send={send} playing={playing} setPlaying={setPlaying} />}
      </aside>
    </div>
  );
}
