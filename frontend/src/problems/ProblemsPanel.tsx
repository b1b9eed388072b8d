import { canMaskHere, checkLabel, coarseCoverage, figureRows, problemKey, reportNotes, sortedProblems, type Preflight, type PreflightProblem } from "../preflight/preflight";
import { useEffect, useRef } from "react";
import type { Problem } from "./problems";

export interface ProblemsPanelProps {
  problems: readonly Problem[];
  onPick: (p: Problem) => void;
  onClose: () => void;
  /** The last run's preflight report (null: none) and whether the recipe changed since. */
  preflight?: Preflight | null;
  preflightStale?: boolean;
  /** A preflight problem clicked: show its layer (and section, point) on the mask canvas. */
  onPickPreflight?: (p: PreflightProblem) => void;
  /** "new mask here" on an uncovered area: the mask-drawing tool on that layer, at that point. */
  onMaskHere?: (p: PreflightProblem) => void;
  /** Opened from the preflight badge: the preflight section is scrolled into view. */
  focusPreflight?: boolean;
}

/** The problems of the last run or request, then its preflight (first when it failed: the program was
 * withheld, and 33 of a run's warnings had hidden its 2 failures below the fold); a click selects the
 * node (and its layer/section). */
export function ProblemsPanel({ problems, onPick, onClose, preflight, preflightStale, onPickPreflight, onMaskHere, focusPreflight }: ProblemsPanelProps) {
  const pfRef = useRef<HTMLElement>(null);
  useEffect(() => {
    if (focusPreflight) pfRef.current?.scrollIntoView?.({ block: "start" });
  }, [focusPreflight, preflight]);
  const pf = preflight ? <PreflightSection sectionRef={pfRef} report={preflight} stale={!!preflightStale} onPick={onPickPreflight} onMaskHere={onMaskHere} /> : null;
  const pfFirst = preflight?.verdict === "fail";
  return (
    <section className="problems" data-testid="problems" aria-label="problems">
      <header>
        <b>Problems</b> <span className="muted">{problems.filter((p) => p.severity === "error").length} errors · {problems.filter((p) => p.severity === "warning").length} warnings</span>
        <span className="grow" />
        <button onClick={onClose} aria-label="close the problems panel">✕</button>
      </header>
      <div className="problems-body">
        {pfFirst && pf}
        {!problems.length && <div className="muted pad">No errors or warnings in the last run.</div>}
        {problems.length > 0 && (
          <ul>
            {problems.map((p) => (
              <li key={p.key}>
                <button className={`problem ${p.severity}`} onClick={() => onPick(p)} data-problem-node={p.node ?? ""} data-problem-layer={p.layer ?? ""} data-problem-section={p.section ?? ""}>
                  <span className="sev">{p.severity === "error" ? "✖" : "⚠"}</span>
                  <span className="where">
                    {[p.node, p.layer != null ? `layer ${p.layer}` : null, p.section, p.field].filter(Boolean).join(" · ")}
                  </span>
                  <span className="msg">{p.message}</span>
                </button>
              </li>
            ))}
          </ul>
        )}
        {!pfFirst && pf}
      </div>
    </section>
  );
}

function PreflightSection({ report, stale, onPick, onMaskHere, sectionRef }: { report: Preflight; stale: boolean; onPick?: (p: PreflightProblem) => void; onMaskHere?: (p: PreflightProblem) => void; sectionRef?: React.Ref<HTMLElement> }) {
  const list = sortedProblems(report);
  return (
    <section ref={sectionRef} className={`preflight-section ${stale ? "stale" : ""}`} data-testid="preflight-section" aria-label="preflight">
      <h3>
        Preflight <span className={`pf-verdict pf-${report.verdict}`}>{report.verdict}</span>
        {report.accepted && <span className="muted"> · accepted by the user</span>}
        {stale && <span className="muted"> · out of date: the recipe changed, run again</span>}
      </h3>
      <dl className="pf-figures">
        {figureRows(report).map(([k, v]) => (
          <div key={k}>
            <dt>{k}</dt>
            <dd>{v}</dd>
          </div>
        ))}
      </dl>
      {coarseCoverage(report).map(([node, used, asked]) => (
        <div key={node} className="muted pad" data-testid="pf-coarse">
          coverage of {node} sampled every {used.toFixed(2)} mm, not {asked.toFixed(2)}: a large part (at most 1,000,000 samples of a wall, 200,000 of a mesh)
        </div>
      ))}
      {reportNotes(report).map(([node, note]) => (
        <div key={`${node}:${note}`} className="muted pad" data-testid="pf-note">
          {(report.programs?.length ?? 0) > 1 ? `${node}: ` : ""}
          {note}
        </div>
      ))}
      {!list.length && (
        <div className="muted pad" data-testid="pf-clean">
          {cleanText(report)}
        </div>
      )}
      <ul>
        {list.map((p, i) => (
          <li key={problemKey(p, i)} className="pf-row">
            <button
              className={`pf-problem ${p.severity === "fail" ? "pf-sev-fail" : "pf-sev-warn"}`}
              onClick={() => onPick?.(p)}
              data-pf-check={p.check}
              data-problem-layer={p.layer ?? ""}
              data-problem-section={p.section ?? ""}
              title={p.value != null && p.limit != null ? `value ${p.value}, limit ${p.limit}` : undefined}
            >
              <span className="sev" aria-label={p.severity === "fail" ? "fail" : "warning"}>{p.severity === "fail" ? "✗" : "⚠"}</span>
              <span className="where">{[checkLabel(String(p.check)), p.node, p.layer != null ? `layer ${p.layer}` : null, p.section].filter(Boolean).join(" · ")}</span>
              <span className="msg">{p.message}</span>
            </button>
            {canMaskHere(p) && onMaskHere && (
              <button className="pf-action" onClick={() => onMaskHere(p)} data-testid="pf-mask-here" title={`draw a new mask section on layer ${p.layer} around the uncovered area`}>
                new mask here
              </button>
            )}
          </li>
        ))}
      </ul>
    </section>
  );
}

/** What a clean preflight vouches for: the program(s), or the last toolpath when the recipe emits
 * no program (the check then reads the toolpath; weld data and wire are the program's). */
function cleanText(report: Preflight): string {
  const programs = report.programs ?? [];
  if (programs.length && programs.every((p) => p.format === "toolpath"))
    return "The toolpath builds the part: no preflight problems. No program is emitted: add a post-process node to write one (its weld data and wire are checked then).";
  return programs.length > 1 ? "The programs build the part: no preflight problems." : "The program builds the part: no preflight problems.";
}
