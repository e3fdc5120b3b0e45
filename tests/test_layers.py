"""The package's layers, checked on the source: no import may run the wrong way.

    core                       imports only core
    tasks, nav                 import core (and themselves)
    tuning                     imports core (and itself)
    companion                  imports core, tasks, nav, tuning (and itself)
    sitl (the simulator)       imports core (and itself)
    demo                       imports core, tasks, nav, tuning, companion, sitl (and itself)
    cli.py                     imports anything

So nothing but cli.py imports ``mavhelm.cli`` or ``mavhelm.demo``, and nothing outside demo and
cli.py imports ``mavhelm.sitl``. Every ``import`` and ``from … import`` counts, wherever it is
(inside a function, under ``if TYPE_CHECKING:``), and so does ``importlib.import_module`` with a
literal name. The bare package ``mavhelm`` (its ``__init__``, imported with any of its
subpackages) may be imported from anywhere, and may itself import only core.
"""

from __future__ import annotations

import ast
from dataclasses import dataclass
from pathlib import Path

import pytest

import mavhelm

PACKAGE = "mavhelm"
PACKAGE_DIR = Path(mavhelm.__file__).resolve().parent
REPO = PACKAGE_DIR.parent

ROOT = "mavhelm"
"""The layer of ``mavhelm/__init__.py`` and of ``import mavhelm`` / ``from mavhelm import
__version__``."""

LAYERS = ("core", "tasks", "nav", "tuning", "companion", "sitl", "demo", "cli")

ALLOWED: dict[str, frozenset[str]] = {
    ROOT: frozenset({ROOT, "core"}),
    "core": frozenset({ROOT, "core"}),
    "tasks": frozenset({ROOT, "core", "tasks"}),
    "nav": frozenset({ROOT, "core", "nav"}),
    "tuning": frozenset({ROOT, "core", "tuning"}),
    "companion": frozenset({ROOT, "core", "tasks", "nav", "tuning", "companion"}),
    "sitl": frozenset({ROOT, "core", "sitl"}),
    "demo": frozenset({ROOT, "core", "tasks", "nav", "tuning", "companion", "sitl", "demo"}),
    "cli": frozenset({ROOT, *LAYERS}),
}


@dataclass(frozen=True)
class Violation:
    path: str
    line: int
    statement: str
    importer: str
    imported: str

    def __str__(self) -> str:
        if self.importer not in ALLOWED:
            return f"{self.path}: in no layer ({self.importer}): add it to ALLOWED"
        allowed = ", ".join(sorted(ALLOWED[self.importer] - {ROOT}))
        return (f"{self.path}:{self.line}: `{self.statement}` makes {self.importer} import "
                f"{self.imported} ({self.importer} may import only {allowed})")


def module_name(path: Path, package_dir: Path = PACKAGE_DIR) -> str:
    """``mavhelm/core/bus.py`` → ``mavhelm.core.bus``; a package's ``__init__`` is the package."""
    parts = list(path.relative_to(package_dir.parent).with_suffix("").parts)
    if parts[-1] == "__init__":
        parts.pop()
    return ".".join(parts)


def layer_of(module: str) -> str | None:
    """The layer a ``mavhelm…`` module belongs to; None for a module outside the package."""
    parts = module.split(".")
    if parts[0] != PACKAGE:
        return None
    if len(parts) == 1:
        return ROOT
    return parts[1] if parts[1] in LAYERS else f"<unknown: {parts[1]}>"


def _resolve_relative(module: str | None, level: int, importer: str, is_package: bool) -> str:
    """The absolute name of ``from <level dots><module> import …`` written in ``importer``."""
    base = importer.split(".")
    if not is_package:
        base = base[:-1]
    if level > 1:
        base = base[: len(base) - (level - 1)]
    return ".".join([*base, module] if module else base)


