"""The layering rules of the code, read from the source (ast): numerics never import the web stack, the
client never imports the server or the numerics, and no private name crosses a module boundary."""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PACKAGES = ("models", "optim", "service", "clients")


def _modules(package: str) -> list[Path]:
    return sorted(p for p in (ROOT / package).rglob("*.py") if "migrations" not in p.parts)


def _imports(path: Path) -> list[tuple[str, list[str], int]]:
    """(module, names, line) of every import statement (relative imports resolved)."""
    tree = ast.parse(path.read_text(encoding="utf-8"))
    pkg = path.relative_to(ROOT).with_suffix("").parts[:-1]
    out = []
    for node in ast.walk(tree):
        if isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                base = ".".join(pkg[:len(pkg) - node.level + 1] + ((base,) if base else ()))
            out.append((base, [a.name for a in node.names], node.lineno))
        elif isinstance(node, ast.Import):
            out.extend((a.name, [], node.lineno) for a in node.names)
    return out


@pytest.mark.parametrize("package", PACKAGES)
def test_no_private_name_is_imported_from_another_project_module(package):
    bad = []
    for path in _modules(package):
        for module, names, line in _imports(path):
            if module.split(".")[0] not in PACKAGES:
                continue
            # a private module imported for its side effect (service._warm, preloaded by the forkserver) is fine
            private = [n for n in names if n.startswith("_") and not n.startswith("__")
                       and not (ROOT / module.replace(".", "/") / f"{n}.py").exists()]
            if private:
                bad.append(f"{path.relative_to(ROOT)}:{line} imports {private} from {module}")
    assert not bad, "private names used across modules (make them public):\n" + "\n".join(bad)


@pytest.mark.parametrize("package,forbidden", [
    ("models", ("fastapi", "starlette", "uvicorn", "service", "clients", "sqlalchemy")),
    ("optim", ("fastapi", "starlette", "uvicorn", "service", "clients", "sqlalchemy")),
    ("clients", ("service", "optim", "models")),
])
def test_layers_point_down(package, forbidden):
    bad = []
    for path in _modules(package):
        for module, _, line in _imports(path):
            if module.split(".")[0] in forbidden:
                bad.append(f"{path.relative_to(ROOT)}:{line} imports {module}")
    if package == "clients":   # `--local` may import the numerics lazily, inside a function
        bad = [b for b in bad if not _inside_function(b)]
    assert not bad, "\n".join(bad)


def _inside_function(entry: str) -> bool:
    where = entry.split(" ")[0]
    rel, line = where.rsplit(":", 1)
    tree = ast.parse((ROOT / rel).read_text(encoding="utf-8"))
    for node in ast.walk(tree):
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
            if node.lineno <= int(line) <= (node.end_lineno or node.lineno):
                return True
    return False
