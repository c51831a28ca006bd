#!/usr/bin/env bash
# Refresh constraints.txt, the exact versions scripts/setup.sh installs (`pip install -c
# constraints.txt -e '.[test]'`), from what .venv holds now.
#
#   bash scripts/lock.sh             # write what .venv has (after installing a package by hand)
#   bash scripts/lock.sh --upgrade   # first move .venv to the newest versions pyproject.toml
#                                    # allows, then write them
#
# Then run `bash scripts/test.sh` (and `bash scripts/main.sh` for the window/panel pair) and
# commit constraints.txt with the result: the file is the set CI tested.  The next set-up
# anywhere reinstalls, since its stamp hashes this file.
set -euo pipefail
cd "$(dirname "$0")/.."
if [ ! -x .venv/bin/python ]; then
    echo "error: no .venv; run: bash scripts/setup.sh" >&2
    exit 1
fi
if [ "${1:-}" = --upgrade ]; then
    .venv/bin/python -m pip install -q --upgrade pip
    .venv/bin/python -m pip install -q --upgrade --upgrade-strategy eager -e '.[test]'
elif [ $# -gt 0 ]; then
    echo "error: unknown argument $1 (use --upgrade or nothing)" >&2
    exit 2
fi
py="$(.venv/bin/python -c 'import sys; print("%d.%d" % sys.version_info[:2])')"
{
    echo "# The tested versions: scripts/setup.sh installs with \`pip install -c constraints.txt -e '.[test]'\`."
    echo "# Refresh: bash scripts/lock.sh (what .venv has) or bash scripts/lock.sh --upgrade (newest"
    echo "# that pyproject.toml allows), then run the tests and commit this file.  Python $py, $(uname -m)."
    .venv/bin/python -m pip freeze --exclude-editable --all | grep -v -i -E '^(setuptools|wheel)==' \
        | grep -v -i '^many-light-lab'
} > constraints.txt.new
mv constraints.txt.new constraints.txt
echo "constraints.txt: $(grep -c '==' constraints.txt) pinned packages" >&2
