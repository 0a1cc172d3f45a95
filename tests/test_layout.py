"""The docs' layout table names every module, so that it cannot drift from the tree."""

from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
PACKAGES = ("sim", "ident", "detect", "bridge", "agent", "trainer", "schemas", "bench", "stiction")


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
