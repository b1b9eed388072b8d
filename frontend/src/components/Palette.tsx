import { memo, useMemo, useState } from "react";
import type { NodeSpec } from "../api/types";

/** Node palette generated from the catalog: categories, search, drag onto the graph or click to add. */
export const Palette = memo(function Palette({ specs, onAdd }: { specs: NodeSpec[]; onAdd: (type: string) => void }) {
  const [q, setQ] = useState("");
  const groups = useMemo(() => {
    const needle = q.trim().toLowerCase();
    const hit = (s: NodeSpec) =>
      !needle || [s.type, s.title, s.category, s.description].some((t) => (t ?? "").toLowerCase().includes(needle));
    const out = new Map<string, NodeSpec[]>();
    for (const s of specs.filter(hit)) out.set(s.category, [...(out.get(s.category) ?? []), s]);
    return [...out].sort(([a], [b]) => a.localeCompare(b));
  }, [specs, q]);
  return (
    <div className="palette" data-testid="palette">
      <input type="search" aria-label="search nodes" placeholder="search nodes…" value={q} onChange={(e) => setQ(e.target.value)} data-testid="palette-search" />
      {groups.map(([cat, items]) => (
        <div key={cat} className="palette-group">
          <div className="palette-cat">{cat}</div>
          {items.map((s) => (
            <div
              key={s.type}
              className="palette-item"
              draggable
              data-type={s.type}
              title={s.description}
              onDragStart={(e) => {
                e.dataTransfer.setData("application/waamflow-node", s.type);
                e.dataTransfer.effectAllowed = "copy";
              }}
              onDoubleClick={() => onAdd(s.type)}
            >
              <span className="ports">
                {s.inputs.map((p) => (
                  <i key={p.name} style={{ background: p.color }} />
                ))}
              </span>
              {s.title}
              <button className="add" title={`add ${s.title} to the graph`} aria-label={`add ${s.title}`} onClick={() => onAdd(s.type)}>
                +
              </button>
            </div>
          ))}
        </div>
      ))}
      {!groups.length && <div className="muted">no node matches “{q}”</div>}
    </div>
  );
});
