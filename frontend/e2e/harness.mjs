// E2E harness: starts `waamflow serve` on free ports with a temporary data folder (the server
// serves the built frontend at /), and a headless Chromium through playwright-core.
import { spawn } from "node:child_process";
import { mkdirSync, mkdtempSync, rmSync } from "node:fs";
import net from "node:net";
import os from "node:os";
import path from "node:path";
import { fileURLToPath } from "node:url";
import { chromium } from "playwright-core";

export const ROOT = path.resolve(path.dirname(fileURLToPath(import.meta.url)), "../..");
export const OUT = path.join(ROOT, "out/e2e");

const freePort = () =>
  new Promise((resolve, reject) => {
    const s = net.createServer();
    s.once("error", reject);
    s.listen(0, "127.0.0.1", () => {
      const { port } = s.address();
      s.close(() => resolve(port));
    });
  });

/** `waamflow serve` over a new temporary data folder, or over `data` (a restart: same store);
 * `env`: extra environment of the server (e.g. WAAMFLOW_TOKEN); `headers`: sent by the harness's own checks. */
export async function startServer({ data: reuse, env = {}, headers = {} } = {}) {
  const port = await freePort();
  const viewerPort = await freePort();
  const data = reuse ?? mkdtempSync(path.join(os.tmpdir(), "waamflow-e2e-"));
  const exe = process.env.WAAMFLOW_BIN ?? path.join(ROOT, ".venv/bin/waamflow");
  const proc = spawn(exe, ["serve", "--port", String(port), "--viewer-port", String(viewerPort), "--data", data], {
    cwd: ROOT,
    env: { ...process.env, ...env },
    stdio: ["ignore", "pipe", "pipe"],
    detached: true,
  });
  let log = "";
  proc.stdout.on("data", (d) => (log += d));
  proc.stderr.on("data", (d) => (log += d));
  const base = `http://127.0.0.1:${port}`;
  for (let i = 0; i < 300; i++) {
    if (proc.exitCode !== null) throw new Error(`server exited:\n${log}`);
    try {
      const r = await fetch(`${base}/api/health`);
      if (r.ok) break;
    } catch {
      /* not up yet */
    }
    await new Promise((r) => setTimeout(r, 100));
  }
  const index = await fetch(`${base}/`, { headers }).then((r) => r.text());
  if (!index.includes('id="root"')) throw new Error("the server does not serve the built frontend (run `npm run build`)");
  return {
    base,
    data,
    log: () => log,
    /** Stop the server; its data folder is removed unless `keep` (to start another over it). */
    async stop({ keep = false } = {}) {
      try {
        process.kill(-proc.pid, "SIGTERM");
      } catch {
        /* already gone */
      }
      await new Promise((r) => (proc.exitCode !== null ? r() : proc.once("exit", r)));
      if (!keep) rmSync(data, { recursive: true, force: true });
    },
  };
}

export async function startBrowser() {
  mkdirSync(OUT, { recursive: true });
  return chromium.launch({
    executablePath: process.env.CHROMIUM ?? "/usr/bin/chromium",
    args: ["--headless", "--no-sandbox", "--disable-gpu", "--disable-background-networking", "--disable-component-update", "--disable-sync", "--no-first-run"],
  });
}

/** A page at 1366×768 that records console errors and uncaught exceptions. */
export async function openPage(browser, base) {
  const context = await browser.newContext({ viewport: { width: 1366, height: 768 }, acceptDownloads: true });
  const page = await context.newPage();
  const errors = [];
  page.on("console", (m) => {
    if (m.type() === "error") errors.push(`${m.location()?.url ?? ""}: ${m.text()}`);
  });
  page.on("pageerror", (e) => errors.push(`pageerror: ${e.message}`));
  page.on("dialog", (d) => d.accept());
  await page.goto(base + "/");
  try {
    await page.waitForSelector("[data-testid=palette] .palette-item", { timeout: 60_000 });
  } catch (e) {
    throw new Error(`the palette did not load: ${e.message}\nconsole: ${errors.join("\n")}`, { cause: e });
  }
  return { page, errors, context };
}

export const shot = (page, name) => page.screenshot({ path: path.join(OUT, `${name}.png`) });

/** Screen coordinates of a layer point (mm) on the mask canvas. */
export function canvasPoint(page, x, y) {
  return page.evaluate(([x, y]) => {
    const svg = document.querySelector("[data-testid=mask-canvas]");
    const p = new DOMPoint(x, -y).matrixTransform(svg.getScreenCTM());
    return [p.x, p.y];
  }, [x, y]);
}

export async function clickAt(page, x, y) {
  const [sx, sy] = await canvasPoint(page, x, y);
  await page.mouse.click(sx, sy);
  await page.waitForTimeout(60); // keep separate clicks from being read as a double-click
}

/** Draw a closed curve (tool must be "curve"): click the points, then the first again to close. */
export async function drawClosed(page, pts) {
  for (const [x, y] of pts) await clickAt(page, x, y);
  await clickAt(page, pts[0][0], pts[0][1]);
}

/** Draw an open polyline (guide): click the points, finish with Enter. */
export async function drawOpen(page, pts) {
  for (const [x, y] of pts) await clickAt(page, x, y);
  await page.keyboard.press("Enter");
}

