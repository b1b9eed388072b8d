// @vitest-environment jsdom
// The graph editor stays mounted behind the other tabs but does not re-render while hidden (#30:
// every canvas edit re-rendered React Flow's nodes, edges and store before its preview request).
import { memo } from "react";
import { createRoot } from "react-dom/client";
import { describe, expect, it } from "vitest";
import { hiddenAlready } from "../src/app/Workspace";
import type { GraphEditorProps } from "../src/graph/GraphEditor";
import { act } from "./renderHook";

type P = Pick<GraphEditorProps, "active"> & { label: string; doc: string | null };

describe("the hidden graph editor", () => {
  it("renders while shown, once on being hidden, not while hidden, with the latest props when shown again, and when another recipe opens behind it", () => {
    const seen: string[] = [];
    const Probe = memo(function Probe({ active, label, doc }: P) {
      seen.push(`${doc}/${label}:${active ? "shown" : "hidden"}`);
      return null;
    }, hiddenAlready as unknown as (a: P, b: P) => boolean);
    const root = createRoot(document.createElement("div"));
    const show = (active: boolean, label: string, doc = "a") => act(() => root.render(<Probe active={active} label={label} doc={doc} />));
    show(true, "r1");
    show(true, "r2"); // an edit while shown
    show(false, "r2"); // another tab: gives up its keys
    show(false, "r3"); // edits on the mask canvas
    show(false, "r4");
    show(true, "r4"); // back to the graph: the recipe of now
    show(false, "r4"); // another tab again
    show(false, "s1", "b"); // another recipe opened behind it: rendered, its nodes shown in the DOM
    show(false, "s2", "b"); // its edits on the canvas: not
    expect(seen).toEqual(["a/r1:shown", "a/r2:shown", "a/r2:hidden", "a/r4:shown", "a/r4:hidden", "b/s1:hidden"]);
    act(() => root.unmount());
  });
});
