"""The package's JavaScript type-checked: ``tsc --checkJs --noEmit`` (TypeScript, a test tool only:
package.json pins it, ``./run.sh test`` installs it with ``npm ci``; users build nothing).

* tsconfig.json takes in every JS module of the package (grasswidget/**/*.js, vendor/ aside) and
  tsc finds no error in them.
* Every module says ``// @ts-check`` on its first line (so an editor checks it too), but those
  tsconfig.json still lists under ``exclude`` (modules not yet typed; the list only shrinks).
* The ``Model`` typedef (browser/types.js) names exactly the traits the browser engine's widget
  syncs, so a ``model.get`` of a trait Python does not send is a type error.

A missing TypeScript fails (it is part of the test set-up), with how to install it.
"""

from __future__ import annotations

import json
import re
import subprocess
from pathlib import Path

import pytest

from grasswidget.browser.engine_widget import BrowserEngineWidget

ROOT = Path(__file__).resolve().parents[2]
PACKAGE = ROOT / "grasswidget"


def _tsc() -> Path:
    tsc = ROOT / "node_modules" / "typescript" / "bin" / "tsc"
    if not tsc.is_file():
        pytest.fail("TypeScript is not installed (a test tool): run `npm ci` in the repository root "
                    "(./run.sh test does; Debian needs the npm package for it)")
    return tsc


def _config() -> dict:
    text = (ROOT / "tsconfig.json").read_text(encoding="utf-8")
    return json.loads(text)


def _package_modules() -> list:
    return sorted(p.relative_to(ROOT).as_posix() for p in PACKAGE.rglob("*.js") if "vendor" not in p.parts)


def test_tsc_checks_every_js_module_of_the_package():
    from conftest import node_executable

    config = _config()
    assert config["compilerOptions"]["checkJs"] is True and config["compilerOptions"]["noEmit"] is True
    run = subprocess.run([node_executable(), str(_tsc()), "-p", str(ROOT / "tsconfig.json"), "--listFiles"],
                         cwd=ROOT, capture_output=True, text=True, timeout=120)
    errors = [line for line in run.stdout.splitlines() if ": error TS" in line]
    assert run.returncode == 0 and not errors, "\n".join(errors) or run.stdout + run.stderr
    checked = {Path(line.strip()).resolve().relative_to(ROOT).as_posix() for line in run.stdout.splitlines()
               if line.strip().endswith(".js") and str(PACKAGE) in str(Path(line.strip()).resolve())}
    excluded = set(config.get("exclude", [])) - {"grasswidget/**/vendor/**"}
    assert set(_package_modules()) - excluded <= checked, set(_package_modules()) - excluded - checked


def test_every_module_asks_to_be_checked():
    excluded = set(_config().get("exclude", [])) - {"grasswidget/**/vendor/**"}
    assert excluded <= set(_package_modules()), excluded - set(_package_modules())  # no stale entry
    for rel in _package_modules():
        if rel in excluded:
            continue
        first = (ROOT / rel).read_text(encoding="utf-8").splitlines()[0]
        assert first.strip() == "// @ts-check", rel


def test_the_model_typedef_is_the_synced_traits():
    text = (PACKAGE / "browser" / "types.js").read_text(encoding="utf-8")
    block = text[text.index("@typedef {Object} Traits"):text.index("*/", text.index("@typedef {Object} Traits"))]
    typed = set(re.findall(r"@property\s+\{(?:[^{}]|\{[^{}]*\})*\}\s+(\w+)", block))
    synced = {name for name in BrowserEngineWidget.class_trait_names(sync=True)
              if not name.startswith("_") and name not in ("layout", "tabbable", "tooltip", "comm", "keys", "log")}
    assert typed == synced, (sorted(typed - synced), sorted(synced - typed))
