"""Finding a notebook in the JupyterLab (or Notebook 7) app of a page: the JS that locates its
panel (``window.jupyterapp``), the notebook's state (kernel, running cells) and bringing it to
the front. Shared by :mod:`tests.e2e.kernel_calls` and :mod:`tests.e2e.notebook_actions`.
"""

from __future__ import annotations

from typing import Optional


# JS function text: find the NotebookPanel for a path (or the current one).
# Playwright's evaluate() needs a single function expression, so JS that uses
# it is built with with_find_panel(function_text).
_JS_FIND_PANEL = r"""
function __gwFindPanel(path) {
  const app = window.jupyterapp;
  if (!app) return null;
  const isNb = (w) => w && w.sessionContext && w.content && Array.isArray(w.content.widgets) && w.context;
  const all = [];
  for (const w of app.shell.widgets('main')) { if (isNb(w)) all.push(w); }
  if (path) return all.find((w) => w.context.path === path) || null;
  const cur = app.shell.currentWidget;
  if (isNb(cur)) return cur;
  return all.length === 1 ? all[0] : null;
}
"""


def with_find_panel(fn: str) -> str:
    return "(__gwArg) => {\n" + _JS_FIND_PANEL + "\nreturn (" + fn.strip() + ")(__gwArg);\n}"


_JS_NOTEBOOK_STATE = with_find_panel(r"""
(path) => {
  const app = window.jupyterapp;
  if (!app) return {ok: false, why: 'window.jupyterapp is not defined yet'};
  const p = __gwFindPanel(path);
  if (!p) {
    const open = [];
    for (const w of app.shell.widgets('main')) open.push(w.context ? w.context.path : w.id);
    return {ok: false, why: 'notebook ' + path + ' is not open; main area has ' + JSON.stringify(open)};
  }
  if (!p.context.isReady) return {ok: false, why: 'document context not ready'};
  const s = p.sessionContext;
  const k = s.session && s.session.kernel;
  if (!k) return {ok: false, why: 'no kernel yet (session ' + (s.session ? 'exists' : 'missing') + ')'};
  const cells = p.content.widgets;
  let running = 0, pending = 0;
  for (const c of cells) {
    if (c.model.type !== 'code') continue;
    if (c.model.executionState === 'running') running++;
    const prompt = c.promptNode ? c.promptNode.textContent : '';
    if (prompt.includes('*')) pending++;
  }
  return {ok: true, path: p.context.path, kernelStatus: k.status, connection: k.connectionStatus,
          cells: cells.length, running, pending, id: p.id};
}
""")


def notebook_state(page, path: Optional[str]):
    return page.evaluate(_JS_NOTEBOOK_STATE, path)


def activate_notebook(page, path: Optional[str]) -> None:
    page.evaluate(
        with_find_panel("(path) => { const p = __gwFindPanel(path); if (p) window.jupyterapp.shell.activateById(p.id); }"),
        path,
    )
