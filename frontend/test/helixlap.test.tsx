// @vitest-environment jsdom
// A helix on the mask canvas, lap by lap (/api/preview `climbs`): each lap says which helix it is
// part of; only the lap that starts the helix has a start marker (one ignition, on its first lap).
import { act } from "react";
import { createRoot } from "react-dom/client";
import { describe, expect, it } from "vitest";
import type { PreviewPath } from "../src/api/types";
import { PathView, climbNote } from "../src/mask/CanvasParts";

(globalThis as { IS_REACT_ACT_ENVIRONMENT?: boolean }).IS_REACT_ACT_ENVIRONMENT = true;

const climbs = { from_layer: 0, laps: 15, z_from: 2, z_to: 30 };
const lap = (z0: number, z1: number): PreviewPath =>
  ({
    key: "tube0", strategy: "helical", zone: ["", "", ""], arc: [true, true, true], inside: [true, true, true], speed: [8, 8, 8],
    length_mm: 30, points: [[8, 0, z0], [0, 8, z0 + (z1 - z0) / 3], [-8, 0, z0 + (2 * (z1 - z0)) / 3], [0, -8, z1]], climbs,
  }) as unknown as PreviewPath;

function draw(path: PreviewPath) {
  const host = document.createElement("div");
  const root = createRoot(host);
  act(() => root.render(<svg><PathView path={path} zone={{}} r={0.5} colorBy="zone" speed={null} bead={null} /></svg>));
  return { host, root };
}

describe("helix laps", () => {
  it("a later lap names its helix and has no start marker", () => {
    const { host, root } = draw(lap(10, 12));
    const g = host.querySelector('[data-path="tube0"]')!;
    expect(g.classList.contains("climbing")).toBe(true);
    expect(g.getAttribute("data-climbs")).toBe("0");
    expect(g.querySelector("title")!.textContent).toBe(climbNote("tube0", climbs));
    expect(climbNote("tube0", climbs)).toBe("tube0: a lap of the helix laid in layer 0 (15 laps, z 2.0–30.0 mm, one ignition on its first lap)");
    expect(g.querySelector(".path-start")).toBeNull();
    act(() => root.unmount());
  });
  it("the first lap keeps its start marker; a plain path has no title", () => {
    const first = draw(lap(2, 2));
    expect(first.host.querySelectorAll(".path-start")).toHaveLength(1);
    act(() => first.root.unmount());
    const plain = draw({ ...lap(2, 2), climbs: null } as PreviewPath);
    expect(plain.host.querySelector("title")).toBeNull();
    expect(plain.host.querySelectorAll(".path-start")).toHaveLength(1);
    act(() => plain.root.unmount());
  });
});
