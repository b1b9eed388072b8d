// E2E of issue #25 faults 6 and 9: one 3D scene per browser tab (two browser contexts on one
// server open different recipes in the 3D tab; each sees its own scene, neither is stuck on
// "Loading…", playback and colours stay per tab), and the 3D tab's state (layer range, colour)
// survives leaving the tab.
import assert from "node:assert/strict";
import { after, before, test } from "node:test";
import { api, startBrowser, startServer } from "./harness.mjs";

// Under load the viser page in the iframe (software WebGL) can hold the page's thread for seconds.
const T = { timeout: 120_000 };

let srv, browser;
before(async () => {
  srv = await startServer();
  browser = await startBrowser();
  // both recipes ran once on the server (the 3D tab shows a recipe's latest run)
  for (const graph of ["mpp-cross", "rectangle-study"]) {
    const { id } = await api(srv.base, "/api/runs", { method: "POST", headers: { "content-type": "application/json" }, body: JSON.stringify({ graph }) });
    for (let i = 0; i < 1800; i++) {
      const r = await api(srv.base, `/api/runs/${id}`);
      if (r.status === "done") break;
      assert.ok(!["failed", "cancelled"].includes(r.status), `${graph}: ${JSON.stringify(r.error)}`);
      await new Promise((res) => setTimeout(res, 100));
    }
  }
});
after(async () => {
  await browser?.close();
  await srv?.stop();
});

async function open3d(graph) {
  const context = await browser.newContext({ viewport: { width: 1366, height: 768 } });
  const page = await context.newPage();
  const errors = [];
  page.on("pageerror", (e) => errors.push(e.message));
  await page.goto(`${srv.base}/?graph=${graph}`);
  page.setDefaultTimeout(120_000);
  await page.waitForSelector(".react-flow__node", T);
  await page.click("[data-tab=viewer]");
  return { page, context, errors };
}

const viewOf = (page) => page.getAttribute("[data-testid=viewer3d]", "data-view");
const stateOf = async (page) => api(srv.base, `/api/viewer/state?view=${encodeURIComponent(await viewOf(page))}`);
const runLine = (page) => page.innerText("[data-testid=viewer-run]");
async function shows(page, graph) {
  await page.waitForFunction((g) => (document.querySelector("[data-testid=viewer-run]")?.textContent ?? "").startsWith(`Latest run of ${g}`), graph, { ...T, polling: 250 });
}

test("two browser sessions, two recipes in the 3D tab: each sees its own scene, playback and colours", async () => {
  const a = await open3d("mpp-cross");
  await shows(a.page, "mpp-cross");
  const b = await open3d("rectangle-study");
  await shows(b.page, "rectangle-study");
  await a.page.waitForTimeout(2000); // tab a polls the server meanwhile
  assert.match(await runLine(a.page), /^Latest run of mpp-cross/);
  assert.match(await runLine(b.page), /^Latest run of rectangle-study/);

  const [va, vb] = [await viewOf(a.page), await viewOf(b.page)];
  assert.ok(va && vb && va !== vb, `two views: ${va} ${vb}`);
  const [sa, sb] = [await stateOf(a.page), await stateOf(b.page)];
  assert.equal(sa.key, "mpp-cross");
  assert.equal(sb.key, "rectangle-study");
  assert.deepEqual(sb.nodes.map((n) => n.id), ["or", "mask", "strategy", "simulate"]);
  assert.ok(sa.nodes.some((n) => n.id === "zone") && !sb.nodes.some((n) => n.id === "zone"));
  assert.equal(sa.layers.hi - sa.layers.lo + 1, 8, "mpp-cross: 8 layers");
  assert.notDeepEqual(sa.layers, sb.layers);
  // each browser's viser client is attached to its own view
  await a.page.waitForFunction(async ([base, v]) => (await (await fetch(`${base}/api/viewer/state?view=${v}`)).json()).attached, [srv.base, va], { ...T, polling: 500 });
  await b.page.waitForFunction(async ([base, v]) => (await (await fetch(`${base}/api/viewer/state?view=${v}`)).json()).attached, [srv.base, vb], { ...T, polling: 500 });

  // colour and playback in b stay in b
  await b.page.selectOption("[data-testid=sim-color]", "deposit");
  await b.page.waitForFunction(async ([base, v]) => (await (await fetch(`${base}/api/viewer/state?view=${v}`)).json()).view.sim_color === "deposit", [srv.base, vb], { ...T, polling: 250 });
  await b.page.locator("[data-testid=viewer-time]").fill(String(((await stateOf(b.page)).duration_s * 0.5).toFixed(1)));
  await b.page.waitForFunction(async ([base, v]) => (await (await fetch(`${base}/api/viewer/state?view=${v}`)).json()).view.time_s > 0, [srv.base, vb], { ...T, polling: 250 });
  const after = await stateOf(a.page);
  assert.equal(after.view.sim_color, "deviation");
  assert.equal(after.view.time_s, 0);
  assert.equal(after.key, "mpp-cross");
  assert.deepEqual([...a.errors, ...b.errors], []);
  await a.context.close();
  await b.context.close();
});

test("the 3D tab keeps its layer range and colours when the user leaves the tab and comes back", async () => {
  const { page, context, errors } = await open3d("mpp-cross");
  await shows(page, "mpp-cross");
  await page.selectOption("[data-testid=layer-mode]", "custom");
  await page.locator("[data-testid=layer-from]").fill("2");
  await page.locator("[data-testid=layer-to]").fill("5");
  await page.selectOption("[data-testid=path-color]", "speed");
  await page.waitForFunction(async ([base, v]) => {
    const s = await (await fetch(`${base}/api/viewer/state?view=${v}`)).json();
    return s.view.layer_lo === 2 && s.view.layer_hi === 5 && s.view.path_color === "speed";
  }, [srv.base, await viewOf(page)], { ...T, polling: 250 });
  await page.click("[data-tab=graph]");
  await page.waitForTimeout(500);
  await page.click("[data-tab=viewer]");
  await shows(page, "mpp-cross");
  await page.waitForTimeout(1500);
  assert.equal(await page.inputValue("[data-testid=layer-mode]"), "custom");
  assert.equal(await page.inputValue("[data-testid=layer-from]"), "2");
  assert.equal(await page.inputValue("[data-testid=layer-to]"), "5");
  assert.equal(await page.inputValue("[data-testid=path-color]"), "speed");
  const st = await stateOf(page);
  assert.deepEqual([st.view.layer_lo, st.view.layer_hi, st.view.path_color], [2, 5, "speed"]);
  assert.match(await page.innerText("[data-testid=viewer-layers]"), /layers 2–5 of 0–7/);
  assert.deepEqual(errors, []);
  await context.close();
});
