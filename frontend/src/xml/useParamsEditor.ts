/**
 * The parameter editor's state, one hook per concern: the XML parsed, the last run's parameters
 * (what its geometry has: our values outside it are orphans), the tree's selection, and edits /
 * import / export of the draft; where a server error points in the table.
 */
import { useEffect, useMemo, useState } from "react";
import { artifactText } from "../api/client";
import type { RunError } from "../api/types";
import { parseParams, serializeParams, type ParamDoc } from "./params";

export type ServerError = RunError & Record<string, unknown>;

/** The shown XML parsed (null with the parser's message when it does not parse). */
export function useParsedDoc(text: string | null) {
  return useMemo((): { doc: ParamDoc | null; error: string | null } => {
    if (text === null) return { doc: null, error: null };
    try {
      return { doc: parseParams(text), error: null };
    } catch (e) {
      return { doc: null, error: (e as Error).message };
    }
  }, [text]);
}

/** The parameters the last run wrote (its first `<zone node>.params.xml`), null until read. */
export function useRunParams(runId: string | null, artifacts: string[]) {
  const [current, setCurrent] = useState<ParamDoc | null>(null);
  useEffect(() => {
    setCurrent(null);
    if (!runId || !artifacts.length) return;
    void artifactText(runId, artifacts[0]).then((t) => {
      if (!t) return;
      try {
        setCurrent(parseParams(t));
      } catch {
        /* shown by the artifact itself */
      }
    });
  }, [runId, artifacts]);
  return current;
}

/** The layer and section the table shows: the first of the document until one is picked. */
export function useTreeSelection(doc: ParamDoc | null) {
  const [sel, setSel] = useState<{ layer: number; section: string } | null>(null);
  useEffect(() => {
    if (doc && !sel && doc.layers[0]?.sections[0]) setSel({ layer: doc.layers[0].index, section: doc.layers[0].sections[0].id });
  }, [doc, sel]);
  return [sel, setSel] as const;
}

/** Edits replace the draft (the original text's layout kept); import checks the file parses; export downloads the draft. */
export function useDraftFiles(original: string | null, doc: ParamDoc | null, graph: string | null, onChange: (text: string) => void) {
  const [importError, setImportError] = useState<string | null>(null);
  const change = (d: ParamDoc) => {
    if (original === null) return;
    setImportError(null);
    onChange(serializeParams(original, d));
  };
  const importFile = async (f: File) => {
    const text = await f.text();
    try {
      parseParams(text);
      setImportError(null);
      onChange(text);
    } catch (e) {
      setImportError(`import: ${(e as Error).message}`);
    }
  };
  const exportFile = () => {
    if (!doc || original === null) return;
    const blob = new Blob([serializeParams(original, doc)], { type: "application/xml" });
    const a = document.createElement("a");
    a.href = URL.createObjectURL(blob);
    a.download = `${graph ?? "parameters"}.params.xml`;
    a.click();
    setTimeout(() => URL.revokeObjectURL(a.href), 1000);
  };
  return { importError, change, importFile, exportFile };
}

/** True when the server's error names this cell: layer and section, then zone and parameter in its field or message. */
export function serverCell(err: ServerError | null, layer: number, section: string, zone: string, name: string) {
  if (!err || err.layer !== layer || err.section !== section) return false;
  const text = `${String(err.field ?? "")} ${err.message}`;
  const z = (typeof err.zone === "string" ? err.zone : text.match(/zone '([^']+)'/)?.[1]) ?? null;
  return (z === null || z === zone) && new RegExp(`\\b${name}\\b`).test(text);
}

/** True when the server's error is on this layer (and section, when given and the error names one). */
export const errAt = (err: ServerError | null, layer: number, section?: string) =>
  !!err && err.layer === layer && (section === undefined || err.section === section || !err.section);
