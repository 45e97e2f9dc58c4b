#!/usr/bin/env bash
# Builds the libFuzzer targets (fuzz/, in the sanitizer build build-asan: scripts/build.sh asan) and runs each for N seconds (default 30).
# Fails on any crash, leak, timeout or out-of-memory; prints each target's executions and coverage
# (cov = edges, ft = features, from libFuzzer's final stats). Issue 12 part 1.
#   scripts/fuzz/run_fuzz.sh [SECONDS] [TARGET...]
# Corpus: the committed seeds (fuzz/corpus/<target>/) plus the files of tests/data, models/ and
# sim_backend/params that fit the target, copied into build-asan/corpus/<target>/ (new inputs the
# fuzzer finds stay there, not in the tree). A crashing input is written to build-asan/findings/;
# after fixing the parser, keep it in tests/data/fuzz_regressions/<target>/ (the unit test
# fuzz_fuzz_regression_test feeds every file there to the same entry point).
set -euo pipefail
cd "$(dirname "$0")/../.."
seconds=${1:-30}
shift || true
all=(dbc candump run_csv frame_stream model_json limits_json dataset)
targets=("${@:-${all[@]}}")
[ ${#targets[@]} -gt 0 ] || targets=("${all[@]}")

# The fuzz targets live in the sanitizer build (build-asan: clang, ASan + UBSan, coverage).
scripts/build.sh asan "${targets[@]/#/fuzz_}"

corpus_files() {  # extra seeds from the repository, per target
  case "$1" in
    dbc) ls can_dbc/ema.dbc tests/data/can/*.dbc ;;
    model_json) ls models/*_typical.json sim_backend/params/*.json ;;
    limits_json) ls sim_backend/params/*.json ;;
    *) ;;
  esac
}

export ASAN_OPTIONS=detect_leaks=1:abort_on_error=1:symbolize=1
export UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1
mkdir -p build-asan/findings
failed=()
summary=()
for t in "${targets[@]}"; do
  corpus=build-asan/corpus/$t
  mkdir -p "$corpus"
  cp -n fuzz/corpus/"$t"/* "$corpus"/ 2>/dev/null || true
  for f in $(corpus_files "$t"); do cp -n "$f" "$corpus"/; done
  log=build-asan/fuzz_$t.log
  echo "== fuzz_$t: $seconds s, corpus $(ls "$corpus" | wc -l) files =="
  # -timeout: one input taking longer than 10 s is a finding; -rss_limit_mb: so is more than 2 GB.
  if build-asan/fuzz/fuzz_"$t" "$corpus" -max_total_time="$seconds" -print_final_stats=1 -timeout=10 \
       -rss_limit_mb=2048 -max_len=65536 -artifact_prefix=build-asan/findings/"$t"- >"$log" 2>&1; then
    status=ok
  else
    status=FAILED
    failed+=("$t")
    grep -E "ERROR|SUMMARY|Test unit written|property failed" "$log" | head -20 || true
  fi
  execs=$(sed -n 's/^stat::number_of_executed_units: *//p' "$log" | tail -1)
  line=$(grep -E "^#[0-9]+.*(DONE|cov:)" "$log" | tail -1 || true)
  cov=$(sed -n 's/.* cov: \([0-9]*\).*/\1/p' <<<"$line")
  ft=$(sed -n 's/.* ft: \([0-9]*\).*/\1/p' <<<"$line")
  summary+=("$(printf '%-13s %-6s executions %-9s cov %-6s ft %s' "$t" "$status" "${execs:-?}" "${cov:-?}" "${ft:-?}")")
done
echo "== fuzz summary ($seconds s per target) =="
printf '%s\n' "${summary[@]}"
if [ ${#failed[@]} -gt 0 ]; then
  echo "run_fuzz: findings in: ${failed[*]} (inputs in build-asan/findings/, logs in build-asan/fuzz_<target>.log)" >&2
  exit 1
fi
echo "run_fuzz: no crash, leak or timeout"
