// End-to-end tests of #25 "GUI state you can trust", faults 4, 5, 7, 8 and 11: two sessions saving
// one recipe, same-name uploads, a new mask from a failed layer, results after reopening, stale
// problem badges, mask fields at 1366×768 and the 3D viewer page's cache header.
// Run: `node e2e/run.mjs e2e/trust.e2e.mjs` (after `npm run build`, or SKIP_BUILD=1 to skip it).
import assert from "node:assert/strict";
import { after, before, test } from "node:test";
import { api, boxesStl, expectRun, openPage, openRecipe, saveAs, shot, startBrowser, startServer } from "./harness.mjs";

let srv, browser;
before(async () => {
  [srv, browser] = await Promise.all([startServer(), startBrowser()]);
});
after(async () => {
  await browser?.close();
  await srv?.stop();
});

const json = (body) => ({ method: "PUT", headers: { "Content-Type": "application/json" }, body: JSON.stringify(body) });

/** A saved copy of a shipped example (recipe and parameter XML), made through the API. */
async function copyOf(example, name) {
  const r = await api(srv.base, `/api/graphs/${example}`);
  await api(srv.base, `/api/graphs/${name}`, json({ ...r, name }));
  const xml = await fetch(`${srv.base}/api/graphs/${example}/params`);
  if (xml.ok) await api(srv.base, `/api/graphs/${name}/params`, { method: "PUT", headers: { "Content-Type": "application/xml" }, body: await xml.text() });
}

async function openGraph(page, name, tab) {
  await page.goto(`${srv.base}/?graph=${encodeURIComponent(name)}${tab ? `&tab=${tab}` : ""}`);
  await page.waitForSelector(`.toolbar .title:text-is("${name}")`, { timeout: 60_000 });
  await page.waitForSelector(".react-flow__node", { state: "attached" });
}

const nodeIds = (page) => page.locator(".react-flow__node").evaluateAll((ns) => ns.map((n) => n.getAttribute("data-id")).sort());

async function deleteNode(page, id) {
  const n = (await nodeIds(page)).length;
  await page.click(`.react-flow__node[data-id="${id}"]`);
  await page.keyboard.press("Delete");
  await page.waitForFunction((k) => document.querySelectorAll(".react-flow__node").length === k, n - 1);
}

test("fault 4: two sessions save the same recipe; the second gets the conflict dialog, reload shows the first's change", async () => {
  await copyOf("mpp-cross", "trust-two");
  const a = await openPage(browser, srv.base);
  const b = await openPage(browser, srv.base);
  await openGraph(a.page, "trust-two");
  await openGraph(b.page, "trust-two");
  const rev0 = (await api(srv.base, "/api/graphs/trust-two/revisions"))[0].revision;
  await deleteNode(a.page, "post");
  await deleteNode(b.page, "sequence");
  await a.page.click("[data-testid=save]");
  await a.page.waitForFunction(() => document.querySelector("[data-testid=save]")?.textContent === "save");
  assert.equal((await api(srv.base, "/api/graphs/trust-two/revisions"))[0].revision, rev0 + 1);
  await b.page.click("[data-testid=save]");
  await b.page.waitForSelector("[data-testid=conflict-dialog]");
  assert.match(await b.page.innerText("[data-testid=conflict-dialog]"), new RegExp(`revision ${rev0 + 1}`));
  await b.page.setViewportSize({ width: 1600, height: 1000 });
  await shot(b.page, "trust-01-conflict-1600");
  await b.page.setViewportSize({ width: 1366, height: 768 });
  await shot(b.page, "trust-01-conflict-1366");
  // the second session's save changed nothing
  const stored = await api(srv.base, "/api/graphs/trust-two");
  assert.deepEqual(stored.nodes.map((n) => n.id).filter((id) => id === "post" || id === "sequence"), ["sequence"]);
  await b.page.click("text=Reload theirs (discard mine)");
  await b.page.waitForSelector("[data-testid=conflict-dialog]", { state: "detached" });
  await b.page.waitForFunction(() => !document.querySelector('.react-flow__node[data-id="post"]') && !!document.querySelector('.react-flow__node[data-id="sequence"]'));
  assert.equal(await b.page.locator("[data-testid=save]").innerText(), "save", "reloaded: clean");
  assert.deepEqual(await nodeIds(b.page), stored.nodes.map((n) => n.id).sort());
  assert.deepEqual([...a.errors, ...b.errors].filter((e) => !/status of 409/.test(e)), []);
  await a.context.close();
  await b.context.close();
});

