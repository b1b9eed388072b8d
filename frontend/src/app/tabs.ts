// The views of the editor (one tab each) and how a tab named in the URL or a draft is read.
export type Tab = "graph" | "mask" | "params" | "results" | "viewer";
export const TABS: [Tab, string][] = [["graph", "Graph"], ["mask", "Mask canvas"], ["params", "Parameters (XML)"], ["results", "Results & plots"], ["viewer", "3D view"]];
/** A tab name from outside (URL, stored draft): one of TABS, else the graph. */
export const asTab = (t: string | null): Tab => (TABS.some(([k]) => k === t) ? (t as Tab) : "graph");
