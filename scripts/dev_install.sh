#!/usr/bin/env bash
# Rebuild and reinstall the package into .venv (serialized: several developers may run it).
set -euo pipefail
cd "$(dirname "$0")/.."
exec flock /tmp/vibrofriction-install.lock .venv/bin/pip install --no-build-isolation -q . "$@"
