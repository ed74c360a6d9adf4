"""What a user installing the package gets: a LICENSE matching pyproject, the
configs in the wheel, a complete ``test`` extra, and the README's first screen
saying what the model covers."""
from __future__ import annotations

import shutil
import subprocess
import sys
import tomllib
import zipfile
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


def pyproject() -> dict:
    return tomllib.loads((ROOT / "pyproject.toml").read_text())


def test_license_file_matches_pyproject():
    project = pyproject()["project"]
    assert project["license"] == {"text": "MIT"}
    assert (ROOT / "LICENSE").read_text().startswith("MIT License")
    assert "License :: OSI Approved :: MIT License" in project["classifiers"]
    assert project["urls"]


def test_test_extra_has_what_the_test_script_uses():
    extra = pyproject()["project"]["optional-dependencies"]["test"]
    assert "pytest" in extra and "pytest-xdist" in extra
    assert " -n auto" in (ROOT / "scripts" / "test.sh").read_text()


@pytest.mark.slow
def test_every_config_is_shipped_in_the_wheel(tmp_path):
    shipped = {p.name: p.read_bytes() for p in (ROOT / "elastica_petsc" / "configs").glob("*.toml")}
    for path in (ROOT / "configs").glob("*.toml"):
        assert shipped.get(path.name) == path.read_bytes(), \
            f"configs/{path.name} differs from elastica_petsc/configs/{path.name}"
    src = tmp_path / "src"          # a copy: building in the worktree would leave build/ there
    src.mkdir()
    for name in ("pyproject.toml", "setup.py", "README.md", "LICENSE"):
        shutil.copy(ROOT / name, src / name)
    shutil.copytree(ROOT / "elastica_petsc", src / "elastica_petsc",
                    ignore=shutil.ignore_patterns("__pycache__", "*.so"))
    subprocess.run([sys.executable, "-m", "pip", "wheel", "--no-deps", "--no-build-isolation",
                    "-q", "-w", str(tmp_path / "dist"), str(src)], check=True)
    wheel, = (tmp_path / "dist").glob("*.whl")
    names = zipfile.ZipFile(wheel).namelist()
    for name in shipped:
        assert f"elastica_petsc/configs/{name}" in names
    assert any(n.endswith("dist-info/LICENSE") for n in names)
    assert "elastica_petsc/schema/output.schema.json" in names     # docs/json.md
    # the compiled kernels (docs/model.md §20), built from their C source
    assert any(n.startswith("elastica_petsc/core/fem_kernels") and n.endswith(".so")
               for n in names)


def test_readme_says_what_the_model_covers_on_its_first_screen():
    first_screen = "\n".join((ROOT / "README.md").read_text().splitlines()[:30])
    assert "What the model covers" in first_screen
    for words in ("planar", "straight", "friction", "gravity"):
        assert words in first_screen


def test_every_subpackage_is_listed_for_the_wheel():
    """setuptools ships only the packages pyproject.toml lists: every folder of the
    package with an ``__init__.py`` must be among them."""
    listed = set(pyproject()["tool"]["setuptools"]["packages"])
    found = {".".join(p.parent.relative_to(ROOT).parts)
             for p in (ROOT / "elastica_petsc").rglob("__init__.py")}
    assert found - listed == set()
