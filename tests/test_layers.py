"""The package's layers import one way (issue 10): core < solvers < io < studies < plots
< api/reproduce < cli, and the command line builds no PETSc object and touches no file format."""
from __future__ import annotations

import ast
from pathlib import Path

PACKAGE = Path(__file__).resolve().parents[1] / "elastica_petsc"
ORDER = ["core", "solvers", "io", "studies", "plots", "api", "reproduce", "cli"]
FORBIDDEN_IN = {
    "core": {"petsc4py", "slepc4py", "mpi4py", "h5py", "matplotlib"},
    "cli": {"petsc4py", "slepc4py", "h5py", "matplotlib"},
}


def layer(path: Path) -> str:
    rel = path.relative_to(PACKAGE)
    return rel.parts[0] if len(rel.parts) > 1 else rel.stem


def imports(path: Path):
    """(absolute module imported, line) for every import statement of a module."""
    tree = ast.parse(path.read_text())
    package = ["elastica_petsc", *path.relative_to(PACKAGE).parent.parts]
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            for alias in node.names:
                yield alias.name, node.lineno
        elif isinstance(node, ast.ImportFrom):
            base = package[: len(package) - node.level + 1] if node.level else []
            module = ".".join(base + ([node.module] if node.module else []))
            if node.module is None:
                for alias in node.names:
                    yield f"{module}.{alias.name}", node.lineno
            else:
                yield module, node.lineno


def violations() -> list[str]:
    found = []
    for path in sorted(PACKAGE.rglob("*.py")):
        own = layer(path)
        if own == "__init__":
            continue
        for module, line in imports(path):
            top = module.split(".")[0]
            where = f"{path.relative_to(PACKAGE.parent)}:{line} imports {module}"
            if top in FORBIDDEN_IN.get(own, ()):
                found.append(where)
            if top == "elastica_petsc" and module.count(".") >= 1:
                other = module.split(".")[1]
                if other in ORDER and own in ORDER and ORDER.index(other) > ORDER.index(own):
                    found.append(where)
    return found


def test_layers_import_one_way():
    assert violations() == []
