// The status bar's toasts: the last few messages, each shown for a while.
import { useCallback, useState } from "react";
import { ApiError } from "../api/client";

export interface Message {
  id: number;
  text: string;
}

/** How many toasts are shown at once, and for how long (ms). */
export const MAX_MESSAGES = 4;
export const MESSAGE_MS = 6000;

/** The list with `m` added, the oldest dropped beyond MAX_MESSAGES. */
export const pushMessage = (list: readonly Message[], m: Message): Message[] => [...list.slice(-(MAX_MESSAGES - 1)), m];

/** What a failed request tells the user: the server's message, else the error as text. */
export const failureText = (e: unknown): string => (e instanceof ApiError ? e.detail.message : String(e));

export function useMessages() {
  const [messages, setMessages] = useState<Message[]>([]);
  const message = useCallback((text: string) => {
    const id = Date.now() + Math.random();
    setMessages((m) => pushMessage(m, { id, text }));
    setTimeout(() => setMessages((m) => m.filter((x) => x.id !== id)), MESSAGE_MS);
  }, []);
  const fail = useCallback((e: unknown) => message(failureText(e)), [message]);
  return { messages, message, fail };
}
