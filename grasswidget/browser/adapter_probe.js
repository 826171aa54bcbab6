// The adapter probe: tells Python which WebGPU adapter this page's browser offers, without a device
// and without the engine (grasswidget/browser/adapter_probe.py; Python decides what to do with it,
// grasswidget/core/engine_choice.py). It shows nothing.

// requestAdapter() that never answers must not leave the widget undecided forever.
const ADAPTER_TIMEOUT_MS = 10000;

async function adapterReport() {
  const gpu = globalThis.navigator ? globalThis.navigator.gpu : undefined;
  if (!gpu) return { webgpu: false, adapter: false, detail: "navigator.gpu is missing" };
  let adapter;
  try {
    const timeout = new Promise((resolve) => setTimeout(() => resolve("timeout"), ADAPTER_TIMEOUT_MS));
    adapter = await Promise.race([gpu.requestAdapter(), timeout]);
  } catch (err) {
    return { webgpu: true, adapter: false, detail: `requestAdapter() failed: ${err.message || err}` };
  }
  if (adapter === "timeout") {
    return { webgpu: true, adapter: false, detail: `requestAdapter() did not answer in ${ADAPTER_TIMEOUT_MS / 1000} s` };
  }
  if (!adapter) return { webgpu: true, adapter: false, detail: "requestAdapter() gave null" };
  const info = adapter.info || {};
  // isFallbackAdapter moved from GPUAdapter to GPUAdapterInfo; either may be missing.
  const fallback = info.isFallbackAdapter !== undefined ? info.isFallbackAdapter : adapter.isFallbackAdapter;
  const report = {
    webgpu: true, adapter: true, fallback: typeof fallback === "boolean" ? fallback : null,
    vendor: info.vendor || "", architecture: info.architecture || "", device: info.device || "",
    description: info.description || "", detail: "",
  };
  // Tests only: a page may stand in for a hardware adapter (its fields replace the real ones).
  const simulated = globalThis.__grasswidgetTestAdapterInfo;
  return simulated ? { ...report, ...simulated, simulated: true } : report;
}

export default {
  render({ model, el }) {
    el.style.display = "none";
    const known = model.get("report");
    if (known && Object.keys(known).length) return;  // one answer per probe (the first view's)
    adapterReport().catch((err) => ({ webgpu: false, adapter: false, detail: `probe failed: ${err.message || err}` }))
      .then((report) => { model.set("report", report); model.save_changes(); });
  },
};
