// @ts-check
// The panel's ipywidgets drawn as plain HTML controls (see control_mirror.py).
// The kernel sends a description of the tree ("snapshot") and patches of single controls;
// this module draws them and sends back what the user did ("set" a value, "click" a button).
// It knows no control of the panel by name: kinds, labels, ranges and options all come from
// the description.

/**
 * One control of the tree as the kernel describes it (control_mirror.py): its kind and id, and
 * the properties of its kind (a patch carries some of them anew).
 * @typedef {object} MirrorNode
 * @property {number} id
 * @property {string} kind "box" | "slider" | "selection_slider" | "dropdown" | "checkbox" | "button" | "toggle" | "html" | "text", else shown as not supported
 * @property {string} [class_name] the ipywidget's class (for one not shown)
 * @property {string} [direction] a box: "row" | "column"
 * @property {MirrorNode[]} [children] a box's
 * @property {string} [description] the label
 * @property {string} [label_width] CSS width of the label
 * @property {string} [tooltip]
 * @property {boolean} [disabled]
 * @property {any} [value] the value (a number, a boolean, HTML or text)
 * @property {number} [index] a selection's index
 * @property {string[]} [labels] a selection's option labels
 * @property {number} [min]
 * @property {number} [max]
 * @property {number} [step]
 * @property {string} [readout_format] e.g. ".2f"
 * @property {boolean} [continuous_update] false: a slider sends on release only
 * @property {string} [button_style]
 * @property {MirrorLayout} [layout]
 */
/**
 * The part of an ipywidgets Layout the mirror applies.
 * @typedef {object} MirrorLayout
 * @property {string} [display]
 * @property {string} [width]
 * @property {string} [max_width]
 * @property {string} [min_height]
 * @property {string} [margin]
 * @property {string} [flex_flow]
 * @property {string} [justify_content]
 * @property {string} [align_items]
 */
/**
 * What the kernel gets back: a value set, or a button clicked, or the mirror ready.
 * @typedef {{type: "set", id: number, value: number | boolean} | {type: "click", id: number} | {type: "ready"}} MirrorMessage
 */
/**
 * One drawn control: its description now, its element and how to redraw it from a description.
 * @typedef {object} MirrorItem
 * @property {MirrorNode} node
 * @property {HTMLElement} dom
 * @property {(p: MirrorNode) => void} update
 */
/**
 * anywidget's model handle for the mirror.
 * @typedef {object} MirrorModel
 * @property {(msg: MirrorMessage) => void} send
 * @property {(event: string, fn: (msg: any) => void) => void} on
 * @property {(event: string, fn: (msg: any) => void) => void} off
 */

/** @param {any} value @param {string | undefined} format @returns {string} */
function fmt(value, format) {
  // ipywidgets' readout formats the panel uses: ".2f", ".0f", ... (else the number as is)
  const m = /^\.(\d+)f$/.exec(format || "");
  return m ? Number(value).toFixed(Number(m[1])) : String(value);
}

/** @param {HTMLElement} dom @param {MirrorLayout | undefined} layout @param {string} baseDisplay */
function applyLayout(dom, layout, baseDisplay) {
  /** @type {MirrorLayout} */
  const l = layout || {};
  dom.style.display = l.display === "none" ? "none" : baseDisplay;
  dom.style.width = l.width || "";
  dom.style.maxWidth = l.max_width || "";
  dom.style.minHeight = l.min_height || "";
  dom.style.margin = l.margin || "";
  if (l.flex_flow) dom.style.flexFlow = l.flex_flow;
  if (l.justify_content) dom.style.justifyContent = l.justify_content;
  if (l.align_items) dom.style.alignItems = l.align_items;
}

/** @param {MirrorNode} props @returns {HTMLSpanElement} */
function label(props) {
  const span = document.createElement("span");
  span.className = "gwm-label";
  span.textContent = props.description || "";
  if (props.label_width) span.style.width = props.label_width;
  if (!props.description) span.style.display = "none";
  return span;
}

/**
 * @param {MirrorNode} node @param {(msg: MirrorMessage) => void} send
 * @param {Map<number, MirrorItem>} registry @returns {HTMLElement}
 */
