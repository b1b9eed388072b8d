import { useCallback, useRef, useState, type RefObject, type WheelEvent } from "react";
import { bbox, type Pt } from "./geom";

/** The visible window in SVG user units (x right, y down = −layer y), mm. */
export interface View {
  x: number;
  y: number;
  w: number;
  h: number;
}

/**
 * Pan/zoom of an SVG drawing in layer millimetres: fit to points, wheel zoom about the cursor,
 * drag to pan, screen ↔ layer conversion and the size of a screen pixel in mm.
 */
export function useSvgView(svgRef: RefObject<SVGSVGElement | null>) {
  const [view, setView] = useState<View | null>(null);
  const pan = useRef<{ start: [number, number]; view: View } | null>(null);

  const fitTo = useCallback(
    (pts: readonly number[][]) => {
      const b = bbox(pts);
      if (!b) return;
      const pad = Math.max(b.maxX - b.minX, b.maxY - b.minY) * 0.08 + 1;
      let w = b.maxX - b.minX + 2 * pad, h = b.maxY - b.minY + 2 * pad;
      // Match the element's aspect so screen ↔ world is one uniform scale (pan/zoom stay exact).
      const el = svgRef.current?.getBoundingClientRect();
      const aspect = el && el.width > 0 && el.height > 0 ? el.width / el.height : w / h;
      const cx = (b.minX + b.maxX) / 2, cy = -(b.minY + b.maxY) / 2;
      if (w / h < aspect) w = h * aspect;
      else h = w / aspect;
      setView({ x: cx - w / 2, y: cy - h / 2, w, h });
    },
    [svgRef],
  );

  /** Size of one screen pixel in mm. */
  const pxSize = () => {
    const el = svgRef.current;
    if (!el || !view) return 0.1;
    const r = el.getBoundingClientRect();
    return Math.max(view.w / Math.max(r.width, 1), view.h / Math.max(r.height, 1));
  };

  /** Layer point (mm) under a pointer event. */
  const toWorld = (e: { clientX: number; clientY: number }): Pt => {
    const m = svgRef.current?.getScreenCTM();
    if (!m) return [0, 0];
    const q = new DOMPoint(e.clientX, e.clientY).matrixTransform(m.inverse());
    return [q.x, -q.y];
  };

  const onWheel = (e: WheelEvent<SVGSVGElement>) => {
    if (!view || !svgRef.current) return;
    const r = svgRef.current.getBoundingClientRect();
    const k = Math.exp(e.deltaY * 0.0015);
    const fx = (e.clientX - r.left) / r.width, fy = (e.clientY - r.top) / r.height;
    const w = view.w * k, h = view.h * k;
    setView({ x: view.x + (view.w - w) * fx, y: view.y + (view.h - h) * fy, w, h });
  };

  const startPan = (e: { clientX: number; clientY: number }) => {
    if (view) pan.current = { start: [e.clientX, e.clientY], view };
  };
  /** Move the pan in progress; false when none is. */
  const movePan = (e: { clientX: number; clientY: number }) => {
    const d = pan.current;
    if (!d || !svgRef.current) return false;
    const k = d.view.w / svgRef.current.getBoundingClientRect().width;
    setView({ ...d.view, x: d.view.x - (e.clientX - d.start[0]) * k, y: d.view.y - (e.clientY - d.start[1]) * k });
    return true;
  };
  const endPan = () => {
    pan.current = null;
  };

  return { view, fitTo, pxSize, toWorld, onWheel, startPan, movePan, endPan };
}
