#!/usr/bin/env bash
# Run a benchmark script in the benchmark environment (./.venv-bench: the tests'
# requirements plus libigl and xatlas, requirements-bench.txt), made once:
#   bash scripts/bench.sh scripts/real_meshes.py --meshes spot homer
source "$(dirname "${BASH_SOURCE[0]}")/env.sh"
cd "$ROOT"
make_venv "$ROOT/.venv-bench" "" "$ROOT/requirements-bench.txt"
exec "$ROOT/.venv-bench/bin/python" "$@"
