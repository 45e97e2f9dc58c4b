#!/usr/bin/env bash
# The HTML maintenance report in a real browser (docs/report-html.md, issue 11 part 4):
#   1. a simulated maintenance history (emadiag history-sim) into a fresh database, then
#      emadiag trend --format html --out report.html;
#   2. the file itself: well-formed, no script, no URL, the CSP, 4 inline SVG plots (report_checks.py html);
#   3. headless Chromium loads it from a file:// URL: its console shows nothing (no error, no CSP
#      violation, no failed load: the report runs no script, so any console message is a fault), the
#      DOM it built holds the 4 plots, and its screenshot shows them (report_checks.py png);
#   4. controls, so the checks are known to bite in this browser: the same report with a script and
#      an external image added must fail the console check, and with its plots removed the screenshot
#      check.
# Usage: browser_check.sh [EMADIAG_BINARY [OUT_DIR]]   (defaults build/src/emadiag, a temp directory)
# Leaves report.html, screenshot.png and the browser logs in OUT_DIR; exits non-zero on any failure.
set -euo pipefail

here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
root="$(cd "$here/../.." && pwd)"
emadiag="${1:-$root/build/src/emadiag}"
out="${2:-$(mktemp -d /tmp/emadiag-browser-check.XXXXXX)}"
mkdir -p "$out"
out="$(cd "$out" && pwd)"
checks="$here/report_checks.py"
chromium_bin="${CHROMIUM:-chromium}"
# The window the screenshot shows: wide enough for two plots side by side, tall enough for all four.
window="1280,1700"
browser_timeout_s=120

[ -x "$emadiag" ] || { echo "browser_check: no emadiag binary at $emadiag (build it first)" >&2; exit 2; }
command -v "$chromium_bin" >/dev/null || { echo "browser_check: $chromium_bin not found (scripts/setup.sh installs it)" >&2; exit 2; }
command -v python3 >/dev/null || { echo "browser_check: python3 not found" >&2; exit 2; }

failures=0
fail() { echo "FAIL: $*"; failures=$((failures + 1)); }

# Runs headless Chromium on an HTML file: `browser HTML NAME MODE` with MODE screenshot or dom.
# Writes NAME.png (screenshot) or NAME.dom.html (dom), and NAME.log (stderr with the console).
browser() {
  local html="$1" name="$2" mode="$3" profile
  profile="$(mktemp -d "$out/profile.XXXXXX")"
  local args=(--headless --disable-gpu --no-sandbox --no-first-run --no-default-browser-check
              --disable-extensions --disable-background-networking --disable-component-update --disable-sync
              --disable-dev-shm-usage
              --hide-scrollbars --user-data-dir="$profile" --enable-logging=stderr --v=0
              --window-size="$window")
  local rc=0
  if [ "$mode" = screenshot ]; then
    rm -f "$out/$name.png"
    timeout "$browser_timeout_s" "$chromium_bin" "${args[@]}" --screenshot="$out/$name.png" "file://$html" \
      >/dev/null 2>"$out/$name.log" || rc=$?
  else
    timeout "$browser_timeout_s" "$chromium_bin" "${args[@]}" --dump-dom "file://$html" \
      >"$out/$name.dom.html" 2>"$out/$name.log" || rc=$?
  fi
  rm -rf "$profile"
  return $rc
}

# Console messages Chromium logged for the page (with --enable-logging=stderr every console message,
# CSP violation and uncaught exception is a line with "CONSOLE").
console_lines() { grep -E 'CONSOLE|Uncaught' "$out/$1.log" || true; }

echo "== browser_check: output in $out"
db="$out/maintenance.db"
rm -f "$db"
"$emadiag" history-sim --db "$db" --tail N123EM --sessions 8 --days-between 30 \
  --fdj-start 0.08 --fdj-rate-per-100d 0.004 --seed 1 >"$out/history-sim.txt"
"$emadiag" trend --db "$db" --tail N123EM --format html --out "$out/report.html"
echo "report: $(wc -c <"$out/report.html") bytes"

echo "== the file"
python3 "$checks" html "$out/report.html" --plots 4 || fail "report.html static checks"

echo "== Chromium: $("$chromium_bin" --version 2>/dev/null | tail -1)"
browser "$out/report.html" report screenshot || fail "chromium exited with $? on the screenshot"
[ -s "$out/report.png" ] || fail "no screenshot written"
msgs="$(console_lines report)"
if [ -n "$msgs" ]; then
  fail "the console shows messages:"
  echo "$msgs"
else
  echo "console: no messages"
fi
[ -s "$out/report.png" ] && { python3 "$checks" png "$out/report.png" || fail "screenshot does not show the plots"; }

browser "$out/report.html" report dom || fail "chromium exited with $? on --dump-dom"
svgs=$(grep -o '<svg' "$out/report.dom.html" | wc -l)
circles=$(grep -o '<circle' "$out/report.dom.html" | wc -l)
echo "dom: $svgs svg elements, $circles circles"
[ "$svgs" -eq 4 ] || fail "the DOM holds $svgs svg elements, expected 4"
[ "$(console_lines report)" = "" ] || fail "the console shows messages on --dump-dom"

echo "== controls (each must be caught)"
sed 's|</body>|<img src="https://example.invalid/x.png"/><script>console.error("control")</script></body>|' \
  "$out/report.html" >"$out/control-script.html"
browser "$out/control-script.html" control-script screenshot || true
if [ -n "$(console_lines control-script)" ]; then
  echo "control with a script and an external image: console check caught $(console_lines control-script | wc -l) message(s)"
else
  fail "control with a script and an external image: the console check saw nothing"
fi
python3 - "$out/report.html" "$out/control-noplots.html" <<'EOF'
import re, sys
text = open(sys.argv[1], encoding="utf-8").read()
open(sys.argv[2], "w", encoding="utf-8").write(re.sub(r"<svg.*?</svg>", "", text, flags=re.S))
EOF
browser "$out/control-noplots.html" control-noplots screenshot || true
if python3 "$checks" png "$out/control-noplots.png" >"$out/control-noplots.check" 2>&1; then
  fail "control without plots: the screenshot check passed it"
else
  echo "control without plots: screenshot check failed it ($(grep -c FAIL "$out/control-noplots.check") problems)"
fi

if [ "$failures" -ne 0 ]; then
  echo "browser_check: $failures failure(s); files in $out"
  exit 1
fi
echo "browser_check: OK (report $(wc -c <"$out/report.html") bytes, screenshot $out/report.png)"
