"""The README is for users and points to the rest: its set-up commands are the ones CI runs, it
stays short, and every relative link in it and in docs/ and benchmarks/ names a file that exists."""

import functools
import re
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
DOCS = [ROOT / "README.md", ROOT / "benchmarks" / "README.md", *sorted((ROOT / "docs").glob("*.md"))]


def test_readme_starts_with_the_two_set_up_commands_and_stays_short():
    """The README is a front page: under 150 lines, none over 200 characters, the two set-up commands
    first, a picture, an example of about ten lines, and a link to every page of docs/."""
    text = (ROOT / "README.md").read_text()
    lines = text.splitlines()
    assert len(lines) < 150, f"README.md has {len(lines)} lines; move detail to docs/"
    long = [i for i, line in enumerate(lines, 1) if len(line) > 200]
    assert not long, f"README.md lines over 200 characters: {long}"
    blocks = re.findall(r"```\n(.*?)\n```", text, re.S)
    assert blocks[:2] == ["./run.sh demo", "./run.sh test"]
    assert "./run.sh test" in (ROOT / ".ci" / "run").read_text()
    pictures = re.findall(r"!\[[^\]]+\]\(([^)]+\.png)\)", text)
    assert pictures and all((ROOT / p).read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" for p in pictures)
    example = re.search(r"```python\n(.*?)\n```", text, re.S).group(1)
    assert 6 <= len([ln for ln in example.splitlines() if ln.strip()]) <= 12
    unlinked = [p.name for p in (ROOT / "docs").glob("*.md") if f"](docs/{p.name}" not in text]
    assert not unlinked, f"docs the README does not link: {unlinked}"


def _widget_defaults() -> dict:
    """GrassWidget.__init__'s keyword defaults, read from the source (no GPU import)."""
    import ast

    tree = ast.parse((ROOT / "grasswidget" / "notebook" / "widget.py").read_text(encoding="utf-8"))
    cls = next(n for n in tree.body if isinstance(n, ast.ClassDef) and n.name == "GrassWidget")
    init = next(n for n in cls.body if isinstance(n, ast.FunctionDef) and n.name == "__init__")
    args = init.args
    pairs = list(zip(args.args[len(args.args) - len(args.defaults):], args.defaults))
    pairs += [(a, d) for a, d in zip(args.kwonlyargs, args.kw_defaults) if d is not None]
    return {a.arg: ast.literal_eval(d) for a, d in pairs}


def test_the_documented_widget_defaults_are_the_code_s():
    """Where the README and docs/usage.md write GrassWidget's signature (with its keyword-only part),
    its defaults (backend="auto", ...) are the ones in notebook/widget.py."""
    defaults = _widget_defaults()
    assert defaults["backend"] == "auto"
    rows = 0
    for doc in (ROOT / "README.md", ROOT / "docs" / "usage.md"):
        for signature in re.findall(r"`gw\.GrassWidget\(([^`]*\*,[^`]*)\)`", doc.read_text(encoding="utf-8")):
            for name, value in re.findall(r"(\w+)=((?:\"[^\"]*\")|(?:\([^)]*\))|[\w.]+)", signature):
                rows += 1
                if name in defaults:
                    assert eval(value, {}) == defaults[name], f"{doc.name}: GrassWidget({name}={value}), the code says {defaults[name]!r}"
    assert rows >= 8


def test_relative_links_name_files_that_exist():
    missing = []
    for doc in DOCS:
        for target in re.findall(r"\]\(([^)#\s]+)(?:#[^)]*)?\)", doc.read_text()):
            if "://" not in target and not (doc.parent / target).exists():
                missing.append(f"{doc.relative_to(ROOT)} -> {target}")
    assert len(DOCS) >= 4 and not missing, missing


def heading_anchors(path: Path) -> set:
    """The anchors GitHub gives the headings of a Markdown file (lower case, punctuation dropped,
    spaces to hyphens; code blocks skipped)."""
    anchors, in_code = set(), False
    for line in path.read_text(encoding="utf-8").splitlines():
        if line.startswith("```"):
            in_code = not in_code
        heading = re.match(r"#+ (.*)", line)
        if heading and not in_code:
            anchors.add(re.sub(r"[^\w\- ]", "", heading.group(1).strip().lower()).replace(" ", "-"))
    return anchors


def test_links_to_a_section_name_a_heading_that_exists():
    """A link like docs/usage.md#main-api keeps working when text moves between pages."""
    broken = []
    for doc in DOCS:
        for target, anchor in re.findall(r"\]\(([^)#\s]*)#([^)\s]+)\)", doc.read_text(encoding="utf-8")):
            page = doc.parent / target if target else doc
            if page.suffix == ".md" and anchor not in heading_anchors(page):
                broken.append(f"{doc.relative_to(ROOT)} -> {target}#{anchor}")
    assert not broken, broken
    assert "main-api" in heading_anchors(ROOT / "docs" / "usage.md")
    assert heading_anchors(ROOT / "docs" / "front-ends.md") >= {
        "where-notebooks-are-jupyterlab-notebook-7-voilà-marimo-vs-code-colab-a-page-with-no-kernel"}


PACKAGE = ROOT / "grasswidget"


def map_modules(text: str) -> set[str]:
    """The files the map at the top of docs/architecture.md names, as paths under the package:
    the first code block after "## Map", where a line ``name/`` (two spaces in) opens a
    subpackage and a line of nothing but file names lists its files."""
    block = re.search(r"## Map\n.*?```\n(.*?)\n```", text, re.S).group(1)
    named, folder = set(), ""
    for line in block.splitlines()[1:]:
        words = line.split()
        if not words:
            continue
        if line.startswith("  ") and not line.startswith("    ") and words[0].endswith("/"):
            folder = words[0]
        elif all(re.fullmatch(r"[\w/]+\.(py|js)", w) for w in words):
            named |= {(folder if line.startswith("    ") else "") + w for w in words}
    return named


def test_the_architecture_map_names_every_module_and_only_modules_that_exist():
    """The one-page map (docs/architecture.md, "## Map") stays true: each Python module of the package
    is named in its folder, and each file named there exists (engine.js and the other ES modules too)."""
    named = map_modules((ROOT / "docs" / "architecture.md").read_text())
    modules = {p.relative_to(PACKAGE).as_posix() for p in PACKAGE.rglob("*.py")}
    modules -= {m for m in modules if m.endswith("/__init__.py")}
    missing = sorted(modules - named)
    stale = sorted(m for m in named if not (PACKAGE / m).is_file())
    assert not missing, f"modules the map does not name: {missing}"
    assert not stale, f"files the map names that do not exist: {stale}"
    assert "engine.js" not in named and "browser/engine.js" in named  # the folders are read as folders


def test_the_map_check_can_fail():
    text = "## Map\n\n```\ngrasswidget/\n  errors.py\n  core/   pure\n    params.py nothing.py\n```\n"
    assert map_modules(text) == {"errors.py", "core/params.py", "core/nothing.py"}


# ---------------------------------------------------------------------------------------------
# The flows of docs/architecture.md ("## Flows"), hop by hop: each hop names a `path::symbol`
# that must exist, and the word before it says how the previous hop reaches it, checked in the
# source so a refactor that breaks the chain fails here, naming the hop:
#   calls / sets / watches   the previous hop's source mentions this hop's name
#                            ("sets" a trait: by its name, or through a generic setattr)
#   called by / read by / set by   this hop's source mentions the previous hop's name
#   notifies ... (registered in `path::symbol`)   this hop is an observer or callback: the
#                            registering function's source mentions this hop's name
# A hop's name is the symbol's last part (a class's name for `Class.__init__`).

FORWARD = ("calls", "sets", "watches")
BACKWARD = ("called by", "read by", "set by")
HOP = re.compile(r"^\d+\.\s+(?:(?P<link>calls|sets|watches|called by|read by|set by|notifies)\s+)?"
                 r"`(?P<ref>[\w./-]+::[\w.]+)`(?:\s*\(registered in `(?P<reg>[\w./-]+::[\w.]+)`\))?")


def parse_flows(text: str) -> dict:
    """{flow name: [hop dict]} from the numbered lists after ``<!-- flow: name -->`` lines."""
    flows = {}
    for match in re.finditer(r"<!-- flow: ([\w-]+) -->\n((?:\d+\..*\n(?:   .*\n)*)+)", text):
        items = re.split(r"\n(?=\d+\.)", match.group(2).strip())
        hops = []
        for item in items:
            hop = HOP.match(item)
            assert hop, f"flow {match.group(1)}: cannot read the hop {item[:80]!r}"
            hops.append({"link": hop["link"], "ref": hop["ref"], "reg": hop["reg"], "text": item})
        flows[match.group(1)] = hops
    return flows


def hop_name(ref: str) -> str:
    parts = ref.split("::")[1].split(".")
    return parts[-2] if parts[-1] == "__init__" and len(parts) > 1 else parts[-1]


@functools.lru_cache(maxsize=None)
def _parsed(path: Path) -> tuple:
    import ast

    text = path.read_text(encoding="utf-8")
    return text.splitlines(), ast.parse(text)


def _python_source(path: Path, symbol: str) -> str | None:
    import ast

    lines, tree = _parsed(path)
    body = tree.body
    node = None
    for part in symbol.split("."):
        found = None
        for child in body:
            if isinstance(child, (ast.ClassDef, ast.FunctionDef, ast.AsyncFunctionDef)) and child.name == part:
                found = child
            elif isinstance(child, (ast.Assign, ast.AnnAssign)):  # a trait or a module-level table
                targets = child.targets if isinstance(child, ast.Assign) else [child.target]
                if any(isinstance(t, ast.Name) and t.id == part for t in targets):
                    found = child
        if found is None:
            return None
        node, body = found, getattr(found, "body", [])
    return "\n".join(lines[node.lineno - 1:node.end_lineno]).strip()


def _braced(text: str, start: int, brace: int) -> str:
    """The text from ``start`` to the brace that closes the ``{`` at ``brace``."""
    depth, i = 0, brace
    while True:
        depth += {"{": 1, "}": -1}.get(text[i], 0)
        if depth == 0:
            return text[start:i + 1]
        i += 1


def _js_source(path: Path, symbol: str) -> str | None:
    text = path.read_text(encoding="utf-8")
    *owner, name = symbol.split(".")
    if owner:
        cls = re.search(rf"^(?:export\s+)?class\s+{re.escape(owner[0])}\b.*$", text, re.M)
        if cls is None:
            return None
        text = _braced(text, cls.start(), text.index("{", cls.start()))
    define = re.search(rf"^[ \t]*(?:export\s+)?(?:async\s+)?(?:function\s+)?{re.escape(name)}\s*\([^)]*\)\s*\{{",
                       text, re.M)
    return _braced(text, define.start(), define.end() - 1).strip() if define else None


def hop_source(ref: str) -> str | None:
    """The source text of a hop (a function, method, class, trait or table), or None if it is gone."""
    path, symbol = ref.split("::")
    file = ROOT / path
    if not file.is_file():
        return None
    return _python_source(file, symbol) if file.suffix == ".py" else _js_source(file, symbol)


def _mentions(source: str, name: str) -> bool:
    return re.search(rf"(?<![\w$]){re.escape(name)}(?![\w$])", source) is not None


def broken_hops(flows: dict) -> list:
    """One sentence per hop that does not hold (empty when every flow is true)."""
    broken = []
    for flow, hops in flows.items():
        for i, hop in enumerate(hops, 1):
            where = f"flow {flow}, hop {i} (`{hop['ref']}`)"
            source = hop_source(hop["ref"])
            if source is None:
                broken.append(f"{where}: no such file or symbol")
                continue
            if i == 1:
                if hop["link"]:
                    broken.append(f"{where}: the first hop has no previous hop to be reached from")
                continue
            prev = hops[i - 2]
            prev_source = hop_source(prev["ref"])
            if prev_source is None:  # named once, at the missing hop
                continue
            link, name, prev_name = hop["link"], hop_name(hop["ref"]), hop_name(prev["ref"])
            if link is None:
                broken.append(f"{where}: say how hop {i - 1} reaches it ({', '.join(FORWARD + BACKWARD)}, notifies)")
            elif link in FORWARD:
                if not (_mentions(prev_source, name) or (link == "sets" and "setattr(" in prev_source)):
                    broken.append(f"{where}: hop {i - 1} (`{prev['ref']}`) no longer mentions `{name}`")
            elif link in BACKWARD:
                if not _mentions(source, prev_name):
                    broken.append(f"{where}: its source no longer mentions hop {i - 1}'s `{prev_name}`")
            else:  # notifies
                registrar = hop_source(hop["reg"]) if hop["reg"] else None
                if registrar is None:
                    broken.append(f"{where}: its registration `{hop['reg']}` is missing")
                elif not _mentions(registrar, name):
                    broken.append(f"{where}: `{hop['reg']}` no longer registers `{name}`")
    return broken


def test_the_architecture_flows_hold_hop_by_hop():
    """docs/architecture.md's flows are true of the code: every named module and symbol exists and
    each hop reaches the next (a broken hop is named: update the flow with the code)."""
    flows = parse_flows((ROOT / "docs" / "architecture.md").read_text(encoding="utf-8"))
    assert set(flows) >= {"slider-kernel", "slider-browser", "engine-auto", "engine-fallback"}, sorted(flows)
    assert all(len(hops) >= 5 for hops in flows.values())
    broken = broken_hops(flows)
    assert not broken, "docs/architecture.md's flows no longer match the code:\n" + "\n".join(broken)
    # Each slider flow ends at the GPU: one of its hops writes the uniform buffer.
    assert any("queue.write_buffer(" in hop_source(h["ref"]) for h in flows["slider-kernel"])
    assert any("queue.writeBuffer(" in hop_source(h["ref"]) for h in flows["slider-browser"])


def test_the_flow_check_names_the_broken_hop():
    text = ("<!-- flow: demo -->\n"
            "1. `grasswidget/notebook/control_link.py::ControlLink.__init__`: observes the control.\n"
            "2. notifies `grasswidget/notebook/control_link.py::ControlLink._from_control` "
            "(registered in `grasswidget/notebook/control_link.py::ControlLink.__init__`): sets the trait.\n"
            "3. calls `grasswidget/notebook/control_link.py::ControlLink.unlink`: not called there.\n"
            "4. called by `grasswidget/notebook/control_link.py::ControlLink._from_obj`: does not call unlink.\n"
            "5. calls `grasswidget/notebook/control_link.py::ControlLink.gone`: no such method.\n")
    flows = parse_flows(text)
    assert [h["link"] for h in flows["demo"]] == [None, "notifies", "calls", "called by", "calls"]
    assert broken_hops(flows) == [
        "flow demo, hop 3 (`grasswidget/notebook/control_link.py::ControlLink.unlink`): hop 2 "
        "(`grasswidget/notebook/control_link.py::ControlLink._from_control`) no longer mentions `unlink`",
        "flow demo, hop 4 (`grasswidget/notebook/control_link.py::ControlLink._from_obj`): its source no longer "
        "mentions hop 3's `unlink`",
        "flow demo, hop 5 (`grasswidget/notebook/control_link.py::ControlLink.gone`): no such file or symbol",
    ]
    assert hop_source("grasswidget/browser/engine.js::GrassEngine.simulate").startswith("simulate(n) {")
    render = hop_source("grasswidget/browser/adapter_probe.js::render")  # braces in the arguments
    assert render.startswith("render({ model, el }) {") and 'model.set("report"' in render
    assert hop_name("grasswidget/notebook/panel.py::ControlPanel.__init__") == "ControlPanel"


def test_the_layer_diagram_draws_the_rules_the_architecture_test_enforces():
    """docs/architecture.md's mermaid diagram: its solid arrows ("may import") are exactly the
    imports between layers that tests/test_architecture.py's FORBIDDEN leaves allowed."""
    import importlib.util

    spec = importlib.util.spec_from_file_location("_architecture_rules", ROOT / "tests" / "test_architecture.py")
    rules = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(rules)
    text = (ROOT / "docs" / "architecture.md").read_text(encoding="utf-8")
    block = re.search(r"```mermaid\n(.*?)\n```", text, re.S).group(1)
    nodes = {node: label.split("/")[0] for node, label in re.findall(r"^\s*(\w+)\[\"([\w]+)/", block, re.M)}
    drawn = {(nodes[a], nodes[b]) for a, b in re.findall(r"^\s*(\w+) --> (\w+)\s*$", block, re.M)}
    layers = ("core", "gpu", "browser", "views", "notebook")
    allowed = {(a, b) for a in layers for b in layers
               if a != b and f"grasswidget.{b}" not in rules.FORBIDDEN.get(a, ())}
    assert {"core", "gpu", "browser", "views", "notebook"} <= set(nodes.values()), nodes
    assert drawn == allowed, f"drawn {sorted(drawn)}, allowed by tests/test_architecture.py {sorted(allowed)}"
