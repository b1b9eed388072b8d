import { useCallback, useEffect, useMemo, useState } from "react";
import { parsePlace } from "../graph/drafts";
import { VIEW_ID } from "../viewer/api";
import { finishedRuns, getBuild, listBuilds, nextProgram, postScan, showIn3d, startBuild } from "./api";
import { setCanvasBuild, useCanvasBuild } from "./canvasBuild";
import { LayerChart } from "./LayerChart";
import { chartSeries, fmt, layerRows, pct, progress, STOP_HEX, timeline, type BuildDetail, type BuildInfo, type LayerRow } from "./data";
import "./builds.css";

const go = (hash: string) => {
  window.location.hash = hash;
};
const message = (e: unknown) => (e instanceof Error ? e.message : String(e));

/** The builds page (#29): `#/builds` lists the builds and starts one from a finished run;
 * `#/builds/<id>` shows one build. Drawn over the editor (which stays mounted underneath). */
export function BuildsPage({ id }: { id: string | null }) {
  const graph = parsePlace(window.location.search).graph ?? null;
  const [builds, setBuilds] = useState<BuildInfo[] | null>(null);
  const [allGraphs, setAllGraphs] = useState(!graph);
  const [error, setError] = useState<string | null>(null);
  const refresh = useCallback(() => {
    listBuilds().then(setBuilds, (e) => setError(message(e)));
  }, []);
  useEffect(refresh, [refresh]);
  useEffect(() => {
    const onKey = (e: KeyboardEvent) => e.key === "Escape" && !(e.target instanceof HTMLInputElement) && go("");
    window.addEventListener("keydown", onKey);
    return () => window.removeEventListener("keydown", onKey);
  }, []);
  const shown = (builds ?? []).filter((b) => allGraphs || !graph || b.graph === graph);
  return (
    <div className="builds-page" data-testid="builds-page" role="main">
      <header className="builds-head">
        <a href="#" className="button" data-testid="builds-back" title="back to the recipe editor (Esc)">← editor</a>
        <h2>Builds</h2>
        <span className="muted">as built vs as planned: a scan per layer in, the next layer's program out</span>
        {graph && (
          <label className="builds-filter">
            <input type="checkbox" checked={!allGraphs} onChange={(e) => setAllGraphs(!e.target.checked)} /> only {graph}
          </label>
        )}
      </header>
      {error && <div className="error-box" role="alert">{error}</div>}
      <div className="builds-body">
        <aside className="builds-list">
          <StartBuild graph={allGraphs ? null : graph} onStarted={(b) => { refresh(); go(`#/builds/${b.id}`); }} />
          <h4>Builds{graph && !allGraphs ? ` of ${graph}` : ""}</h4>
          {builds === null ? (
            <div className="muted">loading…</div>
          ) : shown.length === 0 ? (
            <div className="muted" data-testid="builds-empty">no builds yet: start one from a finished run</div>
          ) : (
            <ul data-testid="builds-list">
              {shown.map((b) => (
                <li key={b.id}>
                  <a href={`#/builds/${b.id}`} className={b.id === id ? "current" : ""} data-build={b.id} aria-current={b.id === id ? "page" : undefined}>
                    <span className="bid">{b.id}</span> <span>{b.graph ?? "unsaved recipe"}</span>
                    <span className={`status s-${b.status}`}>{b.layers_scanned}/{b.layers_planned} {b.status}</span>
                    <span className="muted small">{b.created.replace("T", " ").replace("Z", " UTC")}</span>
                  </a>
                </li>
              ))}
            </ul>
          )}
        </aside>
        <section className="builds-detail">
          {id ? <BuildView id={id} onChange={refresh} /> : <div className="empty">pick a build on the left, or start one</div>}
        </section>
      </div>
    </div>
  );
}

