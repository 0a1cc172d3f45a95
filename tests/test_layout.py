"""The docs' layout table names every module, so that it cannot drift from the tree."""

from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
PACKAGES = ("sim", "ident", "detect", "bridge", "quantify", "agent", "trainer", "schemas", "bench", "stiction")
LAYER = {"schemas": 0, "sim": 1, "bridge": 1, "detect": 2, "ident": 3, "quantify": 4, "agent": 5, "trainer": 5,
         "bench": 6, "stiction": 7}  # fmt: skip
"""Higher imports lower, never the reverse; sim may use bridge's publisher (bridge imports nothing of sim)."""


def test_the_layout_table_names_every_module():
    table = (ROOT / "docs" / "layout.md").read_text()
    missing = [
        str(p.relative_to(ROOT))
        for package in PACKAGES
        for p in sorted((ROOT / package).glob("*.py"))
        if p.name != "__init__.py" and f"`{p.name}`" not in table
    ]
    assert not missing, f"docs/layout.md does not name {missing}"
    assert (ROOT / "stiction" / "commands").is_dir() and "`commands/`" in table


def test_the_readme_stays_short_and_links_every_docs_page():
    readme = (ROOT / "README.md").read_text()
    assert len(readme.encode()) < 8 * 1024
    assert "stiction demo" in readme and "bash scripts/test" in readme
    for page in sorted((ROOT / "docs").glob("*.md")):
        assert f"docs/{page.name}" in readme, f"README does not link {page.name}"


def _imports(path: Path) -> set[str]:
    import ast

    out = set()
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            out.update(f"{node.module}.{a.name}" for a in node.names)
        elif isinstance(node, ast.Import):
            out.update(a.name for a in node.names)
    return out


def _package_of(module: str) -> str | None:
    """The folder a module name lives in: ``stiction.sim.valve`` -> ``sim``, ``stiction.cli`` ->
    ``stiction``, a bare ``sim.valve`` -> ``sim`` (wrong: see below); None outside the product."""
    parts = module.split(".")
    if parts[0] == "stiction":
        return parts[1] if len(parts) > 1 and parts[1] in LAYER else "stiction"
    return parts[0] if parts[0] in LAYER else None


def test_imports_point_one_way():
    wrong = []
    for package in PACKAGES:
        for p in sorted((ROOT / package).rglob("*.py")):
            for module in _imports(p):
                top = _package_of(module)
                if top is None or top == package:
                    continue
                same = LAYER[top] == LAYER[package] and (package, top) != ("sim", "bridge")
                upward = LAYER[top] > LAYER[package] or same
                if upward:
                    wrong.append(f"{p.relative_to(ROOT)} imports {module}")
    assert not wrong, wrong


def test_every_import_names_the_installed_namespace():
    """``pip install`` puts one name into site-packages, ``stiction``: every module of the product and
    of the tests imports the product's packages under it (a bare ``import schemas`` would clash with
    any other distribution's ``schemas``, and load a second copy of the module in a checkout)."""
    bare = [
        f"{p.relative_to(ROOT)} imports {module}"
        for folder in (*PACKAGES, "tests")
        for p in sorted((ROOT / folder).rglob("*.py"))
        for module in _imports(p)
        if module.split(".")[0] in LAYER and module.split(".")[0] != "stiction"
    ]
    assert not bare, bare
