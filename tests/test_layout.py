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


def test_imports_point_one_way():
    wrong = []
    for package in PACKAGES:
        for p in sorted((ROOT / package).rglob("*.py")):
            for module in _imports(p):
                top = module.split(".")[0]
                if top not in LAYER or top == package:
                    continue
                same = LAYER[top] == LAYER[package] and (package, top) != ("sim", "bridge")
                upward = LAYER[top] > LAYER[package] or same
                if upward:
                    wrong.append(f"{p.relative_to(ROOT)} imports {module}")
    assert not wrong, wrong
