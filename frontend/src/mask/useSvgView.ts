import { useCallback, useRef, useState, type RefObject, type WheelEvent } from "react";
import { bbox, type Pt } from "./geom";
import { fitView, panView, pixelSize, screenToLayer, zoomAbout, type View } from "./canvasModel";

export type { View } from "./canvasModel";

/**
 * Pan/zoom of an SVG drawing in layer millimetres: fit to points, wheel zoom about the cursor,
 * drag to pan, screen ↔ layer conversion and the size of a screen pixel in mm (the arithmetic is
 * canvasModel's).
 */
export function useSvgView(svgRef: RefObject<SVGSVGElement | null>) {
  const [view, setView] = useState<View | null>(null);
  const pan = useRef<{ start: [number, number]; view: View } | null>(null);

  const fitTo = useCallback(
    (pts: readonly number[][]) => {
      const b = bbox(pts);
      if (!b) return;
      // Match the element's aspect so screen ↔ world is one uniform scale (pan/zoom stay exact).
      const el = svgRef.current?.getBoundingClientRect();
      setView(fitView(b, el && el.width > 0 && el.height > 0 ? el.width / el.height : null));
    },
    [svgRef],
  );

  /** Size of one screen pixel in mm. */
  const pxSize = () => {
    const el = svgRef.current;
    return el && view ? pixelSize(view, el.getBoundingClientRect()) : 0.1;
  };

  /** Layer point (mm) under a pointer event. */
  const toWorld = (e: { clientX: number; clientY: number }): Pt => {
    const m = svgRef.current?.getScreenCTM();
    return m ? screenToLayer(m, e.clientX, e.clientY) : [0, 0];
  };

  const onWheel = (e: WheelEvent<SVGSVGElement>) => {
    if (!view || !svgRef.current) return;
    setView(zoomAbout(view, svgRef.current.getBoundingClientRect(), e.clientX, e.clientY, e.deltaY));
  };

  const startPan = (e: { clientX: number; clientY: number }) => {
    if (view) pan.current = { start: [e.clientX, e.clientY], view };
  };
  /** Move the pan in progress; false when none is. */
  const movePan = (e: { clientX: number; clientY: number }) => {
    const d = pan.current;
    if (!d || !svgRef.current) return false;
    setView(panView(d.view, d.start, [e.clientX, e.clientY], svgRef.current.getBoundingClientRect().width));
    return true;
  };
  const endPan = () => {
    pan.current = null;
  };

  return { view, fitTo, pxSize, toWorld, onWheel, startPan, movePan, endPan };
}
