// End-to-end tests of the GUI in headless Chromium against a real `waamflow serve`.
// Run: npm run test:e2e (builds the frontend first). Screenshots go to out/e2e/.
import assert from "node:assert/strict";
import { readFileSync, writeFileSync } from "node:fs";
import path from "node:path";
import { after, before, test } from "node:test";
import {
  OUT, api, boxesStl, expectRun, canvasPoint, clickAt, connect, drawClosed, drawOpen, openPage, openRecipe, saveAs, shot, startBrowser, startServer,
} from "./harness.mjs";

let srv, browser;
before(async () => {
  [srv, browser] = await Promise.all([startServer(), startBrowser()]);
});
after(async () => {
  await browser?.close();
  await srv?.stop();
});

const median = (xs) => [...xs].sort((a, b) => a - b)[Math.floor(xs.length / 2)];

/** Text of `<tag>` inside zone `zone` of section `section` of layer `layer` in the parameter XML. */
function xmlValue(xml, layer, section, zone, tag) {
  const l = xml.match(new RegExp(`<layer index="${layer}"[^>]*>([\\s\\S]*?)</layer>`))?.[1] ?? "";
  const s = l.match(new RegExp(`<section id="${section.replace("/", "\\/")}"[^>]*>([\\s\\S]*?)</section>`))?.[1] ?? "";
  const z = s.match(new RegExp(`<zone id="${zone}"[^>]*>([\\s\\S]*?)</zone>`))?.[1] ?? "";
  return z.match(new RegExp(`<${tag}[^>]*>([^<]*)</${tag}>`))?.[1] ?? (z.includes(`<${tag}`) ? "" : null);
}

/** Edit → re-planned canvas latency: make `edit` and wait for the canvas to report the re-plan. */
async function timedEdit(page, edit) {
  await page.evaluate(() => (window.__waamflowReplanMs = []));
  await edit();
  await page.waitForFunction(() => (window.__waamflowReplanMs ?? []).length > 0, null, { timeout: 10_000 });
  return page.evaluate(() => window.__waamflowReplanMs[0]);
}

