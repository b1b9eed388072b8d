/**
 * Bearer-token hook for a server started with WAAMFLOW_TOKEN / --token-file: every same-origin
 * request gets `Authorization: Bearer <token>` from sessionStorage; the first 401 asks for the
 * token once (kept for this browser session only) and reloads. The token is also put in a session
 * cookie so that what cannot send a header (EventSource, artifact links, the viewer) is let in for
 * GET requests.
 */
import { useState } from "react";
import { createRoot } from "react-dom/client";

const KEY = "waamflow.token";
const COOKIE = "waamflow_token";

export const getToken = () => sessionStorage.getItem(KEY);

export function setToken(token: string) {
  sessionStorage.setItem(KEY, token);
  document.cookie = `${COOKIE}=${encodeURIComponent(token)}; path=/; SameSite=Strict${location.protocol === "https:" ? "; Secure" : ""}`;
}

function sameOrigin(url: string): boolean {
  try {
    return new URL(url, location.href).origin === location.origin;
  } catch {
    return false;
  }
}

let prompting = false;

export function TokenPrompt({ rejected, onSubmit }: { rejected: boolean; onSubmit: (token: string) => void }) {
  const [value, setValue] = useState("");
  return (
    <div role="dialog" aria-modal="true" aria-labelledby="token-title"
      style={{ position: "fixed", inset: 0, background: "rgba(0,0,0,.45)", display: "grid", placeItems: "center", zIndex: 10000 }}>
      <form onSubmit={(e) => { e.preventDefault(); if (value.trim()) onSubmit(value.trim()); }}
        style={{ background: "var(--panel, #fff)", color: "inherit", padding: 20, borderRadius: 8, minWidth: 320, display: "grid", gap: 10 }}>
        <h2 id="token-title" style={{ margin: 0, fontSize: 16 }}>Access token</h2>
        <p style={{ margin: 0 }}>
          {rejected ? "The token was not accepted. " : ""}This server needs the access token your administrator gave you.
        </p>
        <input type="password" aria-label="access token" autoFocus autoComplete="current-password"
          value={value} onChange={(e) => setValue(e.target.value)} />
        <button type="submit" disabled={!value.trim()}>Sign in</button>
      </form>
    </div>
  );
}

function askForToken() {
  if (prompting) return;
  prompting = true;
  const host = document.createElement("div");
  document.body.appendChild(host);
  createRoot(host).render(<TokenPrompt rejected={getToken() !== null} onSubmit={(t) => { setToken(t); location.reload(); }} />);
}

/** Wraps window.fetch once (on import, before the API client captures fetch). */
export function installAuth() {
  if ((window.fetch as { waamflowAuth?: boolean }).waamflowAuth) return;
  const original = window.fetch.bind(window);
  window.fetch = async (input: RequestInfo | URL, init?: RequestInit) => {
    const url = input instanceof Request ? input.url : String(input);
    const token = getToken();
    if (!sameOrigin(url)) return original(input, init);
    let req = new Request(input, init);
    if (token && !req.headers.has("Authorization")) {
      const headers = new Headers(req.headers);
      headers.set("Authorization", `Bearer ${token}`);
      req = new Request(req, { headers });
    }
    const res = await original(req);
    if (res.status === 401 && (res.headers.get("WWW-Authenticate") ?? "").startsWith("Bearer")) askForToken();
    return res;
  };
  (window.fetch as { waamflowAuth?: boolean }).waamflowAuth = true;
}

if (typeof window !== "undefined" && typeof window.fetch === "function") installAuth();