function StartBuild({ graph, onStarted }: { graph: string | null; onStarted: (b: BuildDetail) => void }) {
  const [runs, setRuns] = useState<{ id: string; graph: string | null; created: number }[] | null>(null);
  const [run, setRun] = useState("");
  const [target, setTarget] = useState("");
  const [busy, setBusy] = useState(false);
  const [error, setError] = useState<string | null>(null);
  useEffect(() => {
    finishedRuns(graph).then((r) => {
      setRuns(r);
      setRun((cur) => cur || r[0]?.id || "");
    }, (e) => setError(message(e)));
  }, [graph]);
  const start = () => {
    setBusy(true);
    setError(null);
    startBuild(run, target.trim() ? Number(target) : null)
      .then(onStarted, (e) => setError(message(e)))
      .finally(() => setBusy(false));
  };
  return (
    <form className="start-build" onSubmit={(e) => { e.preventDefault(); start(); }} data-testid="start-build">
      <h4>Start a build</h4>
      <label>
        from run
        <select value={run} onChange={(e) => setRun(e.target.value)} data-testid="start-run" aria-label="the finished run to build">
          {!runs?.length && <option value="">{runs === null ? "loading…" : "no finished run"}</option>}
          {runs?.map((r) => (
            <option key={r.id} value={r.id}>
              {r.id} {r.graph ?? ""} {new Date(r.created * 1000).toLocaleString()}
            </option>
          ))}
        </select>
      </label>
      <label title="the part temperature a layer may start at, for dwells from measured temperatures (default: the recipe's interpass node, else 200 °C)">
        interpass target °C
        <input value={target} onChange={(e) => setTarget(e.target.value)} inputMode="decimal" placeholder="recipe / 200" size={8} data-testid="start-interpass" />
      </label>
      <button type="submit" disabled={!run || busy} data-testid="start-build-go">{busy ? "planning…" : "start build"}</button>
      {error && <div className="error" role="alert">{error}</div>}
    </form>
  );
}

function BuildView({ id, onChange }: { id: string; onChange: () => void }) {
  const [d, setD] = useState<BuildDetail | null>(null);
  const [error, setError] = useState<string | null>(null);
  const [note, setNote] = useState<string | null>(null);
  const canvasBuild = useCanvasBuild();
  const load = useCallback(() => {
    getBuild(id).then((x) => { setD(x); setError(null); }, (e) => setError(message(e)));
  }, [id]);
  useEffect(() => {
    setD(null);
    load();
  }, [load]);
  const rows = useMemo(() => (d ? layerRows(d) : []), [d]);
  const series = useMemo(() => chartSeries(rows), [rows]);
  const events = useMemo(() => (d ? timeline(d) : []), [d]);
  if (error) return <div className="error-box" role="alert">{error}</div>;
  if (!d) return <div className="muted">loading build {id}… (a build is re-planned after a server restart)</div>;
  const pr = progress(d);
  const download = async () => {
    try {
      const p = await nextProgram(id);
      for (const [name, text] of Object.entries(p.files)) {
        const a = document.createElement("a");
        a.href = URL.createObjectURL(new Blob([text], { type: "text/plain" }));
        a.download = `${id}_layer${p.layer}_${name}`;
        a.click();
        setTimeout(() => URL.revokeObjectURL(a.href), 1000);
      }
      setNote(`program of layer ${p.layer} downloaded (${Object.keys(p.files).join(", ") || "no post-process node: no files"})`);
      load();
    } catch (e) {
      setNote(message(e));
    }
  };
  const show3d = async () => {
    try {
      const r = await showIn3d(id, VIEW_ID);
      const lg = r.legend as { points?: number; range?: { hi: number } } | null;
      setNote(lg ? `as-built surface in the 3D view: ${lg.points} points, colours ±${fmt(lg.range?.hi ?? null)} mm` : "shown");
    } catch (e) {
      setNote(message(e));
    }
  };
  return (
    <div className="build" data-testid="build" data-build={id} data-done={pr.done} data-planned={pr.planned} data-status={d.status}>
      <div className="build-summary">
        <h3>
          Build {id} <span className="muted">{d.graph ?? "unsaved recipe"} · run {d.run}</span>
        </h3>
        <div className="build-progress" title={`${pr.done} of ${pr.planned} layers scanned`}>
          <div className="bar" style={{ width: `${100 * pr.share}%` }} />
          <span data-testid="build-done">{`${pr.done} / ${pr.planned} layers done`}</span>
        </div>
        <span className={`status s-${d.status}`}>{d.status}</span>
        <span>next layer: <b>{d.next_layer ?? "—"}</b></span>
        <span>last layer: mean <b data-testid="last-mean">{fmt(pr.lastMean)}</b> mm, max <b data-testid="last-max">{fmt(pr.lastMax)}</b> mm</span>
        <span>dwell {fmt(pr.dwellTotal, 1)} s</span>
        <span data-testid="build-added-dropped">layers added {pr.added}, dropped {pr.dropped}</span>
      </div>
      <div className="build-actions">
        <button onClick={() => void download()} disabled={d.status === "complete"} data-testid="download-program" title="the next layer's program, adapted to the scans so far (written by the recipe's post-process node)">
          ⬇ next layer program
        </button>
        <ScanUpload id={id} next={d.next_layer ?? null} disabled={d.status === "complete"} onDone={(t) => { setNote(t); load(); onChange(); }} />
        <button onClick={() => void show3d()} data-testid="show-3d" title="draw the scanned tops coloured by deviation in the 3D view, next to the plan">show in 3D</button>
        <button
          onClick={() => { setCanvasBuild(canvasBuild === id ? null : id); if (canvasBuild !== id) go(""); }}
          className={canvasBuild === id ? "active" : ""}
          data-testid="show-canvas"
          title="overlay the measured deviation along the path on the 2D canvas of the editor (per shown layer)"
        >
          {canvasBuild === id ? "on 2D canvas ✓" : "show on 2D canvas"}
        </button>
        <span className="legend" aria-label="deviation colours">
          <span className="sw" style={{ background: `linear-gradient(90deg, ${STOP_HEX.join(",")})` }} /> below · on · above plan
        </span>
      </div>
      {note && <div className="build-note" role="status" data-testid="build-note">{note}</div>}
      <div className="build-charts">
        <LayerChart title="Top height per layer: as built vs planned" yLabel="top height, mm" series={series.heights} layers={d.layers_planned} />
        <LayerChart title="Top error per layer" yLabel="error vs plan, mm" series={series.errors} layers={d.layers_planned} zero />
      </div>
      <LayerTable rows={rows} />
      <Timeline events={events} />
    </div>
  );
}