test("mpp-cross: draw a mask curve and a guide, change a zone length, run, edit the XML", async () => {
  const { page, errors } = await openPage(browser, srv.base);
  await shot(page, "01-start");
  await page.selectOption("[data-testid=open-graph]", "mpp-cross");
  await page.waitForSelector('.react-flow__node[data-id="zone"]');
  const shipped = await api(srv.base, "/api/graphs/mpp-cross");
  assert.equal(await page.locator(".react-flow__node").count(), shipped.nodes.length);
  assert.equal(await page.locator(".react-flow__edge").count(), shipped.edges.length);
  await saveAs(page, "e2e-cross"); // work on a copy: the example stays as shipped
  await shot(page, "02-graph");
  await page.click('.react-flow__node[data-id="zone"]'); // a selected graph node must survive Delete on the canvas

  // Mask canvas: the three sections of the study with their paths.
  await page.click("[data-tab=mask]");
  await page.waitForSelector('[data-path="bs1/C"]');
  assert.equal(await page.getAttribute("[data-testid=mask-canvas]", "data-paths"), "3");
  await shot(page, "03-mask");
  // Pan (drag on empty space) and wheel zoom change the view, not the recipe.
  const vb = async () => (await page.getAttribute("[data-testid=mask-canvas]", "viewBox")).split(" ").map(Number);
  const v0 = await vb();
  const [ex, ey] = await canvasPoint(page, 40, 40); // outside the cross
  await page.mouse.move(ex, ey);
  await page.mouse.down();
  await page.mouse.move(ex + 60, ey + 30, { steps: 4 });
  await page.mouse.up();
  const v1 = await vb();
  assert.ok(v1[0] < v0[0] && v1[1] < v0[1] && Math.abs(v1[2] - v0[2]) < 1e-6, `panned ${v0} → ${v1}`);
  await page.mouse.wheel(0, -300);
  await page.waitForFunction((w) => Number(document.querySelector("[data-testid=mask-canvas]").getAttribute("viewBox").split(" ")[2]) < w, v1[2]);
  await page.keyboard.press("f");
  await page.waitForFunction((w) => Math.abs(Number(document.querySelector("[data-testid=mask-canvas]").getAttribute("viewBox").split(" ")[2]) - w) < 1e-6, v0[2]);
  assert.equal(await page.locator("[data-testid=save]").innerText(), "save"); // nothing to save: the view is not the recipe

  // Replace section C (right arm) by a newly drawn curve and guide.
  await page.click('[data-section-item="bs1/C"] b');
  await page.keyboard.press("Delete"); // removes the section, not the graph's selected nodes
  await page.waitForFunction(() => document.querySelector("[data-testid=mask-canvas]")?.getAttribute("data-paths") === "2");
  assert.equal(await page.locator('[data-section-item="bs1/C"]').count(), 0);
  await page.click("[data-tool=curve]");
  const drawMs = await timedEdit(page, () => drawClosed(page, [[6, -8], [64, -8], [64, 8], [6, 8]]));
  await page.waitForSelector('[data-path="bs1/C"]');
  assert.equal(await page.getAttribute("[data-testid=mask-canvas]", "data-paths"), "3");
  await page.click("[data-tool=guide]");
  await drawOpen(page, [[3, 1], [68, 1]]);
  await page.waitForSelector('[data-guide="bs1/C"].own');
  assert.equal(await page.getAttribute('[data-guide="bs1/C"]', "data-crossings"), "2");

  // Change the end-zone length of section A: the zone marker on the canvas moves.
  await page.click("[data-tool=select]");
  const markBefore = await page.locator('[data-path="bs1/A"] .zone-mark').nth(1).getAttribute("x");
  const times = [drawMs];
  for (const v of ["20", "14", "18", "12", "20"]) {
    times.push(
      await timedEdit(page, async () => {
        await page.fill('[data-testid="end-bs1/A"]', v);
        await page.press('[data-testid="end-bs1/A"]', "Enter");
      }),
    );
  }
  await page.waitForFunction(
    (before) => document.querySelectorAll('[data-path="bs1/A"] .zone-mark')[1]?.getAttribute("x") !== before,
    markBefore,
  );
  // Strategy per section: bs1/B switches to raster and its path is re-planned.
  const lenB = await page.getAttribute('[data-path="bs1/B"]', "data-length");
  times.push(await timedEdit(page, () => page.selectOption('[data-testid="strategy-bs1/B"]', "raster")));
  await page.waitForFunction((l) => document.querySelector('[data-path="bs1/B"]')?.getAttribute("data-length") !== l, lenB);
  // A zone split point on bs1/B's path adds one middle zone.
  const zonesB = (await page.getAttribute('[data-path="bs1/B"]', "data-zones")).split(",").length;
  await page.click("[data-tool=split]");
  const mid = await page.evaluate(() => {
    // the middle of the longest zone run (start/end zones are short)
    const runs = [...document.querySelectorAll('[data-path="bs1/B"] path.arc-on')];
    const p = runs.sort((a, b) => b.getTotalLength() - a.getTotalLength())[0];
    const q = p.getPointAtLength(p.getTotalLength() / 2);
    return [q.x, -q.y];
  });
  times.push(await timedEdit(page, () => clickAt(page, mid[0], mid[1])));
  await page.waitForFunction((n) => document.querySelector('[data-path="bs1/B"]')?.getAttribute("data-zones").split(",").length === n + 1, zonesB);
  // Move a vertex of bs1/B's curve by dragging it.
  await page.click("[data-tool=select]");
  await page.click('[data-section-item="bs1/B"] b');
  const v = await page.locator('[data-vertex="bs1/B:0"]').boundingBox();
  const [tx, ty] = await canvasPoint(page, -64, -9);
  times.push(
    await timedEdit(page, async () => {
      await page.mouse.move(v.x + v.width / 2, v.y + v.height / 2);
      await page.mouse.down();
      await page.mouse.move(tx, ty, { steps: 5 });
      await page.mouse.up();
    }),
  );
  writeFileSync(
    path.join(OUT, "replan.json"),
    JSON.stringify({ name: "gui_replan_ms", recipe: "mpp-cross", layer: 0, unit: "ms", median: median(times), max: Math.max(...times), samples: times }, null, 1),
  );
  console.log(`edit → canvas re-plan (mpp-cross, one layer): median ${median(times).toFixed(0)} ms, max ${Math.max(...times).toFixed(0)} ms over ${times.length} edits (curve, zone lengths, strategy, split point, vertex drag) [${times.map((t) => t.toFixed(0)).join(", ")}]`);
  await shot(page, "04-mask-edited");

  // Run and follow it to the end: the recipe runs as displayed, unsaved edits included, with the
  // saved graph's files and parameter XML, and running does not save it.
  await expectRun(page, srv.base, "done");
  assert.equal(await page.locator("[data-testid=save]").innerText(), "save *", "the edits are still unsaved after the run");
  assert.deepEqual((await api(srv.base, "/api/graphs/e2e-cross")).nodes, shipped.nodes, "running did not save the graph");
  const runs = await api(srv.base, "/api/runs?limit=1");
  assert.equal(runs[0].graph, "e2e-cross");
  const tp = await api(srv.base, `/api/runs/${runs[0].id}/artifacts/sequence.toolpath.json`);
  const c = tp.layers[0].sections.find((s) => s.key === "bs1/C");
  assert.ok(c, "section bs1/C in the run's toolpath");
  const xs = c.points.map((p) => p[0]);
  assert.ok(Math.min(...xs) >= 5.9 && Math.max(...xs) <= 64.1, `bs1/C path inside its (unsaved) curve: x ${Math.min(...xs)}..${Math.max(...xs)}`);
  // Saved, the graph holds what the canvas drew.
  await page.click("[data-testid=save]");
  await page.waitForFunction(() => document.querySelector("[data-testid=save]")?.textContent === "save");
  const saved = await api(srv.base, "/api/graphs/e2e-cross");
  assert.equal(saved.nodes.length, shipped.nodes.length);
  const mask = saved.nodes.find((n) => n.type === "mask").params.masks[0];
  assert.deepEqual(mask.sections.map((s) => s.id), ["A", "B", "C"]);
  // Drawn at (6,-8) (64,-8) (64,8) (6,8): each vertex snapped to a layer vertex within the 8 px
  // snap radius, else to the 1 mm grid.
  const drawn = [[6, -8], [64, -8], [64, 8], [6, 8]];
  const curve = mask.sections[2].curve;
  assert.equal(curve.length, 4);
  curve.forEach((p, i) => assert.ok(Math.hypot(p[0] - drawn[i][0], p[1] - drawn[i][1]) < 4, `vertex ${i} ${p} near ${drawn[i]}`));
  curve.forEach((p) => assert.ok(Number.isInteger(p[0] * 1000) && Number.isInteger(p[1] * 1000)));
  assert.deepEqual(saved.nodes.find((n) => n.type === "guide").params.guides["bs1/C"], [[3, 1], [68, 1]]);
  const zoneSaved = saved.nodes.find((n) => n.type === "zone").params;
  assert.equal(zoneSaved.sections["bs1/A"].end_length, 20);
  assert.equal(zoneSaved.sections["bs1/B"].split_points.length, 1);
  assert.equal(zoneSaved.sections["bs1/B"].start_length, 10, "a new section entry starts from the default zoning");
  assert.equal(saved.nodes.find((n) => n.type === "strategy").params.sections["bs1/B"].pattern, "raster");
  assert.deepEqual(mask.sections[1].curve[0], [-64, -9]);
  await page.click("[data-tab=graph]");
  assert.match(await page.locator('.react-flow__node[data-id="zone"] .badge').innerText(), /done|cached/);
  await shot(page, "05-graph-after-run");

  // XML parameter editor: edit a value, save, check through the API; an out-of-range value is
  // refused inline, in the browser, against the bounds of GET /api/process-parameters.
  await page.click("[data-tab=params]");
  await page.waitForSelector("[data-testid=zone-table]");
  await page.click('[data-tree-section="0|bs1/A"]');
  await page.fill('[data-cell="start.current"]', "205");
  await page.click("[data-testid=params-save]");
  await page.waitForSelector("[data-testid=params-saved]");
  const xml = await api(srv.base, "/api/graphs/e2e-cross/params");
  assert.equal(xmlValue(xml, 0, "bs1/A", "start", "current"), "205");
  const [exported] = await Promise.all([page.waitForEvent("download"), page.click('button:text-is("export")')]);
  const exportedXml = await exported.path().then((f) => readFileSync(f, "utf8"));
  assert.equal(xmlValue(exportedXml, 0, "bs1/A", "start", "current"), "205");
  assert.equal(await page.innerText('[data-range="current"]'), "0…1000 A");
  await page.fill('[data-cell="start.current"]', "5000");
  await page.waitForSelector('td[data-err] [data-cell="start.current"]'); // marked as typed, before saving
  assert.equal(await page.innerText('[data-cell-error="start.current"]'), "outside 0…1000 A");
  await page.click("[data-testid=params-save]");
  await page.waitForSelector("[data-testid=params-error]");
  assert.match(await page.innerText("[data-testid=params-error]"), /layer 0 · bs1\/A · start · current: outside 0…1000 A/);
  assert.equal(await page.locator("td[data-err]").count(), 1, "only the invalid cell is marked");
  assert.equal(xmlValue(await api(srv.base, "/api/graphs/e2e-cross/params"), 0, "bs1/A", "start", "current"), "205");
  await shot(page, "06-params");
  // Import the exported file back (an edited copy: one more value changed) and save it.
  const imported = exportedXml.replace(/(<layer index="1"[\s\S]*?<section id="bs1\/B"[\s\S]*?<zone id="end"[\s\S]*?<current[^>]*>)[^<]*/, "$1177");
  await page.setInputFiles('.pe-toolbar input[type=file]', { name: "edited.params.xml", mimeType: "application/xml", buffer: Buffer.from(imported) });
  await page.waitForFunction(() => document.querySelector('[data-cell="start.current"]')?.value === "205");
  await page.click("[data-testid=params-save]");
  await page.waitForSelector("[data-testid=params-saved]");
  const afterImport = await api(srv.base, "/api/graphs/e2e-cross/params");
  assert.equal(xmlValue(afterImport, 1, "bs1/B", "end", "current"), "177");
  assert.equal(xmlValue(afterImport, 0, "bs1/A", "start", "current"), "205");
  await page.click("[data-tab=results]");
  await page.waitForSelector('[data-artifact="sequence.toolpath.json"]');
  await shot(page, "07-results");
  assert.deepEqual(errors, []);
  await page.context().close();
});

