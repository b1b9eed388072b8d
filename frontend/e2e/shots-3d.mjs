// Screenshots of the 3D tab (not a test): both curved examples at 0 %, 75 % and 100 % playback,
// 1600×1000 and 1366×768, after "Fit part" at that time — to look at the camera fit.
//   SKIP_BUILD=1 node e2e/shots-3d.mjs   → out/e2e/3d-<recipe>-<w>-<pct>.png
import path from "node:path";
import { chromium } from "playwright-core";
import { OUT, api, startServer } from "./harness.mjs";

const srv = await startServer();
const browser = await chromium.launch({
  executablePath: process.env.CHROMIUM ?? "/usr/bin/chromium",
  args: ["--headless", "--no-sandbox", "--use-gl=angle", "--use-angle=swiftshader", "--enable-unsafe-swiftshader", "--ignore-gpu-blocklist"],
});
const recipes = (process.env.RECIPES ?? "curved-duct,curved-bracket").split(",");
const shots = [];
try {
  for (const graph of recipes) {
    const { id } = await api(srv.base, "/api/runs", { method: "POST", headers: { "content-type": "application/json" }, body: JSON.stringify({ graph }) });
    for (;;) {
      const r = await api(srv.base, `/api/runs/${id}`);
      if (r.status === "done") break;
      if (["failed", "cancelled"].includes(r.status)) throw new Error(`${graph}: ${JSON.stringify(r.error)}`);
      await new Promise((res) => setTimeout(res, 500));
    }
    for (const [w, h] of [[1600, 1000], [1366, 768]]) {
      const context = await browser.newContext({ viewport: { width: w, height: h } });
      const page = await context.newPage();
      page.setDefaultTimeout(180_000);
      await page.goto(`${srv.base}/?graph=${graph}`);
      await page.waitForSelector(".react-flow__node");
      await page.click("[data-tab=viewer]");
      await page.waitForFunction((g) => (document.querySelector("[data-testid=viewer-run]")?.textContent ?? "").startsWith(`Latest run of ${g}`), graph, { polling: 500 });
      const view = await page.getAttribute("[data-testid=viewer3d]", "data-view");
      const state = () => api(srv.base, `/api/viewer/state?view=${view}`);
      for (let i = 0; i < 240 && !(await state()).attached; i++) await page.waitForTimeout(500);
      const dur = (await state()).duration_s;
      for (const pct of [0, 75, 100]) {
        await api(srv.base, "/api/viewer/view", { method: "POST", headers: { "content-type": "application/json" }, body: JSON.stringify({ view, time_s: (dur * pct) / 100, fit: "part" }) });
        await page.waitForTimeout(4000);
        const file = path.join(OUT, `3d-${graph}-${w}-${pct}.png`);
        await page.screenshot({ path: file, timeout: 180_000 });
        const st = await state();
        shots.push({ file, camera: st.camera, has_cell: st.has_cell, time_s: st.view.time_s });
        console.log(file, JSON.stringify(st.camera), st.has_cell);
      }
      await context.close();
    }
  }
} finally {
  await browser.close();
  await srv.stop();
}
