// `npm run test:e2e`: build the frontend, then run the e2e tests (node:test, headless Chromium).
import { execFileSync } from "node:child_process";
import path from "node:path";
import { fileURLToPath } from "node:url";

const here = path.dirname(fileURLToPath(import.meta.url));
if (!process.env.SKIP_BUILD) execFileSync("npm", ["run", "build"], { cwd: path.resolve(here, ".."), stdio: "inherit" });
execFileSync(process.execPath, ["--test", "--test-concurrency=1", "--test-reporter=spec", path.join(here, "gui.e2e.mjs")], { stdio: "inherit" });
