#!/usr/bin/env bash
# ASan + UBSan vcan job (issue 12 part 5): the vcan suite (ctest label `vcan`) of the sanitizer
# build, once, on a real vcan0. User-mode Linux cannot run an ASan binary (its 512 GB address space
# does not hold ASan's fixed shadow layout), so where the host has no vcan this runs inside a QEMU
# VM (scripts/vcan/with_vcan_vm.sh, through run_vcan_tests.sh with EMADIAG_VCAN_VM=qemu).
#   scripts/sanitize/run_asan_vcan.sh
# Builds only what the suite runs in build-asan (scripts/build.sh asan emadiag vcan_session_test;
# EMADIAG_ASAN_VCAN_BUILD=0: use build-asan as it is). Every sanitizer report of every process
# (the test binary, and each emadiag ema-sim / record / test-run it starts) goes to a file of its
# own in build-asan/asan-vcan-reports/ (log_path), so none is lost in a child's stderr; the job
# prints them and fails if there is any, or if a test fails.
# Environment: as run_vcan_tests.sh and with_vcan_vm.sh (EMADIAG_VCAN_TIME_SCALE, EMADIAG_VM_*).
set -uo pipefail
cd "$(dirname "$0")/../.." || exit 2
if [ "${EMADIAG_ASAN_VCAN_BUILD:-1}" != 0 ]; then
    scripts/build.sh asan emadiag vcan_session_test || exit 1
fi
[ -x build-asan/tests/vcan/vcan_session_test ] || { echo "run_asan_vcan: build-asan has no vcan_session_test (scripts/build.sh asan)" >&2; exit 2; }
REPORTS=$PWD/build-asan/asan-vcan-reports
rm -rf "$REPORTS" && mkdir -p "$REPORTS" || exit 2
# As the ASan unit suite in scripts/test-all.sh, plus a report file per process.
export ASAN_OPTIONS="detect_leaks=1:abort_on_error=1:log_path=$REPORTS/asan"
export UBSAN_OPTIONS="print_stacktrace=1:halt_on_error=1:log_path=$REPORTS/ubsan"
export EMADIAG_VCAN_VM=${EMADIAG_VCAN_VM:-qemu}
# The binaries the suite runs, read into the guest's page cache first (with_vcan_vm.sh).
export EMADIAG_VM_PRELOAD=${EMADIAG_VM_PRELOAD:-"$PWD/build-asan/src/emadiag $PWD/build-asan/tests/vcan/vcan_session_test"}
# A second attempt for a test that fails: an emulated guest under ASan runs 7 to 9 times slower than
# the host, and on a loaded host the EMA's real-time 100 ms heartbeat watchdog still trips now and
# then (gaps of 104 to 172 ms right as a sequence starts, in 2 of 21 tests at load average 10).
# What this job is for is every test's path run once under ASan + UBSan; the heartbeat timing is
# the release build's vcan suite's to prove (with two CPU hogs). Every failed attempt is listed at
# the end, a test that fails twice fails the job, and a sanitizer report from any attempt fails it.
export EMADIAG_VCAN_CTEST_ARGS=${EMADIAG_VCAN_CTEST_ARGS:-"--repeat until-pass:2"}
LOG=$PWD/build-asan/asan-vcan.log
start=$(date +%s)
scripts/vcan/run_vcan_tests.sh build-asan 2>&1 | tee "$LOG"
status=${PIPESTATUS[0]}
retried=$(grep -E '^ *[0-9/]*Test +#[0-9]+: .*\*\*\*(Failed|Timeout|Exception)' "$LOG" | sed -E 's/^.*Test +#[0-9]+: ([^ ]+) .*$/\1/' | sort | uniq -c)
if [ -n "$retried" ]; then
    echo "run_asan_vcan: failed attempts (count, test; a test that then passed was retried once):"
    echo "$retried"
else
    echo "run_asan_vcan: every test passed at its first attempt"
fi
found=$(find "$REPORTS" -type f | sort)
if [ -n "$found" ]; then
    for f in $found; do
        echo "== sanitizer report $f =="
        cat "$f"
    done
    echo "run_asan_vcan: $(echo "$found" | wc -l) sanitizer report(s) in $REPORTS" >&2
    [ "$status" -eq 0 ] && status=1
else
    echo "run_asan_vcan: no ASan, LSan or UBSan report"
fi
echo "run_asan_vcan: $(( $(date +%s) - start )) s, status $status"
exit "$status"
