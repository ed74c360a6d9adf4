# elastica_petsc: reproduce Handral & Rangarajan (2019) in a container.
#   docker build -t elastica-petsc .
#   mkdir -p results
#   docker run --rm --user "$(id -u):$(id -g)" -v "$PWD/results:/results" elastica-petsc
# The image is set up by the same script as a Debian 12 machine (scripts/setup.sh
# --runtime: the run-time packages of scripts/system-packages.txt).  Two stages: the
# first also installs the compiler (--build, scripts/system-packages-build.txt) and
# builds the project with its compiled kernels; the image copies the built project
# onto the run-time packages alone, so it holds no compiler.
#
# Base: debian:12.11 (bookworm), pinned by the digest of its multi-arch index
# (tag debian:12.11; to move to a newer point release, change the tag and digest together).
# BASE may be overridden with a local Debian 12 image where no registry is reachable
# (--build-arg BASE=localhost/debian:12; README "Building with podman").
ARG BASE=debian:12.11@sha256:b6507e340c43553136f5078284c8c68d86ec8262b1724dde73c325e8d3dcdeba
FROM ${BASE} AS build
WORKDIR /opt/elastica_petsc
# 1. Debian packages: this layer is rebuilt only when the package lists or the set-up
#    script change, not when the project's sources or README do.
COPY scripts/setup.sh scripts/pythran-standin.sh scripts/system-packages.txt scripts/system-packages-dev.txt \
     scripts/system-packages-build.txt scripts/
RUN bash scripts/setup.sh --runtime --system-only
# 2. The build stage: the compiler (a cached layer too), then the project (the only
#    layers an edit rebuilds), its kernels compiled by the editable install.  A RUN of
#    its own: the layer above is the one the image's stage reuses from the cache.
# hadolint ignore=DL3059
RUN bash scripts/setup.sh --runtime --build --system-only
COPY pyproject.toml setup.py README.md LICENSE ./
COPY configs/ configs/
COPY elastica_petsc/ elastica_petsc/
COPY scripts/container-entry.sh scripts/
RUN bash scripts/setup.sh --runtime --build \
    && .venv/bin/python -m compileall -q elastica_petsc \
    && rm -rf build

# 3. The image: the same run-time packages (the cached layer of step 1), the built
#    project (venv, sources, compiled kernels) from the build stage, no compiler.
FROM ${BASE}
WORKDIR /opt/elastica_petsc
COPY scripts/setup.sh scripts/pythran-standin.sh scripts/system-packages.txt scripts/system-packages-dev.txt \
     scripts/system-packages-build.txt scripts/
RUN bash scripts/setup.sh --runtime --system-only
COPY --from=build /opt/elastica_petsc /opt/elastica_petsc
RUN useradd --uid 1000 --user-group --no-create-home --shell /usr/sbin/nologin elastica
# Any user (docker run --user "$(id -u):$(id -g)") can write matplotlib's cache and a home;
# mpiexec runs as that user, root included (a host user root maps to root here).
ENV MPLCONFIGDIR=/tmp/matplotlib HOME=/tmp OMPI_MCA_rmaps_base_oversubscribe=1 \
    OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1
USER 1000:1000
WORKDIR /results
# elastica-petsc, after refusing a /results that is not a mounted, writable folder
ENTRYPOINT ["/opt/elastica_petsc/scripts/container-entry.sh"]
# The quick reproduction into the mounted folder; it refuses to replace an earlier run's
# files (add --overwrite to the command line to allow it).
CMD ["reproduce", "--quick", "--out", "/results"]
