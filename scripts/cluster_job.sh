#!/bin/bash
# Workspace maps (Fig. 4, 5) on a cluster: an example batch script.
#
# Submit from the repository root (where .venv is) with SLURM:
#     sbatch scripts/cluster_job.sh
# or set the variables below and run it directly on a machine with mpiexec:
#     RANKS=8 bash scripts/cluster_job.sh
#
# What it does
#   * runs `elastica-petsc workspace` under mpiexec on all the job's ranks; every
#     sample is a small problem on one rank (PETSc.COMM_SELF), chunks of samples are
#     handed out dynamically, rank 0 gathers the results and rewrites the HDF5 file
#     atomically every $ELASTICA_PETSC_CHECKPOINT_SECONDS seconds;
#   * always passes --resume: a requeued or resubmitted job (after a time limit, a
#     preemption, a node failure) continues with the chunks not yet done, and a
#     first run (no file yet) simply starts.  --resume refuses a file made with
#     another grid, arm, version or result-changing PETSc option.  The result does
#     not depend on the number of ranks nor on the interruptions;
#   * SLURM sends SIGTERM to the job at its time limit (--signal asks for it a
#     little earlier) and at scancel/preemption: every rank stops at its next
#     sample, rank 0 writes a checkpoint at once (before mpiexec kills the ranks,
#     about 2 s after forwarding the signal), then the last one once the chunks in
#     flight are in, and the command exits with status 130 (interrupted,
#     resumable); the script requeues the job in that case.  A rank killed
#     outright loses at most the chunks finished since the previous checkpoint
#     (every $ELASTICA_PETSC_CHECKPOINT_SECONDS seconds);
#   * a second job on the same output file is refused while the first runs (a
#     lock beside the file), so two submissions cannot overwrite each other.
#
# No `module load`: the Python environment .venv (see scripts/setup.sh) brings
# petsc4py, slepc4py, mpi4py and h5py; mpiexec must be the MPI that mpi4py was
# built with (on Debian, OpenMPI's /usr/bin/mpiexec).  On a cluster whose MPI is
# integrated with SLURM, `srun --kill-on-bad-exit=1 .venv/bin/elastica-petsc ...` works
# the same way (the option ends the job when a rank dies, as mpiexec does).
#
# ---- SLURM header (PBS/Torque: #PBS -l nodes=2:ppn=32, #PBS -l walltime=02:00:00) ----
#SBATCH --job-name=elastica-workspace
#SBATCH --ntasks=64                 # MPI ranks (any number; 1 works too)
#SBATCH --cpus-per-task=1
#SBATCH --time=00:30:00
#SBATCH --signal=TERM@60            # SIGTERM 60 s before the time limit: last checkpoint
#SBATCH --requeue                   # allow `scontrol requeue` below
#SBATCH --open-mode=append          # keep the log of earlier runs of a requeued job
#SBATCH --output=workspace-%j.log

set -u

cd "${SLURM_SUBMIT_DIR:-$(dirname "$0")/..}"

RANKS=${SLURM_NTASKS:-${RANKS:-2}}
OUT=${OUT:-results/workspace.h5}
PLOT=${PLOT:-results/workspace.png}
# The paper's Fig. 4 sampling: 4202 targets in the half-disc y >= 0, 180 elements.
# Every option that defines the grid (mode, spacing, box, chunk, elements, config)
# must stay the same between the runs of a job: --resume refuses another grid.
GRID=(--spacing "${SPACING:-11.67}" --elements "${ELEMENTS:-180}" --chunk 24)
export ELASTICA_PETSC_CHECKPOINT_SECONDS=${ELASTICA_PETSC_CHECKPOINT_SECONDS:-30}
# Open MPI refuses to run as root unless told (containers); harmless otherwise.
# execute_quiet: an input error is one line, without mpiexec's banner about it.
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1 OMPI_MCA_orte_execute_quiet=1

mkdir -p "$(dirname "$OUT")"
[ -e "$OUT" ] && echo "resuming $OUT"

# --resume continues the chunks not yet done (or starts); --plot is drawn when the
# map is complete; --overwrite replaces an old plot.
mpiexec -n "$RANKS" .venv/bin/elastica-petsc workspace "${GRID[@]}" \
    --out "$OUT" --resume --plot "$PLOT" --overwrite --json > "${OUT%.h5}.json"
status=$?

case $status in
    0)   echo "done: $OUT, $PLOT, ${OUT%.h5}.json" ;;
    2)   echo "bad input (see the error above); not requeued" >&2 ;;
    *)   # 130 (interrupted; Open MPI's mpiexec may report 1 or 143 instead) or a lost rank:
         # the file holds every chunk finished up to the last checkpoint
         echo "interrupted (exit status $status); $OUT is resumable" >&2
         if [ -n "${SLURM_JOB_ID:-}" ] && [ "${SLURM_RESTART_COUNT:-0}" -lt "${MAX_REQUEUE:-10}" ]; then
             scontrol requeue "$SLURM_JOB_ID"
         fi ;;
esac
exit $status
