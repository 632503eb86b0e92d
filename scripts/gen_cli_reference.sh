#!/usr/bin/env bash
# Regenerates docs/cli.md from the built binary's --help (every command and subcommand).
# The CTest docs.reference fails until the page is regenerated after a flag changes.
#   scripts/gen_cli_reference.sh [BINARY]     (default: build/socketsmith)
set -euo pipefail
cd "$(dirname "$0")/.."
BIN=${1:-build/socketsmith}
python3 tests/docs/reference_docs.py "$BIN" write-cli docs/cli.md
echo "wrote docs/cli.md from $BIN"