function build(node, send, registry) {
  const kind = node.kind;
  const dom = document.createElement("div");
  dom.className = `gwm gwm-${kind}`;
  dom.dataset.gwmId = String(node.id);
  /** @type {MirrorItem} */
  const item = { node, dom, update: () => {} };
  if (kind === "box") {
    dom.style.flexDirection = node.direction || "";
    dom.style.flexWrap = node.direction === "row" ? "wrap" : "nowrap";
    for (const child of node.children || []) dom.appendChild(build(child, send, registry));
    item.update = (p) => applyLayout(dom, p.layout, "flex");
  } else if (kind === "slider" || kind === "selection_slider") {
    const lab = label(node);
    const input = document.createElement("input");
    input.type = "range";
    const readout = document.createElement("span");
    readout.className = "gwm-readout";
    dom.append(lab, input, readout);
    let dragging = false;
    input.addEventListener("pointerdown", () => { dragging = true; });
    // a drag ends where the pointer is released, on the slider or elsewhere
    const release = () => { dragging = false; };
    input.addEventListener("pointerup", release);
    input.addEventListener("change", release);
    input.addEventListener("blur", release);
    const current = () => Number(input.value);
    const show = () => {
      const p = item.node;
      readout.textContent = kind === "selection_slider" ? (p.labels || [])[Number(input.value)] ?? ""
                                                         : fmt(input.value, p.readout_format);
    };
    const emit = () => { show(); send({ type: "set", id: node.id, value: current() }); };
    input.addEventListener("input", () => { show(); if (item.node.continuous_update !== false) emit(); });
    input.addEventListener("change", emit);
    item.update = (p) => {
      lab.textContent = p.description || "";
      if (kind === "selection_slider") {
        input.min = "0"; input.max = String(Math.max(0, (p.labels || []).length - 1)); input.step = "1";
        if (!dragging) input.value = String(p.index);
      } else {
        input.min = String(p.min); input.max = String(p.max); input.step = String(p.step);
        if (!dragging) input.value = String(p.value);
      }
      input.disabled = !!p.disabled;
      dom.title = p.tooltip || "";
      show();
      applyLayout(dom, p.layout, "flex");
    };
  } else if (kind === "dropdown") {
    const lab = label(node);
    const select = document.createElement("select");
    dom.append(lab, select);
    select.addEventListener("change", () => send({ type: "set", id: node.id, value: Number(select.value) }));
    item.update = (p) => {
      lab.textContent = p.description || "";
      const labels = p.labels || [];
      if (select.options.length !== labels.length || labels.some((t, i) => select.options[i].text !== t)) {
        select.replaceChildren(...labels.map((t, i) => new Option(t, String(i))));
      }
      select.value = String(p.index);
      select.disabled = !!p.disabled;
      dom.title = p.tooltip || "";
      applyLayout(dom, p.layout, "flex");
    };
  } else if (kind === "checkbox") {
    const box = document.createElement("input");
    box.type = "checkbox";
    const text = document.createElement("span");
    const wrap = document.createElement("label");
    wrap.append(box, text);
    dom.append(wrap);
    box.addEventListener("change", () => send({ type: "set", id: node.id, value: box.checked }));
    item.update = (p) => {
      text.textContent = p.description || "";
      box.checked = !!p.value;
      box.disabled = !!p.disabled;
      dom.title = p.tooltip || "";
      applyLayout(dom, p.layout, "flex");
    };
  } else if (kind === "button" || kind === "toggle") {
    const button = document.createElement("button");
    button.type = "button";
    dom.append(button);
    button.addEventListener("click", () => {
      if (kind === "button") send({ type: "click", id: node.id });
      else send({ type: "set", id: node.id, value: !item.node.value });
    });
    item.update = (p) => {
      button.textContent = p.description || "";
      button.disabled = !!p.disabled;
      button.className = `gwm-button gwm-style-${p.button_style || "plain"}` + (p.value ? " gwm-pressed" : "");
      button.setAttribute("aria-pressed", kind === "toggle" ? String(!!p.value) : "false");
      dom.title = p.tooltip || "";
      applyLayout(dom, p.layout, "flex");
    };
  } else if (kind === "html") {
    item.update = (p) => {
      // The kernel's own HTML (the panel escapes what it did not write itself).
      dom.innerHTML = p.value || "";
      applyLayout(dom, p.layout, "block");
    };
  } else if (kind === "text") {
    item.update = (p) => {
      dom.textContent = p.value || "";
      applyLayout(dom, p.layout, "block");
    };
  } else {
    dom.textContent = `(${node.class_name || "a control"} is not shown here)`;
    item.update = (p) => applyLayout(dom, p.layout, "block");
  }
  registry.set(node.id, item);
  item.update(node);
  return dom;
}

/** @param {{model: MirrorModel, el: HTMLElement}} view @returns {() => void} */
function render({ model, el }) {
  const root = document.createElement("div");
  root.className = "gwm-root grasswidget-panel";
  el.appendChild(root);
  /** @type {Map<number, MirrorItem>} */
  let registry = new Map();
  /** @param {MirrorMessage} msg */
  const send = (msg) => model.send(msg);
  /** @param {any} msg a snapshot {type, root} or a patch {type, id, props} */
  const onMessage = (msg) => {
    if (!msg || typeof msg !== "object") return;
    if (msg.type === "snapshot") {
      registry = new Map();
      root.replaceChildren(build(msg.root, send, registry));
    } else if (msg.type === "patch") {
      const item = registry.get(msg.id);
      if (!item) return;
      item.node = { ...item.node, ...msg.props };
      item.update(item.node);
    }
  };
  model.on("msg:custom", onMessage);
  send({ type: "ready" });
  return () => model.off("msg:custom", onMessage);
}

export default { render };
