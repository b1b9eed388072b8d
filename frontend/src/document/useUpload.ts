// Uploading a file the recipe reads: to a saved graph at once (a name already stored with other
// content asks the user: replace, keep both, cancel), else kept until the recipe is saved under a
// name of its own. The recipe pins the uploaded content (one undo step).
import { useCallback, useState } from "react";
import * as API from "../api/client";
import type { FileInfo } from "../api/types";
import type { UploadAsk, UploadChoice } from "../components/UploadDialog";
import { change, freeName, sha256Hex, withPin } from "./document";
import type { DocumentState } from "./useDocument";
import type { SaveState } from "./useSave";

/** The question to ask when `file` (content `sha`) meets a stored file of the same name with
 * other content; null when there is nothing to ask (a new name, or the same content). */
export function uploadQuestion(file: { name: string; size: number }, sha: string, stored: readonly FileInfo[]): UploadAsk | null {
  const have = stored.find((f) => f.name === file.name);
  if (!have?.sha256 || have.sha256 === sha) return null;
  const other = freeName(file.name, stored.map((f) => f.name));
  return { name: file.name, size: file.size, have: { size: have.size, updated: have.updated, sha256: have.sha256 }, other };
}

export function useUpload(o: { doc: DocumentState; isExample: boolean; saving: SaveState; message: (t: string) => void; fail: (e: unknown) => void }) {
  const [uploadAsk, setUploadAsk] = useState<{ ask: UploadAsk; resolve: (c: UploadChoice) => void } | null>(null);
  const { graphName, recipe, setHist, foldNextFor } = o.doc;
  const { pendingFiles, setSaveAs } = o.saving;
  const { isExample, message, fail } = o;
  const upload = useCallback(
    async (file: File): Promise<string | null> => {
      if (!graphName || isExample) {
        // Files belong to a saved graph: keep the file here, ask for a name, upload on save.
        pendingFiles.current = [...pendingFiles.current.filter((f) => f.name !== file.name), file];
        setSaveAs(graphName ? `${graphName}-copy` : recipe.name || "untitled");
        message(`save the recipe under a name of its own: ${file.name} is uploaded right after`);
        return file.name;
      }
      try {
        // A name the recipe's files already have: the user decides (never replaced at once).
        const [stored, sha] = await Promise.all([API.listFiles(graphName), sha256Hex(file)]);
        const have = stored.find((f) => f.name === file.name);
        const ask = uploadQuestion(file, sha, stored);
        let name = file.name;
        if (ask) {
          const choice = await new Promise<UploadChoice>((resolve) => setUploadAsk({ ask, resolve }));
          setUploadAsk(null);
          if (choice === "cancel") {
            message(`${file.name} not uploaded: the recipe keeps the stored one`);
            return null;
          }
          if (choice === "both") name = ask.other;
        }
        const digest = (await API.putFile(graphName, name, file)) ?? sha;
        // the recipe now runs with this content: one undo step (undo pins the previous content again)
        setHist((h) => change(h, withPin(h.present, name, digest)));
        foldNextFor(1500); // "keep both": the new name is set in the same step
        message(`uploaded ${name}${have && name === file.name && have.sha256 !== digest ? " (replaced: undo brings the old one back)" : ""}`);
        return name;
      } catch (e) {
        fail(e);
        return null;
      }
    },
    [graphName, isExample, recipe.name, message, fail, pendingFiles, setSaveAs, setHist, foldNextFor],
  );
  return { upload, uploadAsk };
}
