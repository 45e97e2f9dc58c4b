#!/usr/bin/env bash
# Fuzzing that explores, outside the gate (the gate's stage, scripts/fuzz/run_fuzz.sh, is
# deterministic): each libFuzzer target runs for SECONDS (default 600) with a fresh random seed
# (printed, to repeat a run: FUZZ_SEED=N), on a corpus kept between runs in build-asan/explore/<target>/
# (seeded from fuzz/corpus/, the repository files that fit and the kept findings), so coverage grows
# from one exploration to the next. It does not stop at the first finding (-fork=1,
# -ignore_crashes=1): every crashing or property-breaking input is written to build-asan/findings/.
#   scripts/fuzz/explore.sh [SECONDS] [TARGET...]
#
# Triage of a finding build-asan/findings/<target>-crash-<sha1> (or -leak-, -timeout-, -oom-):
#   1. reproduce:  build-asan/fuzz/fuzz_<target> build-asan/findings/<target>-crash-<sha1>
#   2. minimise:   build-asan/fuzz/fuzz_<target> -minimize_crash=1 -runs=20000 \
#                    -exact_artifact_path=/tmp/min <the finding>
#   3. fix the reader (a clear refusal or a correct answer, never a crash), then keep the input as a
#      regression case under a name that says what it is: tests/data/fuzz_regressions/<target>/<what>;
#      fuzz_fuzz_regression_test (label unit) feeds it to the entry point in every build, and the
#      gate's run_fuzz.sh runs it once under the sanitizers; add a test that names the fix.
#   4. a useful new seed (not a finding) may go to fuzz/corpus/<target>/.
set -euo pipefail
cd "$(dirname "$0")/../.."
. scripts/fuzz/common.sh
seconds=${1:-600}
shift || true
targets=("${@:-${fuzz_all_targets[@]}}")
[ ${#targets[@]} -gt 0 ] || targets=("${fuzz_all_targets[@]}")

scripts/build.sh asan "${targets[@]/#/fuzz_}"

mkdir -p build-asan/findings
found=()
summary=()
for t in "${targets[@]}"; do
  corpus=build-asan/explore/$t
  fuzz_fill_corpus "$t" "$corpus"
  regressions=$(fuzz_regression_dir "$t")
  if [ -d "$regressions" ]; then cp -n "$regressions"/* "$corpus"/ 2>/dev/null || true; fi
  seed=${FUZZ_SEED:-$(od -An -N4 -tu4 /dev/urandom | tr -d ' ')}
  log=build-asan/explore_$t.log
  before=$(find build-asan/findings -type f | wc -l)
  echo "== fuzz_$t: $seconds s, seed $seed, corpus $(ls "$corpus" | wc -l) files =="
  status=ok
  build-asan/fuzz/fuzz_"$t" "$corpus" -seed="$seed" -max_total_time="$seconds" -fork=1 -ignore_crashes=1 -ignore_timeouts=1 \
    -ignore_ooms=1 -print_final_stats=1 -timeout=10 -rss_limit_mb=2048 -max_len=65536 \
    -artifact_prefix=build-asan/findings/"$t"- >"$log" 2>&1 || status=FAILED
  after=$(find build-asan/findings -type f | wc -l)
  if [ "$after" -gt "$before" ] || [ "$status" = FAILED ]; then
    status=FOUND
    found+=("$t")
    fuzz_show_finding "$log"
  fi
  summary+=("$(fuzz_summary_line "$log" "$t" "$status") seed $seed")
done
echo "== exploration summary ($seconds s per target) =="
printf '%s\n' "${summary[@]}"
if [ ${#found[@]} -gt 0 ]; then
  echo "explore: findings in: ${found[*]}: build-asan/findings/ (triage: the head of scripts/fuzz/explore.sh)" >&2
  exit 1
fi
echo "explore: nothing found"
