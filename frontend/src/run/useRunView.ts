// The run the editor shows and what it left: artifacts, the run's merged parameter XML, the
// preflight report and the inputs it was run with, the failure drawn on the mask canvas, a refused
// start. One run started here, or the latest run of a recipe just opened (replayed quietly).
import { useCallback, useMemo, useRef, useState } from "react";
import * as API from "../api/client";
import type { Artifact, RunError } from "../api/types";
import { runRequest, type Doc } from "../document/document";
import type { PreflightMark } from "../mask/MaskView";
import { beadWidthOf, isStale, layerStarts, parsePreflight, preflightBadge, recipeSignature, type Preflight, type RunInputs } from "../preflight/preflight";
import { collectProblems, currentProblems, problemsByNode } from "../problems/problems";
import type { RunState } from "./status";
import { useRun } from "./useRun";

/** What the end of a run shows: its failure (drawn on the canvas), whether the mask tab comes up
 * (a failure on a layer), and the toast. A replayed run (`quiet`) only shows its failure. */
export function endOfRun(s: RunState, quiet: boolean): { failure: RunError | null; toMask: boolean; message: string | null } {
  if (s.phase === "failed" && s.error)
    return { failure: s.error, toMask: !quiet && s.error.layer != null, message: quiet ? null : `run failed: ${s.error.message}` };
  return { failure: null, toMask: false, message: s.phase === "done" && !quiet ? "run finished" : null };
}

/** The merged parameter XML a finished run wrote (new zones filled from the template), if any. */
export const mergedXmlArtifact = (arts: readonly Artifact[]) => arts.find((a) => a.name.endsWith(".params.xml")) ?? null;

export function useRunView(o: { message: (t: string) => void; fail: (e: unknown) => void; toMask: () => void }) {
  const [artifacts, setArtifacts] = useState<Artifact[]>([]);
  const [failure, setFailure] = useState<RunError | null>(null);
  const [requestError, setRequestError] = useState<RunError | null>(null);
  // The last run's merged parameter XML: shown in the editor only while the user has no XML of
  // their own (a template to start from); it never replaces the user's text.
  const [runXml, setRunXml] = useState<string | null>(null);
  // The last run's preflight report, and the recipe and XML it was run with: once either changes
  // the report no longer describes what is on screen (the badge greys out until the next run).
  const [preflight, setPreflight] = useState<Preflight | null>(null);
  const [preflightOf, setPreflightOf] = useState<RunInputs | null>(null);
  const [pfMark, setPfMark] = useState<PreflightMark | null>(null);
  const shownRun = useRef<{ id: string; replay: boolean } | null>(null);
  const lastOpened = useRef<string | null>(null); // the recipe opened last (null: a new one)
  const opts = useRef(o);
  opts.current = o;

  const { run, follow, cancel, reset } = useRun(async (s) => {
    if (!s.id || shownRun.current?.id !== s.id) return; // another recipe was opened meanwhile
    const quiet = shownRun.current.replay;
    let arts: Artifact[] = [];
    try {
      arts = await API.listArtifacts(s.id);
      // never replaces the user's text nor marks the recipe unsaved: kept aside
      const merged = mergedXmlArtifact(arts);
      const xml = s.phase === "done" && merged ? await API.artifactText(s.id, merged.name) : undefined;
      // Read whenever the run wrote one (a failing preflight may end the run as failed).
      const report = arts.some((a) => a.name === "preflight.json") ? parsePreflight(await API.artifactText(s.id, "preflight.json")) : undefined;
      // shown together: the results never appear beside the badge of no report (#27, trust fault 8)
      setArtifacts(arts);
      if (xml !== undefined) setRunXml(xml);
      if (report !== undefined) setPreflight(report);
    } catch (e) {
      setArtifacts(arts);
      opts.current.fail(e);
    }
    const end = endOfRun(s, quiet);
    if (end.failure) setFailure(end.failure);
    if (end.toMask) opts.current.toMask();
    if (end.message) opts.current.message(end.message);
  });

  /** Nothing shown: a recipe (`name`, null: a new one) was opened. */
  const clear = useCallback((name: string | null) => {
    setRunXml(null);
    setFailure(null);
    setRequestError(null);
    setArtifacts([]);
    setPreflight(null);
    setPreflightOf(null);
    setPfMark(null);
    shownRun.current = null;
    lastOpened.current = name;
    reset();
  }, [reset]);

  /** Reopened recipe: its latest run's results, plots, problems and preflight (#25 fault 8). They
   * count as current when that run used the recipe and XML as saved (the server compares). */
  const showLatestRun = useCallback(async (name: string, full: Doc) => {
    const [last] = await API.runsOf(name, 1);
    if (!last || lastOpened.current !== name) return; // another recipe opened meanwhile
    const current = last.same_as_saved !== false;
    setPreflightOf({ recipe: current ? recipeSignature(full.recipe) : "(not the saved recipe)", xml: full.xml });
    shownRun.current = { id: last.id, replay: true };
    follow(last.id);
  }, [follow]);

  /** Run exactly what is on screen; a refused start returns the server's reason (else null). */
  const start = useCallback(async (doc: Doc, graph: string | null): Promise<RunError | null> => {
    setFailure(null);
    setRequestError(null);
    setArtifacts([]);
    setPreflight(null);
    setPfMark(null);
    setPreflightOf({ recipe: recipeSignature(doc.recipe), xml: doc.xml });
    reset(); // the progress bar starts from zero for the new run
    try {
      // The recipe runs as displayed (unsaved edits included) with the XML as shown in the editor
      // (a draft: never stored by the run); a saved graph lends it its uploaded files.
      const { id } = await API.startRun(runRequest(doc, graph));
      shownRun.current = { id, replay: false };
      follow(id);
      return null;
    } catch (e) {
      opts.current.fail(e);
      if (!(e instanceof API.ApiError)) return null;
      if (e.detail.node || e.detail.layer != null) setFailure(e.detail);
      setRequestError(e.detail);
      return e.detail;
    }
  }, [follow, reset]);

  return { run, cancel, artifacts, failure, setFailure, requestError, runXml, preflight, preflightOf, pfMark, setPfMark, clear, showLatestRun, start };
}

export type RunView = ReturnType<typeof useRunView>;

/** What the run tells about the recipe and XML on screen (`now`): problems (stale once either
 * changed), the preflight badge, the ignition starts of `layer` for the canvas, the zone XML files. */
export function useRunFindings(v: RunView, now: RunInputs, layer: number) {
  const { run, requestError, preflight, preflightOf, artifacts } = v;
  const { recipe, xml } = now; // compared by its two fields (`now` is a new object each render)
  const problems = useMemo(
    () => currentProblems(collectProblems(run.warnings, [requestError, run.error]), preflightOf, { recipe, xml }),
    [run.warnings, run.error, requestError, preflightOf, recipe, xml],
  );
  const nodeProblems = useMemo(() => problemsByNode(problems), [problems]);
  const preflightStale = isStale(preflight, preflightOf, now);
  const badge = preflightBadge({ phase: run.phase, report: preflight, stale: preflightStale });
  const canvasStarts = useMemo(
    () => (preflight && !preflightStale ? { ...layerStarts(preflight, layer), radius: beadWidthOf(preflight) } : null),
    [preflight, preflightStale, layer],
  );
  const zoneArtifacts = useMemo(() => artifacts.filter((a) => a.name.endsWith(".params.xml")).map((a) => a.name), [artifacts]);
  return { problems, nodeProblems, preflightStale, badge, canvasStarts, zoneArtifacts };
}
