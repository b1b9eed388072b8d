/** The 3D panel's sections (presentational: props in, HTML out): nodes, layers, colour with the legend, programmed vs simulated with playback. */
import type { ViewSettings, ViewerState } from "./api";
import { legendBlocks } from "./legend";
import type { RangeMode } from "./useViewer3D";

type Send = (v: ViewSettings) => Promise<unknown>;
const RANGE_MODES: [RangeMode, string][] = [["all", "all layers"], ["upto", "up to the canvas layer"], ["only", "only the canvas layer"], ["custom", "range"]];
const PATH_LABELS: Record<string, string> = { zone: "zone", speed: "speed", arc: "arc on/off", section: "section" };
const SIM_LABELS: Record<string, string> = { deviation: "deviation", speed: "speed", deposit: "deposit per mm" };

/** Per-node visibility. */
export function NodesSection({ st, send }: { st: ViewerState | null; send: Send }) {
  const hidden = new Set(st?.view?.hidden ?? []);
  return (
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
  );
}

export interface LayersProps {
  rangeMode: RangeMode;
  setRangeMode: (m: RangeMode) => void;
  custom: [number, number];
  setCustom: (c: [number, number]) => void;
  layer: number;
  setLayer: (n: number) => void;
  extent: { lo: number; hi: number } | null;
  lo: number;
  hi: number;
}

/** The layer range: all, up to / only the canvas layer, or a chosen range. */
export function LayersSection({ rangeMode, setRangeMode, custom, setCustom, layer, setLayer, extent, lo, hi }: LayersProps) {
  return (
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
  );
}

/** Colour modes of the toolpath and the simulation, with the legend of what is shown. */
export function ColourSection({ st, send }: { st: ViewerState | null; send: Send }) {
  const view = st?.view;
  const blocks = legendBlocks(st?.legend ?? [], st?.colormap ?? []);
  const hasSim = (st?.nodes ?? []).some((n) => n.kinds.includes("simulation"));
  const hasPath = (st?.nodes ?? []).some((n) => n.kinds.includes("toolpath"));
  return (
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
  );
}

/** Programmed vs simulated path, the robot, the simulated path's lift, and playback. */
export function SimSection({ st, view, send, playing, setPlaying }: { st: ViewerState; view: NonNullable<ViewerState["view"]>; send: Send; playing: boolean; setPlaying: (v: boolean) => void }) {
  return (
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
  );
}
