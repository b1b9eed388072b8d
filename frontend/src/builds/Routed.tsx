import { useSyncExternalStore, type ReactNode } from "react";
import { BuildsPage } from "./BuildsPage";
import { parseRoute } from "./data";

const subscribe = (l: () => void) => {
  window.addEventListener("hashchange", l);
  return () => window.removeEventListener("hashchange", l);
};

/** The editor (`children`, always mounted: its unsaved edits survive a visit) and, when the URL
 * hash says `#/builds` or `#/builds/<id>`, the builds page over it. */
export function Routed({ children }: { children: ReactNode }) {
  const hash = useSyncExternalStore(subscribe, () => window.location.hash, () => "");
  const route = parseRoute(hash);
  return (
    <>
      {children}
      {route && <BuildsPage key="builds" id={route.id} />}
    </>
  );
}
