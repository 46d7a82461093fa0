#!/usr/bin/env bash
# Set up ./.venv if needed, then run the whole test suite.
source "$(dirname "${BASH_SOURCE[0]}")/env.sh"
cd "$ROOT"
exec "$PYTHON" -m pytest -q "$@"
