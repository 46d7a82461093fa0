#!/usr/bin/env bash
# Set up ./.venv if needed, then run the demo on the embedded example meshes.
source "$(dirname "${BASH_SOURCE[0]}")/env.sh"
cd "$ROOT"
exec "$PYTHON" scripts/demo.py "$@"
