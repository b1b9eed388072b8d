// E2E of the views (issue #11 items 3, 4, 6, 7): the 3D workspace tab, schema forms in the
// inspector, the mask canvas's CAM tools, ARIA tabs and axe-core on every tab of every example.
// WebGL renders through SwiftShader so the 3D screenshots (out/e2e/views-*.png) show the scene.
import assert from "node:assert/strict";
import { createRequire } from "node:module";
import path from "node:path";
import { after, before, test } from "node:test";
import { chromium } from "playwright-core";
import { OUT, api, expectRun, openRecipe, startBrowser, startServer } from "./harness.mjs";

const require = createRequire(import.meta.url);
const AXE = require.resolve("axe-core/axe.min.js");

let srv, browser;
before(async () => {
  srv = await startServer();
  browser = await chromium.launch({
    executablePath: process.env.CHROMIUM ?? "/usr/bin/chromium",
    args: ["--headless", "--no-sandbox", "--use-gl=angle", "--use-angle=swiftshader", "--enable-unsafe-swiftshader", "--ignore-gpu-blocklist",
      "--disable-background-networking", "--disable-component-update", "--disable-sync", "--no-first-run"],
  });
});
after(async () => {
  await browser?.close();
  await srv?.stop();
});

// SwiftShader draws the 3D scene in software: on a loaded machine a frame can take seconds.
const shot = (page, name) => page.screenshot({ path: path.join(OUT, `views-${name}.png`), timeout: 120_000 });

async function open(width, height, graph, on = browser) {
  const context = await on.newContext({ viewport: { width, height } });
  const page = await context.newPage();
  const errors = [];
  page.on("pageerror", (e) => errors.push(e.message));
  page.on("dialog", (d) => d.accept());
  await page.goto(srv.base + "/");
  await page.waitForSelector("[data-testid=palette] .palette-item", { timeout: 60_000 });
  if (graph) {
    await page.selectOption("[data-testid=open-graph]", graph);
    await page.waitForSelector(".react-flow__node");
  }
  return { page, context, errors };
}

/** The 3D state of this page's own view (one scene per browser tab, #25). */
const viewState = async (page) => api(srv.base, `/api/viewer/state?view=${await page.getAttribute("[data-testid=viewer3d]", "data-view")}`);

async function runToEnd(page) {
  const before = await page.getAttribute("[data-testid=progress]", "data-run-id");
  await page.click("[data-testid=run]");
  await page.waitForFunction((b) => {
    const el = document.querySelector("[data-testid=progress]");
    return el.getAttribute("data-run-id") !== b && ["done", "failed"].includes(el.getAttribute("data-phase"));
  }, before, { timeout: 180_000 });
  assert.equal(await page.getAttribute("[data-testid=progress]", "data-phase"), "done");
}

async function waitRunApi(id) {
  for (let i = 0; i < 1800; i++) {
    const r = await api(srv.base, `/api/runs/${id}`);
    if (["done", "failed", "cancelled"].includes(r.status)) return r;
    await new Promise((res) => setTimeout(res, 100));
  }
  throw new Error(`run ${id} did not end`);
}

