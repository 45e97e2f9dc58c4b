#!/usr/bin/env bash
# The fleet site (`emadiag site`, issue 26 part 5, docs/install.md) in a real browser:
#   1. a small fleet (emadiag history-sim): three tails, two positions on one tail (hostile tail
#      names are refused by the database; their file names: tests/src/cli/hostile_site_file_name_test.cpp);
#   2. emadiag site writes it; the files themselves: well-formed, no script, no URL, the CSP, every
#      link relative and resolving to a file and anchor of the site, the index linking every tail
#      page and each page linking back (site_check.py files);
#   3. headless Chromium loads the index and every tail page from file:// URLs: no console message,
#      and every link of the DOM it built resolves (site_check.py dom); screenshots of the index and
#      of one tail page;
#   4. the same fleet with --full-history-max 6: the tail pages summarise their long sections and link
#      the CSV list of every session (site_check.py files: every list linked, as many sessions as the
#      page says); the browser's DOM of a summarised page and its screenshot;
#   5. writing safely: a second run replaces the site; a folder holding a file the tool did not write
#      is refused and left as it was.
# Usage: site_browser_check.sh [EMADIAG_BINARY [OUT_DIR [SCREENSHOT_DIR]]]
#   (defaults build/src/emadiag, a temp directory; SCREENSHOT_DIR: copies site-index.png,
#   site-tail.png and site-tail-paged.png there). Exits non-zero on any failure.
set -euo pipefail

here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
root="$(cd "$here/../.." && pwd)"
emadiag="${1:-$root/build/src/emadiag}"
out="${2:-$(mktemp -d /tmp/emadiag-site-check.XXXXXX)}"
shots="${3:-}"
mkdir -p "$out"
out="$(cd "$out" && pwd)"
checks="$here/site_check.py"
chromium_bin="${CHROMIUM:-chromium}"
window="1280,1100"
browser_timeout_s=120

[ -x "$emadiag" ] || { echo "site_check: no emadiag binary at $emadiag (build it first)" >&2; exit 2; }
command -v "$chromium_bin" >/dev/null || { echo "site_check: $chromium_bin not found (scripts/setup.sh installs it)" >&2; exit 2; }

failures=0
fail() { echo "FAIL: $*"; failures=$((failures + 1)); }

# browser HTML NAME MODE: NAME.png (screenshot) or NAME.dom.html (dom), and NAME.log (the console).
browser() {
  local html="$1" name="$2" mode="$3" profile rc=0
  profile="$(mktemp -d "$out/profile.XXXXXX")"
  local args=(--headless --disable-gpu --no-sandbox --no-first-run --no-default-browser-check
              --disable-extensions --disable-background-networking --disable-component-update --disable-sync
              --disable-dev-shm-usage --hide-scrollbars --user-data-dir="$profile" --enable-logging=stderr --v=0
              --window-size="$window")
  if [ "$mode" = screenshot ]; then
    timeout "$browser_timeout_s" "$chromium_bin" "${args[@]}" --screenshot="$out/$name.png" "file://$html" >/dev/null 2>"$out/$name.log" || rc=$?
  else
    timeout "$browser_timeout_s" "$chromium_bin" "${args[@]}" --dump-dom "file://$html" >"$out/$name.dom.html" 2>"$out/$name.log" || rc=$?
  fi
  rm -rf "$profile"
  return $rc
}
console_lines() { grep -E 'CONSOLE|Uncaught' "$out/$1.log" || true; }

echo "== site_check: output in $out"
db="$out/fleet.db"
rm -f "$db"
"$emadiag" history-sim --db "$db" --tail N123EM --position LH-ELEV --serial SN-LH-1 --sessions 8 --days-between 30 \
  --cycles 1200 --cycles-per-day 5 --fdj-start 0.08 --fdj-rate-per-100d 0.006 --seed 1 >"$out/history-sim-1.txt"
"$emadiag" history-sim --db "$db" --tail N123EM --position RH-ELEV --serial SN-RH-1 --sessions 8 --days-between 30 \
  --cycles 1200 --cycles-per-day 5 --fdj-start 0.08 --fdj-rate-per-100d 0.001 --seed 2 >"$out/history-sim-2.txt"
"$emadiag" history-sim --db "$db" --tail N456EM --position LH-ELEV --serial SN-LH-9 --sessions 6 --days-between 30 \
  --fdj-start 0.085 --fdj-rate-per-100d 0.01 --seed 3 >"$out/history-sim-3.txt"
"$emadiag" history-sim --db "$db" --tail N78-EM --position LH-AIL --serial SN-A-1 --sessions 5 --days-between 30 \
  --seed 4 >"$out/history-sim-4.txt"

site="$out/site"
rm -rf "$site"
"$emadiag" site --db "$db" --out "$site"
ls -la "$site" "$site/tails"
[ -f "$site/tails/tail-N78-EM.html" ] || fail "the tail N78-EM has no page"
python3 "$checks" files "$site" || fail "the site's files"

