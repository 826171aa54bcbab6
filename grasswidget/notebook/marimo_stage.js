// @ts-check
// The stage of a GrassWidget in marimo (see marimo_face.py): the kernel sends the HTML of
// marimo's own anywidget elements (the live view, the chart) and this puts them in the page;
// marimo draws each one. New HTML (the engine switched) replaces the old elements.
/**
 * @typedef {object} StageModel anywidget's model handle for the stage
 * @property {(name: "html") => string} get the HTML of marimo's elements to show
 * @property {(event: string, fn: () => void) => void} on
 * @property {(event: string, fn: () => void) => void} off
 */

/** @param {{model: StageModel, el: HTMLElement}} view @returns {() => void} */
function render({ model, el }) {
  const box = document.createElement("div");
  box.className = "grasswidget-stage";
  el.appendChild(box);
  const show = () => { box.innerHTML = model.get("html") || ""; };
  model.on("change:html", show);
  show();
  return () => model.off("change:html", show);
}

export default { render };
