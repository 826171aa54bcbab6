"""The README is for users and points to the rest: its set-up commands are the ones CI runs, it
stays short, and every relative link in it and in docs/ and benchmarks/ names a file that exists."""

import re
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
DOCS = [ROOT / "README.md", ROOT / "benchmarks" / "README.md", *sorted((ROOT / "docs").glob("*.md"))]


def test_readme_starts_with_the_two_set_up_commands_and_stays_short():
    text = (ROOT / "README.md").read_text()
    assert len(text.splitlines()) <= 300
    blocks = re.findall(r"```\n(.*?)\n```", text, re.S)
    assert blocks[:2] == ["./run.sh demo", "./run.sh test"]
    assert "./run.sh test" in (ROOT / ".ci" / "run").read_text()


def test_relative_links_name_files_that_exist():
    missing = []
    for doc in DOCS:
        for target in re.findall(r"\]\(([^)#\s]+)(?:#[^)]*)?\)", doc.read_text()):
            if "://" not in target and not (doc.parent / target).exists():
                missing.append(f"{doc.relative_to(ROOT)} -> {target}")
    assert len(DOCS) >= 4 and not missing, missing


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