def imported_modules(tree: ast.AST, importer: str,
                     is_package: bool) -> list[tuple[int, str, str]]:
    """(line, imported module, statement text) for every import anywhere in the tree."""
    found: list[tuple[int, str, str]] = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            for alias in node.names:
                found.append((node.lineno, alias.name, f"import {alias.name}"))
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = _resolve_relative(node.module, node.level, importer, is_package)
            else:
                base = node.module or ""
            dots = "." * node.level
            for alias in node.names:
                text = f"from {dots}{node.module or ''} import {alias.name}"
                # ``from mavhelm import demo`` imports the subpackage mavhelm.demo;
                # ``from mavhelm import __version__`` only the package itself
                subpackage = base == PACKAGE and alias.name in LAYERS
                target = f"{base}.{alias.name}" if subpackage else base
                found.append((node.lineno, target, text))
        elif (isinstance(node, ast.Call) and node.args
              and isinstance(node.args[0], ast.Constant) and isinstance(node.args[0].value, str)
              and _is_dynamic_import(node.func)):
            name = node.args[0].value
            found.append((node.lineno, name, f"{ast.unparse(node.func)}({name!r})"))
    return found


def _is_dynamic_import(func: ast.expr) -> bool:
    if isinstance(func, ast.Attribute):
        return func.attr == "import_module"
    return isinstance(func, ast.Name) and func.id in {"import_module", "__import__"}


def check_source(source: str, path: str, module: str, is_package: bool = False) -> list[Violation]:
    """The wrong-way imports in one file's source (``module`` is its dotted name)."""
    importer = layer_of(module)
    assert importer is not None, f"{path} is not in the {PACKAGE} package"
    if importer not in ALLOWED:
        return [Violation(path, 1, "(the file itself)", importer, "-")]
    tree = ast.parse(source, filename=path)
    violations = []
    for line, target, statement in imported_modules(tree, module, is_package):
        imported = layer_of(target)
        if imported is not None and imported not in ALLOWED[importer]:
            violations.append(Violation(path, line, statement, importer, imported))
    return violations


def python_files(package_dir: Path = PACKAGE_DIR) -> list[Path]:
    return sorted(p for p in package_dir.rglob("*.py") if "__pycache__" not in p.parts)


def check_tree(package_dir: Path = PACKAGE_DIR) -> list[Violation]:
    """Every wrong-way import in every .py file of the package at ``package_dir``."""
    violations = []
    for path in python_files(package_dir):
        shown = path.relative_to(package_dir.parent).as_posix()
        violations += check_source(path.read_text(encoding="utf-8"), shown,
                                   module_name(path, package_dir), path.name == "__init__.py")
    return violations


# -- the real tree ------------------------------------------------------------------------------


def test_no_import_runs_the_wrong_way():
    violations = check_tree()
    assert not violations, (f"{len(violations)} import(s) run the wrong way:\n"
                            + "\n".join(str(v) for v in violations))


def test_every_module_is_in_a_known_layer():
    unknown = [module_name(p) for p in python_files()
               if layer_of(module_name(p)) not in ALLOWED]
    assert not unknown, f"modules in no layer (add the layer to ALLOWED): {unknown}"


def test_the_check_sees_the_real_imports():
    """Not vacuous: the walk finds the files and their mavhelm imports, including those in
    subpackages, so an empty violation list means something."""
    files = python_files()
    assert len(files) >= 40
    edges = set()
    for path in files:
        module = module_name(path)
        tree = ast.parse(path.read_text(encoding="utf-8"))
        for _, target, _ in imported_modules(tree, module, path.name == "__init__.py"):
            if layer_of(target) is not None:
                edges.add((layer_of(module), layer_of(target)))
    assert {("companion", "core"), ("companion", "nav"), ("companion", "tasks"),
            ("demo", "sitl"), ("sitl", "core"), ("tasks", "core")} <= edges


# -- the checker catches what it should -----------------------------------------------------------