test("3D tab: fills the window, shows the open recipe's run, node toggles, colour + legend, nothing over the scene", async () => {
  const { page, context, errors } = await open(1600, 1000, "rectangle-study");
  await runToEnd(page);
  await page.click("[data-tab=viewer]");
  await page.waitForSelector('[data-testid=viewer3d] [data-node="simulate"]', { timeout: 60_000 });
  const box = await page.locator("[data-testid=viewer]").boundingBox();
  assert.ok((box.width * box.height) / (1600 * 1000) >= 0.45, `iframe ${box.width}×${box.height} < 45 % of 1600×1000`);
  let st = await viewState(page);
  assert.equal(st.key, "rectangle-study");
  assert.deepEqual(st.nodes.map((n) => n.id), ["or", "mask", "strategy", "simulate"]);

  // Nothing covers the scene: viser's panel is folded, its notices (software WebGL) hidden.
  assert.match(await page.getAttribute("[data-testid=viewer]", "src"), /[?&]embedded(&|$)/);
  const frame = page.frames().find((f) => f !== page.mainFrame());
  assert.ok(frame, "the viewer frame is loaded");
  await frame.waitForSelector("canvas", { timeout: 30_000 });
  assert.equal(await frame.evaluate(() => document.documentElement.classList.contains("wf-embedded")), true);
  assert.equal(await frame.evaluate(() => [...document.querySelectorAll(".mantine-Notification-root, .mantine-Notifications-root")].some((n) => n.getBoundingClientRect().width > 0 && getComputedStyle(n).display !== "none")), false);
  const canvasBox = await frame.locator("canvas").first().boundingBox();
  assert.ok(canvasBox.width >= box.width * 0.85, `the scene canvas (${canvasBox.width} px) fills the frame (${box.width} px)`);

  // Per-node visibility and colour modes go to the viewer through the API.
  // force: under load SwiftShader renders the scene at seconds per frame, and Playwright's
  // "stable" check waits for animation frames; the checkbox itself is there and enabled.
  await page.locator('[data-node="mask"] input').uncheck({ force: true });
  await page.waitForFunction(async (base) => (await (await fetch(base + "/api/viewer/state?view=" + document.querySelector("[data-testid=viewer3d]").dataset.view)).json()).view.hidden.includes("mask"), srv.base);
  await page.selectOption("[data-testid=sim-color]", "deposit");
  await page.waitForFunction(() => /deposit per mm[\s\S]*mm³\/mm/.test(document.querySelector("[data-testid=viewer-legend]")?.textContent ?? ""), null, { polling: 250, timeout: 60_000 });
  st = await viewState(page);
  assert.equal(st.view.sim_color, "deposit");
  assert.ok(st.legend.some((l) => l.kind === "simulation" && l.ranges.deposit.unit === "mm³/mm" && l.ranges.deposit.lo > 0));
  await page.waitForTimeout(1500);
  await shot(page, "3d-1600");

  // Another recipe runs on the server: the open recipe's scene stays.
  const { id } = await api(srv.base, "/api/runs", { method: "POST", headers: { "content-type": "application/json" }, body: JSON.stringify({ graph: "mpp-cross" }) });
  assert.equal((await waitRunApi(id)).status, "done");
  await page.waitForTimeout(1500);
  st = await viewState(page);
  assert.equal(st.key, "rectangle-study");
  assert.ok(st.published.includes("mpp-cross"));

  // Layer range synced with the canvas layer.
  await page.selectOption("[data-testid=layer-mode]", "only");
  await page.waitForFunction(async (base) => {
    const s = await (await fetch(base + "/api/viewer/state?view=" + document.querySelector("[data-testid=viewer3d]").dataset.view)).json();
    return s.view.layer_lo === 0 && s.view.layer_hi === 0;
  }, srv.base);
  assert.deepEqual(errors, []);
  await context.close();

  // 1366×768: the same tab, opened on mpp-cross (run above): its scene is shown, and still ≥ 45 %.
  const small = await open(1366, 768, "mpp-cross");
  await small.page.click("[data-tab=viewer]");
  await small.page.waitForSelector('[data-testid=viewer3d] [data-node="zone"]', { timeout: 60_000 });
  const b2 = await small.page.locator("[data-testid=viewer]").boundingBox();
  assert.ok((b2.width * b2.height) / (1366 * 768) >= 0.45, `iframe ${b2.width}×${b2.height} < 45 % of 1366×768`);
  assert.equal((await viewState(small.page)).key, "mpp-cross");
  await small.page.waitForTimeout(2500);
  await shot(small.page, "3d-1366");
  await small.context.close();
});

