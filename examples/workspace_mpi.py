"""A coarse workspace map of the paper's arm (Fig. 4), on every MPI rank.

Run: mpiexec -n 2 python examples/workspace_mpi.py
(serially: python examples/workspace_mpi.py)
"""
from mpi4py import MPI

import elastica_petsc as ep

arm = ep.Arm.paper()
# collective over every rank (the default, comm=None, maps in this process alone);
# no file is written unless out= is given
wmap = ep.workspace(arm, spacing_mm=60.0, comm=MPI.COMM_WORLD)
if MPI.COMM_WORLD.rank == 0:
    print(f"{MPI.COMM_WORLD.size} rank(s): {len(wmap.status)} targets, "
          f"{int(wmap.masks['W0'].sum())} in W_0 (reached with P >= 0)")
