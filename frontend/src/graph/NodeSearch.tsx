import { useEffect, useMemo, useRef, useState } from "react";
import type { NodeSpec } from "../api/types";

/** Rank catalog entries for a query: title/type prefix first, then any word match. */
export function searchNodes(specs: readonly NodeSpec[], q: string): NodeSpec[] {
  const needle = q.trim().toLowerCase();
  if (!needle) return [...specs].sort((a, b) => a.title.localeCompare(b.title));
  const score = (s: NodeSpec) => {
    const t = s.title.toLowerCase(), ty = s.type.toLowerCase();
    if (t.startsWith(needle) || ty.startsWith(needle)) return 0;
    if (t.includes(needle) || ty.includes(needle)) return 1;
    if ([s.category, s.description].some((x) => (x ?? "").toLowerCase().includes(needle))) return 2;
    return 9;
  };
  return specs.map((s) => [score(s), s] as const).filter(([k]) => k < 9).sort((a, b) => a[0] - b[0] || a[1].title.localeCompare(b[1].title)).map(([, s]) => s);
}

/** Quick node search (double-click on empty canvas or `/`): type to filter, ↑/↓, Enter inserts. */
export function NodeSearch({ specs, at, onPick, onClose }: { specs: readonly NodeSpec[]; at: { x: number; y: number }; onPick: (type: string) => void; onClose: () => void }) {
  const [q, setQ] = useState("");
  const [i, setI] = useState(0);
  const hits = useMemo(() => searchNodes(specs, q), [specs, q]);
  const list = useRef<HTMLUListElement>(null);
  useEffect(() => {
    setI(0);
  }, [q]);
  useEffect(() => {
    list.current?.children[i]?.scrollIntoView({ block: "nearest" });
  }, [i]);
  return (
    <div className="node-search" style={{ left: at.x, top: at.y }} data-testid="node-search" role="dialog" aria-label="add a node">
      <input
        autoFocus
        value={q}
        placeholder="add node: type to search…"
        aria-label="search nodes to add"
        onChange={(e) => setQ(e.target.value)}
        onBlur={onClose}
        onKeyDown={(e) => {
          if (e.key === "ArrowDown") setI((k) => Math.min(k + 1, hits.length - 1));
          else if (e.key === "ArrowUp") setI((k) => Math.max(k - 1, 0));
          else if (e.key === "Enter" && hits[i]) onPick(hits[i].type);
          else if (e.key === "Escape") onClose();
          else return;
          e.preventDefault();
          e.stopPropagation();
        }}
      />
      <ul ref={list} role="listbox">
        {hits.map((s, k) => (
          <li
            key={s.type}
            role="option"
            aria-selected={k === i}
            className={k === i ? "active" : ""}
            onMouseDown={(e) => {
              e.preventDefault();
              onPick(s.type);
            }}
          >
            {s.title} <span className="muted">{s.category}</span>
          </li>
        ))}
        {!hits.length && <li className="muted">no node matches “{q}”</li>}
      </ul>
    </div>
  );
}
