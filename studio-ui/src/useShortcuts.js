// The page's keyboard shortcuts (listed by ShortcutsDialog). In a text field the field's own
// keys win (its undo, its copy); on the canvas, the graph's.
import { useEffect, useRef } from "react";

export default function useShortcuts(actions) {
  const latest = useRef(actions);
  latest.current = actions;
  useEffect(() => {
    const onKey = (e) => {
      const { editable, save, undo, copyBlocks, pasteBlocks, duplicateBlocks, selectAll, showKeys } = latest.current;
      const inField = ["INPUT", "SELECT", "TEXTAREA"].includes(document.activeElement?.tagName);
      if (e.key === "?" && !inField && !e.ctrlKey && !e.metaKey) {
        e.preventDefault();
        showKeys();
        return;
      }
      if (!(e.ctrlKey || e.metaKey)) return;
      const key = e.key.toLowerCase();
      if (!inField && editable && ["c", "v", "d", "a"].includes(key) && !e.shiftKey) {
        if (key === "c" && window.getSelection()?.toString()) return; // copying page text
        e.preventDefault();
        if (key === "c") copyBlocks();
        else if (key === "v") pasteBlocks();
        else if (key === "d") duplicateBlocks();
        else selectAll();
        return;
      }
      if (key === "s") {
        e.preventDefault();
        if (editable) save();
      } else if ((key === "z" || key === "y") && !inField && editable) {
        e.preventDefault();
        undo(key === "y" || e.shiftKey);
      }
    };
    window.addEventListener("keydown", onKey);
    return () => window.removeEventListener("keydown", onKey);
  }, []);
}
