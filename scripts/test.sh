#!/usr/bin/env bash
# Set up ./.venv if needed, then run every part of the checks, each even when an earlier
# one failed, and end with one line naming each part's result (non-zero exit if any failed):
#   lint      ruff check
#   format    ruff format --check
#   types     mypy (settings in pyproject.toml)
#   tests     the whole test suite with bpy 5.0.1 (arguments go to pytest)
#   bpy-X     the Blender tests again with the oldest and a middle supported Blender
#             (bpy 4.2.23 and 4.5.15, each in its own virtualenv); ISOPARAM_COMPAT=0 skips them
source "$(dirname "${BASH_SOURCE[0]}")/env.sh"
cd "$ROOT"
set +e
results=()
failed=0

part() {  # part NAME COMMAND...: run it, remember how it went
    local name="$1"
    shift
    echo "== $name: $*"
    if "$@"; then
        results+=("$name ok")
    else
        results+=("$name FAILED")
        failed=1
    fi
}

part lint "$PYTHON" -m ruff check .
part format "$PYTHON" -m ruff format --check .
part types "$PYTHON" -m mypy
part tests "$PYTHON" -m pytest -q "$@"
if [ "${ISOPARAM_COMPAT:-1}" != "0" ]; then
    for version in 4.2.23 4.5.15; do
        compat() {
            (set -e; make_venv "$ROOT/.venv-bpy-$1" "$1") &&
                "$ROOT/.venv-bpy-$1/bin/python" -m pytest -q -p no:cacheprovider tests/blender
        }
        part "bpy-$version" compat "$version"
    done
fi
summary="$(IFS=,; echo "${results[*]}")"
echo "== test.sh: ${summary//,/, }"
exit "$failed"
