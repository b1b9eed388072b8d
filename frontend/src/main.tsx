import { ReactFlowProvider } from "@xyflow/react";
import "@xyflow/react/dist/style.css";
import { StrictMode } from "react";
import { createRoot } from "react-dom/client";
import "./api/auth"; // first: wraps fetch before the API client captures it
import { App } from "./App";
import { Routed } from "./builds/Routed";
import "./styles.css";
import "./core.css";
import "./preflight/preflight.css";

createRoot(document.getElementById("root")!).render(
  <StrictMode>
    <ReactFlowProvider>
      <Routed>
        <App />
      </Routed>
    </ReactFlowProvider>
  </StrictMode>,
);
