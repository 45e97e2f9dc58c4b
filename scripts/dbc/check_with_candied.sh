#!/usr/bin/env bash
# Third-party check of the ICD: parses can_dbc/ema.dbc with candied, an independent DBC library
# from the npm registry, and lists every message and signal as it understood them.
# Not part of CI (it needs the npm registry); run it after changing ema.dbc.
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
command -v npm >/dev/null || { echo "check_with_candied: npm is not installed (Debian package npm)" >&2; exit 2; }
(cd "$work" && npm install --silent --no-audit --no-fund candied@2.2.0 >/dev/null)
cp "$here/candied_check.cjs" "$work/"
cd "$work" && node candied_check.cjs "$here/../../can_dbc/ema.dbc"
