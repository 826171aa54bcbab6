// What the browser engine adds to the page's objects, for tsc --checkJs (tests/browser/test_js_types.py).

interface HTMLCanvasElement {
  /** Frames drawn into this canvas (js/canvas_view.js; read by the tests). */
  grasswidgetFramesDrawn?: number;
}

// eslint-disable-next-line no-var
declare var __grasswidgetEngines: Map<string, any> | undefined;
