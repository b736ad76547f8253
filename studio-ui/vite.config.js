// Build: `npm install && npm run build` in this folder writes the page into the Python package
// (pasim_graph/studio/static), with fixed file names (the server adds the session token to
// them) and the licences of everything bundled.
import path from "node:path";
import { fileURLToPath } from "node:url";
import react from "@vitejs/plugin-react";
import license from "rollup-plugin-license";
import { defineConfig } from "vite";

const here = path.dirname(fileURLToPath(import.meta.url));
const out = path.resolve(here, "../pasim_graph/studio/static");

export default defineConfig({
  base: "./",
  plugins: [
    react(),
    license({
      thirdParty: {
        includePrivate: false,
        output: { file: path.join(out, "THIRD_PARTY_LICENSES.txt") },
      },
    }),
  ],
  build: {
    outDir: out,
    emptyOutDir: true,
    sourcemap: false,
    target: "es2020",
    rollupOptions: {
      output: {
        entryFileNames: "assets/studio.js",
        assetFileNames: "assets/studio[extname]",
        inlineDynamicImports: true,
      },
    },
  },
});
