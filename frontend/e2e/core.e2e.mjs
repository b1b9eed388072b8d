// End-to-end tests of the GUI's core behaviour: nothing saved changes without a save, examples are
// read-only, drafts survive a reload, the URL names recipe and tab, and graph editing (one-step
// undo of a delete, node search, free placement with auto-wiring, the reason of a refused wire).
// Run: npm run test:e2e (all *.e2e.mjs) or `node e2e/run.mjs e2e/core.e2e.mjs`.
import assert from "node:assert/strict";
import { after, before, test } from "node:test";
import { api, boxesStl, expectRun, openPage, saveAs, shot, startBrowser, startServer } from "./harness.mjs";

let srv, browser;
before(async () => {
  [srv, browser] = await Promise.all([startServer(), startBrowser()]);
});
after(async () => {
  await browser?.close();
  await srv?.stop();
});

/** A saved copy of a shipped example (recipe and parameter XML), made through the API. */
async function copyOf(example, name) {
  const r = await api(srv.base, `/api/graphs/${example}`);
  await api(srv.base, `/api/graphs/${name}`, { method: "PUT", headers: { "Content-Type": "application/json" }, body: JSON.stringify({ ...r, name }) });
  const xml = await fetch(`${srv.base}/api/graphs/${example}/params`);
  if (xml.ok) await api(srv.base, `/api/graphs/${name}/params`, { method: "PUT", headers: { "Content-Type": "application/xml" }, body: await xml.text() });
}

async function openGraph(page, name, tab) {
  await page.goto(`${srv.base}/?graph=${encodeURIComponent(name)}${tab ? `&tab=${tab}` : ""}`);
  await page.waitForSelector(`.toolbar .title:text-is("${name}")`, { timeout: 60_000 });
  await page.waitForSelector(".react-flow__node", { state: "attached" });
}

const count = (page, sel) => page.locator(sel).count();
// until `sel` matches `n` elements (at most 3 s; the assertion after it says what was found)
const settled = (page, sel, n) =>
  page
    .waitForFunction(([s, k]) => document.querySelectorAll(s).length === k, [sel, n], { timeout: 3000 })
    .catch(() => undefined);