@pytest.mark.parametrize(("module", "source", "imported"), [
    ("mavhelm.core.bus", "from mavhelm.companion.companion import Companion\n", "companion"),
    ("mavhelm.core.bus", "import mavhelm.sitl.boat\n", "sitl"),
    ("mavhelm.core.bus", "def f():\n    from mavhelm.tasks import helm\n", "tasks"),
    ("mavhelm.core.bus",
     "from typing import TYPE_CHECKING\nif TYPE_CHECKING:\n    from mavhelm.nav import x\n", "nav"),
    ("mavhelm.tasks.helm", "from mavhelm import demo\n", "demo"),
    ("mavhelm.tasks.helm", "from mavhelm.nav.navigator import Navigator\n", "nav"),
    ("mavhelm.nav.navigator", "from mavhelm.tasks.pid import ScalarPID\n", "tasks"),
    ("mavhelm.companion.companion", "from mavhelm.sitl.flat_earth import Origin\n", "sitl"),
    ("mavhelm.companion.companion", "import mavhelm.cli\n", "cli"),
    ("mavhelm.companion.companion", "from ..demo import harness\n", "demo"),
    ("mavhelm.sitl.boat", "from ..companion.bridge import MavlinkBridge\n", "companion"),
    ("mavhelm.sitl", "from ..tasks import Helm\n", "tasks"),
    ("mavhelm.sitl.boat", "import importlib\nimportlib.import_module('mavhelm.demo')\n", "demo"),
    ("mavhelm.demo.harness", "from mavhelm.cli import main\n", "cli"),
    ("mavhelm", "from mavhelm.companion import companion\n", "companion"),
])
def test_the_checker_catches_a_wrong_way_import(module, source, imported):
    path = module.replace(".", "/") + ".py"
    violations = check_source("import math\n\n" + source, path, module,
                              is_package=module in {"mavhelm", "mavhelm.sitl"})
    assert [v.imported for v in violations] == [imported]
    assert violations[0].line >= 3
    assert f"{path}:{violations[0].line}:" in str(violations[0])


@pytest.mark.parametrize(("module", "source"), [
    ("mavhelm.core.geodesy", "from mavhelm.core.mission import Mission\nimport pymap3d\n"),
    ("mavhelm.core.bus", "from . import clock\nfrom .clock import Clock\nimport mavhelm\n"),
    ("mavhelm.core.names", "from mavhelm import __version__\nimport mavhelm.core.errors\n"),
    ("mavhelm.tasks.helm", "from mavhelm.core.bus import Bus\nfrom mavhelm.tasks import pid\n"),
    ("mavhelm.companion.companion", "from mavhelm.nav import Navigator\nfrom ..tasks import x\n"),
    ("mavhelm.demo.harness", "from mavhelm.sitl import boat\nfrom mavhelm.companion import y\n"),
    ("mavhelm.cli", "from mavhelm.demo import run\nfrom mavhelm.sitl import runner\n"),
])
def test_the_checker_passes_right_way_imports(module, source):
    path = module.replace(".", "/") + ".py"
    assert check_source(source, path, module) == []


def test_the_checker_finds_violations_in_a_tree(tmp_path):
    """The whole walk, on a throwaway package on disk: every wrong import is listed with its
    file and line, and right ones are not."""
    pkg = tmp_path / "mavhelm"
    for sub in ("core", "nav", "sitl", "companion"):
        (pkg / sub).mkdir(parents=True)
        (pkg / sub / "__init__.py").write_text("")
    (pkg / "__init__.py").write_text('__version__ = "0"\n')
    (pkg / "core" / "geodesy.py").write_text(
        "import math\n\n\ndef f():\n    from mavhelm.sitl.flat_earth import Origin\n")
    (pkg / "nav" / "navigator.py").write_text("from mavhelm.core import geodesy\n")
    (pkg / "companion" / "bridge.py").write_text("from ..sitl import boat\nfrom ..nav import x\n")
    violations = check_tree(pkg)
    assert sorted(str(v).split(" (")[0] for v in violations) == [
        "mavhelm/companion/bridge.py:1: `from ..sitl import boat` makes companion import sitl",
        "mavhelm/core/geodesy.py:5: `from mavhelm.sitl.flat_earth import Origin` makes core "
        "import sitl",
    ]


def test_a_new_subpackage_must_be_given_a_layer(tmp_path):
    pkg = tmp_path / "mavhelm" / "extras"
    pkg.mkdir(parents=True)
    (pkg / "thing.py").write_text("import os\n")
    (tmp_path / "mavhelm" / "__init__.py").write_text("")
    violations = check_tree(tmp_path / "mavhelm")
    assert [v.importer for v in violations] == ["<unknown: extras>"]
    assert "mavhelm/extras/thing.py: in no layer" in str(violations[0])
