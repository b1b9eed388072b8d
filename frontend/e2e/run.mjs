// `npm run test:e2e`: build the frontend, then run the e2e tests (node:test, headless Chromium).
import { execFileSync } from "node:child_process";
import { readdirSync } from "node:fs";
import path from "node:path";
import { fileURLToPath } from "node:url";

const here = path.dirname(fileURLToPath(import.meta.url));
if (!process.env.SKIP_BUILD) execFileSync("npm", ["run", "build"], { cwd: path.resolve(here, ".."), stdio: "inherit" });
// Every *.e2e.mjs file (or the ones named on the command line), one after the other.
const files = process.argv.slice(2).length ? process.argv.slice(2).map((f) => path.resolve(f)) : readdirSync(here).filter((f) => f.endsWith(".e2e.mjs")).sort().map((f) => path.join(here, f));
execFileSync(process.execPath, ["--test", "--test-concurrency=1", "--test-reporter=spec", ...files], { stdio: "inherit" });
