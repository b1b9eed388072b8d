// E2E of the preflight in the GUI (issue #22 items 1 and 3): the toolbar's verdict badge after a
// run, the problems panel's Preflight section, a problem's layer / section / point on the mask
// canvas with the layer's arc starts, "new mask here", and the badge greying out once the recipe
// changes. The first test serves a fixed report (e2e/fixtures) over the run's artifacts so every
// state is seen; the second checks the badge against the real backend's preflight.json.
import assert from "node:assert/strict";
import { readFileSync } from "node:fs";
import { createRequire } from "node:module";
import path from "node:path";
import { after, before, test } from "node:test";
import { fileURLToPath } from "node:url";
import { OUT, api, canvasPoint, drawClosed, expectRun, openRecipe, startBrowser, startServer, waitRun } from "./harness.mjs";

const AXE = createRequire(import.meta.url).resolve("axe-core/axe.min.js");
const FIXTURE = readFileSync(path.join(path.dirname(fileURLToPath(import.meta.url)), "fixtures/preflight-mpp-cross.json"), "utf8");

let srv, browser;
before(async () => {
  srv = await startServer();
  browser = await startBrowser();
});
after(async () => {
  await browser?.close();
  await srv?.stop();
});

async function open(width, height) {
  const context = await browser.newContext({ viewport: { width, height } });
  const page = await context.newPage();
  const errors = [];
  page.on("pageerror", (e) => errors.push(e.message));
  page.on("console", (m) => m.type() === "error" && errors.push(m.text()));
  page.on("dialog", (d) => d.accept());
  await page.goto(srv.base + "/");
  await page.waitForSelector("[data-testid=palette] .palette-item", { timeout: 60_000 });
  return { page, context, errors };
}

const shot = (page, name) => page.screenshot({ path: path.join(OUT, `preflight-${name}.png`) });
const badge = "[data-testid=preflight-badge]";

/** Serve the fixture as this page's runs' preflight.json (listed among the artifacts). */
async function serveFixture(page) {
  await page.route(/\/api\/runs\/[^/]+\/artifacts$/, async (route) => {
    const res = await route.fetch();
    const list = (await res.json()).filter((a) => a.name !== "preflight.json");
    await route.fulfill({ response: res, json: [...list, { name: "preflight.json", size: FIXTURE.length }] });
  });
  await page.route(/\/api\/runs\/[^/]+\/artifacts\/preflight\.json$/, (route) => route.fulfill({ status: 200, contentType: "application/json", body: FIXTURE }));
}