test("new user: mesh → slice → two masks (second from the failing layer) → G-code with the XML filled", async () => {
  const { page, errors } = await openPage(browser, srv.base);
  // Build the graph from the palette and wire it by dragging between typed ports.
  const chain = ["mesh", "slice", "mask", "guide", "strategy", "zone", "sequence", "post-process"];
  for (const t of chain) {
    await page.click(`.palette-item[data-type="${t}"] .add`);
    await page.waitForSelector(`.react-flow__node[data-id="${t}"]`);
  }
  await page.click(".react-flow__pane", { position: { x: 20, y: 20 } });
  await page.keyboard.press("f");
  await page.waitForTimeout(400);
  const wires = [["mesh.mesh", "slice.mesh"], ["slice.layers", "mask.layers"], ["mask.sections", "guide.sections"], ["guide.sections", "strategy.sections"],
    ["strategy.toolpath", "zone.toolpath"], ["zone.toolpath", "sequence.toolpath"], ["sequence.toolpath", "post-process.toolpath"]];
  for (const [a, b] of wires) await connect(page, a, b);
  assert.equal(await page.locator(".react-flow__edge").count(), wires.length);
  // A wrong-type connection is refused (mesh output into a layers input).
  await connect(page, "mesh.mesh", "mask.layers");
  assert.equal(await page.locator(".react-flow__edge").count(), wires.length);

  // Node-editor habits: copy/paste, undo/redo, Delete, box select.
  await page.click('.react-flow__node[data-id="mesh"]');
  await page.keyboard.press("Control+c");
  await page.keyboard.press("Control+v");
  await page.waitForSelector('.react-flow__node[data-id="mesh2"]');
  await page.keyboard.press("Control+z");
  await page.waitForSelector('.react-flow__node[data-id="mesh2"]', { state: "detached" });
  await page.keyboard.press("Control+y");
  await page.click('.react-flow__node[data-id="mesh2"]');
  await page.waitForSelector('.react-flow__node[data-id="mesh2"].selected');
  await page.keyboard.press("Delete");
  await page.waitForSelector('.react-flow__node[data-id="mesh2"]', { state: "detached" });
  assert.equal(await page.locator(".react-flow__edge").count(), wires.length);
  const m = await page.locator('.react-flow__node[data-id="mesh"]').boundingBox();
  const sl = await page.locator('.react-flow__node[data-id="slice"]').boundingBox();
  await page.keyboard.down("Shift");
  await page.mouse.move(m.x - 12, Math.min(m.y, sl.y) - 12);
  await page.mouse.down();
  await page.mouse.move(sl.x + sl.width + 8, Math.max(m.y + m.height, sl.y + sl.height) + 12, { steps: 6 });
  await page.mouse.up();
  await page.keyboard.up("Shift");
  await page.waitForSelector("text=2 nodes selected");
  await shot(page, "08a-box-select");
  await page.click(".react-flow__pane", { position: { x: 20, y: 20 } });

  await page.click("[data-testid=save]");
  await page.fill("[data-testid=save-as-name]", "e2e-new");
  await page.press("[data-testid=save-as-name]", "Enter");
  await page.waitForSelector('.toolbar .title:text-is("e2e-new")');

  // Load a mesh: two islands, the second one starting partway up (topology changes there).
  await page.click('.react-flow__node[data-id="mesh"]');
  const stl = boxesStl([[-30, -6, 0, 30, 6, 9], [-30, 14, 4, 30, 20, 9]]);
  await page.setInputFiles('[data-field="path"] input[type=file]', { name: "two-islands.stl", mimeType: "model/stl", buffer: Buffer.from(stl) });
  await page.waitForFunction(() => document.querySelector('[data-field="path"] input[type=text]')?.value === "two-islands.stl");
  await page.click('.react-flow__node[data-id="zone"]');
  await page.fill('[data-field="parameters"] input[type=text]', "two-islands.params.xml");
  await page.click('.react-flow__node[data-id="post-process"]');
  await shot(page, "08-new-graph");

  // First mask over everything.
  await page.click("[data-tab=mask]");
  await page.waitForSelector("[data-testid=mask-canvas] .layer-poly");
  await page.click("[data-tool=curve]");
  await drawClosed(page, [[-34, -10], [34, -10], [34, 24], [-34, 24]]);
  await page.waitForSelector('[data-path="bs1/A"]');

  // The run fails where the second island appears: the GUI jumps there.
  await expectRun(page, srv.base, "failed");
  await page.waitForSelector("[data-testid=failure-banner]");
  const status = await api(srv.base, "/api/runs?limit=1");
  const err = status[0].error ?? (await api(srv.base, `/api/runs/${status[0].id}`)).error;
  assert.equal(err.section, "bs1/A");
  assert.ok(err.layer > 0, `fails above the first layer (layer ${err.layer})`);
  assert.equal(await page.inputValue('.mask-panel .layer-row input[type=number]'), String(err.layer));
  await page.waitForSelector(".section-region.failing, .mask-curve.failing");
  await shot(page, "09-failure");

  // Second mask from the failing layer, prefilled from the first; split it into the two islands.
  await page.click("[data-testid=new-mask-from-layer]");
  await page.waitForSelector('[data-mask="bs2"]');
  await page.click("[data-tool=curve]");
  await drawClosed(page, [[-34, -10], [34, -10], [34, 10], [-34, 10]]);
  await drawClosed(page, [[-34, 11], [34, 11], [34, 24], [-34, 24]]);
  await page.click('[data-section-item="bs2/A"] button:text-is("delete")');
  await page.waitForFunction(() => document.querySelectorAll("[data-section-item]").length === 2);
  await page.waitForSelector('[data-path="bs2/B"]');
  await page.waitForSelector('[data-path="bs2/C"]');
  assert.equal(await page.locator("table.masks tr").count(), 2);
  await shot(page, "10-two-masks");
  await expectRun(page, srv.base, "done");

  // Fill the XML (bulk edit over all layers, sections and zones) and run to G-code.
  await page.click("[data-tab=params]");
  await page.waitForSelector("[data-testid=zone-table]");
  for (const [name, value] of [["current", "180"], ["travel_speed", "8"]]) {
    await page.selectOption("[data-testid=bulk-param]", name);
    await page.fill("[data-testid=bulk-value]", value);
    await page.click("[data-testid=bulk-apply]");
  }
  await page.click("[data-testid=params-save]");
  await page.waitForSelector("[data-testid=params-saved]");
  const xml = await api(srv.base, "/api/graphs/e2e-new/params");
  const speeds = [...xml.matchAll(/<travel_speed[^>]*>([^<]*)<\/travel_speed>/g)].map((m) => m[1]);
  const currents = [...xml.matchAll(/<current[^>]*>([^<]*)<\/current>/g)].map((m) => m[1]);
  assert.ok(speeds.length >= 2 * 3, `zones in the XML: ${speeds.length}`);
  assert.deepEqual(new Set(speeds), new Set(["8"]));
  assert.deepEqual(new Set(currents), new Set(["180"]));
  assert.ok(xml.includes(`<layer index="${err.layer}"`) && xml.includes('<section id="bs2/C"'));
  await shot(page, "11-xml-filled");
  await expectRun(page, srv.base, "done");
  await page.click("[data-tab=results]");
  const link = page.locator('[data-artifact="post-process.gcode"]');
  await link.waitFor();
  const [download] = await Promise.all([page.waitForEvent("download"), link.click()]);
  assert.equal(download.suggestedFilename(), "post-process.gcode");
  const runs = await api(srv.base, "/api/runs?limit=1");
  const gcode = await api(srv.base, `/api/runs/${runs[0].id}/artifacts/post-process.gcode`);
  assert.match(gcode, /\bM3\b/);
  assert.match(gcode, /F480\b/, "the XML travel speed 8 mm/s is programmed as F480 mm/min");
  await shot(page, "12-results");
  assert.deepEqual(errors, []);
  await page.context().close();
});

