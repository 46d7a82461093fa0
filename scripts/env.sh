# Source me: creates a Python 3.11 virtualenv with the pinned requirements, once, and
# re-installs only when the requirements change.
#   make_venv DIR [BPY_VERSION [REQUIREMENTS]]  -> DIR/bin/python ready (bpy pinned to BPY_VERSION
#   if not empty; REQUIREMENTS instead of requirements-dev.txt)
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"

find_python() {
    local py="${ISOPARAM_PYTHON:-python3.11}"
    command -v "$py" >/dev/null 2>&1 || py=python3
    if ! "$py" -c 'import sys; sys.exit(sys.version_info[:2] != (3, 11))'; then
        echo "isoparam needs Python 3.11 (bpy 4.2-5.0 wheels exist only for 3.11); found $("$py" --version)" >&2
        exit 1
    fi
    echo "$py"
}

make_venv() {
    local dir="$1" bpy_version="${2:-}"
    local req="${3:-$ROOT/requirements-dev.txt}"
    local want
    want="$(cat "$req" "$ROOT/requirements-dev.txt" "$ROOT/pyproject.toml"; echo "bpy-override=$bpy_version")"
    want="$(echo "$want" | sha256sum | cut -d' ' -f1)"
    if [ ! -x "$dir/bin/python" ]; then
        "$(find_python)" -m venv "$dir"
    fi
    if [ "$(cat "$dir/.requirements.sha" 2>/dev/null || true)" != "$want" ]; then
        if [ -n "$bpy_version" ]; then
            grep -v '^bpy==' "$req" > "$dir/requirements.txt"
            echo "bpy==$bpy_version" >> "$dir/requirements.txt"
            req="$dir/requirements.txt"
        fi
        "$dir/bin/python" -m pip install --quiet --disable-pip-version-check -r "$req"
        # the project itself, editable: scripts and tests import it wherever they run from
        "$dir/bin/python" -m pip install --quiet --disable-pip-version-check --no-deps --no-build-isolation -e "$ROOT"
        echo "$want" > "$dir/.requirements.sha"
    fi
}

make_venv "$ROOT/.venv"
PYTHON="$ROOT/.venv/bin/python"
