"""The documentation's promises that a build cannot see: every module of the package has its
API reference page, and the README stays a front door."""

import pkgutil
import re
from pathlib import Path

import catenary

ROOT = Path(__file__).resolve().parents[1]


def test_every_module_is_in_the_api_reference():
    # `make docs` renders the pages it is given; a module missing from docs/api/ would simply be
    # absent from the site.
    listed = set()
    for page in (ROOT / "docs" / "api").glob("*.md"):
        listed |= set(re.findall(r"^::: (catenary[\w.]*)$", page.read_text(), flags=re.M))
    modules = {m.name for m in pkgutil.walk_packages(catenary.__path__, "catenary.")}
    assert modules - listed == set(), "modules without an API page: add them to docs/api/"
    assert listed - modules == set(), "API pages name modules that do not exist"


def test_the_readme_is_a_front_door_whose_links_resolve():
    # ≤ 250 lines (issue [15]); every relative link points to a file of the repository.
    text = (ROOT / "README.md").read_text()
    assert len(text.splitlines()) <= 250
    for target in re.findall(r"\]\(([^)#]+)\)", text):
        if "://" not in target:
            assert (ROOT / target).exists(), target


def test_a_long_module_says_why_it_is_one_concern():
    # Issue [15]: no module over 500 lines unless its docstring says why it is one concern.
    for path in (ROOT / "catenary").rglob("*.py"):
        text = path.read_text()
        if len(text.splitlines()) > 500:
            docstring = text.split('"""')[1] if text.lstrip().startswith('"""') else ""
            assert "one concern" in docstring, f"{path.relative_to(ROOT)}: over 500 lines"
