import { createContext } from "react";

// What every block on the canvas needs: the colour of each signal kind.
export const StudioContext = createContext({ colors: {} });