tail_page="$site/tails/tail-N123EM.html"
for page in index.html tails/tail-N123EM.html tails/tail-N456EM.html tails/tail-N78-EM.html; do
  name="$(basename "$page" .html)"
  browser "$site/$page" "$name" dom || fail "chromium exited with $? on --dump-dom of $page"
  msgs="$(console_lines "$name")"
  [ -z "$msgs" ] || { fail "the console shows messages for $page:"; echo "$msgs"; }
  python3 "$checks" dom "$site" "$page" "$out/$name.dom.html" || fail "the links of $page in the browser's DOM"
done
browser "$site/index.html" site-index screenshot || fail "chromium exited with $? on the screenshot of the index"
browser "$tail_page" site-tail screenshot || fail "chromium exited with $? on the screenshot of a tail page"
for s in site-index site-tail; do
  [ -s "$out/$s.png" ] || fail "no screenshot $s.png"
  [ -z "$(console_lines "$s")" ] || fail "the console shows messages on the screenshot $s"
done
python3 "$here/report_checks.py" png "$out/site-tail.png" || fail "the tail page's screenshot does not show the plots"

echo "== long histories summarised (--full-history-max 6 --recent-sessions 3 over the same fleet)"
paged="$out/site-paged"
rm -rf "$paged"
"$emadiag" site --db "$db" --out "$paged" --full-history-max 6 --recent-sessions 3 2>"$out/site-paged.txt" || fail "site --full-history-max 6: $(cat "$out/site-paged.txt")"
cat "$out/site-paged.txt"
# N123EM's two positions (8 sessions each) and N456EM's (6: shown whole); a serial with a position's sessions links its list.
[ "$(find "$paged/tails" -name '*.csv' | wc -l)" -eq 2 ] || fail "expected 2 session lists: $(find "$paged/tails" -name '*.csv' | tr '\n' ' ')"
grep -q 'Long history: 8 sessions' "$paged/tails/tail-N123EM.html" || fail "tail-N123EM.html does not say it summarises"
grep -q 'Long history' "$paged/tails/tail-N456EM.html" && fail "tail-N456EM.html (6 sessions) is summarised"
python3 "$checks" files "$paged" || fail "the summarised site's files"
for page in tails/tail-N123EM.html; do
  name="paged-$(basename "$page" .html)"
  browser "$paged/$page" "$name" dom || fail "chromium exited with $? on --dump-dom of the summarised $page"
  msgs="$(console_lines "$name")"
  [ -z "$msgs" ] || { fail "the console shows messages for the summarised $page:"; echo "$msgs"; }
  python3 "$checks" dom "$paged" "$page" "$out/$name.dom.html" || fail "the links of the summarised $page in the browser's DOM"
  grep -q 'class="full-history" href="tail-N123EM.position-1.csv"' "$out/$name.dom.html" || fail "the browser's DOM of $page has no link to its list"
done
browser "$paged/tails/tail-N123EM.html" site-tail-paged screenshot || fail "chromium exited with $? on the screenshot of a summarised tail page"
[ -s "$out/site-tail-paged.png" ] || fail "no screenshot site-tail-paged.png"
python3 "$here/report_checks.py" png "$out/site-tail-paged.png" || fail "the summarised tail page's screenshot does not show the plots"

echo "== writing safely"
before="$(stat -c %i "$site/index.html")"
"$emadiag" site --db "$db" --out "$site" 2>"$out/site-again.txt" || fail "a second run over the same site was refused: $(cat "$out/site-again.txt")"
[ "$(stat -c %i "$site/index.html")" != "$before" ] || fail "the second run did not replace the index"
foreign="$out/foreign"
mkdir -p "$foreign" && echo "keep me" >"$foreign/notes.txt"
if "$emadiag" site --db "$db" --out "$foreign" 2>"$out/site-foreign.txt"; then
  fail "a folder holding a foreign file was written over"
else
  echo "refused: $(cat "$out/site-foreign.txt")"
fi
[ "$(cat "$foreign/notes.txt")" = "keep me" ] && [ ! -e "$foreign/index.html" ] || fail "the refused folder was changed"
ls "$out" | grep -q '\.new-' && fail "a staging folder was left beside the site"

if [ -n "$shots" ]; then
  cp "$out/site-index.png" "$shots/site-index.png"
  cp "$out/site-tail.png" "$shots/site-tail.png"
  cp "$out/site-tail-paged.png" "$shots/site-tail-paged.png"
fi
if [ "$failures" -ne 0 ]; then
  echo "site_check: $failures failure(s); files in $out"
  exit 1
fi
echo "site_check: OK ($(find "$site" -name '*.html' | wc -l) pages, $(du -sb "$site" | cut -f1) bytes; screenshots $out/site-index.png, $out/site-tail.png)"