function ScanUpload({ id, next, disabled, onDone }: { id: string; next: number | null; disabled: boolean; onDone: (t: string) => void }) {
  const [file, setFile] = useState<File | null>(null);
  const [kind, setKind] = useState<"cloud" | "heights">("cloud");
  const [register, setRegister] = useState(false);
  const [temp, setTemp] = useState("");
  const [busy, setBusy] = useState(false);
  const [error, setError] = useState<string | null>(null);
  const send = async () => {
    if (!file || next === null) return;
    setBusy(true);
    setError(null);
    try {
      const r = await postScan(id, await file.arrayBuffer(), { layer: next, kind, register, interpassC: temp.trim() ? Number(temp) : null });
      const l = r.layer as { mean_error_mm?: number; max_error_mm?: number };
      onDone(`scan of layer ${next}: mean ${fmt(l.mean_error_mm)} mm, max ${fmt(l.max_error_mm)} mm` + (r.next ? `; layer ${r.next.layer}'s program is ready` : "; the build is complete"));
      setFile(null);
      setTemp("");
    } catch (e) {
      setError(message(e));
    } finally {
      setBusy(false);
    }
  };
  return (
    <form className="scan-upload" onSubmit={(e) => { e.preventDefault(); void send(); }} data-testid="scan-upload">
      <label className="button" title="PLY or XYZ/CSV point cloud, or per-path heights CSV (layer,s,height[,width])">
        {file ? file.name : `scan of layer ${next ?? "—"}…`}
        <input type="file" accept=".ply,.xyz,.csv,.txt" onChange={(e) => setFile(e.target.files?.[0] ?? null)} data-testid="scan-file" disabled={disabled} hidden />
      </label>
      <select value={kind} onChange={(e) => setKind(e.target.value as "cloud" | "heights")} aria-label="scan kind" disabled={disabled}>
        <option value="cloud">point cloud</option>
        <option value="heights">heights CSV</option>
      </select>
      <label title="best-fit an uncalibrated scanner frame to the planned top (it also removes a uniform error)">
        <input type="checkbox" checked={register} onChange={(e) => setRegister(e.target.checked)} disabled={disabled} /> register
      </label>
      <label title="part temperature measured after this layer: the next program waits until the heat model says it is at the interpass target">
        T <input value={temp} onChange={(e) => setTemp(e.target.value)} size={5} inputMode="decimal" placeholder="°C" data-testid="scan-temp" disabled={disabled} aria-label="measured interpass temperature, °C" />
      </label>
      <button type="submit" disabled={disabled || !file || busy} data-testid="scan-send">{busy ? "measuring…" : "⬆ post scan"}</button>
      {error && <span className="error" role="alert" data-testid="scan-error">{error}</span>}
    </form>
  );
}

