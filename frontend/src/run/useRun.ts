import { useCallback, useEffect, useRef, useState } from "react";
import { cancelRun, eventsUrl, getRun } from "../api/client";
import type { RunEvent } from "../api/types";
import { idleRun, reduceEvent, startedRun, terminal, type RunState } from "./status";

/** Follow a run through its SSE event stream; falls back to the status endpoint when it ends. */
export function useRun(onEnd?: (s: RunState) => void) {
  const [state, setState] = useState<RunState>(idleRun);
  const source = useRef<EventSource | null>(null);
  const endRef = useRef(onEnd);
  endRef.current = onEnd;

  const close = () => {
    source.current?.close();
    source.current = null;
  };

  const follow = useCallback((id: string) => {
    close();
    let cur = startedRun(id);
    setState(cur);
    const es = new EventSource(eventsUrl(id));
    source.current = es;
    const finish = async () => {
      close();
      try {
        const info = await getRun(id);
        cur = {
          ...cur,
          phase: info.status === "done" ? "done" : info.status === "failed" || info.status === "interrupted" ? "failed" : info.status === "cancelled" ? "cancelled" : cur.phase,
          error: cur.error ?? info.error ?? null,
          progress: info.status === "done" ? 1 : cur.progress,
        };
      } catch {
        /* the events already told us how it ended */
      }
      setState(cur);
      endRef.current?.(cur);
    };
    es.onmessage = (m) => {
      const ev = JSON.parse(m.data) as RunEvent;
      cur = reduceEvent(cur, ev);
      setState(cur);
      if (terminal(cur)) void finish();
    };
    es.onerror = () => {
      // A dropped connection reconnects by itself (resuming after Last-Event-ID; replays are
      // ignored by seq). Only a refused stream (closed for good) ends following: ask the status.
      if (!terminal(cur) && es.readyState === EventSource.CLOSED) void finish();
    };
  }, []);

  const cancel = useCallback(async () => {
    if (state.id) await cancelRun(state.id);
  }, [state.id]);

  const reset = useCallback(() => {
    close();
    setState(idleRun);
  }, []);

  useEffect(() => close, []);
  return { run: state, follow, cancel, reset };
}
