// What the editor shows: the tab, the layer (mask canvas, 3D view) and the node previewed on the
// canvas (clicking the previewed node's eye again hides it).
import { useCallback, useState } from "react";
import type { Tab } from "./tabs";

/** The previewed node after a click on `id`'s preview toggle. */
export const togglePreview = (cur: string | null, id: string) => (cur === id ? null : id);

export function useView() {
  const [tab, setTab] = useState<Tab>("graph");
  const [layer, setLayer] = useState(0);
  const [previewNode, setPreviewNode] = useState<string | null>(null);
  const onPreview = useCallback((id: string) => setPreviewNode((cur) => togglePreview(cur, id)), []);
  /** A recipe (re)opened: its first layer, nothing previewed. */
  const clear = useCallback(() => {
    setPreviewNode(null);
    setLayer(0);
  }, []);
  return { tab, setTab, layer, setLayer, previewNode, setPreviewNode, onPreview, clear };
}

export type ViewState = ReturnType<typeof useView>;