export async function api(base, p, init) {
  const r = await fetch(base + p, init);
  if (!r.ok) throw new Error(`${init?.method ?? "GET"} ${p}: ${r.status} ${await r.text()}`);
  const type = r.headers.get("content-type") ?? "";
  return type.includes("json") ? r.json() : r.text();
}

/** Wait for the run in the toolbar to end in `phase`; else fail with the run's error. */
export async function expectRun(page, base, phase, clickRun = true, timeout = 120_000) {
  const before = await page.getAttribute("[data-testid=progress]", "data-run-id");
  if (clickRun) await page.click("[data-testid=run]");
  try {
    await page.waitForFunction((b) => {
      const el = document.querySelector("[data-testid=progress]");
      return el.getAttribute("data-run-id") && el.getAttribute("data-run-id") !== b;
    }, before, { timeout: 30_000 });
  } catch {
    const toasts = await page.locator("[data-testid=toast]").allInnerTexts();
    throw new Error(`no run started; messages: ${toasts.join(" | ")}`);
  }
  const got = await waitRun(page, timeout);
  if (got !== phase) {
    const [last] = await api(base, "/api/runs?limit=1");
    const info = await api(base, `/api/runs/${last.id}`);
    throw new Error(`run ${last.id} ended ${got}, expected ${phase}: ${JSON.stringify(info.error)}`);
  }
}

/** Pick recipe `name` in the toolbar and wait until exactly its nodes are shown (examples share
 * node ids such as "part" and "post", so one node of it is no proof); returns the recipe. */
/** "save as" `name` (opening the dialog unless it is open) and wait for the toolbar to show it. */
export async function saveAs(page, name) {
  await page.getByRole("button", { name: /save as/ }).click().catch(() => undefined);
  await page.fill("[data-testid=save-as-name]", name);
  await page.press("[data-testid=save-as-name]", "Enter");
  await page.waitForSelector(`.toolbar .title:text-is("${name}")`);
}

export async function openRecipe(page, base, name) {
  await page.selectOption("[data-testid=open-graph]", name);
  const recipe = await api(base, `/api/graphs/${name}`);
  await page.waitForFunction((ids) => {
    const shown = [...document.querySelectorAll(".react-flow__node")].map((e) => e.getAttribute("data-id")).sort();
    return !document.querySelector("[data-testid=open-graph][data-opening]") && JSON.stringify(shown) === JSON.stringify(ids);
  }, recipe.nodes.map((n) => n.id).sort());
  return recipe;
}

/** Wait for the run in the toolbar to end; returns its phase. */
export async function waitRun(page, timeout = 120_000) {
  await page.waitForFunction(() => {
    const p = document.querySelector("[data-testid=progress]")?.getAttribute("data-phase");
    return p === "done" || p === "failed" || p === "cancelled";
  }, null, { timeout });
  return page.getAttribute("[data-testid=progress]", "data-phase");
}

/** Drag from an output handle to an input handle in the graph editor. */
export async function connect(page, from, to) {
  const [fn, fp] = from.split(".");
  const [tn, tp] = to.split(".");
  const a = await page.locator(`.react-flow__node[data-id="${fn}"] .react-flow__handle.source[data-handleid="${fp}"]`).boundingBox();
  const b = await page.locator(`.react-flow__node[data-id="${tn}"] .react-flow__handle.target[data-handleid="${tp}"]`).boundingBox();
  await page.mouse.move(a.x + a.width / 2, a.y + a.height / 2);
  await page.mouse.down();
  await page.mouse.move((a.x + b.x) / 2, (a.y + b.y) / 2, { steps: 4 });
  await page.mouse.move(b.x + b.width / 2, b.y + b.height / 2, { steps: 4 });
  await page.mouse.up();
}

/** An ASCII STL of axis-aligned boxes [[x0,y0,z0,x1,y1,z1], ...] (mm), outward normals. */
export function boxesStl(boxes) {
  const tri = (n, a, b, c) => `facet normal ${n.join(" ")}\nouter loop\n${[a, b, c].map((v) => `vertex ${v.join(" ")}`).join("\n")}\nendloop\nendfacet\n`;
  let s = "solid boxes\n";
  for (const [x0, y0, z0, x1, y1, z1] of boxes) {
    const v = (i, j, k) => [i ? x1 : x0, j ? y1 : y0, k ? z1 : z0];
    const quads = [
      [[0, 0, -1], v(0, 0, 0), v(0, 1, 0), v(1, 1, 0), v(1, 0, 0)],
      [[0, 0, 1], v(0, 0, 1), v(1, 0, 1), v(1, 1, 1), v(0, 1, 1)],
      [[0, -1, 0], v(0, 0, 0), v(1, 0, 0), v(1, 0, 1), v(0, 0, 1)],
      [[0, 1, 0], v(0, 1, 0), v(0, 1, 1), v(1, 1, 1), v(1, 1, 0)],
      [[-1, 0, 0], v(0, 0, 0), v(0, 0, 1), v(0, 1, 1), v(0, 1, 0)],
      [[1, 0, 0], v(1, 0, 0), v(1, 1, 0), v(1, 1, 1), v(1, 0, 1)],
    ];
    for (const [n, a, b, c, d] of quads) s += tri(n, a, b, c) + tri(n, a, c, d);
  }
  return s + "endsolid boxes\n";
}
