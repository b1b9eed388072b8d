// End-to-end: the GUI against a server started with WAAMFLOW_TOKEN. The GUI asks for the token once
// (a wrong one is refused and asked again), keeps it for the browser session (a reload does not ask
// again; a new session does), sends it with every API request, and what cannot send a header
// (the run's Server-Sent Events, the 3D preview iframe under /viewer/) gets in with the session cookie.
// Run: `node e2e/run.mjs e2e/auth.e2e.mjs` (after `npm run build`).
import assert from "node:assert/strict";
import { after, before, test } from "node:test";
import { expectRun, shot, startBrowser, startServer } from "./harness.mjs";

const TOKEN = "e2e-lab-token-0123456789abcdef";
const AUTH = { Authorization: `Bearer ${TOKEN}` };
let srv, browser;
before(async () => {
  [srv, browser] = await Promise.all([startServer({ env: { WAAMFLOW_TOKEN: TOKEN }, headers: AUTH }), startBrowser()]);
});
after(async () => {
  await browser?.close();
  await srv?.stop();
});

const prompt = "[role=dialog][aria-labelledby=token-title]";
const palette = "[data-testid=palette] .palette-item";

async function signIn(page, token) {
  await page.waitForSelector(`${prompt} input[aria-label="access token"]`, { timeout: 60_000 });
  await page.fill(`${prompt} input`, token);
  await Promise.all([page.waitForEvent("load"), page.press(`${prompt} input`, "Enter")]);
}

test("the GUI asks for the token once per session and sends it with every request", async () => {
  const health = await (await fetch(`${srv.base}/api/health`)).json();
  assert.equal(health.auth_required, true);
  assert.equal((await fetch(`${srv.base}/api/graphs`)).status, 401);

  const context = await browser.newContext({ viewport: { width: 1366, height: 768 } });
  const page = await context.newPage();
  const api = []; // every /api and /viewer request after sign-in: [url, status, had Authorization]
  let signedIn = false;
  page.on("response", async (r) => {
    const url = new URL(r.url());
    if (!signedIn || !(url.pathname.startsWith("/api/") || url.pathname.startsWith("/viewer"))) return;
    api.push([url.pathname, r.status(), Boolean(await r.request().headerValue("authorization"))]);
  });
  await page.goto(srv.base + "/");

  // a wrong token is refused and the prompt comes back saying so
  await signIn(page, "not-the-token-0123456789");
  await page.waitForSelector(`${prompt} >> text=The token was not accepted`, { timeout: 60_000 });
  await shot(page, "auth-prompt");

  await signIn(page, TOKEN);
  signedIn = true;
  await page.waitForSelector(palette, { timeout: 60_000 });
  assert.equal(await page.locator(prompt).count(), 0);
  assert.equal(await page.evaluate(() => sessionStorage.getItem("waamflow.token")), TOKEN);

  // a reload in the same session: no prompt
  await page.reload();
  await page.waitForSelector(palette, { timeout: 60_000 });
  await page.waitForTimeout(500);
  assert.equal(await page.locator(prompt).count(), 0, "asked again after a reload");

  // a run: started with the header, its progress (EventSource) let in by the session cookie
  await page.selectOption("[data-testid=open-graph]", "rectangle-study");
  await page.waitForSelector('.toolbar .title:text-is("rectangle-study")', { timeout: 60_000 });
  await expectRun(page, srv.base, "done");
  assert.ok(api.some(([p, s]) => /^\/api\/runs\/[^/]+\/events$/.test(p) && s === 200), "progress events streamed");

  // the 3D preview is served through this origin, behind the same token
  if (health.viewer_url) {
    assert.equal(health.viewer_url, "/viewer/");
    await page.click("[data-tab=viewer]");
    await page.waitForSelector("[data-testid=viewer]", { timeout: 60_000 });
    await page.waitForFunction(() => document.querySelector("[data-testid=viewer]")?.contentDocument?.readyState === "complete");
    // the new iframe's first document (about:blank) is "complete" before its page is requested
    for (let i = 0; i < 300 && !api.some(([p, s]) => p.startsWith("/viewer") && s === 200); i++) await page.waitForTimeout(100);
    assert.ok(api.some(([p, s]) => p.startsWith("/viewer") && s === 200), `viewer page loaded: ${JSON.stringify(api.filter(([p]) => p.startsWith("/viewer")))}`);
  }

  const refused = api.filter(([, s]) => s === 401);
  assert.deepEqual(refused, [], "no request was refused after sign-in");
  const fetches = api.filter(([p]) => p.startsWith("/api/") && !p.endsWith("/events"));
  assert.ok(fetches.length > 5 && fetches.every(([, , h]) => h), "every API fetch carried the token");
  await context.close();

  // a new browser session asks again
  const other = await browser.newContext();
  const page2 = await other.newPage();
  await page2.goto(srv.base + "/");
  await page2.waitForSelector(prompt, { timeout: 60_000 });
  assert.equal(await page2.evaluate(() => sessionStorage.getItem("waamflow.token")), null);
  await other.close();
});
