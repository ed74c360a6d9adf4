#!/usr/bin/env bash
# Container benchmark (issue 26): the image built from scratch with podman (wall time,
# image size), then rebuilt after an edit of README.md only and after an edit of a
# Python source (medians of REPEATS edits each: the layer order should make both fast),
# then run once as a user would (the default command into a mounted folder owned by a
# non-root user).  Works on a copy of this tree (committed files plus edits, no .git or
# .venv) in a throw-away podman storage under /tmp, so the engine's own images and
# cache are left alone and the first build really starts from the bare base image.
#   bash scripts/benchmarks/bench_container.sh [BASE [REPEATS]]
# BASE (default localhost/debian:12, made by scripts/container-base.sh) must be in
# podman's own storage; builds need no extra flags, runs here need RUN_FLAGS (README
# "Building with podman").
set -euo pipefail
here="$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)"
base="${1:-localhost/debian:12}"; repeats="${2:-3}"
read -r -a run_flags <<< "${RUN_FLAGS:---ulimit nofile=20000:20000 --ulimit nproc=32768:32768}"
work="$(mktemp -d /tmp/elastica-bench-container.XXXXXX)"
pm() { podman --root "$work/storage" --runroot "$work/run" --tmpdir "$work/tmp" "$@"; }
cleanup() { pm rmi -a -f >/dev/null 2>&1 || true; rm -rf "$work"; }
trap cleanup EXIT
now() { date +%s.%N; }
median() { python3 -c 'import statistics, sys; print(f"{statistics.median(map(float, sys.argv[1:])):.1f}")' "$@"; }

mkdir "$work/tree"
(cd "$here" && git ls-files -z --cached --others --exclude-standard | tar --null -T - -c) |
    tar -x -C "$work/tree"
podman save -q -o "$work/base.tar" "$base"
pm load -q -i "$work/base.tar" >/dev/null
rm "$work/base.tar"

build() {  # build the tree; prints the wall time in s; the log in $work/build.log
  local t0; t0="$(now)"
  pm build --build-arg BASE="$base" -t elastica-petsc-bench "$work/tree" > "$work/build.log" 2>&1
  python3 -c "print(f'{$(now) - $t0:.1f}')"
}
echo "uptime: $(uptime)"
echo "scratch build: $(build) s"
echo "image size: $(pm images --format '{{.Size}}' elastica-petsc-bench) ($(pm image inspect --format '{{.Size}}' elastica-petsc-bench) bytes)"
readme=(); python=()
for ((k = 1; k <= repeats; k++)); do
  printf '\n<!-- bench edit %d -->\n' "$k" >> "$work/tree/README.md"
  readme+=("$(build)")
  apt_readme="$(grep -c 'setup: installing Debian packages' "$work/build.log" || true)"
  printf '# bench edit %d\n' "$k" >> "$work/tree/elastica_petsc/core/progress.py"
  python+=("$(build)")
  apt_python="$(grep -c 'setup: installing Debian packages' "$work/build.log" || true)"
done
echo "rebuild after a README.md edit: median $(median "${readme[@]}") s (${readme[*]}; apt runs: $apt_readme)"
echo "rebuild after a Python source edit: median $(median "${python[@]}") s (${python[*]}; apt runs: $apt_python)"

mkdir "$work/results" && chown 1234:1234 "$work/results"
t0="$(now)"
pm run --rm "${run_flags[@]}" --user 1234:1234 -v "$work/results:/results" elastica-petsc-bench \
    > "$work/run.log" 2> "$work/run.err"
echo "run (reproduce --quick as uid 1234): $(python3 -c "print(f'{$(now) - $t0:.1f}')") s," \
     "$(find "$work/results" -type f | wc -l) files, owners $(stat -c %u:%g "$work/results"/* | sort -u | tr '\n' ' ')" \
     "warnings on stderr: $(grep -ci warn "$work/run.err" || true)"