/** A recipe whose one mask section fails where a second island appears (layer 3 at 1.5 mm), with a
 * strategy, a zone start length and a guide set for that section. */
async function islandsRecipe(name) {
  const stl = boxesStl([[-30, -6, 0, 30, 6, 9], [-30, 14, 4.5, 30, 20, 9]]);
  const recipe = {
    format: "waamflow/1", name, description: "two islands, the second from z 4.5 mm", inputs: {},
    nodes: [
      { id: "part", type: "mesh", params: { path: "islands.stl" } },
      { id: "layers", type: "slice", params: { layer_height: 1.5 } },
      { id: "mask", type: "mask", params: { masks: [{ id: "bs1", from_layer: 0, sections: [{ id: "A", curve: [[-34, -10], [34, -10], [34, 24], [-34, 24]] }] }] } },
      { id: "guide", type: "guide", params: { guides: { "bs1/A": [[-40, 0], [40, 0]] } } },
      { id: "strategy", type: "strategy", params: { default: { pattern: "raster", bead_width: 6, spacing: 5 }, sections: { "bs1/A": { pattern: "oscillate", bead_width: 6, step: 3 } } } },
      { id: "zone", type: "zone", params: { default: { start_length: 10, end_length: 10 }, sections: { "bs1/A": { start_length: 7, end_length: 9 } } } },
    ],
    edges: [
      { from: "part.mesh", to: "layers.mesh" }, { from: "layers.layers", to: "mask.layers" }, { from: "mask.sections", to: "guide.sections" },
      { from: "guide.sections", to: "strategy.sections" }, { from: "strategy.toolpath", to: "zone.toolpath" },
    ],
  };
  await api(srv.base, `/api/graphs/${name}`, json(recipe));
  await api(srv.base, `/api/graphs/${name}/files/islands.stl`, { method: "PUT", body: stl });
}

test("fault 7: new mask from the failed layer carries strategy, start length and guide over by overlap", async () => {
  await islandsRecipe("trust-islands");
  const { page, errors } = await openPage(browser, srv.base);
  await openGraph(page, "trust-islands");
  await expectRun(page, srv.base, "failed");
  await page.waitForSelector("[data-testid=failure-banner]");
  const [last] = await api(srv.base, "/api/runs?limit=1");
  const err = (await api(srv.base, `/api/runs/${last.id}`)).error;
  assert.equal(err.section, "bs1/A");
  assert.equal(err.layer, 3);
  const dialogs = [];
  page.on("dialog", (d) => dialogs.push(d.message()));
  await page.click("[data-testid=new-mask-from-layer]");
  await page.waitForSelector('[data-mask="bs2"]');
  const said = dialogs.find((m) => m.startsWith("New mask bs2 from layer 3"));
  assert.ok(said, `confirmation shown: ${dialogs}`);
  for (const line of ["guide · guides: bs1/A → bs2/A", "strategy · sections: bs1/A → bs2/A", "zone · sections: bs1/A → bs2/A"])
    assert.ok(said.includes(line), `${line} in:\n${said}`);
  assert.match(said, /Everything carried over/);
  await shot(page, "trust-02-new-mask-after-failure");
  // the carried settings are in the document (saved with it)
  await page.click("[data-testid=save]");
  await page.waitForFunction(() => document.querySelector("[data-testid=save]")?.textContent === "save");
  const r = await api(srv.base, "/api/graphs/trust-islands");
  const params = (id) => r.nodes.find((n) => n.id === id).params;
  assert.deepEqual(params("strategy").sections["bs2/A"], { pattern: "oscillate", bead_width: 6, step: 3 });
  assert.equal(params("zone").sections["bs2/A"].start_length, 7);
  assert.deepEqual(params("guide").guides["bs2/A"], [[-40, 0], [40, 0]]);
  assert.deepEqual(errors, []);
  await page.context().close();
});