test("rectangle-study: run, plots of the simulation and the strategy comparison", async () => {
  const { page, errors } = await openPage(browser, srv.base);
  await page.selectOption("[data-testid=open-graph]", "rectangle-study");
  await page.waitForSelector('.react-flow__node[data-id="simulate"]');
  // Recipe inputs are typed by the parameters that use them: `pattern` is a select of the patterns.
  const patternOptions = await page.locator('[data-input="pattern"] select option').allInnerTexts();
  assert.ok(patternOptions.includes("spiral") && patternOptions.includes("raster"), patternOptions.join(","));
  const shippedPattern = (await api(srv.base, "/api/graphs/rectangle-study")).inputs.pattern;
  assert.notEqual(shippedPattern, "spiral");
  await page.selectOption('[data-input="pattern"] select', JSON.stringify("spiral"));
  // The unsaved input runs as displayed; the example itself is not overwritten by running it.
  await expectRun(page, srv.base, "done");
  assert.equal((await api(srv.base, "/api/graphs/rectangle-study")).inputs.pattern, shippedPattern);
  const [last] = await api(srv.base, "/api/runs?limit=1");
  const tp = await api(srv.base, `/api/runs/${last.id}/artifacts/strategy.toolpath.json`);
  assert.equal(tp.layers[0].sections[0].strategy, "spiral");
  await page.click("[data-tab=results]");
  for (const title of ["Speed vs time", "Speed vs path length", "Deviation vs path", "Arc state", "Deposit per mm vs programmed"])
    await page.waitForSelector(`[data-chart="${title}"] path[stroke][d^="M"]`, { state: "attached" }); // a flat line has no height
  const [run] = await api(srv.base, "/api/runs?limit=1");
  const cmp = await api(srv.base, `/api/runs/${run.id}/artifacts/strategy.comparison.json`);
  await page.waitForSelector("[data-testid=comparison] tbody tr");
  assert.equal(await page.locator("[data-testid=comparison] tbody tr").count(), cmp.patterns.length);
  const sim = await api(srv.base, `/api/runs/${run.id}/artifacts/simulate.simulation.json`);
  const shown = await page
    .locator("[data-testid=sim-metrics] tr")
    .filter({ has: page.locator("td:first-child", { hasText: /^total_time_s$/ }) })
    .innerText();
  assert.ok(shown.includes(String(Number(sim.total_time_s.toPrecision(6)))), shown);
  await shot(page, "13-plots");
  assert.deepEqual(errors, []);
  await page.context().close();
});

