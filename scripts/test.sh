#!/usr/bin/env bash
# Set up ./.venv if needed, run the whole test suite (bpy 5.0.1), then the Blender tests
# again with the oldest and a middle supported Blender (bpy 4.2.23 and 4.5.15, each in
# its own virtualenv). ISOPARAM_COMPAT=0 skips the second part.
source "$(dirname "${BASH_SOURCE[0]}")/env.sh"
cd "$ROOT"
"$PYTHON" -m pytest -q "$@"
if [ "${ISOPARAM_COMPAT:-1}" != "0" ]; then
    for version in 4.2.23 4.5.15; do
        make_venv "$ROOT/.venv-bpy-$version" "$version"
        echo "== Blender tests with bpy $version"
        "$ROOT/.venv-bpy-$version/bin/python" -m pytest -q -p no:cacheprovider tests/blender
    done
fi
