import { createContext } from "react";

// What every block on the canvas needs: the colour of each signal kind, and which inputs each
// output can feed ("type:port" -> ["type:port", ...]).
export const StudioContext = createContext({ colors: {}, feeds: {} });