test("fault 8: reopening a recipe shows its latest run's results, plots and preflight", async () => {
  await copyOf("rectangle-study", "trust-results");
  const { page, errors } = await openPage(browser, srv.base);
  await openGraph(page, "trust-results");
  await expectRun(page, srv.base, "done");
  const id = await page.getAttribute("[data-testid=progress]", "data-run-id");
  await page.click("[data-tab=results]");
  await page.waitForSelector("[data-testid=sim-metrics]");
  const metrics = await page.innerText("[data-testid=sim-metrics]");
  const badge = await page.innerText("[data-testid=preflight-badge]");
  const artifacts = await page.locator("[data-artifact]").count();
  assert.ok(artifacts >= 4, `artifacts listed: ${artifacts}`);
  // another recipe, then this one again (picked in the toolbar, and by a fresh page load)
  await openRecipe(page, srv.base, "mpp-cross");
  await page.waitForFunction(() => !document.querySelector("[data-testid=sim-metrics]"));
  await openRecipe(page, srv.base, "trust-results");
  await page.click("[data-tab=results]");
  await page.waitForSelector("[data-testid=sim-metrics]", { timeout: 30_000 });
  assert.equal(await page.innerText("[data-testid=sim-metrics]"), metrics);
  assert.equal(await page.locator("[data-artifact]").count(), artifacts);
  assert.match(await page.textContent("[data-testid=results] h4"), new RegExp(`run ${id} · done`));
  assert.equal(await page.innerText("[data-testid=preflight-badge]"), badge);
  assert.equal(await page.getAttribute("[data-testid=progress]", "data-run-id"), id);
  assert.equal(await page.locator("[data-testid=save]").innerText(), "save", "showing the results dirties nothing");
  await page.reload();
  await page.waitForSelector('.toolbar .title:text-is("trust-results")');
  await page.waitForSelector("[data-testid=sim-metrics]", { timeout: 30_000 });
  assert.equal(await page.innerText("[data-testid=preflight-badge]"), badge);
  await page.setViewportSize({ width: 1600, height: 1000 });
  await shot(page, "trust-03-results-after-reopen-1600");
  // a run of unsaved edits: reopened, its results show, its preflight marked out of date
  await page.click("[data-tab=graph]");
  await page.getByLabel("input length", { exact: true }).fill("40");
  await expectRun(page, srv.base, "done");
  const edited = await page.getAttribute("[data-testid=progress]", "data-run-id");
  await openRecipe(page, srv.base, "mpp-cross");
  await openRecipe(page, srv.base, "trust-results");
  await page.waitForFunction((r) => document.querySelector("[data-testid=progress]")?.getAttribute("data-run-id") === r, edited);
  await page.waitForSelector('[data-testid=preflight-badge][data-tone="stale"]');
  assert.deepEqual(errors, []);
  await page.context().close();
});

test("fault 11: a refused run's problem badge goes once the graph is fixed", async () => {
  await copyOf("mpp-cross", "trust-badge");
  const { page, errors } = await openPage(browser, srv.base);
  await openGraph(page, "trust-badge");
  await page.click('.react-flow__node[data-id="layers"]');
  const field = page.locator('[data-field="layer_height"] input').first();
  await field.fill("-1");
  await page.click("[data-testid=run]");
  await page.waitForSelector('.react-flow__node[data-id="layers"] [data-testid=problem-badge].errors');
  assert.match(await page.innerText("[data-testid=problem-count]"), /✖ 1/);
  await field.fill("1.5");
  await page.waitForFunction(() => !document.querySelector("[data-testid=problem-badge]"), null, { timeout: 5000 });
  assert.doesNotMatch(await page.innerText("[data-testid=problem-count]"), /✖/);
  assert.deepEqual(errors.filter((e) => !/status of 422/.test(e)), []);
  await page.context().close();
});

test("fault 11: mask layer fields show '100' whole at 1366×768", async () => {
  await copyOf("mpp-cross", "trust-fields");
  const { page, errors } = await openPage(browser, srv.base);
  await openGraph(page, "trust-fields", "mask");
  await page.waitForSelector("[data-testid=mask-canvas] .layer-poly");
  await page.click("[data-testid=new-mask]"); // a second mask row (from layer 0 → refused; pick layer 4 first)
  await page.fill(".mask-panel .layer-row input[type=number]", "4");
  await page.click("[data-testid=new-mask]");
  await page.waitForSelector('[data-mask="bs2"]');
  await page.fill('[aria-label="first layer of mask bs2"]', "100");
  await page.fill('[aria-label="layer index"]', "100");
  const sizes = await page.evaluate(() =>
    ['[aria-label="layer index"]', '[aria-label="first layer of mask bs1"]', '[aria-label="first layer of mask bs2"]'].map((s) => {
      const el = document.querySelector(s);
      return [s, el.value, el.scrollWidth, el.clientWidth];
    }));
  await shot(page, "trust-04-mask-fields-1366");
  for (const [sel, value, sw, cw] of sizes) assert.ok(sw <= cw, `${sel} (${value}): scrollWidth ${sw} > clientWidth ${cw}`);
  assert.equal(sizes[2][1], "100");
  assert.deepEqual(errors.filter((e) => !/status of 422/.test(e)), []);
  await page.context().close();
});

