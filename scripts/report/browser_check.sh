#!/usr/bin/env bash
# The HTML maintenance report in a real browser (docs/report-html.md, issue 11 part 4):
#   1. simulated maintenance histories (emadiag history-sim) into fresh databases, then two reports:
#      trend.html (emadiag trend --format html: one tail, 4 plots) and report.html (emadiag report
#      --format html: two positions with flight cycles, a serial swapped at one of them (3 serials), the
#      technician's name holding markup that must come out escaped: 5 sections of 4 plots);
#   2. each file itself: well-formed, no script, no URL, the CSP, its inline SVG plots (report_checks.py html);
#   3. headless Chromium loads it from a file:// URL: its console shows nothing (no error, no CSP
#      violation, no failed load: the report runs no script, so any console message is a fault), the
#      DOM it built holds the plots, and its screenshot shows them (report_checks.py png);
#   4. controls, so the checks are known to bite in this browser: report.html with a script and
#      an external image added must fail the console check, and with its plots removed the screenshot
#      check.
# Usage: browser_check.sh [EMADIAG_BINARY [OUT_DIR]]   (defaults build/src/emadiag, a temp directory)
# Leaves trend.html, report.html, their screenshots (.png) and the browser logs in OUT_DIR; exits
# non-zero on any failure.
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
echo "== Chromium: $("$chromium_bin" --version 2>/dev/null | tail -1)"

# check_report NAME PLOTS: the static checks, the screenshot with its console and the DOM of NAME.html.
check_report() {
  local name="$1" plots="$2"
  echo "== $name.html: $(wc -c <"$out/$name.html") bytes"
  python3 "$checks" html "$out/$name.html" --plots "$plots" || fail "$name.html static checks"
  browser "$out/$name.html" "$name" screenshot || fail "chromium exited with $? on the screenshot of $name.html"
  [ -s "$out/$name.png" ] || fail "no screenshot of $name.html written"
  local msgs
  msgs="$(console_lines "$name")"
  if [ -n "$msgs" ]; then
    fail "the console shows messages for $name.html:"
    echo "$msgs"
  else
    echo "console: no messages"
  fi
  [ -s "$out/$name.png" ] && { python3 "$checks" png "$out/$name.png" || fail "the screenshot of $name.html does not show the plots"; }
  browser "$out/$name.html" "$name" dom || fail "chromium exited with $? on --dump-dom of $name.html"
  local svgs circles
  svgs=$(grep -o '<svg' "$out/$name.dom.html" | wc -l)
  circles=$(grep -o '<circle' "$out/$name.dom.html" | wc -l)
  echo "dom: $svgs svg elements, $circles circles"
  [ "$svgs" -eq "$plots" ] || fail "the DOM of $name.html holds $svgs svg elements, expected $plots"
  [ "$(console_lines "$name")" = "" ] || fail "the console shows messages on --dump-dom of $name.html"
}

# 1. trend: one tail, no positions.
db="$out/trend.db"
rm -f "$db"
"$emadiag" history-sim --db "$db" --tail N123EM --sessions 8 --days-between 30 \
  --fdj-start 0.08 --fdj-rate-per-100d 0.004 --seed 1 >"$out/history-sim-trend.txt"
"$emadiag" trend --db "$db" --tail N123EM --format html --out "$out/trend.html"
check_report trend 4

# 2. report: LH-ELEV wearing towards its limit with its serial swapped after 6 sessions, RH-ELEV
# healthy; cycles on every session; a technician name with markup (stored as given, shown escaped).
db="$out/report.db"
rm -f "$db"
evil='<b>Jo & "Mo"</b>'
"$emadiag" history-sim --db "$db" --tail N123EM --position LH-ELEV --serial SN-LH-1 --sessions 6 --days-between 30 \
  --cycles 1200 --cycles-per-day 5 --technician "$evil" --certificate B1-4711 \
  --fdj-start 0.08 --fdj-rate-per-100d 0.006 --seed 1 >"$out/history-sim-report-1.txt"
"$emadiag" history-sim --db "$db" --tail N123EM --position LH-ELEV --serial SN-LH-2 --sessions 6 --days-between 30 \
  --start-utc 2026-07-01T08:00:00Z --cycles 2100 --cycles-per-day 5 --technician "$evil" --certificate B1-4711 \
  --fdj-start 0.085 --fdj-rate-per-100d 0.005 --seed 2 >"$out/history-sim-report-2.txt"
"$emadiag" history-sim --db "$db" --tail N123EM --position RH-ELEV --serial SN-RH-1 --sessions 8 --days-between 30 \
  --cycles 1200 --cycles-per-day 5 --fdj-start 0.08 --fdj-rate-per-100d 0.001 --seed 3 >"$out/history-sim-report-3.txt"
"$emadiag" report --db "$db" --tail N123EM --format html --out "$out/report.html"
check_report report 20
if grep -qF '<b>Jo' "$out/report.html"; then
  fail "report.html holds the stored technician name unescaped"
elif grep -qF '&lt;b&gt;Jo &amp; &quot;Mo&quot;&lt;/b&gt;' "$out/report.html"; then
  echo "stored markup: shown escaped"
else
  fail "report.html does not show the stored technician name"
fi

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
echo "browser_check: OK (trend.html $(wc -c <"$out/trend.html") bytes, report.html $(wc -c <"$out/report.html") bytes; screenshots $out/trend.png, $out/report.png)"
