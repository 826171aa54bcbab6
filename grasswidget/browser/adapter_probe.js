// @ts-check
// The adapter probe: tells Python which WebGPU adapter this page's browser offers, without a device
// and without the engine (grasswidget/browser/adapter_probe.py; Python decides what to do with it,
// grasswidget/core/engine_choice.py). It shows nothing.

// requestAdapter() that never answers must not leave the widget undecided forever.
const ADAPTER_TIMEOUT_MS = 10000;

/**
 * What the page reports (grasswidget.core.engine_choice reads it).
 * @typedef {object} AdapterReport
 * @property {boolean} webgpu navigator.gpu exists
 * @property {boolean} adapter requestAdapter() gave one
 * @property {boolean | null} [fallback] a software (fallback) adapter; null: not said
 * @property {string} [vendor]
 * @property {string} [architecture]
 * @property {string} [device]
 * @property {string} [description]
 * @property {string} detail why there is none ("" when there is)
 * @property {boolean} [simulated] a test stood in for the adapter
 */
/**
 * @typedef {object} ProbeModel anywidget's model handle for the probe
 * @property {(name: "report") => AdapterReport | Object<string, never>} get
 * @property {(name: "report", value: AdapterReport) => void} set
 * @property {() => void} save_changes
 */

/** @returns {Promise<AdapterReport>} */
async function adapterReport() {
  /** @type {GPU | undefined} */
  const gpu = globalThis.navigator ? globalThis.navigator.gpu : undefined;
  if (!gpu) return { webgpu: false, adapter: false, detail: "navigator.gpu is missing" };
  let adapter;
  try {
    /** @type {Promise<"timeout">} */
    const timeout = new Promise((resolve) => setTimeout(() => resolve("timeout"), ADAPTER_TIMEOUT_MS));
    adapter = await Promise.race([gpu.requestAdapter(), timeout]);
  } catch (err) {
    return { webgpu: true, adapter: false, detail: `requestAdapter() failed: ${errorText(err)}` };
  }
  if (adapter === "timeout") {
    return { webgpu: true, adapter: false, detail: `requestAdapter() did not answer in ${ADAPTER_TIMEOUT_MS / 1000} s` };
  }
  if (!adapter) return { webgpu: true, adapter: false, detail: "requestAdapter() gave null" };
  /** @type {{vendor?: string, architecture?: string, device?: string, description?: string, isFallbackAdapter?: boolean}} */
  const info = adapter.info || {};
  // isFallbackAdapter moved from GPUAdapter to GPUAdapterInfo; either may be missing.
  const fallback = info.isFallbackAdapter !== undefined ? info.isFallbackAdapter
    : /** @type {{isFallbackAdapter?: boolean}} */ (adapter).isFallbackAdapter;
  const report = {
    webgpu: true, adapter: true, fallback: typeof fallback === "boolean" ? fallback : null,
    vendor: info.vendor || "", architecture: info.architecture || "", device: info.device || "",
    description: info.description || "", detail: "",
  };
  // Tests only: a page may stand in for a hardware adapter (its fields replace the real ones).
  const simulated = /** @type {{__grasswidgetTestAdapterInfo?: Partial<AdapterReport>}} */ (globalThis).__grasswidgetTestAdapterInfo;
  return simulated ? { ...report, ...simulated, simulated: true } : report;
}

/** An error's message, or the thrown value as text. @param {unknown} err @returns {string} */
function errorText(err) {
  return err instanceof Error ? err.message : String(err);
}

export default {
  /** @param {{model: ProbeModel, el: HTMLElement}} view */
  render({ model, el }) {
    el.style.display = "none";
    const known = model.get("report");
    if (known && Object.keys(known).length) return;  // one answer per probe (the first view's)
    adapterReport().catch((err) => ({ webgpu: false, adapter: false, detail: `probe failed: ${errorText(err)}` }))
      .then((report) => { model.set("report", report); model.save_changes(); });
  },
};