test("inspector: strategy, zone and mesh transform are forms (no JSON), labelled by title, inside the window at 1366×768", async () => {
  const { page, context, errors } = await open(1366, 768, "mpp-cross");
  await page.click("[data-tab=mask]"); // the preview publishes the layer's section keys for the pickers
  await page.waitForSelector('[data-path="bs1/C"]', { timeout: 60_000 });
  await page.click("[data-tab=graph]");
  const insideWindow = async (what) => {
    const bad = await page.evaluate(() =>
      [...document.querySelectorAll("[data-testid=inspector] input:not([type=file]), [data-testid=inspector] select, [data-testid=inspector] button, [data-testid=inspector] textarea")]
        .filter((e) => e.getClientRects().length)
        .map((e) => [e.id || e.getAttribute("aria-label") || e.textContent, e.getBoundingClientRect().right])
        .filter(([, r]) => r > window.innerWidth),
    );
    assert.deepEqual(bad, [], `${what}: controls past the window's right edge`);
  };
  for (const id of ["strategy", "zone", "part", "mask", "guide"]) {
    await page.click(`.react-flow__node[data-id="${id}"]`);
    await page.waitForSelector(`[data-testid=inspector] h3:has-text("${id === "part" ? "mesh" : id}")`);
    assert.equal(await page.locator("[data-testid=inspector] textarea").count(), 0, `${id}: no JSON textarea`);
    const text = await page.locator("[data-testid=inspector]").innerText();
    assert.doesNotMatch(text, /SectionStrategy|ZoneSpecParams|TransformParams|Override/, `${id}: class names as labels`);
    await insideWindow(id);
    await shot(page, `inspector-${id}`);
  }
  // mesh transform: translate / rotate as x, y, z inputs
  await page.click('.react-flow__node[data-id="part"]');
  await page.waitForSelector('[data-testid=inspector] [data-field="translate"]');
  assert.equal(await page.locator('[data-testid=inspector] [data-field="translate"] input').count(), 3);
  // strategy: section picker lists the previewed layer's sections; a section's speed edits the recipe
  await page.click('.react-flow__node[data-id="strategy"]');
  const picker = page.locator('[data-testid=inspector] [data-field="sections"] .map-picker select');
  const keys = await picker.locator("option").evaluateAll((os) => os.map((o) => o.value));
  for (const k of ["bs1/A", "bs1/B", "bs1/C"]) assert.ok(keys.includes(k), `section ${k} offered (got ${keys})`);
  await picker.selectOption("bs1/B");
  await page.fill('[data-testid=inspector] [data-section="bs1/B"] [data-field="speed"] input', "7.5");
  await page.click("[data-tab=mask]");
  await page.click('[data-tab=graph]');
  await page.click('.react-flow__node[data-id="strategy"]');
  await picker.selectOption("bs1/B");
  assert.equal(await page.inputValue('[data-testid=inspector] [data-section="bs1/B"] [data-field="speed"] input'), "7.5");
  // the override's pattern is a select with the default's patterns
  assert.ok((await page.locator('[data-testid=inspector] [data-section="bs1/B"] [data-field="pattern"] option').count()) >= 8);
  // zone: split points of a section as a table
  await page.click('.react-flow__node[data-id="zone"]');
  const zp = page.locator('[data-testid=inspector] [data-field="sections"] .map-picker select');
  await zp.selectOption("bs1/A");
  assert.ok(await page.locator('[data-testid=inspector] [data-section="bs1/A"] [data-field="split_points"] table').count());
  assert.deepEqual(errors, []);
  await context.close();
});