test("1366×768: after a run and an edit the toolbar stays in the window and the inspector in view", async () => {
  // the progress, problem count and 'preflight: re-run' badge made the toolbar 1,416 px wide, which
  // widened the page and pushed the inspector 50 px out of the window (its fields cut at the right)
  const { page, errors } = await openPage(browser, srv.base);
  await openRecipe(page, srv.base, "curved-duct");
  await expectRun(page, srv.base, "done");
  await page.click('.react-flow__node[data-id="sim"]');
  await page.selectOption("#sim-blend", { index: 1 });
  await page.waitForSelector("[data-testid=preflight-badge]:has-text('re-run')");
  const m = await page.evaluate(() => ({
    page: document.documentElement.scrollWidth,
    toolbar: document.querySelector(".toolbar").scrollWidth,
    inspector: document.querySelector("[data-testid=inspector]").getBoundingClientRect().right,
    window: window.innerWidth,
  }));
  await shot(page, "trust-05-toolbar-after-run-1366");
  assert.ok(m.page <= m.window && m.toolbar <= m.window, `page ${m.page}, toolbar ${m.toolbar} px in a ${m.window} px window`);
  assert.ok(m.inspector <= m.window, `the inspector ends at ${m.inspector} px, past the ${m.window} px window`);
  assert.deepEqual(errors, []);
  await page.context().close();
});

test("fault 11: the 3D viewer page is served with the hashed assets' cache header", async () => {
  const { page, errors } = await openPage(browser, srv.base);
  await openGraph(page, "rectangle-study", "viewer");
  const src = await page.getAttribute("[data-testid=viewer]", "src");
  const url = new URL(src, srv.base);
  const r = await fetch(url, { headers: { "Accept-Encoding": "gzip" } });
  assert.equal(r.status, 200);
  assert.equal(r.headers.get("cache-control"), "public, max-age=31536000, immutable");
  const body = await r.text();
  assert.ok(body.length > 100_000, `the viewer page: ${body.length} B`);
  // the same URL on the next visit (a new content hash only when viser's page changes)
  await page.click("[data-tab=graph]");
  await page.click("[data-tab=viewer]");
  assert.equal(await page.getAttribute("[data-testid=viewer]", "src"), src);
  assert.deepEqual(errors, []);
  await page.context().close();
});

