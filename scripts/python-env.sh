#!/usr/bin/env bash
# Create (if missing) the repository's Python virtual environment in .venv and install
# python/requirements.txt into it. Idempotent: when every pinned requirement is already
# installed it returns without touching pip's index. Prints the venv's python path on stdout.
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
venv="$root/.venv"
req="$root/python/requirements.txt"
py="$venv/bin/python"
if [ ! -x "$py" ]; then
    python3 -m venv "$venv" >&2
fi
stamp="$venv/.requirements.sha256"
want="$(sha256sum "$req" | cut -d' ' -f1)"
if [ ! -f "$stamp" ] || [ "$(cat "$stamp")" != "$want" ]; then
    "$py" -m pip install --quiet --disable-pip-version-check -r "$req" >&2
    echo "$want" > "$stamp"
fi
echo "$py"