for (const [w, h] of [[1600, 1000], [1366, 768]]) {
  test(`fixture report at ${w}×${h}: badge, panel, canvas starts and mark, new mask here, stale after an edit`, async () => {
    const { page, context, errors } = await open(w, h);
    await serveFixture(page);
    await openRecipe(page, srv.base, "mpp-cross");
    // the first opening: no run yet, no badge; later (#25 fault 8) the recipe shows its latest run's
    if (w === 1600) assert.equal(await page.locator(badge).count(), 0, "no badge before the first run");
    else await page.waitForSelector(badge);
    await expectRun(page, srv.base, "done");

    // the badge: amber, the count, words for screen readers, the figures in its tooltip
    await page.waitForSelector(`${badge}[data-tone=warn]`);
    assert.equal(await page.innerText(badge), "preflight ⚠ 3");
    assert.equal(await page.getAttribute(badge, "aria-label"), "preflight ⚠ 3: preflight warnings, 3 problems; open the list");
    const tip = await page.getAttribute(badge, "title");
    for (const want of ["top gap: 0.00 mm", "bottom gap: n/a", "uncovered: 0.2 %", "wire/part volume: 1.24", "min arc run: 18.2 mm", "start spread: 0.0 mm", "weld data missing: 0"])
      assert.ok(tip.includes(want), `tooltip has "${want}": ${tip}`);
    await shot(page, `${w}-badge`);

    // click → the problems panel with a Preflight section
    await page.click(badge);
    await page.waitForSelector("[data-testid=preflight-section]");
    const rows = await page.$$eval("[data-testid=preflight-section] .pf-problem .where", (els) => els.map((e) => e.textContent));
    assert.deepEqual(rows, ["wire/part volume · post", "stacked starts · post · layer 3 · bs1/C", "uncovered area · post · layer 3 · bs1/C"]);
    assert.equal(await page.locator("[data-testid=pf-mask-here]").count(), 1, "'new mask here' on the uncovered area only");
    await shot(page, `${w}-panel`);
    // axe: no critical/serious violation in the toolbar (badge) or the panel
    await page.addScriptTag({ path: AXE });
    const axe = await page.evaluate(async () => {
      const r = await window.axe.run({ include: [[".toolbar"], ["[data-testid=problems]"]] }, { resultTypes: ["violations"] });
      return r.violations.filter((v) => v.impact === "critical" || v.impact === "serious").map((v) => `${v.id}: ${v.nodes.map((n) => n.target.join(" ")).join(" | ")}`);
    });
    assert.deepEqual(axe, []);

    // a problem → its layer and section on the mask canvas, its point marked, the layer's starts drawn
    await page.click('[data-testid=preflight-section] .pf-problem[data-pf-check="stacked_starts"]');
    await page.waitForSelector("[data-testid=mask-canvas] [data-testid=pf-mark]");
    assert.equal(await page.inputValue(".mask-panel .layer-row input[type=number]"), "3");
    await page.waitForSelector('[data-testid=mask-canvas] .section-region[data-section="bs1/C"].selected');
    assert.equal(await page.getAttribute("[data-testid=pf-mark]", "data-x"), "6.00");
    assert.equal(await page.getAttribute("[data-testid=pf-mark]", "data-y"), "-3.00");
    assert.equal(await page.getAttribute("[data-testid=pf-starts]", "data-count"), "3");
    assert.equal(await page.getAttribute("[data-testid=pf-starts]", "data-stacked"), "3", "every start sits on layer 2's");
    assert.equal(await page.locator("[data-testid=pf-starts] .pf-start-below").count(), 3);
    await page.click("[aria-label='close the problems panel']");
    await shot(page, `${w}-canvas-starts`);

    // "new mask here": the curve tool on layer 3 at the uncovered spot; a drawn curve becomes a section
    await page.click(badge);
    await page.click("[data-testid=pf-mask-here]");
    await page.waitForSelector("[data-testid=pf-draw-hint]");
    assert.match(await page.getAttribute("[data-tool=curve]", "class"), /active/);
    assert.equal(await page.getAttribute("[data-testid=pf-mark]", "data-x"), "40.00");
    await page.click("[aria-label='close the problems panel']");
    await shot(page, `${w}-mask-here`);
    // the mark is on the canvas where the report put it
    const [mx, my] = await canvasPoint(page, 40, 5.5);
    const box = await page.locator("[data-testid=pf-mark] circle").boundingBox();
    assert.ok(Math.abs(box.x + box.width / 2 - mx) < 2 && Math.abs(box.y + box.height / 2 - my) < 2, "mark at (40, 5.5)");
    await drawClosed(page, [[34, 2], [46, 2], [46, 7], [34, 7]]);
    await page.waitForSelector("[data-testid=pf-draw-hint]", { state: "detached" });
    await page.waitForSelector('.mask-panel [data-section-item="bs1/D"]');

    // the recipe changed: the badge greys out and says so, until the next run
    await page.waitForSelector(`${badge}[data-tone=stale]`);
    assert.equal(await page.innerText(badge), "preflight: re-run");
    assert.match(await page.getAttribute(badge, "aria-label"), /out of date/);
    assert.equal(await page.locator("[data-testid=pf-starts]").count(), 0, "no stale starts on the canvas");
    await shot(page, `${w}-stale`);
    // undo back to what was run: fresh again; redo: stale again
    await page.keyboard.press("Control+z");
    await page.waitForSelector(`${badge}[data-tone=warn]`);
    await page.keyboard.press("Control+y");
    await page.waitForSelector(`${badge}[data-tone=stale]`);
    // (mpp-cross's mask covers the whole cross, so the drawn section has no region of its own: run without it)
    await page.keyboard.press("Control+z");
    await page.click("[data-testid=run]");
    await page.waitForSelector(`${badge}[data-tone=pending]`);
    assert.equal(await waitRun(page), "done");
    await page.waitForSelector(`${badge}[data-tone=warn]`);

    assert.deepEqual(errors, []);
    await context.close();
  });
}