test("fault 5: a same-name upload asks (cancel / replace / keep both); the recipe pins the content it runs with; undo runs the old geometry", async () => {
  const tall = boxesStl([[-30, -6, 0, 30, 6, 24]]); // 16 layers of 1.5 mm
  const low = boxesStl([[-30, -6, 0, 30, 6, 12]]); // 8 layers
  const recipe = {
    format: "waamflow/1", name: "trust-upload", description: "one box", inputs: {},
    nodes: [{ id: "part", type: "mesh", params: { path: "part.stl" } }, { id: "layers", type: "slice", params: { layer_height: 1.5 } }],
    edges: [{ from: "part.mesh", to: "layers.mesh" }],
  };
  await api(srv.base, "/api/graphs/trust-upload", json(recipe));
  await api(srv.base, "/api/graphs/trust-upload/files/part.stl", { method: "PUT", body: tall });
  const { page, errors } = await openPage(browser, srv.base);
  await openGraph(page, "trust-upload");
  const layers = async () => {
    const id = await page.getAttribute("[data-testid=progress]", "data-run-id");
    return (await api(srv.base, `/api/runs/${id}`)).summary.layer_count;
  };
  await expectRun(page, srv.base, "done");
  assert.equal(await layers(), 16);
  const versions = () => api(srv.base, "/api/graphs/trust-upload/files/part.stl/versions");
  assert.equal((await versions()).length, 1);
  const pick = () => page.setInputFiles('[data-field="path"] input[type=file]', { name: "part.stl", mimeType: "model/stl", buffer: Buffer.from(low) });
  await page.click('.react-flow__node[data-id="part"]');

  // cancel: nothing stored, nothing changed
  await pick();
  await page.waitForSelector("[data-testid=upload-dialog]");
  assert.match(await page.innerText("[data-testid=upload-dialog]"), /part\.stl.*already in this recipe/);
  await page.setViewportSize({ width: 1600, height: 1000 });
  await shot(page, "trust-05-upload-dialog-1600");
  await page.setViewportSize({ width: 1366, height: 768 });
  await shot(page, "trust-05-upload-dialog-1366");
  await page.click("[data-testid=upload-cancel]");
  await page.waitForSelector("[data-testid=upload-dialog]", { state: "detached" });
  assert.equal((await versions()).length, 1, "cancel stores nothing");
  assert.equal(await page.locator("[data-testid=save]").innerText(), "save");

  // replace: stored as a new version, the recipe unsaved and pinned to it; the run uses it
  await pick();
  await page.click("[data-testid=upload-replace]");
  await page.waitForFunction(() => document.querySelector("[data-testid=save]")?.textContent === "save *");
  const [v2, v1] = await versions();
  assert.equal(v2.version, 2);
  assert.equal(v2.size, low.length);
  await expectRun(page, srv.base, "done");
  assert.equal(await layers(), 8);
  // undo: the old content again (still stored, still what the saved recipe ran with)
  await page.click("[data-testid=undo]");
  await page.waitForFunction(() => document.querySelector("[data-testid=save]")?.textContent === "save");
  await expectRun(page, srv.base, "done");
  assert.equal(await layers(), 16, "undo of a replace runs the old geometry");
  const [last] = await api(srv.base, "/api/runs?graph=trust-upload&limit=1");
  const summary = (await api(srv.base, `/api/runs/${last.id}`)).summary;
  assert.ok(JSON.stringify(summary).includes(v1.sha256), "the run record names the content it used");
  // redo + save: the saved recipe pins the new content
  await page.click("[data-testid=redo]");
  await page.click("[data-testid=save]");
  await page.waitForFunction(() => document.querySelector("[data-testid=save]")?.textContent === "save");
  assert.deepEqual((await api(srv.base, "/api/graphs/trust-upload")).files, { "part.stl": v2.sha256 });

  // the same content again asks nothing; other content and "keep both": a free name, the node reads it
  await pick();
  await page.waitForFunction(async (base) => (await (await fetch(`${base}/api/graphs/trust-upload/files/part.stl/versions`)).json()).length === 3, srv.base);
  assert.equal(await page.locator("[data-testid=upload-dialog]").count(), 0);
  const tall2 = boxesStl([[-30, -6, 0, 30, 6, 3]]);
  await page.setInputFiles('[data-field="path"] input[type=file]', { name: "part.stl", mimeType: "model/stl", buffer: Buffer.from(tall2) });
  await page.click("[data-testid=upload-keep-both]");
  await page.waitForFunction(() => document.querySelector('[data-field="path"] input[type=text]')?.value === "part-2.stl");
  const files = (await api(srv.base, "/api/graphs/trust-upload/files")).map((f) => [f.name, f.size]);
  assert.deepEqual(files, [["part-2.stl", tall2.length], ["part.stl", low.length]]);
  await expectRun(page, srv.base, "done");
  assert.equal(await layers(), 2);
  // one undo takes the whole "keep both" back (pin and file name), redo brings it again
  await page.click("[data-testid=undo]");
  await page.waitForFunction(() => document.querySelector('[data-field="path"] input[type=text]')?.value === "part.stl");
  assert.equal(await page.locator("[data-testid=save]").innerText(), "save");
  await page.click("[data-testid=redo]");
  await page.waitForFunction(() => document.querySelector('[data-field="path"] input[type=text]')?.value === "part-2.stl");
  // "save as" takes the pinned uploads along (the exact content), so the copy runs the same
  await saveAs(page, "trust-upload-copy");
  const copied = (await api(srv.base, "/api/graphs/trust-upload-copy/files")).map((f) => [f.name, f.sha256]);
  const pins = (await api(srv.base, "/api/graphs/trust-upload-copy")).files;
  assert.deepEqual(Object.fromEntries(copied), pins);
  assert.equal(pins["part.stl"], v2.sha256);
  await expectRun(page, srv.base, "done");
  assert.equal(await layers(), 2);
  assert.deepEqual(errors, []);
  await page.context().close();
});
