// What the server offers, loaded once: the node catalog, the zone parameters of the XML file, the
// server's health, and the stored recipes (reloaded after a save or delete).
import { useCallback, useEffect, useMemo, useState } from "react";
import * as API from "../api/client";
import type { GraphInfo, Health, NodeSpec, ProcessParameter } from "../api/types";
import { catalogMap } from "../graph/recipe";
import { boundsByName } from "../xml/params";

/** Whether `name` is one of the shipped (read-only) example recipes. */
export const isExampleGraph = (graphs: readonly GraphInfo[], name: string | null) => !!name && graphs.some((g) => g.name === name && g.example);

export function useCatalog(fail: (e: unknown) => void) {
  const [specs, setSpecs] = useState<NodeSpec[]>([]);
  const [processParams, setProcessParams] = useState<ProcessParameter[]>([]);
  const [graphs, setGraphs] = useState<GraphInfo[]>([]);
  const [health, setHealth] = useState<Health | null>(null);
  const catalog = useMemo(() => catalogMap(specs), [specs]);
  const bounds = useMemo(() => boundsByName(processParams), [processParams]);
  const refreshGraphs = useCallback(() => API.listGraphs().then(setGraphs).catch(fail), [fail]);
  useEffect(() => {
    API.nodes().then(setSpecs).catch(fail);
    API.processParameters().then(setProcessParams).catch(fail);
    API.health().then(setHealth).catch(fail);
    void refreshGraphs();
  }, [fail, refreshGraphs]);
  return { specs, catalog, processParams, bounds, graphs, setGraphs, refreshGraphs, health };
}
