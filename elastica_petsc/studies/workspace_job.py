"""``python -m elastica_petsc.studies.workspace_job SPEC.json``: one workspace map
(:func:`elastica_petsc.studies.workspace.run_map`) run by every rank of mpiexec.

What :func:`spawn` uses to run a map on K ranks from a serial process (``reproduce
--jobs K`` outside mpiexec) without going through the command line.  The spec
file holds the arm (``arm_to_dict``), the element count and the keyword
arguments of ``run_map``.  Exit status: 0 complete, 2 bad input, 130 interrupted.
"""
from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

from ..core import jsontext
from ..core.errors import InputError


def spawn(arm, elements: int, ranks: int, **kwargs) -> int:
    """Run ``run_map(arm, Discretisation.from_arm(arm, elements), **kwargs)`` under
    ``mpiexec -n ranks``; ``kwargs`` must be JSON values (``out`` a path string).
    Returns the job's exit status."""
    from ..core.config import arm_to_dict

    mpiexec = shutil.which("mpiexec")
    if mpiexec is None:
        raise InputError("--jobs > 1 needs mpiexec on the PATH (package openmpi-bin)")
    env = dict(os.environ, OMPI_MCA_rmaps_base_oversubscribe="1")
    if os.geteuid() == 0:
        env.update(OMPI_ALLOW_RUN_AS_ROOT="1", OMPI_ALLOW_RUN_AS_ROOT_CONFIRM="1")
    with tempfile.TemporaryDirectory() as tmp:
        spec = Path(tmp) / "spec.json"
        spec.write_text(jsontext.dumps({"arm": arm_to_dict(arm), "elements": elements,
                                    "kwargs": kwargs}))
        # our stdout (the job writes nothing else there): on a terminal, rank 0 draws its bar
        return subprocess.run([mpiexec, "-n", str(ranks), sys.executable, "-m", __name__,
                               str(spec)], env=env).returncode


def main(argv: list[str]) -> int:
    import petsc4py
    petsc4py.init(argv[:1])
    from ..core.model import arm_from_dict
    from ..core.fem import Discretisation
    from mpi4py import MPI

    from .workspace import run_map

    spec = json.loads(Path(argv[1]).read_text())
    spec["kwargs"].setdefault("progress", False)      # True: a bar, or lines on stderr
    arm = arm_from_dict(spec["arm"])
    try:
        result = run_map(arm, Discretisation.from_arm(arm, spec["elements"]),
                         comm=MPI.COMM_WORLD, **spec["kwargs"])
    except InputError as err:
        print(f"elastica-petsc: error: {err}", file=sys.stderr)
        return 2
    return 0 if result.complete else 130


if __name__ == "__main__":
    sys.exit(main(sys.argv))
