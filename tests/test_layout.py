"""The package's rooms stay apart (docs/layout.md): no module imports another's private (_underscored) names,
and the modules of trms_ident do not import each other in a loop when they are loaded."""
import ast
from pathlib import Path

PACKAGE = Path(__file__).resolve().parents[1] / "trms_ident"


def _modules(package: Path) -> dict[str, Path]:
    """Dotted module name -> file, for every module of ``package``."""
    out = {}
    for p in package.rglob("*.py"):
        parts = list(p.relative_to(package.parent).with_suffix("").parts)
        out[".".join(parts[:-1] if parts[-1] == "__init__" else parts)] = p
    return out


def _source(name: str, path: Path, node: ast.ImportFrom) -> str:
    """The absolute module an ImportFrom of module ``name`` names."""
    if node.level == 0:
        return node.module or ""
    base = name.split(".") if path.name == "__init__.py" else name.split(".")[:-1]
    base = base[:len(base) - (node.level - 1)]
    return ".".join(base + ([node.module] if node.module else []))


def private_imports(modules: dict[str, Path]) -> list[str]:
    root = next(iter(modules)).split(".")[0]
    found = []
    for name, path in sorted(modules.items()):
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, ast.ImportFrom) and _source(name, path, node).split(".")[0] == root:
                private = [a.name for a in node.names if a.name.startswith("_") and not a.name.startswith("__")]
                if private:
                    found.append(f"{name} imports {', '.join(private)} from {_source(name, path, node)}")
    return found


def import_loops(modules: dict[str, Path]) -> list[str]:
    """Loops among the imports each module runs when loaded (those inside functions are left out)."""
    graph = {}
    for name, path in modules.items():
        deps = set()
        for node in ast.parse(path.read_text(encoding="utf-8")).body:
            if isinstance(node, ast.ImportFrom):
                source = _source(name, path, node)
                deps |= {f"{source}.{a.name}" if f"{source}.{a.name}" in modules else source for a in node.names}
            elif isinstance(node, ast.Import):
                deps |= {a.name for a in node.names}
        # a package's own __init__ runs before its modules: an import of the parent package is not a loop
        graph[name] = {d for d in deps if d in modules and d != name and not name.startswith(d + ".")}
    loops, state = [], {}

    def visit(node, stack):
        state[node] = "open"
        for nxt in sorted(graph[node]):
            if state.get(nxt) == "open":
                loops.append(" -> ".join(stack[stack.index(nxt):] + [nxt]))
            elif nxt not in state:
                visit(nxt, stack + [nxt])
        state[node] = "done"

    for name in sorted(graph):
        if name not in state:
            visit(name, [name])
    return loops


def test_no_module_imports_another_modules_private_names():
    assert not private_imports(_modules(PACKAGE)), "\n".join(private_imports(_modules(PACKAGE)))


def test_the_package_has_no_import_loops_at_load_time():
    assert not import_loops(_modules(PACKAGE)), "\n".join(import_loops(_modules(PACKAGE)))


def test_the_checks_see_a_private_import_and_a_loop(tmp_path):
    # the two checks on a package made to break them: they must not pass by reading nothing
    pkg = tmp_path / "pkg"
    pkg.mkdir()
    (pkg / "__init__.py").write_text("")
    (pkg / "a.py").write_text("import math\nfrom .b import _hidden, shown\n")
    (pkg / "b.py").write_text("from . import a\n_hidden = shown = 1\n\n\ndef later():\n    from . import c\n")
    (pkg / "c.py").write_text("from .b import shown\n")
    modules = _modules(pkg)
    assert set(modules) == {"pkg", "pkg.a", "pkg.b", "pkg.c"}
    assert private_imports(modules) == ["pkg.a imports _hidden from pkg.b"]
    assert import_loops(modules) == ["pkg.a -> pkg.b -> pkg.a"]  # b -> c is inside a function: no loop
