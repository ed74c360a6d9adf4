"""Issue 6: the reproduction pipeline, the Dockerfile and the README's commands."""
from __future__ import annotations

import json
import os
import re
import shlex
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

pytestmark = pytest.mark.slow          # left out by scripts/test.sh --fast

ROOT = Path(__file__).resolve().parents[1]
SPEC_ITEMS = [  # docs/model.md §6: every reference number appears in REPORT.md
    "(147.1, 472.5)", "(96.2, 454.3)", "(25.2, 10.8)", "(9.7, 12.6)", "over a dozen",
    "< 5", "< 1 s", "4201", "<= 6.5", "<= 18", "<= 40", "~1.8e-3", "138.56 / 40 / 80",
    "a few mm", "would yield and exceed the motor load"]


def test_reproduce_quick_writes_every_promised_file(tmp_path):
    out = tmp_path / "results"
    run = subprocess.run([sys.executable, "-m", "elastica_petsc.cli", "reproduce", "--quick",
                          "--out", str(out)], capture_output=True, text=True, timeout=600)
    assert run.returncode == 0, run.stderr[-3000:]
    report = (out / "REPORT.md").read_text()
    promised = re.findall(r"`([^`]+\.(?:h5|png|csv))`", report.split("## Files")[1])
    for name in ("fig2_gd.png", "fig3a.png", "fig3b.png", "fig4.png", "fig4_restrictions.png",
                 "fig6a.png", "fig6b.png", "fig6c.png", "fig7.png", "fig8.png"):
        assert name in promised
    for name in promised:
        assert (out / name).stat().st_size > 1000, name
    table = [line for line in report.splitlines() if line.startswith("| ") and "---" not in line]
    assert all(line.count("|") >= 7 for line in table)
    for item in SPEC_ITEMS:
        assert item in report, item
    rows = json.loads((out / "report.json").read_text())
    assert len(rows) == len(table) - 1                         # header row
    again = subprocess.run([sys.executable, "-m", "elastica_petsc.cli", "reproduce", "--quick",
                            "--out", str(out)], capture_output=True, text=True, timeout=60)
    assert again.returncode == 2 and "--overwrite" in again.stderr


def dockerfile_instructions() -> list[list[str]]:
    """(instruction, arguments) of the Dockerfile, continuation lines joined."""
    text = (ROOT / "Dockerfile").read_text().replace("\\\n", " ")
    return [line.split(None, 1) for line in text.splitlines()
            if line.strip() and not line.lstrip().startswith("#")]


def test_dockerfile_layers_user_and_pinned_base():
    """No Docker engine here: CI runs the very script the Dockerfile runs
    (scripts/setup.sh via .ci/run -> scripts/test.sh), and this test pins the
    Dockerfile to it so the two cannot drift.  The system packages are a layer of
    their own, before the project is copied (an edit does not re-run apt); only the
    run-time list is installed; the base is pinned by digest with its tag in a
    comment; the image runs as a non-root user with a writable matplotlib folder;
    the default command is the quick reproduction, which refuses to overwrite."""
    text = (ROOT / "Dockerfile").read_text()
    steps = dockerfile_instructions()
    words = [word for word, _ in steps]
    runs = [rest for word, rest in steps if word == "RUN"]
    assert runs[0] == "bash scripts/setup.sh --runtime --system-only"
    assert runs[1].startswith("bash scripts/setup.sh --runtime ")
    for forbidden in ("apt-get", "pip ", "apt ", "VOLUME", "SHELL"):
        assert forbidden not in text, forbidden
    # the base: a digest, and the same tag named in a comment; overridable (ARG BASE) by
    # a local image where no registry is reachable, and every stage starts from it
    assert words[0] == "ARG" and steps[0][1].startswith("BASE="), steps[0]
    base = steps[0][1].removeprefix("BASE=")
    match = re.fullmatch(r"debian:(12\.\d+)@sha256:[0-9a-f]{64}", base)
    assert match, base
    assert f"debian:{match.group(1)}" in text.split("ARG", 1)[0]
    stages = [rest.split() for word, rest in steps if word == "FROM"]
    assert len(stages) == 2 and all(stage[0] == "${BASE}" for stage in stages), stages
    # layer order: only the set-up script and package lists before the packages' RUN
    first_run = words.index("RUN")
    early_copies = [rest.split()[:-1] for word, rest in steps[:first_run] if word == "COPY"]
    assert early_copies and all(src.startswith("scripts/") for c in early_copies for src in c)
    assert all(not src.startswith(("elastica_petsc", ".", "configs"))
               for c in early_copies for src in c)
    project = [k for k, (word, rest) in enumerate(steps)
               if word == "COPY" and rest.startswith("elastica_petsc/")]
    assert len(project) == 1 and project[0] > first_run
    # the build stage's compiler is a cached layer too, installed before the project
    compiler = steps.index(["RUN", "bash scripts/setup.sh --runtime --build --system-only"])
    assert words.index("FROM") < compiler < project[0]
    assert ["scripts/setup.sh", "scripts/pythran-standin.sh"] == early_copies[0][:2]
    # the package layers keep no .deb files or lists (scripts/setup.sh --runtime)
    assert "apt-get clean; $sudo_cmd rm -rf /var/lib/apt/lists/*" in (
        ROOT / "scripts" / "setup.sh").read_text()
    # a non-root user after the last RUN; a matplotlib folder any user can write
    user = [rest for word, rest in steps if word == "USER"]
    assert len(user) == 1 and user[0].split(":")[0] not in ("0", "root")
    assert words.index("USER") > len(words) - 1 - words[::-1].index("RUN")
    assert "MPLCONFIGDIR=/tmp/" in text
    assert "OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1" in text  # --user 0:0
    cmd = [rest for word, rest in steps if word == "CMD"][0]
    assert '"reproduce", "--quick"' in cmd and "--overwrite" not in cmd
    # the packages installed are the run-time list; the dev list holds the compilers
    runtime = (ROOT / "scripts" / "system-packages.txt").read_text()
    assert "petsc-dev" not in runtime and "pytest" not in runtime
    assert "petsc-dev" in (ROOT / "scripts" / "system-packages-dev.txt").read_text()
    assert "bash scripts/setup.sh" in (ROOT / "scripts" / "test.sh").read_text().replace(
        '"$here/scripts/setup.sh"', "scripts/setup.sh")
    assert "scripts/test.sh" in (ROOT / ".ci" / "run").read_text()