test("the real backend: mpp-cross's run shows its own preflight verdict", async () => {
  const { page, context, errors } = await open(1600, 1000);
  await openRecipe(page, srv.base, "mpp-cross");
  // the badge in the frame the run turns "done": the report already read, never "no preflight"
  // (the toolbar said "done" beside "no preflight" for the ~50 ms the report took to arrive)
  await page.evaluate(() => {
    window.__badgeAtDone = null;
    const progress = document.querySelector("[data-testid=progress]");
    new MutationObserver(() => {
      if (window.__badgeAtDone === null && progress.getAttribute("data-phase") === "done")
        window.__badgeAtDone = document.querySelector("[data-testid=preflight-badge]")?.textContent ?? "(no badge)";
    }).observe(progress, { attributes: true, attributeFilter: ["data-phase"] });
  });
  await expectRun(page, srv.base, "done");
  const atDone = await page.evaluate(() => window.__badgeAtDone);
  assert.match(atDone ?? "", /^preflight (ok|⚠|✗)/, `the badge as the run turned done: ${atDone}`);
  const id = await page.getAttribute("[data-testid=progress]", "data-run-id");
  const arts = await api(srv.base, `/api/runs/${id}/artifacts`);
  assert.ok(arts.some((a) => a.name === "preflight.json"), "every run writes preflight.json");
  const report = await api(srv.base, `/api/runs/${id}/artifacts/preflight.json`);
  const n = report.problems?.length ?? 0;
  await page.waitForSelector(`${badge}[data-tone=${report.verdict}]`);
  const want = report.verdict === "ok" ? (n ? `preflight ok · ${n}` : "preflight ok") : report.verdict === "warn" ? `preflight ⚠ ${n}` : `preflight ✗ ${n}`;
  assert.equal(await page.innerText(badge), want + (report.accepted ? " (accepted)" : ""));
  await page.click(badge);
  await page.waitForSelector("[data-testid=preflight-section]");
  assert.equal(await page.locator("[data-testid=preflight-section] .pf-problem").count(), n);
  await shot(page, "real-mpp-cross");
  // a problem on a layer: that layer on the mask canvas (else layer 1), with its arc starts read back from the program
  const onLayer = (report.problems ?? []).find((p) => p.layer != null);
  if (onLayer) await page.click(`[data-testid=preflight-section] .pf-problem[data-pf-check="${onLayer.check}"][data-problem-layer="${onLayer.layer}"]`);
  else {
    await page.click("[data-tab=mask]");
    await page.fill(".mask-panel .layer-row input[type=number]", "1");
  }
  const index = onLayer?.layer ?? 1;
  const layers = report.layers?.length ? report.layers : report.programs.find((p) => p.layers?.length)?.layers ?? [];
  const starts = layers.find((l) => l.index === index)?.starts ?? [];
  await page.waitForSelector(".mask-canvas .layer-poly");
  assert.equal(await page.inputValue(".mask-panel .layer-row input[type=number]"), String(index));
  if (starts.length) {
    await page.waitForSelector("[data-testid=mask-canvas] [data-testid=pf-starts]");
    assert.equal(Number(await page.getAttribute("[data-testid=pf-starts]", "data-count")), starts.length);
  }
  if (onLayer?.point) await page.waitForSelector("[data-testid=pf-mark]");
  if (await page.locator("[aria-label='close the problems panel']").count()) await page.click("[aria-label='close the problems panel']");
  await shot(page, "real-mpp-cross-canvas");
  assert.deepEqual(errors, []);
  await context.close();
});
