#!/usr/bin/env bash
# Set up ./.venv if needed, then build the extension zips into dist/ (arguments go to
# scripts/build_extension.py, e.g. --platforms linux-x64):
#   bash scripts/build.sh --platforms linux-x64      # dist/isoparam-<version>-linux_x64.zip
source "$(dirname "${BASH_SOURCE[0]}")/env.sh"
cd "$ROOT"
exec "$PYTHON" scripts/build_extension.py "$@"
