// @vitest-environment jsdom
import { act } from "react";
import { createRoot } from "react-dom/client";
import { describe, expect, it } from "vitest";
import { LineChart } from "../src/plots/LineChart";

(globalThis as { IS_REACT_ACT_ENVIRONMENT?: boolean }).IS_REACT_ACT_ENVIRONMENT = true;

function render(el: React.ReactElement) {
  const host = document.createElement("div");
  document.body.appendChild(host);
  act(() => createRoot(host).render(el));
  return host;
}

const x = Array.from({ length: 400 }, (_, i) => i);
const yTicks = (host: HTMLElement) =>
  [...host.querySelectorAll("text.tick")].filter((t) => t.getAttribute("text-anchor") === "end").map((t) => Number(t.textContent));

describe("results chart: one outlier does not flatten it", () => {
  it("a 48,500 spike among values of 1–3: the axis spans the ordinary values, the spike is clamped and marked", () => {
    const y = x.map((i) => 1 + (2 * i) / 399);
    y[200] = 48_500;
    const host = render(<LineChart title="deposit" xLabel="s [mm]" yLabel="mm³/mm" series={[{ label: "deposit", x, y, color: "#000" }]} />);
    expect(Math.max(...yTicks(host))).toBeLessThan(10);
    expect(host.querySelector("[data-clamped]")?.textContent).toMatch(/1 clamped.*48500/);
  });
  it("ordinary data keeps its full range, nothing marked", () => {
    const y = x.map((i) => Math.sin(i / 20) * 10);
    const host = render(<LineChart title="speed" xLabel="t [s]" yLabel="mm/s" series={[{ label: "speed", x, y, color: "#000" }]} />);
    expect(Math.max(...yTicks(host))).toBeGreaterThanOrEqual(10);
    expect(host.querySelector("[data-clamped]")).toBeNull();
  });
});
