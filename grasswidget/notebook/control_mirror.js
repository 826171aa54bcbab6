// The panel's ipywidgets drawn as plain HTML controls (see control_mirror.py).
// The kernel sends a description of the tree ("snapshot") and patches of single controls;
// this module draws them and sends back what the user did ("set" a value, "click" a button).
// It knows no control of the panel by name: kinds, labels, ranges and options all come from
// the description.

function fmt(value, format) {
  // ipywidgets' readout formats the panel uses: ".2f", ".0f", ... (else the number as is)
  const m = /^\.(\d+)f$/.exec(format || "");
  return m ? Number(value).toFixed(Number(m[1])) : String(value);
}

function applyLayout(dom, layout, baseDisplay) {
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

function label(props) {
  const span = document.createElement("span");
  span.className = "gwm-label";
  span.textContent = props.description || "";
  if (props.label_width) span.style.width = props.label_width;
  if (!props.description) span.style.display = "none";
  return span;
}

function build(node, send, registry) {
  const kind = node.kind;
  const dom = document.createElement("div");
  dom.className = `gwm gwm-${kind}`;
  dom.dataset.gwmId = String(node.id);
  const item = { node, dom, update: null };
  if (kind === "box") {
    dom.style.flexDirection = node.direction;
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
        input.min = 0; input.max = Math.max(0, (p.labels || []).length - 1); input.step = 1;
        if (!dragging) input.value = p.index;
      } else {
        input.min = p.min; input.max = p.max; input.step = p.step;
        if (!dragging) input.value = p.value;
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

function render({ model, el }) {
  const root = document.createElement("div");
  root.className = "gwm-root grasswidget-panel";
  el.appendChild(root);
  let registry = new Map();
  const send = (msg) => model.send(msg);
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