def test_container_entry_refuses_an_unmounted_results_folder(tmp_path):
    """Without -v the results would vanish with the container: the entry point
    says so and stops (exit 2) before running anything."""
    entry = ROOT / "scripts" / "container-entry.sh"
    env = dict(os.environ, RESULTS_DIR=str(tmp_path), ELASTICA_PETSC="/bin/echo")
    run = subprocess.run([str(entry), "reproduce", "--quick", "--out", str(tmp_path)],
                         env=env, capture_output=True, text=True)
    assert run.returncode == 2 and "not a mounted folder" in run.stderr
    assert 'mkdir -p results' in run.stderr and '--user "$(id -u):$(id -g)"' in run.stderr
    other = subprocess.run([str(entry), "solve", "--tensions", "1", "1"], env=env,
                           capture_output=True, text=True)
    assert other.returncode == 0 and other.stdout.strip() == "solve --tensions 1 1"


@pytest.mark.skipif(shutil.which("dpkg-deb") is None, reason="not a Debian system")
def test_pythran_standin_is_an_empty_package_that_satisfies_scipy(tmp_path):
    """Debian 12's python3-scipy depends on python3-pythran (and so on g++, python3-dev
    and the Boost headers, about 470 MB) though scipy does not import it; the container's
    run-time layer (setup.sh --runtime) installs an empty package providing it first.
    The stand-in is a valid package with no files and no dependencies, and scipy's
    dependency on pythran is unversioned, so the stand-in satisfies it."""
    deb = tmp_path / "standin.deb"
    subprocess.run(["bash", str(ROOT / "scripts" / "pythran-standin.sh"), str(deb)], check=True)
    fields = subprocess.run(["dpkg-deb", "--field", str(deb)], capture_output=True,
                            text=True, check=True).stdout
    assert "Provides: python3-pythran\n" in fields and "Depends" not in fields, fields
    listing = subprocess.run(["dpkg-deb", "--contents", str(deb)], capture_output=True,
                             text=True, check=True).stdout.split()
    assert listing[-1] == "./" and listing[0] == "drwxr-xr-x", listing
    assert 'scripts/pythran-standin.sh" "$standin"' in (ROOT / "scripts" / "setup.sh").read_text()
    depends = subprocess.run(["dpkg-query", "-W", "-f=${Depends}", "python3-scipy"],
                             capture_output=True, text=True).stdout
    if depends:                                  # scipy is a run-time package of setup.sh
        pythran = [d.strip() for d in depends.split(",") if "python3-pythran" in d]
        assert pythran == ["python3-pythran"], depends


@pytest.mark.skipif(shutil.which("hadolint") is None and not (
    Path(sys.executable).parent / "hadolint").exists(), reason="hadolint not installed")
def test_dockerfile_passes_hadolint():
    exe = shutil.which("hadolint") or str(Path(sys.executable).parent / "hadolint")
    run = subprocess.run([exe, str(ROOT / "Dockerfile")], capture_output=True, text=True)
    assert run.returncode == 0, run.stdout + run.stderr
