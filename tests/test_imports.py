"""Imports run one way through the package's layers (read from the source with ast, so imports
inside functions and under ``if TYPE_CHECKING:`` count as much as those at the top).

    spatial/model (and errors, models) -> control, planar, kinematic -> sim -> analysis -> viz
    -> outputs (experiments) -> cli

A module may import its own package and any layer below its own; packages of the same layer are
independent of each other (control does not import planar or kinematic, and so on).
"""

from __future__ import annotations

import ast
from pathlib import Path

import biped

PACKAGE = Path(biped.__file__).parent

#: Layer of each top-level module or subpackage of ``biped`` (lowest first). The one table.
LAYERS = {
    "": 0,  # biped/__init__.py
    "errors": 0,
    "files": 0,  # every file biped writes or reads from the user (imports errors only)
    "_numba_cache": 0,  # where numba caches the kernels; imports nothing from biped
    "_progress": 0,  # progress counters (tqdm on a terminal, lines otherwise)
    "spatial": 0,
    "model": 0,
    "models": 0,
    "control": 1,
    "planar": 1,
    "kinematic": 1,
    "sim": 2,
    "analysis": 3,
    "viz": 4,
    "outputs": 5,
    "experiments": 5,
    "cli": 6,
    "__main__": 7,  # python -m biped: runs the cli
}
ORDER = "spatial/model -> control, planar, kinematic -> sim -> analysis -> viz -> outputs -> cli"


def _module_name(path: Path) -> str:
    rel = path.relative_to(PACKAGE.parent).with_suffix("")
    parts = list(rel.parts)
    if parts[-1] == "__init__":
        parts.pop()
    return ".".join(parts)


def _is_package(name: str) -> bool:
    return (PACKAGE.parent / Path(*name.split(".")) / "__init__.py").is_file()


def _exists(name: str) -> bool:
    p = PACKAGE.parent / Path(*name.split("."))
    return p.with_suffix(".py").is_file() or (p / "__init__.py").is_file()


def _imported(module: str, tree: ast.AST):
    """(line, imported biped module) for every import in ``tree``, relative ones resolved."""
    package = module if _is_package(module) else module.rpartition(".")[0]
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            for alias in node.names:
                if alias.name == "biped" or alias.name.startswith("biped."):
                    yield node.lineno, alias.name
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = package.split(".")
                base = base[: len(base) - (node.level - 1)]
                target = ".".join(base + ([node.module] if node.module else []))
            else:
                target = node.module or ""
            if target != "biped" and not target.startswith("biped."):
                continue
            for alias in node.names:  # `from biped import models` imports biped.models
                sub = f"{target}.{alias.name}"
                yield node.lineno, sub if _exists(sub) else target


def _top(name: str) -> str:
    parts = name.split(".")
    return parts[1] if len(parts) > 1 else ""


def _modules():
    return sorted(PACKAGE.rglob("*.py"))


def test_every_top_level_module_has_a_layer():
    tops = {_top(_module_name(p)) for p in _modules()}
    missing = sorted(tops - set(LAYERS))
    assert not missing, f"add {missing} to LAYERS in tests/test_imports.py ({ORDER})"


def test_imports_run_one_way():
    bad = []
    for path in _modules():
        module = _module_name(path)
        top = _top(module)
        layer = LAYERS.get(top)
        if layer is None:
            continue  # reported by the test above
        tree = ast.parse(path.read_text(), filename=str(path))
        for line, target in _imported(module, tree):
            ttop = _top(target)
            tlayer = LAYERS.get(ttop)
            if tlayer is None or ttop == top:
                continue
            if tlayer > layer or (tlayer == layer and layer > 0):
                where = path.relative_to(PACKAGE.parent)
                bad.append(
                    f"{where}:{line} ({top or 'biped'}, layer {layer}) imports {target} "
                    f"({ttop}, layer {tlayer})"
                )
    assert not bad, f"imports that run upward or sideways ({ORDER}):\n" + "\n".join(bad)


def test_the_checker_sees_function_level_and_relative_imports():
    """The walker itself: an import inside a function, a relative import and `from biped import
    <subpackage>` are all found and resolved."""
    src = (
        "def f():\n    from biped.viz import replay\n"
        "from . import scene\nfrom ..control import policy\nfrom biped import models\n"
    )
    found = {t for _, t in _imported("biped.sim.push", ast.parse(src))}
    assert found == {"biped.viz.replay", "biped.sim.scene", "biped.control.policy", "biped.models"}
