// The URL names the open recipe and tab (`/?graph=NAME&tab=mask`): opening the page at a URL opens
// that recipe and tab, every change of either pushes a history entry, back/forward move between them.
import { useEffect, useRef } from "react";
import { parsePlace, placeSearch } from "../graph/drafts";
import { asTab, type Tab } from "./tabs";

/** What the URL `search` asks for, given the recipe on screen: a recipe to open (null: the one
 * shown stays) and the tab to show. */
export function placeRequest(search: string, shown: string | null): { open: string | null; tab: Tab } {
  const p = parsePlace(search);
  return { open: p.graph && p.graph !== shown ? p.graph : null, tab: asTab(p.tab) };
}

export function usePlace(graphName: string | null, tab: Tab, setTab: (t: Tab) => void, open: (name: string, tab?: Tab) => Promise<void>) {
  const navigating = useRef(false);
  // The listener set up once reads the current `open` and recipe name.
  const openRef = useRef(open);
  openRef.current = open;
  const graphRef = useRef(graphName);
  graphRef.current = graphName;
  useEffect(() => {
    const place = parsePlace(location.search);
    if (place.graph) {
      navigating.current = true;
      void openRef.current(place.graph, asTab(place.tab)).finally(() => (navigating.current = false));
    } else if (place.tab) setTab(asTab(place.tab));
    const onPop = () => {
      const want = placeRequest(location.search, graphRef.current);
      navigating.current = true;
      const done = () => {
        setTab(want.tab);
        navigating.current = false;
      };
      if (want.open) void openRef.current(want.open, want.tab).finally(done);
      else done();
    };
    window.addEventListener("popstate", onPop);
    return () => window.removeEventListener("popstate", onPop);
  }, [setTab]);
  useEffect(() => {
    if (navigating.current) return;
    const want = placeSearch({ graph: graphName, tab });
    if (want !== location.search) window.history.pushState(null, "", want || location.pathname);
  }, [graphName, tab]);
}
