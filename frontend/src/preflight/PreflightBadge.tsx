import type { BadgeView } from "./preflight";

/** The toolbar's preflight verdict (icon + words + colour, figures in the tooltip); a click opens the problems panel. */
export function PreflightBadge({ view, onOpen }: { view: BadgeView | null; onOpen: () => void }) {
  if (!view) return null;
  return (
    <button
      className={`preflight-badge pf-${view.tone}`}
      data-testid="preflight-badge"
      data-tone={view.tone}
      data-count={view.count}
      aria-label={view.aria}
      title={view.tooltip}
      onClick={onOpen}
      disabled={!view.clickable}
    >
      {view.label}
    </button>
  );
}
