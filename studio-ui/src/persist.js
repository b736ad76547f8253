// What the page keeps across a reload of the tab: per graph, the edited document and its
// undo and redo steps (sessionStorage: this tab only, gone when it closes); the page's own
// layout (panel widths, open or closed: localStorage, every tab). Runs, results and
// comparisons are not kept here: the server holds them and the page asks for them again.

const PREFIX = "pasim-studio";
const MAX_STEPS = 60;

function read(store, key) {
  try {
    const text = store.getItem(`${PREFIX}:${key}`);
    return text ? JSON.parse(text) : null;
  } catch {
    return null;
  }
}

function write(store, key, value) {
  try {
    store.setItem(`${PREFIX}:${key}`, JSON.stringify(value));
  } catch {
    // Storage full or refused (private mode): the page works, only without memory.
  }
}

// {sha256, doc, undo, redo} of one graph file, as the tab left it.
export function loadEdits(path) {
  return read(window.sessionStorage, `graph:${path}`);
}

export function saveEdits(path, state) {
  write(window.sessionStorage, `graph:${path}`, {
    sha256: state.sha256,
    doc: state.doc,
    undo: state.undo.slice(-MAX_STEPS),
    redo: state.redo.slice(-MAX_STEPS),
  });
}

// Which run is shown, which two are compared, which tab and dock are open.
export function loadView() {
  return read(window.sessionStorage, "view") || {};
}

export function saveView(view) {
  write(window.sessionStorage, "view", view);
}

// Panel widths and whether each is open.
export function loadPanels() {
  return read(window.localStorage, "panels") || {};
}

export function savePanels(panels) {
  write(window.localStorage, "panels", panels);
}

// The panels as the user left them; on a first visit, what the window has room for.
export function initialPanels() {
  const saved = loadPanels();
  const wide = window.innerWidth;
  return {
    left: saved.left || 220,
    right: saved.right || 390,
    dock: saved.dock || Math.round(window.innerHeight * 0.42),
    leftOpen: saved.leftOpen ?? wide >= 1100,
    rightOpen: saved.rightOpen ?? wide >= 760,
  };
}
