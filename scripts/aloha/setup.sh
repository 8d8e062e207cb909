#!/usr/bin/env bash
# Makes the recorder's own venv (default <repo root>/.venv-aloha, ignored by git; or the path
# in ALOHA_VENV) with the pinned packages of requirements.txt, then gym-aloha 0.1.5 without
# its dependencies (its pins ask for MuJoCo 3, under which the scripted tasks fail).
set -euo pipefail
here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
root="$(cd "$here/../.." && pwd)"
venv="${ALOHA_VENV:-$root/.venv-aloha}"
if [ ! -x "$venv/bin/python" ]; then
    python3 -m venv "$venv"
fi
"$venv/bin/python" -m pip install --quiet --disable-pip-version-check -r "$here/requirements.txt"
"$venv/bin/python" -m pip install --quiet --disable-pip-version-check --no-deps gym-aloha==0.1.5
echo "ALOHA recorder venv ready: $venv/bin/python $here/record.py --help"
