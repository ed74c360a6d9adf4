#!/bin/sh
# The container's entry point: elastica-petsc, after checking that the results folder
# (RESULTS_DIR, default /results) is a mounted, writable folder whenever the command
# writes there: otherwise the results would vanish with the container.
results="${RESULTS_DIR:-/results}"
case " $* " in
  *" $results "*|*" $results/"*)
    if ! mountpoint -q "$results"; then
      echo "elastica-petsc: error: $results is not a mounted folder, so the results would be lost" \
           "with the container; run: mkdir -p results && docker run --rm" \
           "--user \"\$(id -u):\$(id -g)\" -v \"\$PWD/results:$results\" elastica-petsc" >&2
      exit 2
    fi
    if [ ! -w "$results" ]; then
      echo "elastica-petsc: error: user $(id -u) cannot write to $results; run the container" \
           "with --user \"\$(id -u):\$(id -g)\" (the owner of the mounted folder)" >&2
      exit 2
    fi
    ;;
esac
exec "${ELASTICA_PETSC:-/opt/elastica_petsc/.venv/bin/elastica-petsc}" "$@"
