import { memo } from "react";
import type { components } from "../api/schema";
import { polygonPathD } from "./geom";

export type SectionCoverage = components["schemas"]["CoverageJSON"];

/**
 * Bead coverage of the shown layer (POST /api/preview with `coverage: true`): voids — section area
 * no bead reaches — in red, overlaps — area the torch passes over twice or more — darker. Areas
 * per section are exposed as data attributes (mm²) for tests and tooltips.
 */
export const CoverageLayer = memo(function CoverageLayer({ coverage }: { coverage: SectionCoverage[] | null | undefined }) {
  if (!coverage?.length) return null;
  return (
    <g className="coverage" pointerEvents="none">
      {coverage.map((c) => (
        <g
          key={c.key}
          data-coverage={c.key}
          data-void-mm2={c.void_area_mm2.toFixed(2)}
          data-overlap-mm2={c.overlap_area_mm2.toFixed(2)}
        >
          <title>{`${c.key}: void ${c.void_area_mm2.toFixed(1)} mm² (${(100 * c.void_share).toFixed(1)} %), overlap ${c.overlap_area_mm2.toFixed(1)} mm², outside ${c.over_deposit_area_mm2.toFixed(1)} mm² at ${c.bead_width_mm} mm bead`}</title>
          {c.overlap.map((q, i) => (
            <path key={`o${i}`} d={polygonPathD(q)} fillRule="evenodd" className="coverage-overlap" style={{ fill: "rgba(0,0,0,0.28)", stroke: "none" }} />
          ))}
          {c.void.map((q, i) => (
            <path key={`v${i}`} d={polygonPathD(q)} fillRule="evenodd" className="coverage-void" style={{ fill: "rgba(214,40,40,0.55)", stroke: "none" }} />
          ))}
        </g>
      ))}
    </g>
  );
});
