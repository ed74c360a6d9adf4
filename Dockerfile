# elastica_petsc: reproduce Handral & Rangarajan (2019) in a container.
#   docker build -t elastica-petsc .
#   docker run --rm -v "$PWD/results:/results" elastica-petsc
# The image is set up by the same script as a Debian 12 machine (scripts/setup.sh,
# system packages listed once in scripts/system-packages.txt).
FROM debian:12
SHELL ["/bin/bash", "-o", "pipefail", "-c"]
WORKDIR /opt/elastica_petsc
COPY . .
RUN bash scripts/setup.sh
ENV OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1 OMPI_MCA_rmaps_base_oversubscribe=1
VOLUME ["/results"]
ENTRYPOINT ["/opt/elastica_petsc/.venv/bin/elastica-petsc"]
CMD ["reproduce", "--out", "/results", "--overwrite"]
