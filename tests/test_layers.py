"""The package's layers (docs/layout.md): import-linter's contracts in pyproject.toml hold on the
tree, and they are not a test that cannot fail — an import planted upwards breaks them."""

import shutil
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
LAYERS = {"report", "stages", "measurement", "physics", "plumbing"}


def lint_imports(tree: Path) -> subprocess.CompletedProcess:
    """import-linter on the package under ``tree`` with the repository's contracts."""
    lint = Path(sys.executable).with_name("lint-imports")
    return subprocess.run([str(lint), "--config", str(ROOT / "pyproject.toml"), "--no-cache"], cwd=tree,
                          env={"PYTHONPATH": str(tree), "PATH": "/usr/bin:/bin"}, capture_output=True, text=True,
                          timeout=300)


def test_the_tree_is_its_layers():
    # Every module of catenary stands in a layer: nothing at the package's root but its face.
    children = {p.name for p in (ROOT / "catenary").iterdir() if p.name != "__pycache__"}
    assert children == LAYERS | {"__init__.py", "schemas"}


def test_the_contracts_hold():
    out = lint_imports(ROOT)
    assert out.returncode == 0, out.stdout + out.stderr
    assert "2 kept, 0 broken" in out.stdout


@pytest.mark.parametrize("module, planted, contract", [
    # the physics reading a stage: the layers contract
    ("physics/static.py", "from catenary.stages.identification import fit", "layers:"),
    # a measurement reading the report
    ("measurement/projection.py", "import catenary.report.front_page", "layers:"),
    # the identification reading the diagnosis that stands on it: the stages contract
    ("stages/identification/fit.py", "from catenary.stages.diagnosis import settings", "stages:"),
    # two stages of one level
    ("stages/inversion.py", "from catenary.stages.correction import settings", "stages:"),
])
def test_a_planted_upward_import_breaks_a_contract(tmp_path, module, planted, contract):
    shutil.copytree(ROOT / "catenary", tmp_path / "catenary", ignore=shutil.ignore_patterns("__pycache__"))
    path = tmp_path / "catenary" / module
    path.write_text(path.read_text() + f"\n{planted}  # planted\n")
    out = lint_imports(tmp_path)
    assert out.returncode != 0
    broken = [line for line in out.stdout.splitlines() if line.endswith("BROKEN")]
    # a planted import may break the other contract too (through a chain of imports): the one
    # it runs against must be among the broken
    assert any(line.startswith(contract) for line in broken), out.stdout


def test_the_contributors_map_lists_every_module():
    # docs/layout.md's listing by layer names every module and subpackage of the tree.
    text = (ROOT / "docs" / "layout.md").read_text()
    missing = []
    for layer in sorted(LAYERS):
        for path in sorted((ROOT / "catenary" / layer).iterdir()):
            if path.name in ("__init__.py", "__pycache__"):
                continue
            name = f"{path.name}/" if path.is_dir() else path.name
            if f"`{name}`" not in text and f"`{name}," not in text and f", `{name}`" not in text:
                missing.append(f"{layer}/{name}")
    assert not missing, f"docs/layout.md does not list {missing}"
