import { useCallback, useEffect, useRef, useState } from "react";
import { cancelRun, eventsUrl, getRun } from "../api/client";
import type { RunEvent } from "../api/types";
import { idleRun, reduceEvent, startedRun, terminal, type RunState } from "./status";

/** How often and how many times the run's record is asked for its end after the stream ended. */
export const END_POLL_MS = 250;
export const END_POLLS = 40;
/** While a run is followed, its record is also asked every STALL_POLL_MS: a stream that stays
 * open without its terminal event must not leave the toolbar at "running" for good (the record
 * is what counts; a connection kept open by a forked server process once did exactly that). */
export const STALL_POLL_MS = 3000;

/** The run's record once it has ended (the store has its summary and artifacts); after END_POLLS
 * asks, the record as it is. */
/** A run's record that has not ended yet. */
const pending = (status: string) => status === "running" || status === "queued";

export async function storedEnd(id: string, wait = (ms: number) => new Promise((r) => setTimeout(r, ms))) {
  let info = await getRun(id);
  for (let i = 1; i < END_POLLS && pending(info.status); i++) {
    await wait(END_POLL_MS);
    info = await getRun(id);
  }
  return info;
}

/** Follow a run through its SSE event stream; its end is shown once the server has stored it. */
export function useRun(onEnd?: (s: RunState) => void | Promise<void>) {
  const [state, setState] = useState<RunState>(idleRun);
  const source = useRef<EventSource | null>(null);
  // Which follow is current: a run followed or reset since makes an older run's late end moot.
  const generation = useRef(0);
  const endRef = useRef(onEnd);
  endRef.current = onEnd;

  const stall = useRef<ReturnType<typeof setInterval> | null>(null);

  const close = () => {
    source.current?.close();
    source.current = null;
    if (stall.current !== null) clearInterval(stall.current);
    stall.current = null;
  };

  const follow = useCallback((id: string) => {
    close();
    const gen = ++generation.current;
    let cur = startedRun(id);
    setState(cur);
    const es = new EventSource(eventsUrl(id));
    source.current = es;
    let ending = false;
    const finish = async () => {
      ending = true;
      close();
      try {
        // The stream's last event can arrive before the server has stored the run's end (its
        // record, summary and artifacts): the end is shown once the record has it.
        const info = await storedEnd(id);
        cur = {
          ...cur,
          phase: info.status === "done" ? "done" : info.status === "failed" || info.status === "interrupted" ? "failed" : info.status === "cancelled" ? "cancelled" : cur.phase,
          error: cur.error ?? info.error ?? null,
          progress: info.status === "done" ? 1 : cur.progress,
        };
      } catch {
        /* the events already told us how it ended */
      }
      if (gen !== generation.current) return; // another run is shown by now
      // the end's findings (artifacts, the preflight report) are read before the end is shown: the
      // toolbar never says "done" beside "no preflight" while the report is still on its way
      try {
        await endRef.current?.(cur);
      } finally {
        if (gen === generation.current) setState(cur);
      }
    };
    es.onmessage = (m) => {
      const ev = JSON.parse(m.data) as RunEvent;
      cur = reduceEvent(cur, ev);
      if (terminal(cur)) void finish();
      else setState(cur);
    };
    let asking = false; // one ask at a time: a slow answer is not asked again on top of itself
    stall.current = setInterval(() => {
      if (ending || asking || terminal(cur) || gen !== generation.current) return;
      asking = true;
      getRun(id)
        .then((info) => {
          if (!ending && !terminal(cur) && !pending(info.status)) void finish();
        })
        .catch(() => undefined)
        .finally(() => (asking = false));
    }, STALL_POLL_MS);
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
    generation.current++;
    close();
    setState(idleRun);
  }, []);

  useEffect(() => close, []);
  return { run: state, follow, cancel, reset };
}
