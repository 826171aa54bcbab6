// @ts-check
// The lab bench's live chart (grasswidget.browser.trace_chart.TraceChart): draws the series
// Python sends in the "data" trait with uPlot (prepended to this module by Python, vendored
// in grasswidget/browser/vendor/uplot). No rule lives here: Python decides what is drawn,
// its labels, colours and how often it changes; this only draws it.
//
// data: {x: [...], x_label, y_label, y_zero, series: [{label, color, values: [...], fill}]}; null
// values are gaps. The chart's root carries data-points, data-x-last and data-series
// (labels joined by "|"), so a page (and the tests) can see what is drawn, and data-draws /
// data-draw-ms (updates drawn, milliseconds spent drawing them: the chart's cost in the page).

/**
 * One line of the chart (Python's: grasswidget.core.traces' chart series).
 * @typedef {object} Series
 * @property {string} label
 * @property {string} color CSS colour "#rrggbb"
 * @property {(number | null)[]} values null: a gap
 * @property {boolean} [fill] fill under the line
 */
/**
 * The "data" trait.
 * @typedef {object} ChartData
 * @property {number[]} [x]
 * @property {string} [x_label]
 * @property {string} [y_label]
 * @property {boolean} [y_zero] the y axis starts at 0
 * @property {Series[]} [series]
 */
/**
 * anywidget's model handle for the chart.
 * @typedef {object} ChartModel
 * @property {(name: string) => any} get "data" (ChartData), "width", "height" (px), "hidden"
 * @property {(event: string, fn: () => void) => void} on
 * @property {(event: string, fn: () => void) => void} off
 */

/** @param {{model: ChartModel, el: HTMLElement}} view @returns {() => void} */
function render({ model, el }) {
  const box = document.createElement("div");
  box.className = "gw-trace-chart";
  el.appendChild(box);
  /** @type {any} a uPlot (its types are not vendored) */
  let plot = null;
  let shape = "";

  let draws = 0, drawMs = 0;
  /** @type {number | null} */
  let started = null;

  // uPlot paints in a microtask after setData: time from the update to its "draw" hook.
  function painted() {
    if (started === null) return;
    draws += 1;
    drawMs += performance.now() - started;
    started = null;
    box.dataset.draws = String(draws);
    box.dataset.drawMs = drawMs.toFixed(2);
  }

  function draw() {
    started = performance.now();
    paint();
  }

  function paint() {
    /** @type {ChartData} */
    const d = model.get("data") || {};
    const series = d.series || [];
    const x = d.x || [];
    const width = model.get("width") || 640;
    const height = model.get("height") || 180;
    const data = [x, ...series.map((s) => s.values)];
    box.dataset.points = String(x.length);
    box.dataset.xLast = x.length ? String(x[x.length - 1]) : "";
    box.dataset.series = series.map((s) => s.label).join("|");
    const key = JSON.stringify([d.x_label, d.y_label, !!d.y_zero, width, height,
                                series.map((s) => [s.label, s.color, !!s.fill])]);
    if (plot && key === shape) {
      plot.setData(data);
      return;
    }
    if (plot) plot.destroy();
    shape = key;
    // @ts-expect-error uPlot: the vendored IIFE Python puts before this module (vendor/uplot)
    plot = new uPlot({
      width, height,
      // y_zero: the y axis starts at 0 (counts, distances, angles, times), else it fits the data
      scales: {
        x: { time: false },
        y: d.y_zero ? { range: (/** @type {any} */ _u, /** @type {number} */ _lo, /** @type {number} */ hi) => [0, hi > 0 ? hi * 1.05 : 1] } : {},
      },
      legend: { live: false },
      hooks: { draw: [painted] },
      cursor: { drag: { x: false, y: false } },
      axes: [{ label: d.x_label || "", size: 36, labelSize: 16 }, { label: d.y_label || "", size: 56, labelSize: 16 }],
      series: [
        { label: d.x_label || "x" },
        ...series.map((s) => ({
          label: s.label, stroke: s.color, width: 1.5, points: { show: false },
          fill: s.fill ? s.color + "40" : undefined,
        })),
      ],
    }, data, box);
  }

  // "hidden": a front end that ignores the widget's layout (marimo) hides the chart by this trait.
  const showHidden = () => { box.style.display = model.get("hidden") ? "none" : ""; };
  model.on("change:data", draw);
  model.on("change:width", draw);
  model.on("change:height", draw);
  model.on("change:hidden", showHidden);
  showHidden();
  draw();
  return () => {
    model.off("change:hidden", showHidden);
    model.off("change:data", draw);
    model.off("change:width", draw);
    model.off("change:height", draw);
    if (plot) plot.destroy();
  };
}

export default { render };
