"""The package layering of DESIGN.md, checked on every import (also inside functions).

Each package depends only on those above it in DESIGN.md's list
(robots, campaign, twin, modal, tl, sld, stock, plan, diagnose, cli) and not on what its
"knows nothing of" column excludes; the top-level helper modules import no
package at all (``__main__``, ``python -m robolobe``, is in the CLI's layer).
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

SRC = Path(__file__).resolve().parents[1] / "src" / "robolobe"

#: Packages each package may import (besides itself and top-level modules).
ALLOWED: dict[str, set[str]] = {
    "robots": set(),
    # measured data; checks postures against the robot's limits
    "campaign": {"robots"},
    "twin": {"robots", "campaign"},
    "modal": {"campaign"},  # knows nothing of robots (FRFs and modal parameters only)
    "tl": {"robots", "campaign", "twin", "modal"},
    "sld": set(),  # knows nothing of robots or learning
    # stock definitions, in-process workpiece, engagement: knows nothing of robots,
    # dynamics or lobes
    "stock": set(),
    "plan": {"robots", "campaign", "twin", "modal", "tl", "sld", "stock"},
    "diagnose": {"robots", "campaign", "twin", "modal", "tl"},  # knows nothing of cutting
    "cli": {"robots", "campaign", "twin", "modal", "tl", "sld", "stock", "plan", "diagnose"},
    "data": set(),
}

#: Top-level modules that belong to a package's layer: ``python -m robolobe`` is the CLI.
TOP_LEVEL_LAYER: dict[str, str] = {"__main__.py": "cli"}

#: Known breaches, each with the issue that removes it. Keep this short.
KNOWN: dict[tuple[str, str], str] = {}


def _imports(path: Path, src: Path = SRC) -> list[tuple[int, str]]:
    """Absolute module names imported by ``path`` (relative imports resolved)."""
    package = list(path.relative_to(src.parent).parts[:-1])
    out = []
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.Import):
            out += [(node.lineno, a.name) for a in node.names]
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = package[: len(package) - node.level + 1]
                mod = ".".join([*base, node.module] if node.module else base)
            else:
                mod = node.module or ""
            out.append((node.lineno, mod))
            # `from robolobe import plan` imports the package `plan`
            if mod == "robolobe":
                out += [(node.lineno, f"robolobe.{a.name}") for a in node.names]
    return out


def _violations(src: Path = SRC) -> list[str]:
    bad = []
    for path in sorted(src.rglob("*.py")):
        rel = path.relative_to(src)
        own = rel.parts[0] if len(rel.parts) > 1 else TOP_LEVEL_LAYER.get(rel.name)
        for lineno, mod in _imports(path, src):
            parts = mod.split(".")
            if parts[0] != "robolobe" or len(parts) < 2:
                continue
            target = parts[1]
            if not (src / target).is_dir() or target == own:
                continue
            allowed = ALLOWED.get(own, set()) if own is not None else set()
            if target in allowed or (rel.as_posix(), target) in KNOWN:
                continue
            bad.append(f"src/robolobe/{rel.as_posix()}:{lineno} imports robolobe.{target}")
    return bad


def test_every_package_is_in_the_layering() -> None:
    packages = {p.name for p in SRC.iterdir() if p.is_dir() and (p / "__init__.py").exists()}
    assert packages <= set(ALLOWED), packages - set(ALLOWED)


@pytest.mark.slow
def test_no_package_imports_one_it_must_not_know() -> None:
    assert _violations() == []


def test_known_breaches_still_exist() -> None:
    # a known breach that was fixed must leave the list (so it cannot return)
    for (file, target), why in KNOWN.items():
        mods = {m.split(".")[1] for _, m in _imports(SRC / file) if m.startswith("robolobe.")}
        assert target in mods, f"{file} no longer imports {target}: remove it from KNOWN ({why})"


def test_the_checker_sees_imports_inside_functions(tmp_path: Path) -> None:
    src = tmp_path / "robolobe"
    for pkg in ("sld", "plan", "tl"):
        (src / pkg).mkdir(parents=True)
        (src / pkg / "__init__.py").write_text("")
    (src / "sld" / "_layering_probe.py").write_text(
        "def f():\n    from robolobe.plan import job\n    from ..tl import network\n"
    )
    (src / "plan" / "ok.py").write_text("from robolobe.sld import zoa\nfrom ..tl import x\n")
    bad = _violations(src)
    assert len(bad) == 2, bad
    assert any("_layering_probe.py:2 imports robolobe.plan" in b for b in bad)
    assert any("_layering_probe.py:3 imports robolobe.tl" in b for b in bad)


@pytest.mark.parametrize("package", sorted(ALLOWED))
def test_allowed_packages_are_above_in_design_order(package: str) -> None:
    order = ["robots", "campaign", "twin", "modal", "tl", "sld", "stock", "plan", "diagnose", "cli"]
    if package not in order:
        return
    assert all(order.index(a) < order.index(package) for a in ALLOWED[package])
