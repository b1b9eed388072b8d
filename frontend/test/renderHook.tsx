// A hook rendered in a real React root (jsdom): `result.current` is the hook's latest return value;
// `act` wraps every state change. (@testing-library/react is not a dependency: this is all it takes.)
import { act } from "react";
import { createRoot } from "react-dom/client";

(globalThis as { IS_REACT_ACT_ENVIRONMENT?: boolean }).IS_REACT_ACT_ENVIRONMENT = true;

export function renderHook<P, R>(hook: (props: P) => R, initial: P) {
  const result = { current: undefined as unknown as R };
  let props = initial;
  function Probe() {
    result.current = hook(props);
    return null;
  }
  const root = createRoot(document.createElement("div"));
  act(() => root.render(<Probe />));
  return {
    result,
    rerender(next: P) {
      props = next;
      act(() => root.render(<Probe />));
    },
    unmount: () => act(() => root.unmount()),
  };
}

export { act };