test("every shipped example opens, runs, and shows its layer on the canvas", async () => {
  const { page, errors } = await openPage(browser, srv.base);
  const graphs = (await api(srv.base, "/api/graphs")).filter((g) => g.example);
  const catalog = await api(srv.base, "/api/nodes");   // [{type, per_layer, ...}]
  assert.ok(graphs.length >= 4, `examples: ${graphs.map((g) => g.name)}`);
  for (const g of graphs) {
    let step = "open";
    const t0 = Date.now();
    try {
      // until the picked recipe is shown the run button waits (it would run the one on screen)
      const recipe = await openRecipe(page, srv.base, g.name);
      // the recipe's inputs are valid as shipped; an optional one left unset is an empty field
      step = "inputs";
      assert.deepEqual(await page.locator("[data-testid=inputs] .field.err").allInnerTexts(), [], `${g.name}: inputs shown as errors`);
      for (const [k, v] of Object.entries(recipe.inputs ?? {}))
        if (v === null) {
          const field = page.locator(`[data-input="${k}"] input[type=text]`);
          assert.equal(await field.inputValue(), "", `${g.name}: unset input ${k}`);
          assert.equal(await field.getAttribute("placeholder"), "not set");
        }
      step = "run";
      // the heaviest example (curved-bracket: fan sections, 148 layers, cell simulation) takes
      // ~15 s on an idle 2-core machine; allow for a loaded one
      await expectRun(page, srv.base, "done", true, 300_000);
      // node statuses arrive on the event stream; the run's end may be seen first
      step = "badges";
      await page
        .waitForFunction((n) => {
          const b = [...document.querySelectorAll(".react-flow__node .badge")].map((e) => e.textContent ?? "");
          return b.length >= n && b.every((t) => /^(done|cached)/.test(t));
        }, recipe.nodes.length, { timeout: 30_000 })
        .catch(() => undefined);
      const badges = await page.locator(".react-flow__node .badge").allInnerTexts();
      if (badges.length !== recipe.nodes.length) {
        const shown = await page.$$eval(".react-flow__node", (els) => els.map((e) => `${e.getAttribute("data-id")}: ${e.querySelector(".badge")?.textContent ?? "-"}`));
        const [last] = await api(srv.base, "/api/runs?limit=1");
        const log = await api(srv.base, `/api/runs/${last.id}/log`);
        await shot(page, `14-example-${g.name}-badges`);
        assert.fail(`${g.name}: a badge per node; nodes ${shown.join(", ")}; run ${last.id} ${last.status}, events ${log.map((e) => `${e.kind}:${e.node ?? ""}`).join(" ")}; progress ${await page.getAttribute("[data-testid=progress]", "data-run-id")}`);
      }
      assert.ok(badges.every((b) => /^(done|cached)/.test(b)), `${g.name}: ${badges}`);
      // a computed layer node's badge says how long its layers took, wherever they were computed
      const perLayer = new Set(catalog.filter((c) => c.per_layer).map((c) => c.type));
      for (const n of recipe.nodes.filter((n) => perLayer.has(n.type))) {
        const badge = page.locator(`.react-flow__node[data-id="${n.id}"] .badge`);
        if (/^done/.test(await badge.innerText()))
          assert.match((await badge.getAttribute("title")) ?? "", /^layers computed in \d/, `${g.name}: ${n.id}`);
      }
      step = "canvas";
      await page.click("[data-tab=mask]");
      await page.waitForSelector("[data-testid=mask-canvas] .layer-poly, [data-testid=mask-canvas] .layer-curve", { state: "attached", timeout: 60_000 });
      // Every example plans paths; they are drawn in the layer's own plane (fan-sliced layers too).
      step = "paths";
      await page.waitForFunction(() => Number(document.querySelector("[data-testid=mask-canvas]").getAttribute("data-paths")) > 0, null, { timeout: 60_000 });
      await shot(page, `14-example-${g.name}`);
      await page.click("[data-tab=graph]");
    } catch (e) {
      throw new Error(`example ${g.name}, step ${step}, after ${Date.now() - t0} ms: ${e.message}\nserver log (tail):\n${srv.log().slice(-3000)}`, { cause: e });
    }
  }
  assert.deepEqual(errors, []);
  await page.context().close();
});
