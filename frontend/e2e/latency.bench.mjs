// GUI latency under a heavy recipe (#30 item 4): the 300-layer bracket (graphs/bracket.json) on the
// 2D canvas at layer 150; each edit (a section's end length changed in the side panel, or a vertex
// of its mask curve nudged with the arrow keys) is timed from the edit to the frame that shows the
// re-planned layer (the app's `window.__waamflowReplanMs`, also the performance measure
// "waamflow:edit-to-canvas"). Beside it, the server's own time for the same previews (the
// response's `ms`), so the GUI's share can be told from the re-plan's.
//
// Not a test (not *.e2e.mjs: `make test` does not run it); `make bench` runs it through
// bench/bench_gui.py. Alone: `node frontend/e2e/latency.bench.mjs` (serves frontend/dist, or
// WAAMFLOW_STATIC_DIR); writes out/bench/gui_latency.json and prints it.
import { mkdirSync, writeFileSync } from "node:fs";
import path from "node:path";
import { ROOT, openPage, openRecipe, startBrowser, startServer } from "./harness.mjs";

const RECIPE = "bracket";
const LAYER = Number(process.env.GUI_BENCH_LAYER ?? 150);
const EDITS = Math.max(10, Number(process.env.GUI_BENCH_EDITS ?? 12));
const median = (xs) => {
  const s = [...xs].sort((a, b) => a - b);
  return s.length % 2 ? s[(s.length - 1) / 2] : (s[s.length / 2 - 1] + s[s.length / 2]) / 2;
};

/** Make `edit`, wait for the canvas to show its re-plan; the app's edit → canvas time, ms. The
 * edit's start (epoch ms) goes to `starts` (from the app's performance measure). */
async function timedEdit(page, edit, starts) {
  await page.evaluate(() => {
    window.__waamflowReplanMs = [];
    performance.clearMeasures("waamflow:edit-to-canvas");
  });
  await edit();
  await page.waitForFunction(() => (window.__waamflowReplanMs ?? []).length > 0, null, { timeout: 60_000 });
  const [ms, start] = await page.evaluate(() => [
    window.__waamflowReplanMs[0],
    performance.timeOrigin + (performance.getEntriesByName("waamflow:edit-to-canvas")[0]?.startTime ?? NaN),
  ]);
  starts.push(start);
  return ms;
}

async function main() {
  const [srv, browser] = await Promise.all([startServer(), startBrowser()]);
  try {
    const { page, errors } = await openPage(browser, srv.base);
    // The server's time of each canvas preview (the layer with coverage; ghosts are asked without)
    // and the request's wall time in the browser (sent → last byte).
    const serverMs = [], httpMs = [], sentAt = [];
    page.on("requestfinished", async (q) => {
      if (!q.url().endsWith("/api/preview") || q.method() !== "POST") return;
      try {
        if (JSON.parse(q.postData() ?? "{}").coverage !== true) return;
        const t = q.timing();
        const body = await (await q.response()).json();
        if (typeof body.ms === "number") serverMs.push(body.ms);
        if (t.responseEnd > 0) httpMs.push(t.responseEnd);
        sentAt.push(t.startTime);
      } catch {
        /* an aborted (superseded) preview has no body */
      }
    });
    await openRecipe(page, srv.base, RECIPE);
    await page.click("[data-tab=mask]");
    const t0 = Date.now();
    await page.fill('input[aria-label="layer index"]', String(LAYER));
    await page.waitForFunction(
      (layer) => {
        const svg = document.querySelector("[data-testid=mask-canvas]");
        return svg?.getAttribute("aria-label")?.includes(`layer ${layer}:`) && Number(svg.getAttribute("data-paths")) > 0;
      },
      LAYER,
      { timeout: 300_000 },
    );
    const firstMs = Date.now() - t0;
    const key = await page.getAttribute("[data-section-item]", "data-section-item");
    const points = Number(await page.getAttribute("[data-testid=mask-canvas]", "data-path-points"));
    const endInput = `[data-testid="end-${key}"]`;
    const before = Number((await page.inputValue(endInput)) || 10);
    const param = [], vertex = [], editStarts = [];
    for (let i = 0; i < EDITS; i++) {
      if (i % 2 === 0) {
        // a parameter: the section's end-zone length, a value not used before at every edit (no
        // cache or memo of an earlier state serves the preview: a user's edits are mostly new)
        const v = before + 2 + i;
        param.push(await timedEdit(page, async () => {
          await page.fill(endInput, String(v));
          await page.press(endInput, "Enter");
        }, editStarts));
      } else {
        // a mask point: pick the section's first curve vertex, nudge it 1 mm right (a new shape each time)
        await page.evaluate(() => document.activeElement?.blur());
        await page.click(`[data-section-item="${key}"] b`);
        if (i === 1) await page.keyboard.press("]");
        vertex.push(await timedEdit(page, () => page.keyboard.press("ArrowRight"), editStarts));
      }
    }
    const all = [...param, ...vertex];
    const edits = serverMs.slice(-all.length), http = httpMs.slice(-all.length);
    // edit → preview request sent (the app's state update and render before its fetch), per edit
    const sent = sentAt.slice(-all.length);
    const toSend = editStarts.map((t, i) => sent[i] - t).filter(Number.isFinite);
    const out = {
      name: "gui_edit_to_canvas_ms_median",
      recipe: RECIPE,
      layer: LAYER,
      section: key,
      path_points: points,
      unit: "ms",
      median: median(all),
      max: Math.max(...all),
      param_median: median(param),
      vertex_median: median(vertex),
      server_ms_median: edits.length ? median(edits) : null,
      http_ms_median: http.length ? median(http) : null,
      edit_to_request_ms_median: toSend.length ? median(toSend) : null,
      first_layer_ms: firstMs,
      samples: all,
      console_errors: errors,
    };
    const dir = path.join(ROOT, "out/bench");
    mkdirSync(dir, { recursive: true });
    writeFileSync(path.join(dir, "gui_latency.json"), JSON.stringify(out, null, 1));
    console.log(JSON.stringify(out));
  } finally {
    await browser.close();
    await srv.stop();
  }
}

await main();
