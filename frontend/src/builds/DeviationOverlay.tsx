import { memo, useEffect, useMemo, useState } from "react";
import { getSurface } from "./api";
import { setCanvasBuild, useCanvasBuild } from "./canvasBuild";
import { fmt, overlaySegments, type SurfaceLayer } from "./data";

/**
 * The measured deviation of the shown layer along its path, on the 2D mask canvas (SVG user
 * units: x, −y mm): the build picked with "show on 2D canvas" on the builds page, coloured blue
 * (below plan) → white → red (above) over ± the layer's largest deviation. Nothing when no build
 * is picked or the layer was not scanned.
 */
export const DeviationOverlay = memo(function DeviationOverlay({ layer, r }: { layer: number | null; r: number }) {
  const build = useCanvasBuild();
  const [data, setData] = useState<{ key: string; layer: SurfaceLayer | null } | null>(null);
  const key = build && layer !== null ? `${build}:${layer}` : null;
  useEffect(() => {
    if (!build || layer === null) return;
    let live = true;
    getSurface(build, layer)
      .then((s) => live && setData({ key: `${build}:${layer}`, layer: s.layers[0] ?? null }))
      .catch((e: { status?: number }) => {
        if (!live) return;
        if (e?.status === 404) setCanvasBuild(null); // the build is gone
        setData({ key: `${build}:${layer}`, layer: null });
      });
    return () => {
      live = false;
    };
  }, [build, layer]);
  const shown = data && data.key === key ? data.layer : null;
  const ov = useMemo(() => (shown ? overlaySegments(shown) : null), [shown]);
  if (!ov || !shown) return null;
  // a short legend above the layer's paths, at their left end (SVG y = −y); the full one in the title
  const box = { x: Math.min(...shown.x), y: -Math.max(...shown.y) - r * 3 };
  return (
    <g className="asbuilt-overlay" pointerEvents="none" data-testid="asbuilt-overlay" data-build={build ?? ""} data-layer={shown.layer}
      data-samples={ov.samples} data-seen={ov.seen} data-min={ov.lo.toFixed(3)} data-max={ov.hi.toFixed(3)}>
      <title>{`as built, build ${build}, layer ${shown.layer}: deviation ${fmt(ov.lo)}…${fmt(ov.hi)} mm (blue below plan, red above; ±${fmt(ov.limit)} mm)`}</title>
      <path d={ov.segs.map((s) => `M${s.x1} ${-s.y1}L${s.x2} ${-s.y2}`).join("")} stroke="#1f2933" strokeWidth={r * 3} strokeLinecap="round" fill="none" />
      {ov.segs.map((s, i) => (
        <line key={i} x1={s.x1} y1={-s.y1} x2={s.x2} y2={-s.y2} stroke={s.color} strokeWidth={r * 2.2} strokeLinecap="round" />
      ))}
      <text x={box.x} y={box.y} fontSize={r * 3} className="asbuilt-legend" data-testid="asbuilt-legend"
        style={{ paintOrder: "stroke", stroke: "#fff", strokeWidth: r * 0.8, fill: "#1f2933" }}>
        {`as built L${shown.layer}: ${fmt(ov.lo, 2)}…${fmt(ov.hi, 2)} mm`}
      </text>
    </g>
  );
});
