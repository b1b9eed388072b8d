import { useRef, type KeyboardEvent } from "react";

/**
 * ARIA tabs (WAI-ARIA Authoring Practices "tabs with automatic activation"): role tablist/tab,
 * aria-selected, aria-controls → the panel `panel-<id>`, roving tabindex, and Left/Right/Home/End
 * move between tabs. The panels carry role="tabpanel" and aria-labelledby="tab-<id>" (see tabPanelProps).
 */
export function Tabs<T extends string>({ tabs, active, onChange, label }: { tabs: readonly (readonly [T, string])[]; active: T; onChange: (t: T) => void; label: string }) {
  const refs = useRef(new Map<T, HTMLButtonElement>());
  const onKey = (e: KeyboardEvent<HTMLButtonElement>) => {
    const i = tabs.findIndex(([t]) => t === active);
    const next = { ArrowRight: i + 1, ArrowLeft: i - 1, Home: 0, End: tabs.length - 1 }[e.key];
    if (next === undefined) return;
    e.preventDefault();
    const [t] = tabs[(next + tabs.length) % tabs.length];
    onChange(t);
    refs.current.get(t)?.focus();
  };
  return (
    <nav className="tabs" role="tablist" aria-label={label}>
      {tabs.map(([t, text]) => (
        <button
          key={t}
          ref={(el) => {
            if (el) refs.current.set(t, el);
            else refs.current.delete(t);
          }}
          role="tab"
          id={`tab-${t}`}
          aria-selected={active === t}
          aria-controls={`panel-${t}`}
          tabIndex={active === t ? 0 : -1}
          className={active === t ? "active" : ""}
          onClick={() => onChange(t)}
          onKeyDown={onKey}
          data-tab={t}
        >
          {text}
        </button>
      ))}
    </nav>
  );
}

/** Props of the panel of tab `t`. */
export const tabPanelProps = (t: string) => ({ role: "tabpanel", id: `panel-${t}`, "aria-labelledby": `tab-${t}` }) as const;
