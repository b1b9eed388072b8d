import type { Problem } from "./problems";

/** The problems of the last run or request; a click selects the node (and its layer/section). */
export function ProblemsPanel({ problems, onPick, onClose }: { problems: readonly Problem[]; onPick: (p: Problem) => void; onClose: () => void }) {
  return (
    <section className="problems" data-testid="problems" aria-label="problems">
      <header>
        <b>Problems</b> <span className="muted">{problems.filter((p) => p.severity === "error").length} errors · {problems.filter((p) => p.severity === "warning").length} warnings</span>
        <span className="grow" />
        <button onClick={onClose} aria-label="close the problems panel">✕</button>
      </header>
      {!problems.length && <div className="muted">No problems in the last run.</div>}
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
    </section>
  );
}
