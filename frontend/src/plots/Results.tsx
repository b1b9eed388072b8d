/** Results of the latest run: downloads, simulation metrics, the study's plots, strategy comparison. */
import { useEffect, useMemo, useState } from "react";
import { artifactText, artifactUrl } from "../api/client";
import type { Artifact, Recipe } from "../api/types";
import type { RunState } from "../run/status";
import { parseCsv, pathLength, programmedProfile, programmedSpeed, type Columns } from "./data";
import { LineChart, type Series } from "./LineChart";

const COLORS = ["#1d3557", "#e63946", "#2a9d8f", "#f4a261", "#8e7dbe"];

export function Results({ recipe, run, artifacts }: { recipe: Recipe; run: RunState; artifacts: Artifact[] }) {
  const sims = useMemo(() => {
    const fromRecipe = recipe.nodes.filter((n) => n.type === "simulate-robot").map((n) => n.id);
    const fromFiles = artifacts.filter((a) => a.name.endsWith(".trace.csv")).map((a) => a.name.slice(0, -".trace.csv".length));
    return [...new Set([...fromRecipe, ...fromFiles])].filter((id) => artifacts.some((a) => a.name.startsWith(id + ".")));
  }, [recipe, artifacts]);
  const [sim, setSim] = useState<string>("");
  const simId = sims.includes(sim) ? sim : sims[0] ?? "";
  const comparisons = artifacts.filter((a) => a.name.endsWith(".comparison.json"));
  const figures = artifacts.filter((a) => FIGURES.some((f) => a.name.endsWith(f)));

  return (
    <div className="results" data-testid="results">
      <section>
        <h4>Artifacts {run.id ? <span className="muted">run {run.id} · {run.phase}</span> : null}</h4>
        {!run.id && <div className="muted">Run the recipe to see its artifacts and plots.</div>}
        <div className="artifacts">
          {artifacts.map((a) => (
            <a key={a.name} href={artifactUrl(run.id!, a.name)} download={a.name} data-artifact={a.name}>
              {a.name} <span className="muted">{a.size < 1024 ? `${a.size} B` : `${(a.size / 1024).toFixed(1)} kB`}</span>
            </a>
          ))}
        </div>
        {run.warnings.length > 0 && (
          <details>
            <summary>{run.warnings.length} warning(s)</summary>
            {run.warnings.map((w) => (
              <div key={w.seq} className="warn">
                {w.node ?? ""} {w.layer != null ? `layer ${w.layer}` : ""} {w.section ?? ""}: {w.message}
              </div>
            ))}
          </details>
        )}
      </section>
      {sims.length > 0 && run.id && (
        <section>
          <h4>
            Simulation{" "}
            {sims.length > 1 && (
              <select value={simId} onChange={(e) => setSim(e.target.value)}>
                {sims.map((s) => (
                  <option key={s}>{s}</option>
                ))}
              </select>
            )}
          </h4>
          <SimulationPlots runId={run.id} node={simId} artifacts={artifacts} toolpathNode={upstreamOf(recipe, simId, "toolpath")} />
        </section>
      )}
      {comparisons.map((c) => (
        <section key={c.name}>
          <h4>Strategy comparison · {c.name}</h4>
          <JsonTable runId={run.id!} name={c.name} />
        </section>
      ))}
      {run.id && figures.length > 0 && (
        <section>
          <h4>Process plots</h4>
          {figures.map((f) => (
            <figure key={f.name} data-figure={f.name}>
              <img src={artifactUrl(run.id!, f.name)} alt={f.name} />
              <figcaption className="muted">{f.name}</figcaption>
            </figure>
          ))}
        </section>
      )}
    </div>
  );
}

/** Plots the process nodes write as SVG: deposit before/after compensation, interpass, bead fit. */
const FIGURES = [".deposit.svg", ".interpass.svg", ".fit.svg"];

function useArtifact(runId: string, name: string, present: boolean) {
  const [text, setText] = useState<string | null>(null);
  useEffect(() => {
    setText(null);
    if (present) void artifactText(runId, name).then(setText);
  }, [runId, name, present]);
  return text;
}

/** The node feeding input `port` of `node` (e.g. the toolpath a simulation ran on). */
function upstreamOf(r: Recipe, node: string, port: string): string | null {
  const e = r.edges.find((x) => x.to === `${node}.${port}`);
  return e ? e.from.slice(0, e.from.indexOf(".")) : null;
}

function SimulationPlots({ runId, node, artifacts, toolpathNode }: { runId: string; node: string; artifacts: Artifact[]; toolpathNode: string | null }) {
  const has = (s: string) => artifacts.some((a) => a.name === `${node}.${s}`);
  const traceText = useArtifact(runId, `${node}.trace.csv`, has("trace.csv"));
  const simText = useArtifact(runId, `${node}.simulation.json`, has("simulation.json"));
  const depText = useArtifact(runId, `${node}.deposit.csv`, has("deposit.csv"));
  const tpName = toolpathNode ? `${toolpathNode}.toolpath.json` : "";
  const tpText = useArtifact(runId, tpName, !!tpName && artifacts.some((a) => a.name === tpName));
  const trace = useMemo(() => (traceText ? parseCsv(traceText) : null), [traceText]);
  const programmed = useMemo(() => {
    try {
      return tpText ? programmedProfile(JSON.parse(tpText)) : null;
    } catch {
      return null;
    }
  }, [tpText]);
  const dep = useMemo(() => (depText ? parseCsv(depText) : null), [depText]);
  const metrics = useMemo(() => {
    try {
      return simText ? (JSON.parse(simText) as Record<string, unknown>) : null;
    } catch {
      return null;
    }
  }, [simText]);

  return (
    <div className="sim">
      <div className="charts">
        {trace && <TraceCharts c={trace} programmed={programmed} />}
        {dep && <DepositChart c={dep} />}
      </div>
      {metrics && (
        <details open>
          <summary>metrics ({node}.simulation.json)</summary>
          <table className="metrics" data-testid="sim-metrics">
            <tbody>
              {Object.entries(metrics)
                .filter(([, v]) => typeof v === "number" || typeof v === "string" || typeof v === "boolean")
                .map(([k, v]) => (
                  <tr key={k}>
                    <td>{k}</td>
                    <td>{typeof v === "number" ? Number(v.toPrecision(6)) : String(v)}</td>
                  </tr>
                ))}
            </tbody>
          </table>
        </details>
      )}
    </div>
  );
}

