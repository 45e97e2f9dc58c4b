#!/usr/bin/env bash
# CI stage "the Debian package" (issue 26, docs/install.md): build the package, install it with apt,
# run the main job's quick steps with the INSTALLED binary and the installed helpers only (nothing
# from the source or build tree), then remove it and check that nothing is left.
#   scripts/package/ci_package.sh [WORK_DIR]     (default: a fresh temporary folder; run as root)
# Steps: build_deb.sh (cpack, lintian) -> apt-get install ./emadiag_*.deb -> from WORK_DIR (with a
# decoy ./models folder that must be ignored): --version, help, the manual page, bash completion,
# simulate, the technician's test run over vcan (/usr/libexec/emadiag/with_vcan.sh, user-mode Linux
# when the kernel has no vcan) which must end SERVICEABLE on the installed models, history-sim,
# report (text and HTML), fleet, site; every stored session names the installed tool's version ->
# apt-get purge -> every file dpkg -L listed is gone. Exits non-zero at the first failure.
set -euo pipefail
root="$(cd "$(dirname "$0")/../.." && pwd)"
work="${1:-$(mktemp -d /tmp/emadiag-package-ci.XXXXXX)}"
mkdir -p "$work"
work="$(cd "$work" && pwd)"
E=/usr/bin/emadiag
LIBEXEC=/usr/libexec/emadiag
step() { echo "== package: $*"; }
fail() { echo "ci_package: FAIL: $*" >&2; exit 1; }

step "build the package"
deb="$("$root/scripts/package/build_deb.sh" | tee "$work/build_deb.log" | tail -n 1)"
grep -v "^$deb\$" "$work/build_deb.log"
[ -f "$deb" ] || fail "no package built"
if dpkg-query -W -f='${Status}' emadiag 2>/dev/null | grep -q "install ok installed"; then
  step "an emadiag package is installed already: purging it first"
  apt-get purge -y -qq emadiag >/dev/null
fi

step "install: apt-get install ./$(basename "$deb")"
cp "$deb" "$work/"
(cd "$work" && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq "./$(basename "$deb")") >"$work/apt-install.log" 2>&1 ||
  { cat "$work/apt-install.log"; fail "apt-get install failed"; }
dpkg -L emadiag | sort >"$work/files.txt"
echo "installed: $(dpkg-query -W -f='${Package} ${Version}, Installed-Size ${Installed-Size} KiB' emadiag); $(wc -l <"$work/files.txt") paths"
echo "Depends: $(dpkg-query -W -f='${Depends}' emadiag)"

# Everything below runs in WORK_DIR, outside the source tree, with the installed files only.
cd "$work"
mkdir -p models
echo '{ "not": "a model" }' >models/case_b_typical.json  # a decoy: ./models must never be read

step "emadiag --version"
"$E" --version | tee version.txt
release="$(head -n 1 version.txt | awk '{print $2}')"
grep -q "^models: *$(dirname "$(dirname "$E")")/share/emadiag/models (installed)" version.txt || fail "--version does not name the installed models"

step "help, manual page, completion"
"$E" help site >help-site.txt
head -n 3 help-site.txt
[ "$(ls /usr/share/man/man1/emadiag*.1.gz | wc -l)" -gt 10 ] || fail "fewer manual pages than commands"
zcat /usr/share/man/man1/emadiag-site.1.gz >emadiag-site.1
grep -q -- '\\-\\-out' emadiag-site.1 || fail "emadiag-site(1) does not document --out"
completions="$(bash -c 'source /usr/share/bash-completion/completions/emadiag; COMP_WORDS=(emadiag tr); COMP_CWORD=1; _emadiag; echo "${COMPREPLY[*]}"')"
[ "$completions" = "train trend" ] || fail "bash completion of 'emadiag tr': '$completions', expected 'train trend'"
values="$(bash -c 'source /usr/share/bash-completion/completions/emadiag; COMP_WORDS=(emadiag fleet --format ""); COMP_CWORD=3; _emadiag; echo "${COMPREPLY[*]}"')"
[ "$values" = "text json csv" ] || fail "bash completion of 'emadiag fleet --format': '$values'"
echo "completion: 'emadiag tr' -> $completions; 'emadiag fleet --format' -> $values"

