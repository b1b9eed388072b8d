// End-to-end test of #25 Build 2 "revisions are kept": the toolbar's history lists a saved
// recipe's revisions newest first; an earlier one opens as an unsaved edit on top of the current
// revision (save → a new revision equal to it, with If-Match; undo → back), keyboard and axe clean.
// Run: `node e2e/run.mjs e2e/history.e2e.mjs` (after `npm run build`, or SKIP_BUILD=1 to skip it).
import assert from "node:assert/strict";
import { createRequire } from "node:module";
import { after, before, test } from "node:test";
import { api, openPage, openRecipe, saveAs, shot, startBrowser, startServer } from "./harness.mjs";

const AXE = createRequire(import.meta.url).resolve("axe-core/axe.min.js");
let srv, browser;
before(async () => {
  [srv, browser] = await Promise.all([startServer(), startBrowser()]);
});
after(async () => {
  await browser?.close();
  await srv?.stop();
});

const clean = (page) => page.waitForFunction(() => document.querySelector("[data-testid=save]")?.textContent === "save");
const layerHeight = (page) => page.locator('[data-field="layer_height"] input').first();

async function setLayerHeight(page, v) {
  await page.click('.react-flow__node[data-id="layers"]');
  await layerHeight(page).fill(v);
  await page.waitForFunction(() => document.querySelector("[data-testid=save]")?.textContent === "save *");
}

test("history: 3 revisions listed 3,2,1; revision 1 opens unsaved, saves as revision 4 equal to it, undo returns to 3", async () => {
  const { page, errors } = await openPage(browser, srv.base);
  await openRecipe(page, srv.base, "mpp-cross");
  // an example: history disabled, with a tooltip saying why
  const exBtn = page.locator("[data-testid=history]");
  assert.equal(await exBtn.isDisabled(), true);
  assert.match(await exBtn.getAttribute("title"), /example/);

  await saveAs(page, "hist-cross"); // revision 1
  await clean(page);
  await page.click('.react-flow__node[data-id="layers"]');
  const rev1Value = await layerHeight(page).inputValue();
  assert.ok(rev1Value && rev1Value !== "1.2" && rev1Value !== "1.1", rev1Value);
  await setLayerHeight(page, "1.2");
  await page.click("[data-testid=save]"); // revision 2
  await clean(page);
  await setLayerHeight(page, "1.1");
  await page.click("[data-testid=save]"); // revision 3
  await clean(page);
  const revs = await api(srv.base, "/api/graphs/hist-cross/revisions");
  assert.deepEqual(revs.map((r) => r.revision), [3, 2, 1]);

  // the dialog: 3 rows, newest first, local time shown
  await page.click("[data-testid=history]");
  await page.waitForSelector("[data-testid=history-row]");
  const rows = page.locator("[data-testid=history-row]");
  assert.equal(await rows.count(), 3);
  assert.deepEqual(await rows.evaluateAll((rs) => rs.map((r) => r.getAttribute("data-revision"))), ["3", "2", "1"]);
  assert.match(await rows.first().innerText(), /rev 3 \(current\)/);
  const local = await page.evaluate((t) => new Date(t * 1000).toLocaleString(), revs[0].time);
  assert.ok((await rows.first().innerText()).includes(local), `local time ${local} shown`);
  // focus is inside and stays there (Tab wraps), Escape closes
  assert.equal(await page.evaluate(() => !!document.activeElement?.closest("[data-testid=history-dialog]")), true);
  for (let i = 0; i < 8; i++) {
    await page.keyboard.press("Tab");
    assert.equal(await page.evaluate(() => !!document.activeElement?.closest("[data-testid=history-dialog]")), true, `focus inside after ${i + 1} Tab`);
  }
  await page.keyboard.press("Escape");
  await page.waitForSelector("[data-testid=history-dialog]", { state: "detached" });
  assert.equal(await page.evaluate(() => document.activeElement?.getAttribute("data-testid")), "history", "focus back on the button");

  // keyboard: open again, pick revision 1 with Enter
  await page.keyboard.press("Enter");
  await page.waitForSelector('[data-testid=history-row][data-revision="1"]');
  await page.focus('[data-testid=history-row][data-revision="1"]');
  await page.keyboard.press("Enter");
  await page.waitForFunction(() => /^Revision 1: .*nodes/.test(document.querySelector("[data-testid=history-summary]")?.textContent ?? ""));
  const summary = await page.innerText("[data-testid=history-summary]");
  assert.match(summary, /settings of layers differ/, summary);
  for (const [w, h] of [[1600, 1000], [1366, 768]]) {
    await page.setViewportSize({ width: w, height: h });
    await shot(page, `history-dialog-${w}`);
    const fits = await page.evaluate(() => {
      const b = document.querySelector("[data-testid=history-dialog] > div").getBoundingClientRect();
      return b.top >= 0 && b.left >= 0 && b.bottom <= innerHeight && b.right <= innerWidth;
    });
    assert.ok(fits, `the dialog fits at ${w}×${h}`);
  }
  await page.addScriptTag({ path: AXE });
  const axe = await page.evaluate(async () => {
    const r = await window.axe.run({ include: [["[data-testid=history-dialog]"], [".toolbar"]] }, { resultTypes: ["violations"] });
    return r.violations.filter((v) => v.impact === "critical" || v.impact === "serious").map((v) => `${v.id}: ${v.nodes.map((n) => n.target.join(" ")).join(" | ")}`);
  });
  assert.deepEqual(axe, []);

  // open it: revision 1's value on screen, unsaved; nothing saved yet
  await page.click("[data-testid=history-open]");
  await page.waitForSelector("[data-testid=history-dialog]", { state: "detached" });
  await page.click('.react-flow__node[data-id="layers"]');
  assert.equal(await layerHeight(page).inputValue(), rev1Value);
  assert.equal(await page.locator("[data-testid=save]").innerText(), "save *");
  assert.equal((await api(srv.base, "/api/graphs/hist-cross/revisions")).length, 3, "opening saves nothing");

  // save → revision 4 = revision 1's recipe (If-Match on revision 3: no conflict)
  await page.click("[data-testid=save]");
  await clean(page);
  const after = await api(srv.base, "/api/graphs/hist-cross/revisions");
  assert.deepEqual(after.map((r) => r.revision), [4, 3, 2, 1]);
  const [r1, r4] = await Promise.all([api(srv.base, "/api/graphs/hist-cross/revisions/1"), api(srv.base, "/api/graphs/hist-cross/revisions/4")]);
  assert.deepEqual(r4, r1);

  // undo → revision 3's value, marked unsaved against revision 4
  await page.click("[data-testid=undo]");
  await page.click('.react-flow__node[data-id="layers"]');
  assert.equal(await layerHeight(page).inputValue(), "1.1");
  assert.equal(await page.locator("[data-testid=save]").innerText(), "save *");
  assert.deepEqual(errors, []);
  await page.context().close();
});