test("mask canvas: colour by speed with legend, bead width, cursor coordinates, measure, keyboard", async () => {
  const { page, context, errors } = await open(1366, 768, "mpp-cross");
  await page.click("[data-tab=mask]");
  await page.waitForSelector('[data-path="bs1/C"]', { timeout: 60_000 });
  // bead width from the strategy (6 mm in the MPP study)
  assert.deepEqual(await page.locator(".section-path").evaluateAll((gs) => gs.map((g) => Number(g.getAttribute("data-bead")))), [6, 6, 6]);
  assert.ok(await page.locator(".section-path path.bead").count());
  assert.equal(await page.locator(".section-path path.bead").first().evaluate((p) => getComputedStyle(p).strokeWidth), "6px");
  await page.selectOption("[data-testid=color-by]", "speed");
  await page.waitForFunction(() => /mm\/s/.test(document.querySelector("[data-testid=canvas-legend]")?.textContent ?? ""));
  const colours = await page.locator('.section-path path.arc-on').evaluateAll((ps) => new Set(ps.map((p) => p.style.stroke)).size);
  assert.ok(colours >= 1);

  // measure two points: the readout equals the distance between the cursor coordinates shown
  const box = await page.locator("[data-testid=mask-canvas]").boundingBox();
  await page.click("[data-tool=measure]");
  await page.fill('.mask-toolbar input[type=number]', "0"); // grid off: the points are where the mouse is
  const read = async (x, y) => {
    await page.mouse.move(box.x + x, box.y + y);
    const t = await page.textContent("[data-testid=cursor-coords]");
    const m = t.match(/x (-?[\d.]+)\s+y (-?[\d.]+)/);
    return [Number(m[1]), Number(m[2])];
  };
  await page.locator('.mask-toolbar input[type=checkbox]').first().uncheck(); // no vertex snapping
  const a = await read(100, 400);
  await page.mouse.click(box.x + 100, box.y + 400);
  const b = await read(400, 150);
  await page.mouse.click(box.x + 400, box.y + 150);
  const txt = await page.textContent("[data-testid=measure-readout]");
  const d = Number(txt.match(/distance ([\d.]+) mm/)[1]);
  const ang = Number(txt.match(/angle (-?[\d.]+)°/)[1]);
  assert.ok(Math.abs(d - Math.hypot(b[0] - a[0], b[1] - a[1])) < 0.03, `${d} vs ${a} → ${b}`);
  assert.ok(Math.abs(ang - (Math.atan2(b[1] - a[1], b[0] - a[0]) * 180) / Math.PI) < 0.1);
  await shot(page, "mask-measure");
  await page.keyboard.press("Escape");
  assert.equal(await page.locator("[data-testid=measure]").count(), 0);

  // keyboard: layer up, pick a section and a vertex, nudge it right by 1 mm, tools by letter
  await page.fill('.mask-toolbar input[type=number]', "1");
  await page.locator("[data-testid=mask-canvas]").focus();
  await page.keyboard.press("PageUp");
  await page.waitForFunction(() => document.querySelector(".mask-panel .layer-row input[type=number], .mask-panel input[type=number]")?.value === "1");
  await page.keyboard.press("v");
  await page.keyboard.press("}");
  await page.keyboard.press("]");
  const vtx = page.locator(".mask-canvas .vertex.picked");
  await vtx.waitFor();
  const cx0 = Number(await vtx.getAttribute("cx"));
  await page.keyboard.press("ArrowRight");
  await page.waitForFunction((c) => Number(document.querySelector(".mask-canvas .vertex.picked")?.getAttribute("cx")) !== c, cx0);
  assert.ok(Math.abs(Number(await vtx.getAttribute("cx")) - cx0 - 1) < 1e-6);
  await page.keyboard.press("m");
  assert.equal(await page.getAttribute("[data-tool=measure]", "class"), "active");
  await page.keyboard.press("v");
  assert.deepEqual(errors, []);
  await context.close();
});

test("tabs are ARIA tabs with arrow keys; axe finds no critical/serious violation on any tab of any example", async () => {
  const graphs = (await api(srv.base, "/api/graphs")).map((g) => g.name);
  assert.ok(graphs.length >= 5);
  // axe needs no WebGL: a browser without it keeps the 3D tab from rendering in software meanwhile
  const plain = await startBrowser();
  const { page, context } = await open(1366, 768, undefined, plain);
  const tabs = await page.locator('[role=tablist] [role=tab]').evaluateAll((ts) => ts.map((t) => t.getAttribute("data-tab")));
  assert.deepEqual(tabs, ["graph", "mask", "params", "results", "viewer"]);
  await page.locator("[role=tab][aria-selected=true]").focus();
  await page.keyboard.press("ArrowRight");
  assert.equal(await page.getAttribute("[role=tab][aria-selected=true]", "data-tab"), "mask");
  assert.equal(await page.evaluate(() => document.activeElement?.getAttribute("data-tab")), "mask");
  await page.keyboard.press("End");
  assert.equal(await page.getAttribute("[role=tab][aria-selected=true]", "data-tab"), "viewer");
  assert.equal(await page.getAttribute("#panel-viewer", "aria-labelledby"), "tab-viewer");
  assert.equal(await page.locator("h1").count(), 1);

  const found = [];
  const axeTabs = async (g) => {
    for (const t of tabs) {
      await page.click(`[data-tab=${t}]`);
      await page.waitForTimeout(t === "mask" ? 1500 : 400);
      if (!(await page.evaluate(() => "axe" in window))) await page.addScriptTag({ path: AXE });
      const res = await page.evaluate(async () => {
        const r = await window.axe.run(document, { iframes: false, resultTypes: ["violations"] });
        return r.violations.filter((v) => v.impact === "critical" || v.impact === "serious")
          .map((v) => `${v.id} (${v.impact}): ${v.nodes.slice(0, 3).map((n) => n.target.join(" ")).join(" | ")}`);
      });
      for (const v of res) found.push(`${g}/${t}: ${v}`);
    }
  };
  for (const g of graphs) {
    await page.click("[data-tab=graph]");
    await openRecipe(page, srv.base, g);
    await axeTabs(g);
  }
  // #25 fault 11: after a run too (progress bar "done 100%", preflight badge, results and plots)
  await page.click("[data-tab=graph]");
  await openRecipe(page, srv.base, "rectangle-study");
  await expectRun(page, srv.base, "done");
  await axeTabs("rectangle-study after a run");
  await context.close();
  await plain.close();
  assert.deepEqual(found, []);
});