test("a run never changes what was saved: save as, new mask from layer 4, run unsaved; the saved XML is byte-identical", async () => {
  const { page, errors } = await openPage(browser, srv.base);
  await page.selectOption("[data-testid=open-graph]", "mpp-cross");
  await page.waitForSelector('.react-flow__node[data-id="zone"]');
  await saveAs(page, "core-cross");
  await page.waitForURL(/[?&]graph=core-cross\b/); // the URL names the open recipe
  const savedXml = await api(srv.base, "/api/graphs/core-cross/params");
  const exampleXml = await api(srv.base, "/api/graphs/mpp-cross/params");
  assert.equal(savedXml, exampleXml, "save as takes the parameter XML along");
  const savedRecipe = await api(srv.base, "/api/graphs/core-cross");

  // New mask from layer 4, run without saving.
  await page.click("[data-tab=mask]");
  await page.waitForSelector("[data-testid=mask-canvas] .layer-poly");
  await page.fill(".mask-panel .layer-row input[type=number]", "4");
  await page.waitForSelector('[data-path="bs1/C"]'); // the layer's regions are known
  const dialogs = [];
  page.on("dialog", (d) => dialogs.push(d.message()));
  await page.click("[data-testid=new-mask]");
  await page.waitForSelector('[data-mask="bs2"]');
  assert.equal(await page.locator("[data-testid=save]").innerText(), "save *");
  // Before confirming, the user saw what is carried over (matched by region overlap on layer 4).
  const said = dialogs.find((m) => m.startsWith("New mask bs2 from layer 4"));
  assert.ok(said, `confirmation shown: ${dialogs}`);
  for (const line of ["guide · guides: bs1/A → bs2/A", "guide · guides: bs1/C → bs2/C", "strategy · sections: bs1/A → bs2/A", "zone · sections: bs1/A → bs2/A", "XML values: bs1/B → bs2/B on 4 layer(s)"])
    assert.ok(said.includes(line), `${line} in:\n${said}`);
  assert.match(said, /Everything carried over/);
  await expectRun(page, srv.base, "done");

  // Nothing saved changed: the XML byte for byte, and the recipe.
  assert.equal(await api(srv.base, "/api/graphs/core-cross/params"), savedXml, "the saved XML is byte-identical after an unsaved run");
  assert.deepEqual(await api(srv.base, "/api/graphs/core-cross"), savedRecipe, "the saved recipe is unchanged after an unsaved run");
  // The run used the draft and wrote its merged XML as an artifact; the editor keeps the draft, unsaved.
  const [last] = await api(srv.base, "/api/runs?limit=1");
  const merged = await api(srv.base, `/api/runs/${last.id}/artifacts/zone.params.xml`);
  assert.ok(merged.includes('<section id="bs2/A"'), "the merged XML has the new mask's sections");
  await page.click("[data-tab=params]");
  await page.waitForSelector("[data-testid=params-unsaved]");
  await shot(page, "core-01-run-draft");

  // Saving saves recipe and XML together.
  await page.click("[data-testid=save]");
  await page.waitForFunction(() => document.querySelector("[data-testid=save]")?.textContent === "save");
  await page.waitForSelector("[data-testid=params-saved]");
  // what is saved is the XML on screen (the carried-over draft, the user's comments kept), not
  // the run's merged version (#25: a run never rewrites the user's XML)
  const stored = await api(srv.base, "/api/graphs/core-cross/params");
  assert.ok(stored.includes('<section id="bs2/A"') && stored.includes("<!--"), "the saved draft has bs2 and the comments");
  const recipe = await api(srv.base, "/api/graphs/core-cross");
  assert.deepEqual(recipe.nodes.find((n) => n.type === "mask").params.masks.map((m) => [m.id, m.from_layer]), [["bs1", 0], ["bs2", 4]]);
  const byType = (t) => recipe.nodes.find((n) => n.type === t).params;
  assert.deepEqual(byType("guide").guides["bs2/B"], byType("guide").guides["bs1/B"]);
  assert.deepEqual(byType("strategy").sections["bs2/A"], byType("strategy").sections["bs1/A"]);
  assert.deepEqual(byType("zone").sections["bs2/A"], byType("zone").sections["bs1/A"]);
  // The study's values of layers 4–7 now belong to bs2 (nothing dropped): same numbers as bs1 had.
  const values = (xml, layer, section) => {
    const l = xml.match(new RegExp(`<layer index="${layer}"[^>]*>([\\s\\S]*?)</layer>`))[1];
    const sec = l.match(new RegExp(`<section id="${section.replace("/", "\\/")}"[^>]*>([\\s\\S]*?)</section>`))?.[1] ?? "";
    return [...sec.matchAll(/<(\w+) unit="[^"]*">([^<]+)</g)].map((m) => `${m[1]}=${m[2]}`);
  };
  for (const layer of [4, 7])
    for (const sec of ["A", "B", "C"]) {
      const was = values(savedXml, layer, `bs1/${sec}`);
      assert.ok(was.length > 0, `the example has values for layer ${layer} bs1/${sec}`);
      assert.deepEqual(values(stored, layer, `bs2/${sec}`), was, `layer ${layer} bs2/${sec}`);
    }
  assert.deepEqual(errors, []);
  await page.context().close();
});

test("shipped examples are read-only: marker, save offers save as, delete disabled, API 409", async () => {
  const { page, errors } = await openPage(browser, srv.base);
  await openGraph(page, "rectangle-study");
  await page.waitForSelector("[data-testid=example-badge]");
  assert.equal(await page.innerText("[data-testid=example-badge]"), "example (read-only)");
  assert.equal(await page.isDisabled("[data-testid=delete]"), true);
  await page.click("[data-testid=save]");
  assert.equal(await page.inputValue("[data-testid=save-as-name]"), "rectangle-study-copy");
  await page.keyboard.press("Escape");
  await page.click('button[aria-label="cancel save as"]');
  await page.keyboard.press("Control+s");
  await page.waitForSelector("[data-testid=save-as-name]");
  await shot(page, "core-02-example");
  const before = await api(srv.base, "/api/graphs/rectangle-study");
  const put = await fetch(`${srv.base}/api/graphs/rectangle-study`, { method: "PUT", headers: { "Content-Type": "application/json" }, body: JSON.stringify(before) });
  assert.equal(put.status, 409);
  assert.match((await put.json()).detail.message, /save as/);
  const del = await fetch(`${srv.base}/api/graphs/rectangle-study`, { method: "DELETE" });
  assert.equal(del.status, 409);
  assert.deepEqual(errors, []);
  await page.context().close();
});

test("unsaved edits survive a reload; deep link opens recipe and tab; back/forward", async () => {
  await copyOf("mpp-cross", "core-draft");
  const { page, errors } = await openPage(browser, srv.base);
  await openGraph(page, "core-draft", "params");
  await page.waitForSelector("[data-testid=params-editor]");
  assert.equal(await page.getAttribute("[data-tab=params]", "class"), "active");
  // Back/forward between tabs.
  await page.click("[data-tab=mask]");
  await page.waitForURL(/tab=mask/);
  await page.goBack();
  await page.waitForURL((u) => /tab=params/.test(u.search));
  await page.waitForSelector("[data-testid=params-editor]");
  await page.goForward();
  await page.waitForSelector("[data-testid=mask-canvas]");

  // Edit: a node added, an XML value changed; then reload.
  await page.click("[data-tab=graph]");
  const n0 = await count(page, ".react-flow__node");
  await page.click('button[aria-label="add Mask (segmentation)"]');
  await page.waitForFunction((n) => document.querySelectorAll(".react-flow__node").length === n + 1, n0);
  await page.click("[data-tab=params]");
  await page.click('[data-tree-section="0|bs1/A"]');
  await page.fill('[data-cell="start.current"]', "211");
  await page.waitForSelector("[data-testid=params-unsaved]");
  await page.reload();
  await page.waitForSelector("[data-testid=draft-offer]");
  assert.match(await page.innerText("[data-testid=draft-offer]"), /restore unsaved changes from .+\?/);
  await shot(page, "core-03-draft-offer");
  await page.click("[data-testid=draft-restore]");
  await page.waitForSelector("[data-testid=params-editor]"); // the tab of the draft
  await page.click('[data-tree-section="0|bs1/A"]');
  assert.equal(await page.inputValue('[data-cell="start.current"]'), "211");
  await page.click("[data-tab=graph]");
  assert.equal(await count(page, ".react-flow__node"), n0 + 1);
  assert.equal(await page.locator("[data-testid=save]").innerText(), "save *");
  // Nothing was saved by all this.
  const xml = await api(srv.base, "/api/graphs/core-draft/params");
  assert.ok(!xml.includes(">211<"));
  // Discard: the saved state comes back and the draft is gone.
  await page.reload();
  await page.click("[data-testid=draft-discard]");
  await page.reload();
  await page.waitForSelector(".react-flow__node");
  assert.equal(await count(page, "[data-testid=draft-offer]"), 0);
  assert.equal(await count(page, ".react-flow__node"), n0);
  assert.deepEqual(errors, []);
  await page.context().close();
});

test("graph editing: one-step undo of a delete, node search with Enter, free placement with auto-wire, wire refusal reason", async () => {
  await copyOf("mpp-cross", "core-edit");
  const { page, errors } = await openPage(browser, srv.base);
  await openGraph(page, "core-edit");
  const n0 = await count(page, ".react-flow__node");
  const e0 = await count(page, ".react-flow__edge");

  // Delete a node with two edges; one undo brings back node and edges.
  await page.click('.react-flow__node[data-id="strategy"]');
  await page.keyboard.press("Delete");
  await page.waitForFunction((n) => document.querySelectorAll(".react-flow__node").length === n - 1, n0);
  await settled(page, ".react-flow__edge", e0 - 2);
  assert.equal(await count(page, ".react-flow__edge"), e0 - 2);
  await page.click("[data-testid=undo]");
  await page.waitForFunction((n) => document.querySelectorAll(".react-flow__node").length === n, n0);
  // React Flow draws a node's edges a frame after the node (once it is measured): wait for them, then
  // count (one undo, no second step: the edges came back with the node or this fails)
  await settled(page, ".react-flow__edge", e0);
  assert.equal(await count(page, ".react-flow__edge"), e0, "edges come back with the node in the same step");
  await page.click("[data-testid=redo]");
  await page.waitForFunction((n) => document.querySelectorAll(".react-flow__node").length === n - 1, n0);
  await settled(page, ".react-flow__edge", e0 - 2);
  assert.equal(await count(page, ".react-flow__edge"), e0 - 2);
  await page.keyboard.press("Control+z");
  await page.waitForFunction((e) => document.querySelectorAll(".react-flow__edge").length === e, e0);

  // Node search: double-click on empty canvas, type, arrows, Enter.
  const [px, py] = await page.evaluate(() => {
    // an empty spot of the canvas (no node, control or minimap under it)
    const r = document.querySelector(".react-flow__pane").getBoundingClientRect();
    for (let fy = 0.1; fy < 0.95; fy += 0.05)
      for (let fx = 0.1; fx < 0.95; fx += 0.05) {
        const x = r.left + fx * r.width, y = r.top + fy * r.height;
        if (document.elementFromPoint(x, y)?.classList.contains("react-flow__pane")) return [x, y];
      }
    return [0, 0];
  });
  assert.ok(px > 0, "an empty spot on the canvas");
  await page.mouse.dblclick(px, py);
  await page.waitForSelector("[data-testid=node-search] input");
  await page.keyboard.type("slice");
  await page.keyboard.press("ArrowDown");
  await page.keyboard.press("ArrowUp");
  await shot(page, "core-04-node-search");
  await page.keyboard.press("Enter");
  await page.waitForFunction((n) => document.querySelectorAll(".react-flow__node").length === n + 1, n0);
  assert.equal(await count(page, '.react-flow__node[data-id="slice"]'), 1);
  assert.equal(await count(page, "[data-testid=node-search]"), 0);
  // `/` opens it too; Escape closes without adding.
  await page.click(".react-flow__pane", { position: { x: 10, y: 10 } });
  await page.keyboard.press("/");
  await page.waitForSelector("[data-testid=node-search] input");
  await page.keyboard.press("Escape");
  await page.waitForFunction(() => !document.querySelector("[data-testid=node-search]"));
  assert.equal(await count(page, ".react-flow__node"), n0 + 1);

  // "+" with the mask node selected: the new guide lands on free space, wired from the mask.
  await page.click('.react-flow__node[data-id="mask"]');
  await page.click('button[aria-label="add Guide"]');
  await page.waitForSelector('.react-flow__node[data-id="guide2"]');
  await page.click('button[aria-label="add Guide"]'); // guide2 selected: wired from guide2
  await page.waitForSelector('.react-flow__node[data-id="guide3"]');
  const boxes = await page.$$eval(".react-flow__node", (els) => els.map((e) => ({ id: e.dataset.id, ...e.getBoundingClientRect().toJSON() })));
  for (const a of boxes)
    for (const b of boxes)
      if (a.id < b.id) {
        const overlap = Math.min(a.right, b.right) - Math.max(a.left, b.left) > 1 && Math.min(a.bottom, b.bottom) - Math.max(a.top, b.top) > 1;
        assert.ok(!overlap, `${a.id} overlaps ${b.id}`);
      }
  assert.equal(await count(page, '.react-flow__edge[data-testid="rf__edge-mask.sections->guide2.sections"]'), 1, "auto-wired from the selected node");
  assert.equal(await count(page, '.react-flow__edge[data-testid="rf__edge-guide2.sections->guide3.sections"]'), 1);

  // Dragging a wire onto an incompatible input says why.
  await page.keyboard.press("f");
  await page.waitForTimeout(300);
  const from = await page.locator('.react-flow__node[data-id="part"] .react-flow__handle.source[data-handleid="mesh"]').boundingBox();
  const to = await page.locator('.react-flow__node[data-id="zone"] .react-flow__handle.target[data-handleid="toolpath"]').boundingBox();
  await page.mouse.move(from.x + from.width / 2, from.y + from.height / 2);
  await page.mouse.down();
  await page.mouse.move((from.x + to.x) / 2, (from.y + to.y) / 2, { steps: 5 });
  await page.mouse.move(to.x + to.width / 2, to.y + to.height / 2, { steps: 5 });
  await page.waitForSelector("[data-testid=wire-reason]");
  assert.match(await page.getAttribute("[data-testid=wire-reason]", "data-reason"), /^type mismatch: \w+ → \w+$/);
  // Every incompatible input says why on the handle itself (class, title, description, visible tag);
  // the compatible one (a mesh input) says nothing.
  const handle = (node, port) => `.react-flow__node[data-id="${node}"] .react-flow__handle.target[data-handleid="${port}"]`;
  for (const [node, port, type] of [["zone", "toolpath", "toolpath"], ["mask", "layers", "layers"], ["sequence", "toolpath", "toolpath"]]) {
    assert.match(await page.getAttribute(handle(node, port), "class"), /\brefused\b/, `${node}.${port} is marked`);
    assert.equal(await page.getAttribute(handle(node, port), "title"), `cannot connect: type mismatch: mesh → ${type}`);
    assert.equal(await page.getAttribute(handle(node, port), "aria-description"), `cannot connect: type mismatch: mesh → ${type}`);
    assert.equal(await page.innerText(`.react-flow__node[data-id="${node}"] .port.refused [data-testid=port-refusal]`), `✕ type mesh ≠ ${type}`);
  }
  assert.doesNotMatch(await page.getAttribute(handle("layers", "mesh"), "class"), /\brefused\b/);
  assert.equal(await page.getAttribute(handle("layers", "mesh"), "data-reason"), null);
  // on the slice node only the optional bead-model input is refused
  assert.deepEqual(await page.locator('.react-flow__node[data-id="layers"] [data-testid=port-refusal]').allInnerTexts(), ["✕ type mesh ≠ bead-model"]);
  await shot(page, "core-05-wire-reason");
  await page.mouse.up();
  assert.equal(await count(page, '.react-flow__edge[data-testid="rf__edge-part.mesh->zone.toolpath"]'), 0);
  assert.equal(await count(page, "[data-testid=port-refusal]"), 0, "the reasons go when the drag ends");
  // A wire from the sequence's output back into the zone (same type, upstream) would close a cycle.
  const seq = await page.locator('.react-flow__node[data-id="sequence"] .react-flow__handle.source[data-handleid="toolpath"]').boundingBox();
  await page.mouse.move(seq.x + seq.width / 2, seq.y + seq.height / 2);
  await page.mouse.down();
  await page.mouse.move(seq.x - 40, seq.y - 40, { steps: 5 });
  await page.waitForSelector(`${handle("zone", "toolpath")}.refused`);
  assert.equal(await page.getAttribute(handle("zone", "toolpath"), "title"), "cannot connect: this edge would create a cycle");
  assert.equal(await page.innerText('.react-flow__node[data-id="zone"] .port.refused [data-testid=port-refusal]'), "✕ would create a cycle");
  assert.doesNotMatch(await page.getAttribute(handle("post", "toolpath"), "class"), /\brefused\b/, "the post-processor's toolpath input is compatible");
  await page.mouse.up();
  assert.deepEqual(errors, []);
  await page.context().close();
});

test("frames: a frame around selected nodes moves them with it and is saved in the recipe's ui", async () => {
  await copyOf("mpp-cross", "core-frame");
  const { page, errors } = await openPage(browser, srv.base);
  await openGraph(page, "core-frame");
  await page.click('.react-flow__node[data-id="zone"]');
  await page.click('.react-flow__node[data-id="sequence"]', { modifiers: ["Control"] });
  await page.click("[data-testid=add-frame]");
  await page.waitForSelector('[data-frame-id="f1"]');
  const pos = async (id) => page.locator(`.react-flow__node[data-id="${id}"]`).boundingBox();
  const [z0, s0, p0] = [await pos("zone"), await pos("sequence"), await pos("part")];
  const head = await page.locator('[data-frame-id="f1"] .wframe-head').boundingBox();
  await page.mouse.move(head.x + 20, head.y + head.height / 2);
  await page.mouse.down();
  await page.mouse.move(head.x + 60, head.y + 60, { steps: 6 });
  await page.mouse.move(head.x + 100, head.y + 80, { steps: 6 });
  await page.mouse.up();
  await page.waitForTimeout(200);
  const [z1, s1, p1] = [await pos("zone"), await pos("sequence"), await pos("part")];
  const head1 = await page.locator('[data-frame-id="f1"] .wframe-head').boundingBox();
  const [fx, fy] = [head1.x - head.x, head1.y - head.y]; // the frame's move on screen (zoom ≠ 1)
  assert.ok(fx > 30 && fy > 30, `the frame moved: ${fx}, ${fy}`);
  assert.ok(Math.abs(z1.x - z0.x - fx) < 2 && Math.abs(z1.y - z0.y - fy) < 2, `zone moved with the frame: ${z1.x - z0.x},${z1.y - z0.y} vs ${fx},${fy}`);
  assert.ok(Math.abs(s1.x - s0.x - (z1.x - z0.x)) < 1 && Math.abs(s1.y - s0.y - (z1.y - z0.y)) < 1, "sequence moved by the same amount");
  assert.deepEqual([p1.x, p1.y], [p0.x, p0.y], "a node outside the frame stays");
  await shot(page, "core-07-frame");
  await page.keyboard.press("Control+s");
  await page.waitForFunction(() => document.querySelector("[data-testid=save]")?.textContent === "save");
  const saved = await api(srv.base, "/api/graphs/core-frame");
  assert.equal(saved.ui.frames.length, 1);
  const f = saved.ui.frames[0];
  const [zx, zy] = saved.ui.positions.zone;
  assert.ok(zx >= f.x && zy >= f.y && zx <= f.x + f.w && zy <= f.y + f.h, "the saved frame holds the zone node");
  assert.deepEqual(errors, []);
  await page.context().close();
});

test("upload before the first save (sent right after save as), and the same file picked twice uploads twice", async () => {
  const { page, errors } = await openPage(browser, srv.base);
  await page.click('.palette-item[data-type="mesh"] .add');
  await page.waitForSelector('.react-flow__node[data-id="mesh"]');
  await page.click('.react-flow__node[data-id="mesh"]');
  const a = Buffer.from(boxesStl([[0, 0, 0, 10, 10, 5]]));
  const b = Buffer.from(boxesStl([[0, 0, 0, 20, 10, 5], [30, 0, 0, 40, 10, 5]]));
  const pick = (buffer) => page.setInputFiles('[data-field="path"] input[type=file]', { name: "part.stl", mimeType: "model/stl", buffer });
  await pick(a);
  // no graph yet: the file waits, the path names it, "save as" is offered
  await page.waitForFunction(() => document.querySelector('[data-field="path"] input[type=text]')?.value === "part.stl");
  await page.fill("[data-testid=save-as-name]", "core-upload");
  await page.press("[data-testid=save-as-name]", "Enter");
  await page.waitForSelector('.toolbar .title:text-is("core-upload")');
  const files = async () => (await api(srv.base, "/api/graphs/core-upload/files")).map((f) => [f.name, f.size]);
  for (let i = 0; i < 50 && !(await files()).length; i++) await page.waitForTimeout(100);
  assert.deepEqual(await files(), [["part.stl", a.length]], "uploaded right after the save");
  // saved: other content under the same name asks first (#25: replace / keep both / cancel); the
  // same file again uploads at once (and the same file picked twice uploads twice)
  const uploads = async () => (await api(srv.base, "/api/audit?limit=100")).filter((e) => e.action === "upload_file" && e.target === "core-upload").length;
  const n0 = await uploads();
  await pick(b);
  await page.click("[data-testid=upload-replace]");
  await page.waitForFunction(async ([base, size]) => (await (await fetch(`${base}/api/graphs/core-upload/files`)).json())[0].size === size, [srv.base, b.length]);
  await pick(b);
  for (let i = 0; i < 50 && (await uploads()) < n0 + 2; i++) await page.waitForTimeout(100);
  assert.equal(await uploads(), n0 + 2, "the same file picked twice is uploaded twice");
  await pick(a);
  await page.click("[data-testid=upload-replace]");
  await page.waitForFunction(async ([base, size]) => (await (await fetch(`${base}/api/graphs/core-upload/files`)).json())[0].size === size, [srv.base, a.length]);
  assert.deepEqual(await files(), [["part.stl", a.length]]);
  assert.deepEqual(errors, []);
  await page.context().close();
});

test("a refused run (422 naming node and field) selects and marks the node", async () => {
  await copyOf("mpp-cross", "core-422");
  const { page, errors } = await openPage(browser, srv.base);
  // An unsaved edit with an invalid value, as a local draft (what a reload would offer back).
  const bad = await api(srv.base, "/api/graphs/core-422");
  bad.nodes.find((n) => n.id === "layers").params.layer_height = -1;
  await page.evaluate((r) => localStorage.setItem("waamflow:draft:core-422", JSON.stringify({ recipe: r, xml: null, tab: "graph", savedAt: Date.now() })), bad);
  await openGraph(page, "core-422");
  await page.click("[data-testid=draft-restore]");
  await page.click("[data-testid=run]");
  await page.waitForSelector('.react-flow__node[data-id="layers"] [data-testid=problem-badge].errors');
  assert.match(await page.getAttribute('.react-flow__node[data-id="layers"]', "class"), /\bselected\b/);
  assert.match(await page.getAttribute('.react-flow__node[data-id="layers"] [data-testid=problem-badge]', "title"), /layer_height/);
  await page.waitForSelector('[data-testid=problems] .problem.error[data-problem-node="layers"]');
  assert.match(await page.innerText("[data-testid=problems]"), /layers · layer_height/);
  assert.match(await page.innerText("[data-testid=problem-count]"), /✖ 1/);
  await shot(page, "core-08-refused-run");
  assert.deepEqual(errors.filter((e) => !/status of 422/.test(e)), []);
  await page.context().close();
});

test("problems: badges on nodes, toolbar count, panel selects the node (and jumps to its layer)", async () => {
  await copyOf("mpp-cross", "core-problems");
  const { page, errors } = await openPage(browser, srv.base);
  await openGraph(page, "core-problems", "mask");
  await page.waitForSelector("[data-testid=mask-canvas] .layer-poly");
  await page.fill(".mask-panel .layer-row input[type=number]", "4");
  await page.click("[data-testid=new-mask]");
  await page.waitForSelector('[data-mask="bs2"]');
  await expectRun(page, srv.base, "done");
  const [last] = await api(srv.base, "/api/runs?limit=1");
  const events = await (await fetch(`${srv.base}/api/runs/${last.id}/events`)).text().catch(() => "");
  const warnings = events.split("\n").filter((l) => l.startsWith("data:")).map((l) => JSON.parse(l.slice(5))).filter((e) => e.kind === "warning");
  const distinct = new Set(warnings.map((w) => `${w.node}|${w.layer}|${w.section}|${w.message}`)).size;
  const shown = await page.innerText("[data-testid=problem-count]");
  assert.equal(shown, `⚠ ${distinct}`, `toolbar count vs ${distinct} distinct warnings`);
  if (warnings.length) {
    await page.click("[data-tab=graph]");
    const w = warnings.find((x) => x.node);
    await page.waitForSelector(`.react-flow__node[data-id="${w.node}"] [data-testid=problem-badge]`);
    const title = await page.getAttribute(`.react-flow__node[data-id="${w.node}"] [data-testid=problem-badge]`, "title");
    assert.ok(title.includes(w.message), "the badge's tooltip has the message");
    await page.click("[data-testid=problem-count]");
    await page.waitForSelector("[data-testid=problems] .problem");
    await shot(page, "core-06-problems");
    await page.click(`[data-testid=problems] .problem[data-problem-node="${w.node}"]`);
    if (w.layer != null) {
      await page.waitForSelector("[data-testid=mask-canvas]");
      assert.equal(await page.inputValue(".mask-panel .layer-row input[type=number]"), String(w.layer));
    }
    await page.click("[data-tab=graph]");
    assert.match(await page.getAttribute(`.react-flow__node[data-id="${w.node}"]`, "class"), /selected/);
  }
  assert.deepEqual(errors, []);
  await page.context().close();
});

test("a problem naming layer and section: a click selects the node, the layer and the section (canvas, list, inspector)", async () => {
  // An orphan value in the saved XML (zone z9 of bs1/A on layer 2) is reported with its layer and section.
  await copyOf("mpp-cross", "core-orphan");
  const xml = await api(srv.base, "/api/graphs/core-orphan/params");
  const at = xml.indexOf('<section id="bs1/A">', xml.indexOf('<layer index="2"'));
  assert.ok(at > 0);
  const cut = at + '<section id="bs1/A">'.length;
  const orphan = xml.slice(0, cut) + '<zone id="z9"><current unit="A">205</current></zone>' + xml.slice(cut);
  await api(srv.base, "/api/graphs/core-orphan/params", { method: "PUT", headers: { "Content-Type": "application/xml" }, body: orphan });
  const { page, errors } = await openPage(browser, srv.base);
  await openGraph(page, "core-orphan", "graph");
  await expectRun(page, srv.base, "done");
  await page.click("[data-testid=problem-count]");
  const item = '[data-testid=problems] .problem[data-problem-node="zone"][data-problem-layer="2"][data-problem-section="bs1/A"]';
  await page.waitForSelector(item);
  assert.match(await page.innerText(item), /zone · layer 2 · bs1\/A/);
  await page.click(item);
  await page.waitForSelector('[data-testid=mask-canvas] .section-region[data-section="bs1/A"].selected');
  assert.equal(await page.inputValue(".mask-panel .layer-row input[type=number]"), "2");
  assert.match(await page.getAttribute('.mask-panel [data-section-item="bs1/A"]', "class"), /\bselected\b/);
  assert.equal(await page.locator(".mask-panel .section-item.selected").count(), 1);
  // the inspector shows the zone node with that section picked in its per-section form
  assert.match(await page.innerText("[data-testid=inspector] h3"), /zone/);
  await page.waitForSelector('[data-testid=inspector] .map-value[data-section="bs1/A"]');
  await shot(page, "core-07-problem-section");
  // another problem of another section moves the selection with it
  const other = await page.$$eval("[data-testid=problems] .problem", (els) =>
    els.map((e) => [e.dataset.problemSection, e.dataset.problemLayer]).find(([s, l]) => s && s !== "bs1/A" && l !== ""));
  if (other) {
    await page.click(`[data-testid=problems] .problem[data-problem-section="${other[0]}"][data-problem-layer="${other[1]}"]`);
    await page.waitForSelector(`[data-testid=inspector] .map-value[data-section="${other[0]}"]`);
  }
  assert.deepEqual(errors, []);
  await page.context().close();
});

test("progress bar restarts at 0 on a new run", async () => {
  const { page, errors } = await openPage(browser, srv.base);
  await openGraph(page, "core-problems", "graph");
  await expectRun(page, srv.base, "done");
  // A new run starts from 0 %, not from the last run's 100 %.
  await page.evaluate(() => {
    window.__progress = [];
    new MutationObserver(() => window.__progress.push(document.querySelector("[data-testid=progress]").title)).observe(document.querySelector("[data-testid=progress]"), { attributes: true, subtree: true });
  });
  await expectRun(page, srv.base, "done");
  const seen = await page.evaluate(() => window.__progress);
  assert.ok(seen.length && seen[0] !== "100%", `first progress after starting: ${seen[0]}`);
  assert.deepEqual(errors, []);
  await page.context().close();
});
