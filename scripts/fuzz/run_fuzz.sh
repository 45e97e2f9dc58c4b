#!/usr/bin/env bash
# The gate's fuzz stage (scripts/test-all.sh; issue 12 part 1, made deterministic for issue 21 item 17):
# the same commit gives the same result, so the gate never fails whoever lands next on an input the
# fuzzer happened to draw for them. For each libFuzzer target (fuzz/, in the sanitizer build build-asan):
#   1. every stored input is run once (-runs=0): the seeds (fuzz/corpus/<target>/ and the repository
#      files that fit) and the kept findings (tests/data/fuzz_regressions/<target>/);
#   2. a mutation run with a fixed seed and a fixed number of executions (-seed=FUZZ_SEED, default 1;
#      -runs=FUZZ_RUNS, default 20000), from a fresh copy of the seeds (nothing carried over from an
#      earlier run), with what libFuzzer does by the clock turned off (-reload=0: it rereads its
#      corpus directory once a second; -purge_allocator_interval=-1: it purges the allocator once a
#      second, which moves later allocations) and address-space randomisation off (setarch -R: the comparisons libFuzzer records to guide
#      its mutations include pointer values, so with randomisation two runs of seed 1 differed, cov
#      466 and 468 after 8000 executions of fuzz_candump; without it, 3 of 3 runs gave the same
#      corpus and coverage).
# Fails on any crash, sanitizer report, leak, broken property, timeout (10 s per input) or more than
# 2 GB; prints each target's executions and coverage. Exploring with fresh randomness and for longer
# is scripts/fuzz/explore.sh, outside the gate; its findings become regression inputs (see there).
#   scripts/fuzz/run_fuzz.sh [TARGET...]          FUZZ_SEED=N FUZZ_RUNS=N override the defaults
set -euo pipefail
cd "$(dirname "$0")/../.."
. scripts/fuzz/common.sh
if [[ ${1:-} =~ ^[0-9]+$ ]]; then
  echo "run_fuzz: the gate no longer fuzzes for a number of seconds (it is deterministic: FUZZ_SEED, FUZZ_RUNS);" \
       "for a timed exploration run scripts/fuzz/explore.sh $1" >&2
  exit 2
fi
seed=${FUZZ_SEED:-1}
runs=${FUZZ_RUNS:-20000}
targets=("${@:-${fuzz_all_targets[@]}}")
[ ${#targets[@]} -gt 0 ] || targets=("${fuzz_all_targets[@]}")

scripts/build.sh asan "${targets[@]/#/fuzz_}"

# Address-space randomisation off for the fuzzers, where the system lets a process ask for it.
norandom=(setarch "$(uname -m)" -R)
if ! "${norandom[@]}" true 2>/dev/null; then
  echo "run_fuzz: setarch -R is refused here; the mutation runs may differ from one run to the next" >&2
  norandom=()
fi
mkdir -p build-asan/findings
failed=()
summary=()
common=(-print_final_stats=1 -timeout=10 -rss_limit_mb=2048 -max_len=65536)
for t in "${targets[@]}"; do
  corpus=build-asan/fuzz-gate/$t
  rm -rf "$corpus"
  fuzz_fill_corpus "$t" "$corpus"
  regressions=$(fuzz_regression_dir "$t")
  stored=("$corpus")
  [ -d "$regressions" ] && stored+=("$regressions")
  log=build-asan/fuzz_$t.log
  n_regressions=0
  [ -d "$regressions" ] && n_regressions=$(find "$regressions" -type f | wc -l)
  echo "== fuzz_$t: $(ls "$corpus" | wc -l) seeds and $n_regressions kept findings once each, then seed $seed for $runs executions =="
  status=ok
  # 1. The stored inputs, each once (libFuzzer does not write into its corpus directories with -runs=0).
  if ! "${norandom[@]}" build-asan/fuzz/fuzz_"$t" "${stored[@]}" -runs=0 "${common[@]}" -artifact_prefix=build-asan/findings/"$t"- >"$log" 2>&1; then
    status=FAILED
  # 2. Fixed seed, fixed count, from the fresh copy of the seeds.
  elif ! "${norandom[@]}" build-asan/fuzz/fuzz_"$t" "$corpus" -seed="$seed" -runs="$runs" -reload=0 -purge_allocator_interval=-1 "${common[@]}" \
         -artifact_prefix=build-asan/findings/"$t"- >>"$log" 2>&1; then
    status=FAILED
  fi
  if [ "$status" = FAILED ]; then
    failed+=("$t")
    fuzz_show_finding "$log"
  fi
  summary+=("$(fuzz_summary_line "$log" "$t" "$status")")
done
echo "== fuzz summary (stored inputs, then seed $seed for $runs executions per target) =="
printf '%s\n' "${summary[@]}"
if [ ${#failed[@]} -gt 0 ]; then
  echo "run_fuzz: findings in: ${failed[*]} (inputs in build-asan/findings/, logs in build-asan/fuzz_<target>.log);" \
       "reproduce with build-asan/fuzz/fuzz_<target> <input>" >&2
  exit 1
fi
echo "run_fuzz: no crash, leak, timeout or broken property"
