"""The package's layers import one way (issue 10): core < solvers < io < ui < studies < plots
< api/reproduce < cli, and the command line builds no PETSc object and touches no file format."""
from __future__ import annotations

import ast
from pathlib import Path

PACKAGE = Path(__file__).resolve().parents[1] / "elastica_petsc"
ORDER = ["core", "solvers", "io", "ui", "studies", "plots", "api", "reproduce", "cli"]
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


def module_name(path: Path) -> str:
    """The dotted name of a module of the package (a package: its ``__init__``)."""
    parts = ["elastica_petsc", *path.relative_to(PACKAGE).with_suffix("").parts]
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def graph() -> dict[str, set[str]]:
    """Module -> the package's modules it imports, at module level or inside a
    function alike.  Importing ``a.b.c`` first runs the packages ``a.b`` and
    ``a``: those count too, except the importer's own enclosing packages
    (always initialised before it).  ``from package import name`` counts as an
    import of the submodule ``package.name`` where that is a module."""
    paths = sorted(PACKAGE.rglob("*.py"))
    known = {module_name(p) for p in paths}
    edges = {}
    for path in paths:
        own = module_name(path)
        mine = {".".join(own.split(".")[:k]) for k in range(1, own.count(".") + 1)}
        edges[own] = set()
        for module, _ in imports(path):
            if module not in known:
                module = module.rsplit(".", 1)[0]
            parts = module.split(".")
            for k in range(1, len(parts) + 1):
                target = ".".join(parts[:k])
                if target in known and target not in mine and target != own:
                    edges[own].add(target)
    return edges


def cycles() -> list[list[str]]:
    """The strongly connected components of more than one module (Tarjan)."""
    edges, index, low, stack, on, out = graph(), {}, {}, [], set(), []

    def visit(v):
        index[v] = low[v] = len(index)
        stack.append(v)
        on.add(v)
        for w in sorted(edges[v]):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            component = []
            while True:
                w = stack.pop()
                on.discard(w)
                component.append(w)
                if w == v:
                    break
            if len(component) > 1:
                out.append(sorted(component))

    for v in sorted(edges):
        if v not in index:
            visit(v)
    return out


def test_no_import_cycles():
    assert cycles() == []


def private(name: str) -> bool:
    return name.startswith("_") and not (name.startswith("__") and name.endswith("__"))


def private_imports() -> list[str]:
    """A private name (one leading underscore) of one module of the package used
    in another: ``from elastica_petsc.x import _name``, or ``x._name`` on a
    module imported as ``x``."""
    known = {module_name(p) for p in PACKAGE.rglob("*.py")}
    found = []
    for path in sorted(PACKAGE.rglob("*.py")):
        tree = ast.parse(path.read_text())
        package = ["elastica_petsc", *path.relative_to(PACKAGE).parent.parts]
        where = f"{path.relative_to(PACKAGE.parent)}"
        modules = set()                       # local names bound to modules of the package
        for node in ast.walk(tree):
            if isinstance(node, ast.Import):
                modules |= {a.asname for a in node.names
                            if a.asname and a.name.startswith("elastica_petsc")}
            if not isinstance(node, ast.ImportFrom):
                continue
            base = package[: len(package) - node.level + 1] if node.level else []
            module = ".".join(base + ([node.module] if node.module else []))
            if not module.startswith("elastica_petsc"):
                continue
            for alias in node.names:
                if private(alias.name) or any(private(p) for p in module.split(".")):
                    found.append(f"{where}:{node.lineno} imports {alias.name} from {module}")
                elif f"{module}.{alias.name}" in known:
                    modules.add(alias.asname or alias.name)
        for node in ast.walk(tree):
            if (isinstance(node, ast.Attribute) and private(node.attr)
                    and isinstance(node.value, ast.Name) and node.value.id in modules):
                found.append(f"{where}:{node.lineno} uses {node.value.id}.{node.attr}")
    return found


def test_no_private_names_across_modules():
    assert private_imports() == []