step "simulate"
"$E" simulate --case B --sequence dyn --out reference_dyn_B.csv
[ -s reference_dyn_B.csv ] || fail "simulate wrote nothing"

step "the technician's test run over vcan (installed with_vcan.sh and test-run-demo.sh)"
rm -rf test-run
"$LIBEXEC/with_vcan.sh" "$work/test-run/uml" "$LIBEXEC/test-run-demo.sh" "$E" "$work/test-run" | tee test-run.log ||
  fail "the installed test run did not end SERVICEABLE"
grep -q "SERVICEABLE" test-run.log || fail "no SERVICEABLE verdict in the test run's output"
model="$(sqlite3 test-run/maintenance.db "SELECT name FROM session_artifacts WHERE role = 'model'")"
echo "the session's model: $model"
case "$model" in /usr/share/emadiag/models/*.json) ;; *) fail "the test run did not use the installed models: '$model'" ;; esac
! grep -q "skipped models/" test-run.log || fail "the test run read the decoy ./models"

step "history-sim, report, trend, fleet"
rm -rf trend && mkdir trend
"$E" history-sim --db trend/maintenance.db --tail N456EM --position LH-ELEV --sessions 6 --days-between 30 \
  --fdj-rate-per-100d 0.004 --fsj-rate-per-100d 0.002 --seed 3
"$E" history-sim --db trend/maintenance.db --tail N789EM --position LH-ELEV --serial 3003 --sessions 6 --days-between 30 \
  --fdj-rate-per-100d 0.002 --fsj-rate-per-100d 0.001 --seed 5
"$E" report --db trend/maintenance.db --tail N456EM --format text >trend/N456EM.txt
head -n 12 trend/N456EM.txt
"$E" report --db trend/maintenance.db --tail N456EM --format html --out trend/N456EM.html
"$E" fleet --db trend/maintenance.db
for db in test-run/maintenance.db trend/maintenance.db; do
  versions="$(sqlite3 "$db" 'SELECT DISTINCT tool_version FROM test_sessions')"
  echo "$db: tool_version $versions"
  echo "$versions" | grep -q "^$release (git " || fail "$db: a session without the installed tool's version: $versions"
done
grep -q "emadiag $release (git " trend/N456EM.html || fail "the HTML report does not name the tool version"

step "site"
"$E" site --db trend/maintenance.db --out site
[ -f site/index.html ] && [ "$(ls site/tails | wc -l)" -eq 2 ] || fail "the site lacks its index or its 2 tail pages"
grep -q 'href="tails/tail-N456EM.html"' site/index.html || fail "the index does not link N456EM's page"
grep -q 'href="../index.html"' site/tails/tail-N456EM.html || fail "N456EM's page does not link back to the index"

step "remove: apt-get purge emadiag"
cd /
DEBIAN_FRONTEND=noninteractive apt-get purge -y -qq emadiag >"$work/apt-purge.log" 2>&1 || { cat "$work/apt-purge.log"; fail "apt-get purge failed"; }
! dpkg-query -W -f='${Status}' emadiag 2>/dev/null | grep -q "installed" || fail "emadiag is still installed"
left=0
while read -r path; do
  # Folders other packages own too (/usr, /usr/bin, /usr/share/man/man1, ...) stay; every file and
  # every folder of emadiag's own must be gone.
  if [ -d "$path" ] && [ ! -L "$path" ]; then
    case "$path" in */emadiag|*/emadiag/*) [ -e "$path" ] && { echo "left: $path/"; left=$((left + 1)); } ;; esac
  elif [ -e "$path" ] || [ -L "$path" ]; then
    echo "left: $path"; left=$((left + 1))
  fi
done <"$work/files.txt"
[ "$left" -eq 0 ] || fail "$left path(s) of the package left after purge"
echo "ci_package: installed, ran (simulate, test run SERVICEABLE over vcan, history-sim, report, fleet, site) and purged $(wc -l <"$work/files.txt") paths, none left; work in $work"
