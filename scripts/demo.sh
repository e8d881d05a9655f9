#!/usr/bin/env bash
# make demo: the default scenario end to end.
set -euo pipefail
cd "$(dirname "$0")/.."
.venv/bin/emla --version
