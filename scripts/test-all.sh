#!/usr/bin/env bash
# README command (b): set up, build, and pass every test:
#   1. Release build (GCC): unit tests, the HTML report in headless Chromium, the fleet server on a
#      real PostgreSQL server, the storage faults
#      (kill -9 of history-sim, import and test-run, full disk), the vcan suite (inside user-mode
#      Linux when this kernel has no vcan), the main job (quick counts), a small fleet-scale run;
#   2. the sanitizer build (clang, ASan + UBSan, libFuzzer coverage; scripts/build.sh asan): every
#      libFuzzer target for 30 s, then the unit tests under ASan + UBSan;
#   3. ThreadSanitizer on the tests with threads.
# Each stage prints its wall time, and the end a table of them (CI must stay under 30 minutes).
# Two builds overlap with tests to use both cores: the sanitizer build compiles (at nice 10, log in
# build/sanitizer-build.log) while the release build's tests run, most of which wait on real time (the vcan
# suite paces its telemetry, the kill tests sleep); the ThreadSanitizer build compiles while
# libFuzzer uses one core. The vcan tests thus run with a busy host, as they must anyway (issue 8:
# they pass with two CPU hogs).
set -euo pipefail
cd "$(dirname "$0")/.."
t_start=$(date +%s)
t_stage=$t_start
stage_name=""
times=()
stage() {  # stage NAME: closes the previous stage's timer and opens the next
  local now
  now=$(date +%s)
  [ -z "$stage_name" ] || times+=("$(printf '%5d s  %s' $((now - t_stage)) "$stage_name")")
  t_stage=$now
  stage_name=$1
  [ -z "$1" ] || echo "== $1 =="
}

stage "setup (packages)"
scripts/setup.sh

stage "release build"
scripts/build.sh release
echo "== sanitizer build (clang: ASan + UBSan, libFuzzer coverage) starts in the background: build/sanitizer-build.log =="
nice -n 10 scripts/build.sh asan >build/sanitizer-build.log 2>&1 &
asan_build=$!
stage "unit tests (release), the hostile-input suite apart"
ctest --test-dir build -L unit -LE hostile -j "$(nproc)" --output-on-failure
stage "the hostile-input suite (issue 21: output paths, control characters, concurrency, signals, size bounds, model and limit semantics)"
ctest --test-dir build -L hostile -j "$(nproc)" --output-on-failure
stage "the hostile probe (issue 21: every reproduction against the real binary, docs/hostile-probe.md)"
rm -rf build/hostile-probe
scripts/hostile/probe.sh "$PWD/build/src/emadiag" "$PWD/build/hostile-probe"
stage "the HTML report in a real browser (headless Chromium)"
ctest --test-dir build -L browser --output-on-failure
stage "the fleet server: a real PostgreSQL server (sync, kill -9 mid-sync, privileges, reports byte for byte)"
ctest --test-dir build -L postgres --output-on-failure
stage "storage under faults (kill -9 x 50 of history-sim and of import, full tmpfs)"
scripts/storage/run_storage_faults.sh build 50
stage "vcan tests (real SocketCAN on vcan0)"
scripts/vcan/run_vcan_tests.sh "$PWD/build"
stage "kill -9 of test-run over vcan, 10 times"
scripts/storage/run_test_run_kills.sh build 10
stage "the main job (README command (a)), quick counts"
EMADIAG_MAIN_QUICK=1 scripts/run-main.sh
stage "the Debian package: install, the main job's quick steps and the site from /usr/bin/emadiag, purge"
scripts/package/ci_package.sh
stage "fleet scale, CI size (bench/fleet_scale_bench: 5 tails x 30 days)"
./build/bench/fleet_scale_bench 5 30 build/fleet_scale_ci.db

stage "sanitizer build (clang: ASan + UBSan, libFuzzer coverage): waiting for the rest of it"
if ! wait "$asan_build"; then
  tail -n 60 build/sanitizer-build.log >&2
  echo "test-all: the sanitizer build failed (build/sanitizer-build.log)" >&2
  exit 1
fi
tail -n 2 build/sanitizer-build.log
stage "libFuzzer targets: stored inputs, then fixed seeds (the ThreadSanitizer build compiles beside them: build/tsan-build.log)"
EMADIAG_TSAN_BUILD_ONLY=1 nice -n 10 scripts/sanitize/run_tsan.sh >build/tsan-build.log 2>&1 &
tsan_build=$!
scripts/fuzz/run_fuzz.sh
stage "unit tests (ASan + UBSan)"
ASAN_OPTIONS=detect_leaks=1:abort_on_error=1 UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1 \
  ctest --test-dir build-asan -L unit -j "$(nproc)" --output-on-failure
stage "ThreadSanitizer: the tests with threads"
if ! wait "$tsan_build"; then
  tail -n 60 build/tsan-build.log >&2
  echo "test-all: the ThreadSanitizer build failed (build/tsan-build.log)" >&2
  exit 1
fi
scripts/sanitize/run_tsan.sh
stage ""
echo "== stage times =="
printf '%s\n' "${times[@]}"
echo "total $(( $(date +%s) - t_start )) s"
echo "test-all: every suite passed"