test("3D tab after a server restart: the open recipe's last run is rebuilt from the store; every colour mode has its legend", async () => {
  const runs = await api(srv.base, "/api/runs?limit=100");
  const last = runs.find((r) => r.graph === "rectangle-study" && r.status === "done");
  assert.ok(last, "rectangle-study ran before the restart");
  const data = srv.data;
  await srv.stop({ keep: true });
  srv = await startServer({ data }); // the same store and cache; the viewer's scenes are gone
  assert.deepEqual((await api(srv.base, "/api/viewer/state")).published, []);
  const { page, context, errors } = await open(1600, 1000, "rectangle-study");
  await page.evaluate(() => {
    window.__runLines = [];
    new MutationObserver(() => {
      const t = document.querySelector("[data-testid=viewer-run]")?.textContent;
      if (t && window.__runLines.at(-1) !== t) window.__runLines.push(t);
    }).observe(document.body, { subtree: true, childList: true, characterData: true });
  });
  await page.click("[data-tab=viewer]");
  await page.waitForFunction((id) => {
    const el = document.querySelector("[data-testid=viewer-run]");
    return el?.dataset.run === id && !el.dataset.loading;
  }, last.id, { timeout: 120_000, polling: 250 });
  assert.equal(await page.innerText("[data-testid=viewer-run]"), `Latest run of rectangle-study (run ${last.id})`);
  const lines = await page.evaluate(() => window.__runLines);
  assert.ok(!lines.some((l) => /No run of/.test(l)), `never "no run yet": ${lines.join(" | ")}`);
  console.log(`# 3D panel lines after the restart: ${lines.join(" | ")}`);
  const st = await viewState(page);
  assert.equal(st.run, last.id);
  assert.equal(st.loading, null);
  assert.deepEqual(st.nodes.map((n) => n.id), ["or", "mask", "strategy", "simulate"]);

  // Every colour mode of the toolpath and of the simulated path draws its legend (with units).
  const legend = () => page.innerText("[data-testid=viewer-legend]");
  const modes = [
    ["path-color", "zone", /strategy — toolpath by zone/],
    ["path-color", "speed", /strategy — toolpath by speed[\s\S]*mm\/s/],
    ["path-color", "arc", /toolpath by arc[\s\S]*arc on[\s\S]*arc off/],
    ["path-color", "section", /toolpath by section[\s\S]*one colour per section/],
    ["sim-color", "deviation", /simulated path by deviation[\s\S]*\d mm\b/],
    ["sim-color", "speed", /simulated path by speed[\s\S]*mm\/s/],
    ["sim-color", "deposit", /simulated path by deposit per mm[\s\S]*mm³\/mm/],
  ];
  for (const [sel, mode, want] of modes) {
    await page.selectOption(`[data-testid=${sel}]`, mode);
    // polled on a timer: animation frames stall while SwiftShader draws the scene on a busy machine
    await page.waitForFunction(([, src]) => new RegExp(src).test(document.querySelector("[data-testid=viewer-legend]")?.innerText ?? ""), [mode, want.source], { polling: 250, timeout: 60_000 });
    assert.match(await legend(), want);
  }
  // programmed (near black, thin) vs simulated (colour map) vs toolpath (wide): the legend names them
  assert.match(await legend(), /programmed/);
  await page.selectOption("[data-testid=path-color]", "speed");
  await page.selectOption("[data-testid=sim-color]", "deviation");
  await page.click("[data-testid=fit-part]", { force: true }); // rAF stalls under SwiftShader load (see above)
  await page.waitForTimeout(2500);
  await shot(page, "3d-restart-1600");
  assert.deepEqual(errors, []);
  await context.close();
});
