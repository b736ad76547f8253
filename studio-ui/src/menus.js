// The context menus' actions, with their shortcuts (the page wires them to its own edits).

export function blockMenuItems(names, editable, act) {
  const many = names.length > 1 ? ` (${names.length})` : "";
  return [
    { label: `Duplicate${many}`, keys: "Ctrl+D", run: act.duplicate, disabled: !editable },
    { label: `Copy${many}`, keys: "Ctrl+C", run: act.copy },
    { label: "Paste", keys: "Ctrl+V", run: act.paste, disabled: !editable },
    { label: "Swap type…", run: act.swap, disabled: names.length > 1 },
    { label: `Delete${many}`, keys: "Delete", run: act.remove, disabled: !editable },
  ];
}

export function paneMenuItems(editable, act) {
  return [
    { label: "Paste", keys: "Ctrl+V", run: act.paste, disabled: !editable },
    { label: "Select all", keys: "Ctrl+A", run: act.selectAll },
    { label: "Auto layout", run: act.autoLayout },
    { label: "Fit to view", run: act.fit },
    { label: "Keyboard shortcuts", keys: "?", run: act.keys },
  ];
}