function LayerTable({ rows }: { rows: LayerRow[] }) {
  return (
    <div className="layer-table-wrap">
      <table className="layer-table" data-testid="layer-table">
        <caption>Per layer: as built vs planned (mm), the adaptation of the program that built it, the interpass dwell before it</caption>
        <thead>
          <tr>
            <th>layer</th><th>state</th><th>planned top</th><th>as-built top</th><th>mean error</th><th>max |error|</th><th>added</th><th>coverage</th>
            <th>speed × plan</th><th>WFS × plan</th><th>clamped</th><th>T after, °C</th><th>dwell before, s</th>
          </tr>
        </thead>
        <tbody>
          {rows.map((r) => (
            <tr key={`${r.layer}:${r.pass}:${r.state}`} className={`st-${r.state}`} data-layer={r.layer} data-pass={r.pass} data-state={r.state} data-mean={r.meanError ?? ""} data-max={r.maxError ?? ""} title={r.then ?? undefined}>
              <td>{r.layer}{r.pass > 1 ? ` (pass ${r.pass})` : ""}</td>
              <td>{r.state === "scanned" ? (r.then ? `✓ done → ${r.then.includes("again") ? "lay again" : "next left out"}` : "✓ done") : r.state === "next" ? "▶ next" : r.state === "dropped" ? "left out" : "planned"}</td>
              <td>{fmt(r.plannedTop)}</td>
              <td>{fmt(r.asBuiltTop)}</td>
              <td className={dev(r.meanError)}>{fmt(r.meanError)}</td>
              <td className={dev(r.maxError)}>{fmt(r.maxError)}</td>
              <td>{fmt(r.addedError)}</td>
              <td>{pct(r.coverage)}</td>
              <td>{r.adapted === null ? "—" : r.adapted ? `${fmt(r.speedMin, 2)}…${fmt(r.speedMax, 2)}` : "1 (plan)"}</td>
              <td title="the loop adapts travel speed; the wire feed stays as planned">{r.adapted === null ? "—" : "1"}</td>
              <td>{r.clampedSlow === null ? "—" : r.clampedSlow + (r.clampedFast ?? 0) > 0 ? <span className="warn">{`${r.clampedSlow} slow, ${r.clampedFast} fast`}</span> : "none"}</td>
              <td>{fmt(r.measuredC, 0)}</td>
              <td>{r.dwellS === null ? "—" : <>{fmt(r.dwellS, 1)}{r.dwellClamped && <span className="warn" title="clamped to the build's longest dwell"> (clamped)</span>}</>}</td>
            </tr>
          ))}
        </tbody>
      </table>
      <div className="muted small">A layer whose top comes out more than half a layer low is laid again (pass 2, 3…); more than half a layer high, the next one is left out.</div>
    </div>
  );
}

const dev = (v: number | null) => (v === null ? "" : Math.abs(v) > 0.5 ? "bad" : Math.abs(v) > 0.25 ? "warn" : "");

function Timeline({ events }: { events: ReturnType<typeof timeline> }) {
  return (
    <div className="build-log">
      <h4>Timeline and log</h4>
      <ol data-testid="build-log">
        {events.map((e, i) => (
          <li key={i} className={`a-${e.action}`} data-action={e.action}>
            <time dateTime={e.time} title={e.time}>+{fmt(e.t, 0)} s</time>
            <span className="who">{e.who}</span>
            <span>{e.text}</span>
          </li>
        ))}
      </ol>
    </div>
  );
}
