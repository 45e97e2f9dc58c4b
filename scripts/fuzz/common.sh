# shellcheck shell=bash
# Shared by scripts/fuzz/run_fuzz.sh (the gate's deterministic stage) and scripts/fuzz/explore.sh
# (longer exploration outside the gate). Sourced from the repository root.
# shellcheck disable=SC2034  # used by the scripts that source this file
fuzz_all_targets=(dbc candump run_csv frame_stream model_json limits_json dataset)

export ASAN_OPTIONS=detect_leaks=1:abort_on_error=1:symbolize=1
export UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1

# The seeds of a target: the committed corpus (fuzz/corpus/<target>/) and the repository files that fit.
fuzz_seed_files() {
  ls fuzz/corpus/"$1"/* 2>/dev/null || true
  case "$1" in
    dbc) ls can_dbc/ema.dbc tests/data/can/*.dbc ;;
    model_json) ls models/*_typical.json sim_backend/params/*.json ;;
    limits_json) ls sim_backend/params/*.json ;;
    *) ;;
  esac
}

# Copies the seeds of target $1 into directory $2 (kept files of the same name are not overwritten).
fuzz_fill_corpus() {
  mkdir -p "$2"
  local f
  for f in $(fuzz_seed_files "$1"); do cp -n "$f" "$2"/; done
}

# The kept findings of target $1 (inputs that once crashed or broke a property; fixed since).
fuzz_regression_dir() { echo "tests/data/fuzz_regressions/$1"; }

# One summary line from a libFuzzer log: executions, coverage (cov = edges, ft = features).
fuzz_summary_line() {  # LOG TARGET STATUS
  local execs line cov ft
  execs=$(sed -n 's/^stat::number_of_executed_units: *//p' "$1" | tail -1)
  line=$(grep -E "^#[0-9]+.*(DONE|cov:)" "$1" | tail -1 || true)
  cov=$(sed -n 's/.* cov: \([0-9]*\).*/\1/p' <<<"$line")
  ft=$(sed -n 's/.* ft: \([0-9]*\).*/\1/p' <<<"$line")
  printf '%-13s %-6s executions %-9s cov %-6s ft %s' "$2" "$3" "${execs:-?}" "${cov:-?}" "${ft:-?}"
}

# Prints what a failed run found (the sanitizer report, the property, the input written).
fuzz_show_finding() { grep -E "ERROR|SUMMARY|Test unit written|property failed" "$1" | head -20 || true; }
