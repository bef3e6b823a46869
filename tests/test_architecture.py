"""The package's layers: imports point down only, and nothing goes round in a circle.

Every ``import`` of a ``studies`` module is read from the source (at the top
of a module or inside a function alike) and mapped to the layer of the
package it names. A module may import its own package and any lower layer;
an import of a higher layer, or a cycle between modules, fails the test with
the offending import named. ``docs/architecture.md`` describes the layers.
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

SRC = Path(__file__).resolve().parents[1] / "src" / "studies"

#: lowest first; packages of one layer may import each other (the cycle test
#: still applies)
LAYERS = [
    ("foundation", {"errors", "config", "conf", "interrupt", "plotting", "markdown", "threads", "lazy", "stages", "formatting"}),
    ("data", {"data", "papers"}),
    ("models", {"models", "vessels", "environment"}),
    ("simulate", {"simulate"}),
    ("identification", {"identification"}),
    ("analysis", {"analysis"}),
    ("roll", {"roll"}),
    ("discovery", {"discovery"}),
    ("scenarios", {"scenarios"}),
    ("studies", {"workflows", "roll.workflow"}),
    ("runtime", {"runtime"}),
    ("report", {"report"}),
    ("command line", {"cli", "cli_help", "console", "config_check", "progress", "bench", "bench_discovery", "benchmarks",
                      "__main__", "api",
                      "<root>"}),
]

def _rank(package: str) -> int:
    for rank, (_, members) in enumerate(LAYERS):
        if package in members:
            return rank
    raise AssertionError(f"package studies.{package} has no layer in tests/test_architecture.py")


def _modules() -> dict[str, Path]:
    out = {}
    for path in SRC.rglob("*.py"):
        parts = ["studies", *path.relative_to(SRC).with_suffix("").parts]
        if parts[-1] == "__init__":
            parts = parts[:-1]
        out[".".join(parts)] = path
    return out


def _imports(name: str, path: Path, modules: dict) -> list[tuple[str, int]]:
    """(imported studies module, line) for every import statement of a module."""
    tree = ast.parse(path.read_text(), str(path))
    package = name if path.name == "__init__.py" else name.rsplit(".", 1)[0]
    found = []
    for node in ast.walk(tree):
        targets = []
        if isinstance(node, ast.Import):
            targets = [a.name for a in node.names]
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = package.split(".")
                base = base[:len(base) - (node.level - 1)]
                module = ".".join(base + ([node.module] if node.module else []))
            else:
                module = node.module or ""
            targets = [f"{module}.{a.name}" if f"{module}.{a.name}" in modules else module
                       for a in node.names]
        for target in targets:
            if not target.startswith("studies"):
                continue
            while target not in modules and "." in target:
                target = target.rsplit(".", 1)[0]
            if target != name:
                found.append((target, node.lineno))
    return found


#: sub-packages whose layer is not their parent's: a kind of study keeps its pipelines in its
#: own folder (``studies/roll/workflow``) while the rest of that folder lies lower
SUBPACKAGE_LAYERS = ("roll.workflow",)


def _package(module: str) -> str:
    parts = module.split(".")
    if len(parts) > 2 and ".".join(parts[1:3]) in SUBPACKAGE_LAYERS:
        return ".".join(parts[1:3])
    return parts[1] if len(parts) > 1 else "<root>"


@pytest.fixture(scope="module")
def graph():
    modules = _modules()
    return modules, {name: _imports(name, path, modules) for name, path in modules.items()}


def test_every_package_has_a_layer(graph):
    modules, _ = graph
    for name in modules:
        _rank(_package(name))


def test_imports_point_down_only(graph):
    _, edges = graph
    upward = []
    for name, targets in edges.items():
        here = _package(name)
        for target, line in targets:
            there = _package(target)
            if _rank(there) > _rank(here):
                upward.append(f"{name}:{line} imports {target} "
                              f"({LAYERS[_rank(here)][0]} -> {LAYERS[_rank(there)][0]})")
    assert not upward, "imports that do not point down:\n" + "\n".join(sorted(upward))


def test_no_import_cycles(graph):
    _, edges = graph
    index, low, stack, on_stack, cycles = {}, {}, [], set(), []

    def visit(v):                       # Tarjan's strongly connected components
        index[v] = low[v] = len(index)
        stack.append(v)
        on_stack.add(v)
        for w, _ in edges.get(v, ()):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on_stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            component = []
            while True:
                w = stack.pop()
                on_stack.discard(w)
                component.append(w)
                if w == v:
                    break
            if len(component) > 1:
                cycles.append(sorted(component))

    for v in list(edges):
        if v not in index:
            visit(v)
    assert not cycles, "import cycles: " + "; ".join(" <-> ".join(c) for c in cycles)


def test_no_hydra_config_below_the_command_line(graph):
    """Only the command line sees Hydra and its DictConfig; the rest takes the
    typed settings of :mod:`studies.config` (which declares the schema)."""
    allowed = {"studies.cli", "studies.cli_help", "studies.config_check", "studies.config", "studies.progress"}
    modules, _ = graph
    offenders = []
    for name, path in modules.items():
        if name in allowed or name.startswith("studies.config."):
            continue
        tree = ast.parse(path.read_text(), str(path))
        for node in ast.walk(tree):
            roots = []
            if isinstance(node, ast.Import):
                roots = [a.name.split(".")[0] for a in node.names]
            elif isinstance(node, ast.ImportFrom) and not node.level:
                roots = [(node.module or "").split(".")[0]]
            if {"hydra", "omegaconf"} & set(roots):
                offenders.append(f"{name}:{node.lineno} imports {', '.join(roots)}")
        if "DictConfig" in path.read_text():
            offenders.append(f"{name} mentions DictConfig")
    assert not offenders, "\n".join(offenders)


def test_roll_decay_lives_in_one_folder():
    """The roll-decay feature is studies/roll (its pipelines in roll/workflow); its causes are
    classes of the one catalogue. No other package holds a roll module."""
    strays = [str(p.relative_to(SRC)) for p in SRC.rglob("*roll*.py")
              if p.relative_to(SRC).parts[0] != "roll"
              and p.relative_to(SRC) != Path("discovery/causes/roll_decay.py")
              and p.relative_to(SRC).parts[:2] != ("report", "reproduction")]
    assert not strays, f"roll-decay modules outside studies/roll: {strays}"


def test_no_dispatch_on_the_model_name_roll():
    offenders = [str(p.relative_to(SRC)) for p in SRC.rglob("*.py")
                 if '== "roll"' in p.read_text() or "== 'roll'" in p.read_text()]
    assert not offenders, offenders


def test_nothing_but_the_command_line_imports_report(graph):
    """Reports read what runs logged: no layer that computes may need one to work."""
    _, edges = graph
    found = [f"{name}:{line}" for name, targets in edges.items() for target, line in targets
             if _package(target) == "report" and _package(name) not in ("report", "cli", "<root>")]
    assert not found, "imports of studies.report outside the command line:\n" + "\n".join(sorted(found))


def test_report_pages_neither_simulate_nor_identify(graph):
    """A page formats what runs logged; what a reproduction must compute beside them lives in the
    layer that computes (workflows/reproduction/), where it can be run and tested on its own."""
    _, edges = graph
    found = [f"{name}:{line} imports {target}" for name, targets in edges.items() for target, line in targets
             if _package(name) == "report" and _package(target) in ("simulate", "identification")]
    assert not found, "report modules that compute:\n" + "\n".join(sorted(found))


def _string_tuples(path: Path) -> dict:
    """Module-level ``NAME = ("a", "b", ...)`` assignments of strings: {name: values}."""
    out = {}
    for node in ast.parse(path.read_text(), str(path)).body:
        if isinstance(node, ast.Assign) and isinstance(node.value, ast.Tuple) and node.value.elts and \
                all(isinstance(e, ast.Constant) and isinstance(e.value, str) for e in node.value.elts):
            for target in node.targets:
                if isinstance(target, ast.Name):
                    out[target.id] = tuple(e.value for e in node.value.elts)
    return out


def test_allowed_values_are_defined_once():
    """The allowed values of a setting live in config/values.py; a module that needs them imports
    them, so a new option cannot be accepted by one and refused by the other."""
    values_file = SRC / "config" / "values.py"
    allowed = {values: name for name, values in _string_tuples(values_file).items() if len(values) > 1}
    assert {"DERIVATIVES", "BAYES_DISCREPANCIES", "WEIGHTINGS", "ROLL_TERMS"} <= set(allowed.values())
    repeated = []
    for path in SRC.rglob("*.py"):
        if path == values_file:
            continue
        for name, values in _string_tuples(path).items():
            if values in allowed:
                repeated.append(f"{path.relative_to(SRC)}: {name} repeats config.{allowed[values]} {values}")
    assert not repeated, "allowed values defined twice:\n" + "\n".join(sorted(repeated))
