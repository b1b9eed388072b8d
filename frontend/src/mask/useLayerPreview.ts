import { useEffect, useRef, useState } from "react";
import { ApiError, preview } from "../api/client";
import type { LayerJson, Preview, Recipe, RunError } from "../api/types";
import { publishSectionKeys } from "../forms/sectionKeys";
import { ancestors, engineView } from "../graph/recipe";

export interface PreviewState {
  data: Preview | null;
  error: RunError | null;
  loading: boolean;
  /** performance.now() of the canvas edit this preview answers (null: not caused by an edit). */
  editT0: number | null;
  ghosts: { prev: LayerJson | null; next: LayerJson | null };
}

/**
 * The one-layer re-plan: POST /api/preview for the current (unsaved) recipe, node and layer after
 * every change, newest request wins. `editStarted` holds the time of the edit that caused the
 * request so the edit → canvas latency can be measured. The neighbouring layers (ghosts) come from
 * the slice node and are cached while nothing upstream of it changes.
 */
export function useLayerPreview(
  recipe: Recipe,
  node: string | undefined,
  sliceNode: string | undefined,
  layer: number,
  graph: string | null,
  editStarted: React.MutableRefObject<number | null>,
): PreviewState {
  const [state, setState] = useState<PreviewState>({ data: null, error: null, loading: false, editT0: null, ghosts: { prev: null, next: null } });
  const ghostCache = useRef(new Map<string, LayerJson | null>());
  const key = JSON.stringify(engineView(recipe));

  useEffect(() => {
    if (!node) return;
    const ctl = new AbortController();
    const t0 = editStarted.current;
    setState((s) => ({ ...s, loading: true }));
    preview({ recipe, node, layer, graph, coverage: true }, ctl.signal)
      .then((data) => {
        if (ctl.signal.aborted) return;
        if (editStarted.current === t0) editStarted.current = null;
        if (data.sections.length) publishSectionKeys(data.sections.map((x) => x.key));
        setState((s) => ({ ...s, data, error: data.error, loading: false, editT0: t0 }));
      })
      .catch((e) => {
        if (ctl.signal.aborted || (e as Error).name === "AbortError") return;
        const err = e instanceof ApiError ? e.detail : { message: String(e) };
        setState((s) => ({ ...s, error: err, loading: false }));
      });
    return () => ctl.abort();
    // eslint-disable-next-line react-hooks/exhaustive-deps -- `key` stands for the recipe (its engine view): a new recipe object with the same content must not refetch
  }, [key, node, layer, graph]);

  // Ghost layers: the slice output of layer ± 1, cached per upstream-of-slice signature.
  const sliceKey = sliceNode
    ? JSON.stringify(recipe.nodes.filter((n) => n.id === sliceNode || ancestors(recipe, sliceNode).has(n.id)))
    : "";
  useEffect(() => {
    if (!sliceNode) return;
    const ctl = new AbortController();
    const count = state.data?.layer_count ?? null;
    const load = async (i: number): Promise<LayerJson | null> => {
      // Above the shown layer only once the layer count is known: the server refuses (422) a
      // layer past the top, and the browser logs every refused request.
      if (i < 0 || (i > layer && (count === null || i >= count))) return null;
      const k = `${sliceKey}|${i}`;
      if (ghostCache.current.has(k)) return ghostCache.current.get(k)!;
      try {
        const p = await preview({ recipe, node: sliceNode, layer: i, graph, coverage: false }, ctl.signal);
        ghostCache.current.set(k, p.layer);
        return p.layer;
      } catch {
        return null;
      }
    };
    void Promise.all([load(layer - 1), load(layer + 1)]).then(([prev, next]) => {
      if (!ctl.signal.aborted) setState((s) => ({ ...s, ghosts: { prev, next } }));
    });
    return () => ctl.abort();
    // eslint-disable-next-line react-hooks/exhaustive-deps -- `sliceKey` stands for the recipe upstream of the slice node: edits below it must not refetch the ghosts
  }, [sliceKey, sliceNode, layer, graph, state.data?.layer_count]);

  return state;
}
