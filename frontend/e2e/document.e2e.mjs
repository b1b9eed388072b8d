// End-to-end tests of the open recipe as one document (#25 faults 1 and 3): the parameter XML is
// part of the recipe's undo history, and a run of an unchanged saved recipe leaves it clean.
// Run: `node e2e/run.mjs e2e/document.e2e.mjs` (after `npm run build`, or SKIP_BUILD=1 to skip it).
import assert from "node:assert/strict";
import { after, before, test } from "node:test";
import { api, expectRun, openPage, saveAs, shot, startBrowser, startServer } from "./harness.mjs";

let srv, browser;
before(async () => {
  [srv, browser] = await Promise.all([startServer(), startBrowser()]);
});
after(async () => {
  await browser?.close();
  await srv?.stop();
});

/** The G-code of the run shown in the toolbar, as the server wrote it. */
async function gcodeOfShownRun(page) {
  const id = await page.getAttribute("[data-testid=progress]", "data-run-id");
  return api(srv.base, `/api/runs/${id}/artifacts/post.gcode`);
}
const feeds = (g) => new Set(g.match(/\bF\d+(\.\d+)?\b/g) ?? []);
const zoneFeeds = ["F360", "F480", "F240"];

test("undo restores recipe and XML together; an unchanged saved recipe stays clean after runs", async () => {
  const { page, errors } = await openPage(browser, srv.base);
  // examples are read-only: save a copy first
  await page.selectOption("[data-testid=open-graph]", "mpp-cross");
  await page.waitForSelector('.react-flow__node[data-id="zone"]');
  await saveAs(page, "doc-cross");
  const savedXml = await api(srv.base, "/api/graphs/doc-cross/params");
  const savedRecipe = await api(srv.base, "/api/graphs/doc-cross");

  // Fault 3: running the unchanged saved recipe leaves it clean, its XML untouched.
  await expectRun(page, srv.base, "done");
  const first = await gcodeOfShownRun(page);
  for (const f of zoneFeeds) assert.ok(feeds(first).has(f), `first run has zone feed ${f}: ${[...feeds(first)]}`);
  assert.equal(await page.locator("[data-testid=save]").innerText(), "save", "no unsaved marker after a run");
  await shot(page, "document-01-clean-after-run");
  assert.equal(await page.evaluate(() => Object.keys(localStorage).filter((k) => k.includes("draft")).length), 0, "no draft written by the run");
  await page.reload();
  await page.waitForSelector('.toolbar .title:text-is("doc-cross")');
  await page.waitForSelector(".react-flow__node", { state: "attached" });
  await page.waitForTimeout(300);
  assert.equal(await page.locator("[data-testid=draft-offer]").count(), 0, "a reload offers nothing to restore");
  assert.equal(await api(srv.base, "/api/graphs/doc-cross/params"), savedXml);

  // Fault 1: delete section bs1/C, run, undo, run again: the same program as before the delete.
  await page.click("[data-tab=mask]");
  await page.waitForSelector('.mask-panel [data-section-item="bs1/C"]');
  await page.click('.mask-panel [data-section-item="bs1/C"] button:text-is("delete")');
  await page.waitForSelector('.mask-panel [data-section-item="bs1/C"]', { state: "detached" });
  assert.equal(await page.locator("[data-testid=save]").innerText(), "save *");
  await expectRun(page, srv.base, "done");
  await page.click("[data-testid=undo]");
  await page.waitForSelector('.mask-panel [data-section-item="bs1/C"]');
  assert.equal(await page.locator("[data-testid=save]").innerText(), "save", "undo returns to the saved document");
  await expectRun(page, srv.base, "done");
  const second = await gcodeOfShownRun(page);
  for (const f of zoneFeeds) assert.ok(feeds(second).has(f), `second run keeps zone feed ${f}: ${[...feeds(second)]}`);
  const body = (g) => g.split("\n").filter((l) => !l.startsWith(";")).join("\n");
  assert.equal(body(second), body(first), "undo-then-run gives the program of before the delete");
  assert.equal(await page.locator("[data-testid=save]").innerText(), "save");
  await shot(page, "document-02-after-undo-run");
  assert.deepEqual(await api(srv.base, "/api/graphs/doc-cross"), savedRecipe);
  assert.deepEqual(errors, []);
});
