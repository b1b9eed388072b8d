import { defineConfig } from "vitest/config";
import react from "@vitejs/plugin-react";

// The FastAPI server serves frontend/dist at `/`; in dev, proxy /api to a running `waamflow serve`.
export default defineConfig({
  plugins: [react()],
  base: "/",
  build: { outDir: "dist", emptyOutDir: true, chunkSizeWarningLimit: 1500 },
  server: { proxy: { "/api": process.env.WAAMFLOW_API ?? "http://127.0.0.1:8000" } },
  test: { environment: "node", include: ["test/**/*.test.ts", "test/**/*.test.tsx"] },
});