function TraceCharts({ c, programmed }: { c: Columns; programmed: { s: number[]; speed: number[] } | null }) {
  const s = pathLength(c);
  const prog = programmedSpeed(c);
  const charts: { title: string; x: string; y: string; series: Series[]; step?: boolean }[] = [];
  if (c.t && c.speed) {
    const ser: Series[] = [{ label: "actual speed", x: c.t, y: c.speed, color: COLORS[0] }];
    if (prog) ser.push({ label: "programmed", x: c.t, y: prog.values, color: COLORS[1], dashed: true });
    charts.push({ title: "Speed vs time", x: "time [s]", y: "speed [mm/s]", series: ser });
  }
  if (s && c.speed) {
    const ser: Series[] = [{ label: "actual speed", x: s, y: c.speed, color: COLORS[0] }];
    if (prog) ser.push({ label: "programmed", x: s, y: prog.values, color: COLORS[1], dashed: true });
    else if (programmed) ser.push({ label: "programmed (toolpath)", x: programmed.s, y: programmed.speed, color: COLORS[1], dashed: true });
    charts.push({ title: "Speed vs path length", x: "path length [mm]", y: "speed [mm/s]", series: ser });
  }
  if (s && c.deviation) charts.push({ title: "Deviation vs path", x: "path length [mm]", y: "deviation [mm]", series: [{ label: "deviation", x: s, y: c.deviation, color: COLORS[2] }] });
  if (c.t && c.arc) charts.push({ title: "Arc state", x: "time [s]", y: "arc on", series: [{ label: "arc", x: c.t, y: c.arc, color: COLORS[3], step: true }] });
  return (
    <>
      {charts.map((ch) => (
        <LineChart key={ch.title} title={ch.title} xLabel={ch.x} yLabel={ch.y} series={ch.series} />
      ))}
    </>
  );
}

/** deposit.csv: deposited volume per mm (actual vs programmed) along the path, one step per segment. */
function DepositChart({ c }: { c: Columns }) {
  const names = Object.keys(c);
  const xName = names.find((n) => /^(s|s_mm|path_mm|position_mm)$/i.test(n)) ?? names[0];
  const ys = names.filter((n) => n !== xName && /(mm3|per_mm|volume|deposit)/i.test(n)).slice(0, 4);
  if (!xName || !ys.length) return null;
  return (
    <LineChart
      title="Deposit per mm vs programmed"
      xLabel={`${xName} [mm]`}
      yLabel="volume per mm [mm³/mm]"
      series={ys.map((n, i) => ({ label: n, x: c[xName], y: c[n], color: COLORS[i % COLORS.length], dashed: /prog|nominal|target/i.test(n), step: true }))}
    />
  );
}

/** A comparison artifact as a table: rows are entries (pattern …), columns their numeric fields. */
function JsonTable({ runId, name }: { runId: string; name: string }) {
  const text = useArtifact(runId, name, true);
  const rows = useMemo(() => {
    if (!text) return [];
    try {
      return tableRows(JSON.parse(text));
    } catch {
      return [];
    }
  }, [text]);
  if (!rows.length) return <div className="muted">{text ? "no rows" : "loading…"}</div>;
  const cols = [...new Set(rows.flatMap((r) => Object.keys(r)))];
  return (
    <table className="comparison" data-testid="comparison">
      <thead>
        <tr>
          {cols.map((c) => (
            <th key={c}>{c}</th>
          ))}
        </tr>
      </thead>
      <tbody>
        {rows.map((r, i) => (
          <tr key={i}>
            {cols.map((c) => (
              <td key={c}>{fmtCell(r[c])}</td>
            ))}
          </tr>
        ))}
      </tbody>
    </table>
  );
}

function fmtCell(v: unknown): string {
  if (typeof v === "number") return Number.isInteger(v) ? String(v) : Number(v.toPrecision(4)).toString();
  if (v === null || v === undefined) return "";
  if (typeof v === "object") return JSON.stringify(v).slice(0, 60);
  return String(v);
}

/** Rows from a list of objects, an object of objects ({pattern: {...}}), or the first such list inside. */
export function tableRows(j: unknown): Record<string, unknown>[] {
  if (Array.isArray(j)) return j.filter((r) => r && typeof r === "object") as Record<string, unknown>[];
  if (j && typeof j === "object") {
    const o = j as Record<string, unknown>;
    const list = Object.values(o).find((v) => Array.isArray(v) && v.length && typeof v[0] === "object");
    if (list) return tableRows(list);
    const vals = Object.entries(o);
    if (vals.length && vals.every(([, v]) => v && typeof v === "object" && !Array.isArray(v)))
      return vals.map(([k, v]) => ({ name: k, ...(v as Record<string, unknown>) }));
  }
  return [];
}
