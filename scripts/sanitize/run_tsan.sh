#!/usr/bin/env bash
# ThreadSanitizer job (issue 12 part 5): builds, in build-tsan, only the test suites listed in
# EMADIAG_THREAD_TESTS (tests/CMakeLists.txt: the batch simulator, the recorder with the EMA node and its heartbeat on an in-memory
# bus, the EMA node) with -fsanitize=thread, and runs them. Any data
# race or lock-order inversion fails the job (halt_on_error). EMADIAG_TSAN_BUILD_ONLY=1: build only.
set -euo pipefail
cd "$(dirname "$0")/../.."
launcher=()
command -v ccache >/dev/null && launcher=(-DCMAKE_CXX_COMPILER_LAUNCHER=ccache)
# Paths below the checkout hash as relative ones, so another clone of the same sources (CI's clean
# clone, a git worktree) reuses the cache.
export CCACHE_BASEDIR="$PWD"
cmake -S . -B build-tsan -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo "${launcher[@]}" \
  "-DCMAKE_CXX_FLAGS_RELWITHDEBINFO=-O2 -g1 -DNDEBUG" -DCMAKE_CXX_FLAGS="-fsanitize=thread -fno-omit-frame-pointer" -DCMAKE_EXE_LINKER_FLAGS="-fsanitize=thread" \
  -DEMADIAG_NATIVE=OFF -DEMADIAG_BUILD_BENCH=OFF >/dev/null
targets=$(sed -n 's/^set(EMADIAG_THREAD_TESTS \(.*\))$/\1/p' tests/CMakeLists.txt)
[ -n "$targets" ] || { echo "run_tsan: no EMADIAG_THREAD_TESTS list in tests/CMakeLists.txt" >&2; exit 2; }
# shellcheck disable=SC2086
cmake --build build-tsan -j "$(nproc)" --target $targets
if [ "${EMADIAG_TSAN_BUILD_ONLY:-0}" = 1 ]; then
  echo "run_tsan: built ($targets)"
  exit 0
fi
export TSAN_OPTIONS="halt_on_error=1 second_deadlock_stack=1 history_size=4"
for t in $targets; do
  echo "== $t (ThreadSanitizer) =="
  build-tsan/tests/"$t" --gtest_brief=1
done
echo "run_tsan: no data race in the threads suites ($targets)"
