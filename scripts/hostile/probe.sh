#!/usr/bin/env bash
# Hostile-input probe of the emadiag CLI (issue 21): every reproduction of items 1-15 of the issue
# that concerns the command line, and variants of each class, run against one binary in a fresh
# work directory. Items 16 (a unit-test flake under load) and 17 (a fuzz gate) are about the test
# suite and the fuzz stage, not the CLI; they are not probed here.
#
#   scripts/hostile/probe.sh EMADIAG_BINARY [WORKDIR]
#
# Each case prints one line
#   PASS|FAIL <class> <case>: <what was expected> -- <what happened>
# and the script ends with the line "N passed, N failed" and exits 1 when a case failed (2 on a
# usage or set-up error). Cases judge the outcome (exit status, files, database contents, bytes in
# the output), not the wording of messages. Every command runs under `timeout`: a hang is a FAIL of
# that case, never a stuck probe. A crash is an exit status >= 128 (a signal) or "terminate called"
# / "std::" in stderr, and fails the case whatever else it did.
#
# Needs: bash, coreutils (timeout, sha256sum), python3, sqlite3, util-linux (unshare, mount; for the
# full-disk and read-only cases, run as root; without the privilege those cases are reported as
# FAIL of the probe's set-up, never silently skipped). WORKDIR (default: a new mktemp -d) is left
# in place for inspection; PROBE_KEEP=0 removes it at the end.
set -u
if [ $# -lt 1 ] || [ ! -x "$1" ]; then
    echo "usage: $0 EMADIAG_BINARY [WORKDIR]" >&2
    exit 2
fi
EMADIAG=$(cd "$(dirname "$1")" && pwd)/$(basename "$1")
HERE=$(cd "$(dirname "$0")" && pwd)
REPO=$(cd "$HERE/../.." && pwd)
MODELS="$REPO/models"
for tool in python3 sqlite3 timeout sha256sum; do
    command -v "$tool" >/dev/null || { echo "$0: needs $tool" >&2; exit 2; }
done
if [ $# -ge 2 ]; then
    W="$2"
    mkdir -p "$W" || exit 2
    W=$(cd "$W" && pwd)
    [ -z "$(ls -A "$W")" ] || { echo "$0: WORKDIR $W is not empty" >&2; exit 2; }
else
    W=$(mktemp -d "${TMPDIR:-/tmp}/emadiag-probe.XXXXXX") || exit 2
fi
cd "$W" || exit 2
echo "# emadiag hostile probe: binary $EMADIAG, work directory $W, $(date -u +%Y-%m-%dT%H:%M:%SZ)"
echo "# issue 21 items 16 (EmaNode test flake) and 17 (fuzz gate) concern the test suite, not the CLI: not probed"

PASSED=0
FAILED=0
T_DEFAULT=30
OUT="$W/.out"
ERR="$W/.err"
RC=0

# ---------------------------------------------------------------- helpers
# run [-t SECONDS] [-m KBYTES] [-i STDIN] [-e VAR=VALUE] [-C DIR] -- ARGS...: emadiag ARGS under timeout
# (and an address-space cap), in DIR (default the work directory), stdout to $OUT, stderr to $ERR, exit
# status in RC.
run() {
    local t=$T_DEFAULT mem="" in=/dev/null envs=() dir=.
    while [ $# -gt 0 ]; do
        case "$1" in
            -t) t=$2; shift 2 ;;
            -m) mem=$2; shift 2 ;;
            -i) in=$2; shift 2 ;;
            -e) envs+=("$2"); shift 2 ;;
            -C) dir=$2; shift 2 ;;
            --) shift; break ;;
            *) break ;;
        esac
    done
    # In a subshell whose own stderr is discarded: bash's "Aborted"/"Killed" job notices stay out of the report.
    (
        [ -n "$mem" ] && ulimit -v "$mem"
        cd "$dir" || exit 99
        env "${envs[@]}" timeout -k 5 "$t" "$EMADIAG" "$@" <"$in" >"$OUT" 2>"$ERR"
    ) 2>/dev/null
    RC=$?
}
# What the last run did, on one line, printable.
said() {
    local s
    s=$(cat "$ERR" "$OUT" 2>/dev/null | head -c 600 | tr '\n\t' '  ' | tr -c '[:print:]' '?' | cut -c1-170)
    echo "exit $RC; ${s:-no output}"
}
# Empty when the last run neither hung nor crashed; else why.
broken() {
    if [ "$RC" -eq 124 ] || [ "$RC" -eq 137 ]; then echo "hung (killed by the timeout)"
    elif [ "$RC" -ge 128 ]; then echo "crashed (signal $((RC - 128)))"
    elif grep -aq -e 'terminate called' -e 'std::' "$ERR" 2>/dev/null; then echo "crashed or leaked an exception ('$(grep -ao -m1 -e 'terminate called.*' -e 'std::[a-z_:]*' "$ERR" | head -1 | tr -c '[:print:]' '?')')"
    fi
}
# result CLASS CASE EXPECTED OK [HAPPENED]: OK is 0 (pass) or anything else; a hang or crash of the
# last run fails the case whatever OK says.
result() {
    local cls=$1 case=$2 exp=$3 ok=$4 what=${5:-}
    local b
    b=$(broken)
    [ -z "$what" ] && what=$(said)
    if [ -n "$b" ]; then ok=1; what="$b; $what"; fi
    if [ "$ok" = 0 ]; then
        PASSED=$((PASSED + 1))
        echo "PASS $cls $case: $exp -- $what"
    else
        FAILED=$((FAILED + 1))
        echo "FAIL $cls $case: $exp -- $what"
    fi
}
# cpdb SRC DST: a database with its sidecar files (SRC.anchor, SRC-wal, ...), as an operator copies it.
cpdb() {
    rm -f "$2" "$2".* "$2"-*
    cp "$1" "$2"
    local f
    for f in "$1".* "$1"-*; do [ -e "$f" ] && cp "$f" "$2${f#"$1"}"; done
    return 0
}
sha() { if [ -e "$1" ]; then sha256sum "$1" | cut -c1-64; else echo absent; fi; }
both() { cat "$OUT" "$ERR"; }
has() { both | grep -aqi "$@"; }
serviceable_said() { both | grep -aqE '(^|[^A-Z_])(verdict|VERDICT):? SERVICEABLE'; }
# Read-only queries; a missing or empty file is 0 sessions (and is not created by asking).
sessions() {
    [ -s "$1" ] || { echo 0; return; }
    sqlite3 -readonly "$1" "select count(*) from test_sessions${2:+ where tail_number='$2'}" 2>/dev/null || echo 0
}
verdicts() { [ -s "$1" ] && sqlite3 -readonly "$1" "select group_concat(verdict, ',') from test_sessions" 2>/dev/null; }
is_fifo() { [ -p "$1" ]; }
is_chr() { [ -c "$1" ] && [ ! -L "$1" ]; }
is_link() { [ -L "$1" ]; }
esc() { both | grep -aqP '\x1b|\xc2\x9b'; }   # raw ESC or C1 CSI in the last run's output

# ---------------------------------------------------------------- fixtures
mk() { timeout -k 5 120 "$EMADIAG" "$@" >/dev/null 2>"$W/.fixture.err" || { echo "# fixture failed: emadiag $*: $(head -c 300 "$W/.fixture.err")"; }; }
mk simulate --case A --sequence dyn --noise typical --seed 2 --out run_a.csv
mk simulate --case B --sequence dyn --noise typical --seed 3 --out run_b.csv
mk simulate --case B --sequence dyn --noise typical --seed 4 --effect viscous=2e-5 --out run_v.csv
python3 "$HERE/make_candump.py" run_a.csv full.log
python3 "$HERE/make_candump.py" run_a.csv nodone.log --no-done
python3 "$HERE/make_candump.py" run_a.csv aborted.log --abort
head -n 1000 full.log >trunc.log                                   # the issue's first 1,000 lines
head -c "$(($(wc -c <full.log) * 2 / 3 + 7))" full.log >torn.log   # cut mid-line, no final newline
awk '!(/ vcan0 10[01]#/ && NR % 3 == 0)' full.log >lossy.log       # a third of the telemetry lost
mk history-sim --db hh.db --tail N100 --position LH-ELEV --sessions 3 --noise none
mk dataset --case B --count 12 --seed 3 --out t.ds
echo "precious" >victim.txt
VICTIM_SHA=$(sha victim.txt)
UTC=2026-06-02T10:00:00Z
imp() { local db=$1 run=$2; shift 2; run -- import "$run" --db "$db" --tail N200 --position LH-ELEV --utc "$UTC" "$@"; }

# ---------------------------------------------------------------- control: the probe's inputs are good
imp ctl.db full.log
result control candump-session "the synthesised complete session log imports as SERVICEABLE (the generator is right)" \
    "$(test "$RC" = 0 -a "$(verdicts ctl.db)" = SERVICEABLE; echo $?)"
imp ctl2.db run_a.csv
result control csv-run "a simulated ground run imports as SERVICEABLE" "$(test "$RC" = 0 -a "$(verdicts ctl2.db)" = SERVICEABLE; echo $?)"
echo '{"FDJ_Nm": {"max": 0.09}}' >limits_ok.json
imp ctl3.db run_a.csv --limits limits_ok.json
result control limits-file "a sane limits file is accepted" "$(test "$RC" = 0; echo $?)"

run -m 400000 -- estimate run_b.csv
result control estimate-under-400MB-cap "estimate of a normal run works within the 400 MB address space the bounds cases use" "$(test "$RC" = 0; echo $?)"

# ---------------------------------------------------------------- 1. trend: never pool two actuators
mk history-sim --db tr.db --tail N456EM --position LH-ELEV --sessions 4 --days-between 30 --fdj-rate-per-100d 0.004 --seed 3
mk history-sim --db tr.db --tail N456EM --position RH-ELEV --serial 2002 --sessions 4 --days-between 30 --fdj-rate-per-100d 0.001 --seed 4
run -- trend --db tr.db --tail N456EM --json
cp "$OUT" trend.json
mixed=$(python3 - tr.db trend.json <<'EOF'
import json, sqlite3, sys
db = sqlite3.connect(sys.argv[1])
pos = dict(db.execute("select session_id, coalesce(position, '') from test_sessions"))
ser = dict(db.execute("select session_id, actuator_serial from test_sessions"))
try:
    j = json.load(open(sys.argv[2]))
except Exception as e:
    print("no JSON: %s" % e); sys.exit()
series = j.get("series", [])
bad = []
for s in series:
    ids = s.get("trend_session_ids", [])
    if len({pos.get(i) for i in ids}) > 1 or len({ser.get(i) for i in ids}) > 1:
        bad.append("series %s/%s mixes sessions %s" % (s.get("position"), s.get("serial"), ids))
names = {s.get("position") for s in series if s.get("kind") == "position"}
if not {"LH-ELEV", "RH-ELEV"} <= names:
    bad.append("position series %s" % sorted(map(str, names)))
print("; ".join(bad))
EOF
)
result trend json-per-position "one series per position, none mixing two positions or serials" "$(test -z "$mixed"; echo $?)" "exit $RC; ${mixed:-each series holds one position and serial}"
run -- trend --db tr.db --tail N456EM
result trend text-per-position "the text report names LH-ELEV and RH-ELEV, no pooled ALL position" \
    "$(both | grep -q LH-ELEV && both | grep -q RH-ELEV && ! both | grep -qw ALL; echo $?)"
run -- trend --db tr.db --tail N456EM --format html --out trend.html
result trend html-per-position "the HTML names both positions and never says one position holds every session" \
    "$(test "$RC" = 0 && grep -q LH-ELEV trend.html && grep -q RH-ELEV trend.html && ! grep -qi 'holds every session' trend.html; echo $?)"
run -- trend --db tr.db --tail N456EM --position LH-ELEV --json
n=$(python3 -c "import json,sys; j=json.load(open(sys.argv[1])); print(sum(len(s.get('trend_session_ids',[])) for s in j.get('series',[])))" "$OUT" 2>/dev/null)
result trend position-filter "--position LH-ELEV trends LH-ELEV's 4 sessions only" "$(test "${n:-x}" = 4; echo $?)" "exit $RC; ${n:-no} sessions in its series"

# ---------------------------------------------------------------- 2. truncated / invalid runs: NO_TEST, never SERVICEABLE
notest() {  # notest CASE FILE [import args]: the run must not give, or be stored with, a SERVICEABLE verdict
    local case=$1 file=$2; shift 2
    rm -f "nt_$case.db"
    imp "nt_$case.db" "$file" "$@"
    local v
    v=$(verdicts "nt_$case.db")
    result truncated "$case" "NO_TEST stored, or refused (exit != 0, nothing stored); never SERVICEABLE" \
        "$({ [ "$v" = NO_TEST ] || { [ -z "$v" ] && [ "$RC" != 0 ]; }; } && ! serviceable_said; echo $?)" \
        "$(said); stored verdicts: ${v:-none}"
}
notest candump-first-1000-lines trunc.log
notest candump-torn-mid-line torn.log
notest candump-no-done-status nodone.log
notest candump-aborted aborted.log
notest candump-third-of-telemetry-lost lossy.log
run -- estimate trunc.log
result truncated estimate-says-why "estimate of the truncated log warns it is incomplete/invalid" \
    "$(has -e incomplete -e invalid -e 'not valid' -e truncat -e warning -e NO_TEST; echo $?)"
meta_csv() {  # meta_csv OUT SED-EXPR: run_a.csv edited
    sed -e "$2" run_a.csv >"$1"
}
meta_csv valid_false.csv '1i # valid=false'
notest csv-valid-false valid_false.csv
meta_csv status_incomplete.csv '1i # status=incomplete'
notest csv-status-incomplete status_incomplete.csv
meta_csv status_aborted.csv '1i # status=aborted'
notest csv-status-aborted status_aborted.csv
meta_csv invalid_reason.csv '1i # invalid_reason=telemetry loss 40 %'
notest csv-invalid-reason invalid_reason.csv
header_lines=$(grep -c '^#' run_a.csv)
head -n $((header_lines + 1 + 462)) run_a.csv >cut_rows.csv
notest csv-462-of-1000-rows cut_rows.csv

# ---------------------------------------------------------------- 3. nonsense metadata and values: refused
nonsense() {  # nonsense CASE FILE: import refuses it and stores nothing
    local case=$1 file=$2
    rm -f "ns_$case.db"
    imp "ns_$case.db" "$file"
    local v
    v=$(verdicts "ns_$case.db")
    result nonsense "$case" "refused (exit != 0, nothing stored) or at most NO_TEST; never SERVICEABLE" \
        "$({ [ "$v" = NO_TEST ] || { [ -z "$v" ] && [ "$RC" != 0 ]; }; } && ! serviceable_said; echo $?)" "$(said); stored verdicts: ${v:-none}"
}
meta_csv case_z.csv 's/^# case=A$/# case=Z/'
nonsense case-Z case_z.csv
meta_csv seq_zz.csv 's/^# sequence=dyn$/# sequence=zz/'
nonsense sequence-zz seq_zz.csv
meta_csv case_empty.csv 's/^# case=A$/# case=/'
nonsense case-empty case_empty.csv
meta_csv kt_neg.csv 's/^# k_t_Nm_per_A=.*/# k_t_Nm_per_A=-0.2/'
nonsense k_t-negative kt_neg.csv
meta_csv period0.csv 's/^# sample_period_s=.*/# sample_period_s=0/'
nonsense sample-period-zero period0.csv
meta_csv j_huge.csv 's/^# J_kgm2=.*/# J_kgm2=1e308/'
nonsense inertia-1e308 j_huge.csv
first_row=$((header_lines + 2))
python3 - run_a.csv "$first_row" <<'EOF'
import sys
src, row = sys.argv[1], int(sys.argv[2]) + 200
lines = open(src).read().split("\n")
def put(name, col, value):
    l = list(lines)
    cells = l[row - 1].split(",")
    cells[col] = value
    l[row - 1] = ",".join(cells)
    open(name, "w").write("\n".join(l))
put("cur_1e308.csv", 1, "1e308")
put("speed_1e300.csv", 2, "-1e300")
put("hinge_1e308.csv", 4, "1e308")
put("time_back.csv", 0, "0.0001")
EOF
nonsense current-1e308-one-sample cur_1e308.csv
nonsense speed-minus-1e300-one-sample speed_1e300.csv
nonsense hinge-1e308-one-sample hinge_1e308.csv
nonsense time-goes-back time_back.csv

# ---------------------------------------------------------------- 3. bad models: refused
model_variant() {  # model_variant OUT PYTHON-STATEMENT-ON-m
    python3 - "$MODELS/case_b_typical.json" "$1" "$2" <<'EOF'
import json, sys
m = json.load(open(sys.argv[1]))
exec(sys.argv[3])
open(sys.argv[2], "w").write(json.dumps(m))
EOF
}
badmodel() {
    local case=$1 file=$2
    run -- estimate run_b.csv --model "$file"
    result model "$case" "estimate --model refuses it: exit != 0, no negative '+/-' or inverted interval printed" \
        "$(test "$RC" != 0 && ! both | grep -aq '+/- -'; echo $?)"
}
model_variant m_neg_se.json 'm["std_error_normalised"][0] = -abs(m["std_error_normalised"][0])'
badmodel std-error-negative m_neg_se.json
model_variant m_huge_se.json 'm["std_error_normalised"][0] = 1e308'
badmodel std-error-1e308 m_huge_se.json
model_variant m_zero_se.json 'm["std_error_normalised"][0] = 0'
badmodel std-error-zero m_zero_se.json
model_variant m_bogus.json 'm["network"]["hidden_transfer"] = "bogus"'
badmodel hidden-transfer-bogus m_bogus.json
model_variant m_flat.json 'm["input_normalisation"]["max"] = list(m["input_normalisation"]["min"])'
badmodel input-normalisation-max-eq-min m_flat.json
model_variant m_dup.json 'm["spec"]["outputs"] = ["FDJ_Nm", "FDJ_Nm"]; m["output_normalisation"][1]["name"] = "FDJ_Nm"'
badmodel duplicate-outputs m_dup.json
model_variant m_out_lohi.json 'm["output_normalisation"][0]["lo"], m["output_normalisation"][0]["hi"] = 0.096, 0.064'
badmodel output-normalisation-inverted m_out_lohi.json
sed 's/"hidden_transfer": *"tansig"/"hidden_transfer": "tansig", "hidden_transfer": "bogus"/' "$MODELS/case_b_typical.json" >m_dupkey.json
badmodel duplicate-key m_dupkey.json

# ---------------------------------------------------------------- 3. bad limits files: refused
badlimits() {
    local case=$1 text=$2
    printf '%s\n' "$text" >"l_$case.json"
    rm -f "l_$case.db"
    imp "l_$case.db" run_a.csv --limits "l_$case.json"
    result limits "$case" "import --limits refuses it: exit != 0, nothing stored" \
        "$(test "$RC" != 0 -a "$(sessions "l_$case.db")" = 0; echo $?)" "$(said); $(sessions "l_$case.db") sessions stored"
}
badlimits eta_O-min-5 '{"eta_O": {"min": 5}}'
badlimits eta_A-min-1.5 '{"eta_A": {"min": 1.5}}'
badlimits duplicate-key '{"FDJ_Nm": {"max": 0.01}, "FDJ_Nm": {"max": 10}}'
badlimits FDJ-max-1e300 '{"FDJ_Nm": {"max": 1e300}}'
badlimits nested-duplicate '{"FDJ_Nm": {"max": 0.09, "max": 5}}'

# ---------------------------------------------------------------- 3. a foreign run into discover --db --tail
# A binary whose discover stores a finding per actuator takes --position with --db/--tail; give it so
# that a refusal is about the hostile input, not a missing option.
DPOS=()
timeout 20 "$EMADIAG" discover --help 2>/dev/null | grep -q -- '--position' && DPOS=(--position LH-ELEV)
cpdb hh.db fd.db
before=$(sqlite3 fd.db "select count(*) from discovery_findings")
run -t 90 -- discover run_v.csv --db fd.db --tail N100 "${DPOS[@]}"
after=$(sqlite3 fd.db "select count(*) from discovery_findings")
result foreign discover-run-into-tail "a run not of N100 is not mixed in: refused or no finding stored under N100" \
    "$(test "$before" = "$after"; echo $?)" "$(said); discovery findings $before -> $after"
before=$(sha fd.db)
run -t 90 -- discover run_v.csv --db fd.db --tail N999 "${DPOS[@]}"
result foreign discover-unknown-tail "a run given with a tail the database lacks: nothing stored" \
    "$(test "$before" = "$(sha fd.db)" -a "$(sqlite3 fd.db "select count(*) from aircraft where tail_number='N999'")" = 0; echo $?)"

# ---------------------------------------------------------------- 4. output paths
mkfifo fifo
mknod devfull c 1 7 2>/dev/null || echo "# mknod failed: the device cases write to a missing node"
HH_SHA=$(sha hh.db)
IN_SHA=$(sha run_a.csv)
DS_SHA=$(sha t.ds)
outcase() {  # outcase WRITER TARGET-KIND TARGET ARGS... (the args hold the target)
    local writer=$1 kind=$2 target=$3; shift 3
    rm -f victim.txt; echo precious >victim.txt
    cpdb hh.db odb.db; cp run_a.csv oin.csv; cp t.ds oin.ds
    local t=20
    [ "$writer" = discover ] && t=90
    run -t "$t" -- "$@"
    local ok=1 state=""
    case "$kind" in
        database) [ "$(sha odb.db)" = "$HH_SHA" ] && [ "$RC" != 0 ] && ok=0; state="database sha256 $([ "$(sha odb.db)" = "$HH_SHA" ] && echo unchanged || echo CHANGED)" ;;
        input)    local s0=$IN_SHA; [ "$target" = oin.ds ] && s0=$DS_SHA
                  [ "$(sha "$target")" = "$s0" ] && [ "$RC" != 0 ] && ok=0; state="input sha256 $([ "$(sha "$target")" = "$s0" ] && echo unchanged || echo CHANGED)" ;;
        device)   is_chr devfull && [ "$RC" != 0 ] && ok=0; state="device node $(is_chr devfull && echo kept || echo REPLACED)" ;;
        fifo)     is_fifo fifo && [ "$RC" != 0 ] && ok=0; state="FIFO $(is_fifo fifo && echo kept || echo REPLACED)" ;;
        symlink)  is_link link && [ "$(sha victim.txt)" = "$VICTIM_SHA" ] && [ "$RC" != 0 ] && ok=0
                  state="link $(is_link link && echo kept || echo REPLACED), victim $([ "$(sha victim.txt)" = "$VICTIM_SHA" ] && echo unchanged || echo OVERWRITTEN)" ;;
        planted)  [ "$(sha victim.txt)" = "$VICTIM_SHA" ] && ok=0; state="victim behind the planted temp link $([ "$(sha victim.txt)" = "$VICTIM_SHA" ] && echo unchanged || echo OVERWRITTEN)" ;;
    esac
    # A refusal names the path it refuses.
    if [ "$ok" = 0 ] && [ "$RC" != 0 ] && ! has -F "$(basename "$target")"; then ok=1; state="$state, message does not name $(basename "$target")"; fi
    local exp="exit != 0, the $kind target untouched, the message names it"
    [ "$kind" = planted ] && exp="the file behind a planted temp-name symlink untouched"
    result outpath "$writer-$kind" "$exp" "$ok" "$(said); $state"
    rm -f link; ln -s victim.txt link
}
ln -s victim.txt link
for kind in database device fifo symlink; do
    case $kind in database) tg=odb.db ;; device) tg=devfull ;; fifo) tg="fifo" ;; symlink) tg="link" ;; esac
    outcase report "$kind" "$tg" report --db odb.db --tail N100 --out "$tg"
    outcase trend "$kind" "$tg" trend --db odb.db --tail N100 --out "$tg"
    outcase fleet "$kind" "$tg" fleet --db odb.db --out "$tg"
    outcase export "$kind" "$tg" export --db odb.db --tail N100 --format json --out "$tg"
    # The writers that take no database: their inputs, devices, FIFOs and links (a database they do not
    # open is just another file to them).
    [ "$kind" = database ] && continue
    outcase simulate "$kind" "$tg" simulate --case A --out "$tg"
    outcase dataset "$kind" "$tg" dataset --count 2 --out "$tg"
    outcase train "$kind" "$tg" train --dataset oin.ds --timesteps 20 --neurons 2 --max-epochs 2 --out "$tg"
done
outcase export-csv database odb.db export --db odb.db --tail N100 --format csv --out odb.db
outcase train input oin.ds train --dataset oin.ds --timesteps 20 --neurons 2 --max-epochs 2 --out oin.ds
outcase discover-out-model input oin.csv discover oin.csv --out-model oin.csv
outcase discover-out-params input oin.csv discover oin.csv --out-params oin.csv
outcase discover-plot input oin.csv discover oin.csv --plot oin.csv
outcase discover-plot fifo fifo discover oin.csv --plot fifo
outcase discover-plot symlink link discover oin.csv --plot link
outcase discover-out-model database odb.db discover --db odb.db --tail N100 "${DPOS[@]}" --out-model odb.db
outcase discover-plot database odb.db discover --db odb.db --tail N100 "${DPOS[@]}" --plot odb.db
outcase import-db input oin.csv import oin.csv --db oin.csv --tail N1 --position LH-ELEV --utc "$UTC"
# Symlinks planted at the temporary names a writer might use beside its target (OUT.tmp, OUT.part, OUT~).
for w in report trend fleet export simulate dataset train; do
    rm -f out.txt out.txt.tmp out.txt.part out.txt~
    for s in .tmp .part '~'; do ln -sf victim.txt "out.txt$s"; done
    case $w in
        report)   outcase report planted out.txt report --db odb.db --tail N100 --out out.txt ;;
        trend)    outcase trend planted out.txt trend --db odb.db --tail N100 --out out.txt ;;
        fleet)    outcase fleet planted out.txt fleet --db odb.db --out out.txt ;;
        export)   outcase export planted out.txt export --db odb.db --tail N100 --format json --out out.txt ;;
        simulate) outcase simulate planted out.txt simulate --case A --out out.txt ;;
        dataset)  outcase dataset planted out.txt dataset --count 2 --out out.txt ;;
        train)    outcase train planted out.txt train --dataset oin.ds --timesteps 20 --neurons 2 --max-epochs 2 --out out.txt ;;
    esac
done
# A full disk: the writer fails and leaves no partial or empty file behind.
fulldisk() {  # fulldisk CASE ARGS...: the output goes to full/, a 64 KiB tmpfs filled to the last byte first
    local case=$1; shift
    rm -rf full; mkdir full
    if ! unshare -m true 2>/dev/null; then
        result outpath "full-disk-$case" "a probe set-up: unshare -m (run as root)" 1 "unshare -m not permitted"; return
    fi
    rm -f .left
    unshare -m bash -c 'mount -t tmpfs -o size=64k tmpfs "$0/full" || exit 99; cd "$0"; head -c 1M /dev/zero >full/filler 2>/dev/null
        timeout -k 5 60 "$@"; rc=$?; ls -A full | grep -vx filler >.left; exit $rc' "$W" "$EMADIAG" "$@" >"$OUT" 2>"$ERR"
    RC=$?
    local left
    left=$(tr '\n' ' ' <.left 2>/dev/null)
    result outpath "full-disk-$case" "exit != 0 and nothing left in the full directory" "$(test "$RC" != 0 -a "$RC" != 99 -a -z "$left"; echo $?)" \
        "$(said); left: ${left:-nothing}"
}
fulldisk simulate simulate --case A --out full/o.csv
fulldisk dataset dataset --count 2 --out full/o.ds
fulldisk train train --dataset t.ds --timesteps 500 --neurons 50 --max-epochs 1 --out full/o.json
fulldisk report-html report --db hh.db --tail N100 --format html --out full/o.html
fulldisk discover-out-model discover run_a.csv --out-model full/o.json --out-params full/p.json

# ---------------------------------------------------------------- 5. verify sees changes made outside the tool
tamper() {  # tamper CASE SQL: on a copy of hh.db with the append-only triggers dropped
    local case=$1 sql=$2 src=${3:-hh.db}
    cpdb "$src" "tp_$case.db"
    local drops
    drops=$(sqlite3 "tp_$case.db" "select 'DROP TRIGGER ' || name || ';' from sqlite_master where type = 'trigger'")
    sqlite3 "tp_$case.db" "$drops $sql" 2>"$W/.sql.err" || echo "# tamper $case: $(head -c 200 "$W/.sql.err")"
    run -- verify --db "tp_$case.db" --tail N100
    result verify "$case" "verify reports the change: exit != 0" "$(test "$RC" != 0; echo $?)"
}
tamper installation-serial "UPDATE installations SET to_serial = 'FAKE-1';"
cpdb hh.db df.db
run -t 90 -- discover --db df.db --tail N100 "${DPOS[@]}"
dfn=$(sqlite3 df.db "select count(*) from discovery_findings")
[ "$dfn" -gt 0 ] || echo "# discover --db df.db --tail N100 stored no finding: $(said)"
if [ "$dfn" -gt 0 ]; then
    tamper finding-summary "UPDATE discovery_findings SET summary = 'nothing found';" df.db
    tamper finding-status "UPDATE discovery_findings SET status = 'closed';" df.db
else
    for c in finding-summary finding-status; do
        result verify "$c" "a probe set-up: discover --db --tail stores a finding to edit" 1 "no finding stored: $(said)"
    done
fi
tamper delete-last-session "DELETE FROM findings WHERE session_id = 3; DELETE FROM estimates WHERE run_id IN (SELECT run_id FROM runs WHERE session_id = 3);
  DELETE FROM samples WHERE run_id IN (SELECT run_id FROM runs WHERE session_id = 3); DELETE FROM raw_logs WHERE run_id IN (SELECT run_id FROM runs WHERE session_id = 3);
  DELETE FROM runs WHERE session_id = 3; DELETE FROM session_artifacts WHERE session_id = 3; DELETE FROM test_sessions WHERE session_id = 3;
  UPDATE chain_heads SET session_id = 2, sessions = 2, content_sha256 = (SELECT content_sha256 FROM test_sessions WHERE session_id = 2);"
tamper technician-name "UPDATE test_sessions SET technician_name = 'Nobody' WHERE session_id = 1;"
cpdb hh.db junk.db
head -c 5000 /dev/urandom >>junk.db
run -- verify --db junk.db --tail N100
result verify appended-5000-random-bytes "verify reports the file is not what the tool wrote: exit != 0" "$(test "$RC" != 0; echo $?)"
run -- report --db junk.db --tail N100
result verify report-appended-bytes "report refuses or warns on a file with 5000 bytes appended" \
    "$(test "$RC" != 0 || has -e tamper -e damag -e corrupt -e 'not intact' -e broken -e mismatch; echo $?)"
tamper sample-cell "UPDATE samples SET current_a = current_a + 1 WHERE sample_index = 10;"
run -- report --db tp_sample-cell.db --tail N100
result verify report-after-cell-damage "report refuses or warns on a record whose hash chain is broken" \
    "$(test "$RC" != 0 || has -e tamper -e damag -e corrupt -e 'not intact' -e broken -e mismatch; echo $?)"
n0=$(sessions tp_sample-cell.db)
run -- import run_a.csv --db tp_sample-cell.db --tail N100 --position LH-ELEV --utc "$UTC"
result verify import-onto-broken-chain "import refuses (or warns) to append to a broken chain" \
    "$(test "$RC" != 0 -a "$(sessions tp_sample-cell.db)" = "$n0" || has -e tamper -e damag -e corrupt -e 'not intact' -e broken -e mismatch; echo $?)"

# ---------------------------------------------------------------- 6. recover stores only what the spool holds
spool_manifest() {  # spool_manifest FILE TAIL LOG_PATH
    python3 - "$1" "$2" "$3" <<'EOF'
import json, sys
json.dump({"format": "emadiag-session-spool-1", "tail_number": sys.argv[2], "phase": "pre-flight",
           "started_utc": "2026-06-02T10:00:00Z", "tool_version": "probe", "limits_json": "{}", "sequences": ["dyn"],
           "logs": [{"sequence": "dyn", "attempt": 1, "log_path": sys.argv[3]}], "state": "recorded", "record_json": "{}"},
          open(sys.argv[1], "w"))
EOF
}
# recover runs inside the spool directory, so that a log_path given by its file name (or relative to
# the spool) resolves the same way whether the binary resolves it against the spool or the working
# directory.
SECRET="PRIVATE-KEY-$(head -c 8 /dev/urandom | od -An -tx1 | tr -d ' \n')"
printf '%s\n' "$SECRET" >private.txt
hexsecret=$(printf '%s' "$SECRET" | od -An -tx1 | tr -d ' \n')
b64=$(printf '%s\n' "$SECRET" | base64 -w0 | cut -c1-16)
private_case() {  # private_case CASE LOG_PATH [SETUP-IN-SPOOL]: the private file must not reach the database
    local case=$1 path=$2 db=rp_$1.db
    mkdir -p "$db.spool"
    [ -n "${3:-}" ] && ( cd "$db.spool" && eval "$3" )
    spool_manifest "$db.spool/N300_20260602T100000Z_pre-flight.json" N300 "$path"
    run -C "$db.spool" -- recover --db "../$db"
    local rc=$RC leak=no
    { grep -aqF "$SECRET" "$db" 2>/dev/null || { [ -s "$db" ] && sqlite3 -readonly "$db" .dump 2>/dev/null | grep -aqi "$hexsecret"; }; } && leak=yes
    if [ -s "$db" ]; then
        run -- export --db "$db" --tail N300 --format json
        grep -aqF "$b64" "$OUT" && leak=yes
    fi
    RC=$rc
    result recover "$case" "a manifest naming a file outside the spool: the file is not stored" "$(test "$leak" = no; echo $?)" "recover exit $rc; secret in the database/export: $leak"
}
private_case private-file-absolute "$W/private.txt"
private_case private-file-dotdot ../private.txt
private_case private-file-symlink-in-spool N300_dyn_1.log 'ln -s ../private.txt N300_dyn_1.log'
mkdir -p rc2.db.spool
cp full.log rc2.db.spool/N301_dyn_1.log
printf '{"format": "emadiag-session-spool-1", "tail_number": ' >rc2.db.spool/A_bad.json
spool_manifest rc2.db.spool/N301_20260602T100000Z_pre-flight.json N301 N301_dyn_1.log
run -C rc2.db.spool -- recover --db ../rc2.db
result recover bad-then-good-manifest "a bad manifest is reported and the good one still stored (1 session of N301)" \
    "$(test "$(sessions rc2.db N301)" = 1; echo $?)" "$(said); $(sessions rc2.db N301) sessions of N301"

# ---------------------------------------------------------------- 7. forged lines and control characters
NL=$'\n'
ESCS=$'\e[31mRED\e[0m\e]0;title\a'
for field in serial technician operator certificate; do
    db=ctl_$field.db
    rm -f "$db"
    imp "$db" run_a.csv "--$field" "X1${NL}VERDICT: SERVICEABLE INJECTED-$field"
    imp_rc=$RC
    forged=no
    both | grep -aq "^VERDICT: SERVICEABLE INJECTED" && forged=yes
    run -- report --db "$db" --tail N200
    both | grep -aq "^VERDICT: SERVICEABLE INJECTED" && forged=yes
    run -- fleet --db "$db"
    both | grep -aq "^VERDICT: SERVICEABLE INJECTED" && forged=yes
    result ctrl "newline-in-$field" "no forged 'VERDICT: SERVICEABLE' line in import, report or fleet" "$(test $forged = no; echo $?)" "import exit $imp_rc; forged line printed: $forged"
done
for field in serial technician; do
    db=esc_$field.db
    rm -f "$db"
    imp "$db" run_a.csv "--$field" "A${ESCS}"
    raw=no; esc && raw=yes
    for cmd in report fleet; do
        if [ $cmd = report ]; then run -- report --db "$db" --tail N200; else run -- fleet --db "$db"; fi
        esc && raw=yes
    done
    run -- export --db "$db" --tail N200 --format json --no-samples
    esc && raw=yes
    result ctrl "escape-in-$field" "no raw ESC byte in import/report/fleet/export output" "$(test $raw = no; echo $?)" "raw ESC echoed: $raw"
done
rm -f c1.db
imp c1.db run_a.csv --technician $'A\xc2\x9b2J'
raw=no; esc && raw=yes
run -- report --db c1.db --tail N200; esc && raw=yes
result ctrl c1-csi-in-technician "no raw C1 CSI (U+009B) in import/report output" "$(test $raw = no; echo $?)" "raw CSI echoed: $raw"
meta_csv esc_meta.csv "s/^# source=.*/# source=$(printf '\033')[2J$(printf '\033')[31mRED/"
run -- estimate esc_meta.csv
raw=no; esc && raw=yes
imp esc_meta.db esc_meta.csv; esc && raw=yes
result ctrl escape-in-run-metadata "no raw ESC from run metadata in estimate/import output" "$(test $raw = no; echo $?)" "raw ESC echoed: $raw"
sed "$((header_lines + 1))s/\$/,$(printf '\033')[2Jextra/" run_a.csv | sed "$((header_lines + 2)),\$s/\$/,0/" >esc_header.csv
run -- estimate esc_header.csv
result ctrl escape-in-csv-header "no raw ESC from a CSV column name in estimate output" "$(! esc; echo $?)"
sed "$((header_lines + 5))s/^\([^,]*\),/\1$(printf '\033')[2J,/" run_a.csv >esc_cell.csv
run -- estimate esc_cell.csv
result ctrl escape-in-csv-cell "a cell holding ESC is refused without echoing the raw byte" "$(test "$RC" != 0 && ! esc; echo $?)"
cp run_a.csv $'run\e[31mred.csv'
run -- estimate $'run\e[31mred.csv'
result ctrl escape-in-file-name "no raw ESC from the file name in estimate output" "$(! esc; echo $?)"
run -- estimate $'missing\e[2J.csv'
result ctrl escape-in-missing-file-name "the error for a missing file with ESC in its name echoes no raw ESC" "$(test "$RC" != 0 && ! esc; echo $?)"
for field in serial technician; do
    rm -f "long_$field.db"
    imp "long_$field.db" run_a.csv "--$field" "$(head -c 100000 /dev/zero | tr '\0' S)"
    result ctrl "100000-char-$field" "refused: exit != 0, nothing stored, the message is short (< 2000 bytes)" \
        "$(test "$RC" != 0 -a "$(sessions "long_$field.db")" = 0 -a "$(both | wc -c)" -lt 2000; echo $?)" "$(said | cut -c1-120); $(both | wc -c) bytes of output"
done

# ---------------------------------------------------------------- 7. live formulas in CSV outputs
rm -f fx.db
imp fx.db run_a.csv --serial '=HYPERLINK("http://evil.example/s","s")' --operator '+SUM(1,2)' \
    --technician '-cmd|x' --certificate '@SUM(1)'
fx_rc=$RC
csv_formulas() {  # prints the first cell that would be a live formula in a spreadsheet
    python3 -c '
import csv, re, sys
for name in sys.argv[1:]:
    try:
        for row in csv.reader(open(name, newline="", errors="replace")):
            for c in row:
                if (c and c[0] in "=+@\t\r") or (c[:1] == "-" and not re.fullmatch(r"-[0-9.eE+-]+", c)):
                    print("%s: %r" % (name.rsplit("/", 1)[-1], c[:40])); sys.exit()
    except OSError:
        pass
' "$@"
}
run -- fleet --db fx.db --format csv --out fleet.csv
f=$(csv_formulas fleet.csv)
result formula fleet-csv "no CSV cell starting with = + - @ (neutralised) in fleet --format csv" "$(test "$RC" = 0 -a -z "$f"; echo $?)" "import exit $fx_rc, fleet exit $RC; ${f:-no formula cell}"
rm -rf exportcsv
run -- export --db fx.db --tail N200 --format csv --out exportcsv --no-samples
f=$(csv_formulas exportcsv/*.csv)
result formula export-csv "no CSV cell starting with = + - @ in export --format csv" "$(test "$RC" = 0 -a -z "$f"; echo $?)" "export exit $RC; ${f:-no formula cell}"
run -- report --db fx.db --tail N200 --format csv --out report.csv
f=$(csv_formulas report.csv)
result formula report-csv "no CSV cell starting with = + - @ in report --format csv" "$(test "$RC" = 0 -a -z "$f"; echo $?)" "report exit $RC; ${f:-no formula cell}"

# ---------------------------------------------------------------- 8. passwords in URIs
PW=S3cretPW
mkdir -p pwdir
pwcase() {  # pwcase CASE ARGS...: run in the empty pwdir; the password never printed, no file created
    local case=$1; shift
    ( cd pwdir && timeout -k 5 20 "$EMADIAG" "$@" ) </dev/null >"$OUT" 2>"$ERR"
    RC=$?
    local made
    made=$(cd pwdir && find . -mindepth 1 | head -3 | tr '\n' ' ')
    result password "$case" "exit != 0, '$PW' never printed, no file created" \
        "$(test "$RC" != 0 -a -z "$made" && ! has -F "$PW"; echo $?)" "$(said); created: ${made:-nothing}"
    rm -rf pwdir; mkdir pwdir
}
BADURI="postgresql://alice:$PW@[::1:5432/fleet"
pwcase report-malformed-uri report --db "$BADURI" --tail N100
pwcase trend-malformed-uri trend --db "$BADURI" --tail N100
pwcase fleet-malformed-uri fleet --db "$BADURI"
pwcase sync-malformed-uri sync --db "$W/hh.db" --to "$BADURI"
pwcase sync-password-in-uri sync --db "$W/hh.db" --to "postgresql://alice:$PW@127.0.0.1:1/fleet?user=alice"
pwcase report-password-query report --db "postgresql://127.0.0.1:1/fleet?user=alice&password=$PW" --tail N100
pwcase import-uri-as-db import "$W/run_a.csv" --db "postgresql://alice:$PW@localhost/fleet" --tail N100 --position LH-ELEV --utc "$UTC"
pwcase verify-uri-as-db verify --db "postgresql://alice:$PW@localhost/fleet" --tail N100
pwcase export-uri-as-db export --db "postgresql://alice:$PW@localhost/fleet" --tail N100
pwcase history-sim-uri-as-db history-sim --db "postgresql://alice:$PW@localhost/fleet" --tail N100 --sessions 1
pwcase recover-uri-as-db recover --db "postgresql://alice:$PW@localhost/fleet"

# ---------------------------------------------------------------- 9. partial histories (failure, signals)
# A history whose third session fails (FDJ driven out of the simulator's range between sessions 2 and 3).
rm -f ph.db
run -- history-sim --db ph.db --tail N400 --position LH-ELEV --sessions 3 --noise none --days-between 30 --fdj-start 0.08 --fdj-rate-per-100d 0.09
n=$(sessions ph.db)
result partial session-3-fails "a history whose session 3 fails: exit != 0 and no partial set (0 or 3 sessions)" \
    "$(test "$RC" != 0 && { [ "$n" = 0 ] || [ "$n" = 3 ]; }; echo $?)" "$(said); $n sessions stored"
HS_N=20
signal_case() {  # signal_case SIGNAL: history-sim of HS_N sessions, SIGNAL 0.5 s after it created the database
    local sig=$1 db=sig_$1.db
    rm -f "$db"
    timeout -k 5 60 "$EMADIAG" history-sim --db "$db" --tail N500 --position LH-ELEV --sessions $HS_N --noise none >"$OUT" 2>"$ERR" &
    local pid=$! i
    for i in $(seq 200); do [ -e "$db" ] && break; sleep 0.05; done
    sleep 0.5
    # timeout forwards TERM/INT; KILL goes to emadiag itself.
    if [ "$sig" = KILL ]; then
        local child
        child=$(pgrep -P "$pid" | head -1)
        [ -n "$child" ] && kill -KILL "$child"
    else
        kill -s "$sig" "$pid" 2>/dev/null
    fi
    { wait "$pid"; } 2>/dev/null
    RC=$?
    local n1 n2 what
    n1=$(sessions "$db")
    what="after SIG$sig: $n1 of $HS_N sessions"
    [ "$n1" = $HS_N ] && what="$what (it finished before the signal: nothing shown)"
    if [ "$n1" != 0 ] && [ "$n1" != $HS_N ]; then
        timeout -k 5 60 "$EMADIAG" history-sim --db "$db" --tail N500 --position LH-ELEV --sessions $HS_N --noise none >/dev/null 2>&1
        n2=$(sessions "$db")
        what="$what, the same command again -> $n2"
    fi
    RC=0   # the signal is the probe's own doing, not a crash
    result partial "sig$sig" "history-sim is all or nothing, or resumable: 0 or $HS_N sessions, or $HS_N after re-running it" \
        "$(test "$n1" = 0 -o "$n1" = $HS_N -o "${n2:-x}" = $HS_N; echo $?)" "$what"
    run -- verify --db "$db" --tail N500
    [ "$n1" = 0 ] && [ ! -e "$db" ] && RC=0
    result partial "sig$sig-verify" "the database after SIG$sig verifies (or was never created)" \
        "$(test "$RC" = 0 || { test "$(sessions "$db")" = 0 && ! has -i -e corrupt -e malformed; }; echo $?)"
}
signal_case INT
signal_case TERM
signal_case KILL

# ---------------------------------------------------------------- 10. concurrent creation of a new database
for rep in 1 2 3 4 5; do
    db=cc$rep.db
    rm -f "$db"
    pids=()
    for i in 1 2 3 4; do
        timeout -k 5 60 "$EMADIAG" import run_a.csv --db "$db" --tail N60$i --position LH-ELEV --utc "$UTC" >"$W/.cc$i" 2>&1 &
        pids+=($!)
    done
    fails=0
    for p in "${pids[@]}"; do wait "$p" || fails=$((fails + 1)); done
    n=$(sessions "$db")
    RC=0
    result concurrency "4-imports-new-db-$rep" "4 concurrent imports into a new database: all exit 0, 4 sessions stored" \
        "$(test "$fails" = 0 -a "$n" = 4; echo $?)" "$fails of 4 failed ($(cat "$W"/.cc? | grep -a -m1 -i error | tr -c '[:print:]' ' ' | cut -c1-100)); $n sessions"
done
rm -f cch.db
pids=()
for i in 1 2 3 4; do
    timeout -k 5 60 "$EMADIAG" history-sim --db cch.db --tail N70$i --position LH-ELEV --sessions 1 --noise none >"$W/.cc$i" 2>&1 &
    pids+=($!)
done
fails=0
for p in "${pids[@]}"; do wait "$p" || fails=$((fails + 1)); done
RC=0
result concurrency 4-history-sims-new-db "4 concurrent history-sims into a new database: all exit 0, 4 sessions" \
    "$(test "$fails" = 0 -a "$(sessions cch.db)" = 4; echo $?)" "$fails of 4 failed; $(sessions cch.db) sessions"

# ---------------------------------------------------------------- 11. train: no abort, no unusable model
trainc() {  # trainc CASE DATASET ARGS...: refused (1..127), no model written
    local case=$1 ds=$2; shift 2
    rm -f "m_$case.json"
    local defaults=()
    [[ " $* " == *" --neurons "* ]] || defaults+=(--neurons 3)
    [[ " $* " == *" --max-epochs "* ]] || defaults+=(--max-epochs 3)
    run -t 25 -- train --dataset "$ds" --out "m_$case.json" "${defaults[@]}" "$@"
    result train "$case" "refused: 0 < exit < 128, no model file written" "$(test "$RC" != 0 -a ! -e "m_$case.json"; echo $?)"
}
trainc timesteps-0 t.ds --timesteps 0
trainc timesteps-1 t.ds --timesteps 1
trainc timesteps-minus-1 t.ds --timesteps -1
trainc outputs-duplicate t.ds --timesteps 20 --outputs FDJ_Nm,FDJ_Nm
trainc goal-nan t.ds --timesteps 20 --goal nan
trainc goal-inf t.ds --timesteps 20 --goal inf
trainc max-epochs-minus-3 t.ds --timesteps 20 --max-epochs -3
trainc neurons-0 t.ds --timesteps 20 --neurons 0
trainc runs-minus-1 t.ds --timesteps 20 --runs -1
python3 - t.ds <<'EOF'
import json, math, struct, sys
raw = open(sys.argv[1], "rb").read()
L = struct.unpack_from("<Q", raw, 8)[0]
h = json.loads(raw[16:16 + L])
S, runs = h["samples_per_run"], h["runs"]
R = 8 * (4 + 1 + 6 * S)
body = raw[16 + L:]
def write(name, header, records):
    t = json.dumps(header).encode()
    open(name, "wb").write(b"EMADSET1" + struct.pack("<Q", len(t)) + t + b"".join(records))
recs = [bytearray(body[i * R:(i + 1) * R]) for i in range(runs)]
# 1 and 2 samples per run
for n in (1, 2):
    write("ds_%dsamples.ds" % n, dict(h, samples_per_run=n), [r[:8 * 5 + 8 * 6 * n] for r in recs])
def patched(off, value, which=0):
    out = [bytearray(r) for r in recs]
    struct.pack_into("<d", out[which], off, value)
    return out
write("ds_inf_sample.ds", h, patched(8 * 5 + 8 * 6 * 100 + 8 * 1, math.inf))   # current of sample 100, run 0
write("ds_nan_label.ds", h, patched(0, math.nan))
write("ds_fdj_100.ds", h, patched(0, 100.0))
EOF
for n in 1 2; do
    run -t 25 -- train --dataset "ds_${n}samples.ds" --out "m_${n}s.json" --neurons 3 --max-epochs 3 --resample mean
    result train "dataset-$n-samples-per-run" "no abort: refused, or a model trained (exit < 128, no 'terminate called')" "$(true; echo $?)"
done
for c in inf_sample nan_label fdj_100; do
    rm -f "m_$c.json"
    run -t 25 -- train --dataset "ds_$c.ds" --out "m_$c.json" --neurons 3 --max-epochs 3 --timesteps 20
    bad=$(python3 -c '
import json, math, sys
try:
    m = json.load(open(sys.argv[1]))
except FileNotFoundError:
    sys.exit()
except Exception as e:
    print("unreadable model: %s" % e); sys.exit()
se = m.get("std_error_normalised") or [None]
if any(v is None or not math.isfinite(v) for v in se): print("model written with std_error %s" % se)
else: print("model written")' "m_$c.json")
    result train "dataset-$c" "refused (exit != 0, no model) — never a model trained on it" "$(test "$RC" != 0 -a -z "$bad"; echo $?)" "$(said); ${bad:-no model}"
done
run -t 25 -- train --dataset t.ds --out m_neg.json --neurons -1 --timesteps 20
result messages train-neurons-minus-1 "refused with a clear message (no bad_alloc, no std::), exit non-zero, no crash" "$(test "$RC" -ne 0 && test "$RC" -lt 128 && ! has -e bad_alloc; echo $?)"

# ---------------------------------------------------------------- 12/13. unbounded work and input
python3 - run_b.csv 100000 <<'EOF'
import sys
src, n = sys.argv[1], int(sys.argv[2])
head, rows = [], []
for line in open(src):
    (head if line.startswith("#") or line[:1].isalpha() else rows).append(line.rstrip("\n"))
p = 0.0005
with open("long_%d.csv" % n, "w") as f:
    f.write("\n".join(head) + "\n")
    for k in range(n):
        cells = rows[k % len(rows)].split(",")
        cells[0] = repr(p * (k + 1))
        f.write(",".join(cells) + "\n")
EOF
start=$(date +%s)
run -t 40 -m 2000000 -- discover long_100000.csv
result bounds discover-100000-rows "discover on 100,000 rows ends within 40 s under a 2 GB address-space cap, no crash" "$(true; echo $?)" "$(said); $(( $(date +%s) - start )) s"
truncate -s 600M huge.csv
run -t 20 -m 400000 -- import huge.csv --db huge.db --tail N800 --position LH-ELEV --utc "$UTC"
result bounds import-600MB-file "a 600 MB file is refused within a 400 MB address space: 0 < exit < 128, nothing stored" \
    "$(test "$RC" != 0 -a "$(sessions huge.db)" = 0; echo $?)"
run -t 20 -m 400000 -- estimate huge.csv
result bounds estimate-600MB-file "a 600 MB file is refused within a 400 MB address space" "$(test "$RC" != 0; echo $?)"
{ printf '{"positions": ['; for i in $(seq 1 2000); do printf '{"name": "P%d", "ata": "27-30", "description": "%s"},' "$i" "$(head -c 20000 /dev/zero | tr '\0' d)"; done; printf '{"name": "LH-ELEV", "ata": "27-30", "description": "x"}]}\n'; } >big_positions.json
run -t 20 -m 400000 -- import run_a.csv --db bp.db --tail N801 --position LH-ELEV --utc "$UTC" --positions big_positions.json
result positions file-40MB "a 40 MB positions file is refused within a 400 MB address space, nothing stored" \
    "$(test "$RC" != 0 -a "$(sessions bp.db)" = 0; echo $?)" "$(said); $(sessions bp.db) sessions; db $(du -k bp.db 2>/dev/null | cut -f1) KB"
run -t 20 -m 400000 -e EMADIAG_POSITIONS=/dev/zero -- import run_a.csv --db bz.db --tail N802 --position LH-ELEV --utc "$UTC"
result positions env-dev-zero "EMADIAG_POSITIONS=/dev/zero is refused (no unbounded read), nothing stored" "$(test "$RC" != 0 -a "$(sessions bz.db)" = 0; echo $?)"
run -t 10 -e EMADIAG_POSITIONS="$W/fifo" -- history-sim --db bf.db --tail N803 --position LH-ELEV --sessions 1 --noise none
result positions env-fifo "EMADIAG_POSITIONS=FIFO nobody writes: refused, no hang" "$(test "$RC" != 0; echo $?)"

# ---------------------------------------------------------------- 14. seeds and counts do not wrap
numcase() {  # numcase CASE ARGS...: refused with exit 1..127
    local case=$1; shift
    run -t 20 -- "$@"
    result numbers "$case" "refused: exit != 0" "$(test "$RC" != 0; echo $?)"
}
numcase simulate-seed-minus-1 simulate --case A --seed -1
numcase simulate-seed-2pow64 simulate --case A --seed 18446744073709551616
numcase simulate-seed-empty simulate --case A --seed ""
numcase dataset-seed-minus-1 dataset --count 2 --seed -1 --out ds_seed.ds
numcase report-seed-minus-1 report --db hh.db --tail N100 --seed -1
numcase fleet-seed-2pow64 fleet --db hh.db --seed 18446744073709551616
numcase fleet-horizon-cycles-nan fleet --db hh.db --horizon-cycles nan
numcase report-horizon-cycles-nan report --db hh.db --tail N100 --horizon-cycles nan
numcase report-horizon-days-inf report --db hh.db --tail N100 --horizon-days inf
numcase trend-horizon-days-nan trend --db hh.db --tail N100 --horizon-days nan
numcase fleet-draws-minus-1 fleet --db hh.db --draws -1
numcase report-draws-0 report --db hh.db --tail N100 --draws 0
numcase trend-draws-2pow31 trend --db hh.db --tail N100 --draws 2147483648
rm -f cy.db
run -t 20 -- history-sim --db cy.db --tail N900 --position LH-ELEV --sessions 3 --noise none --cycles 9223372036854775807 --cycles-per-day 4
result numbers history-sim-cycles-int64-max "refused before anything is stored (exit != 0, 0 sessions)" "$(test "$RC" != 0 -a "$(sessions cy.db)" = 0; echo $?)" "$(said); $(sessions cy.db) sessions"
rm -f cy2.db
run -t 20 -- history-sim --db cy2.db --tail N901 --position LH-ELEV --sessions 3 --noise none --hours 1e308 --cycles-per-day 4
result numbers history-sim-hours-1e308 "refused before anything is stored (exit != 0, 0 sessions)" "$(test "$RC" != 0 -a "$(sessions cy2.db)" = 0; echo $?)" "$(said); $(sessions cy2.db) sessions"

# ---------------------------------------------------------------- 15. clear messages
run -t 20 -- dataset --count 0 --out c0.ds
result messages dataset-count-0 "refused with a short message: no number of 30+ digits, < 500 bytes" \
    "$(test "$RC" != 0 -a "$(both | wc -c)" -lt 500 && ! both | grep -aqE '[0-9]{30}'; echo $?)"
run -t 20 -m 2000000 -- dataset --count 2147483647 --out cbig.ds
result messages dataset-count-int-max "refused at once with a message naming the limit (not 'only 0 of 0')" \
    "$(test "$RC" != 0 && ! has -e 'only 0 of 0'; echo $?)"
printf '# k_t_Nm_per_A=0.2\n# J_kgm2=0.000165\n# tau=800\n# sample_period_s=0.0005\n# case=B\x00TRAILING-PART\n# sequence=dyn\n' >nul.csv
tail -n +"$(($(grep -c '^#' run_b.csv) + 1))" run_b.csv >>nul.csv
run -- estimate nul.csv
result messages nul-byte-in-csv "refused; the message shows what follows the NUL (not cut short) and holds no NUL byte" \
    "$(test "$RC" != 0 && ! both | grep -aqP '\x00' && has -e TRAILING; echo $?)"
mkdir -p dbdir.db
run -- report --db dbdir.db --tail N100
result messages report-db-directory "says the database is a directory (not 'does not exist')" \
    "$(test "$RC" != 0 && has -e director && ! has -e 'does not exist'; echo $?)"
python3 -c "open('enc16.csv','wb').write(open('run_b.csv').read().encode('utf-16'))"
run -- estimate enc16.csv
result messages utf16-csv "a UTF-16 file is refused with an encoding hint (UTF-16/encoding)" "$(test "$RC" != 0 && has -e 'utf-16' -e utf16 -e encoding; echo $?)"
{ printf '\xef\xbb\xbf'; cat run_b.csv; } >mark8.csv
run -- estimate mark8.csv
result messages utf8-bom-csv "a UTF-8 BOM is read, or refused with a BOM/encoding hint" "$(test "$RC" = 0 || has -e bom -e 'byte order' -e encoding; echo $?)"
deep="torque: $(head -c 30000 /dev/zero | tr '\0' '(')0.01$(head -c 30000 /dev/zero | tr '\0' ')')"
run -- simulate --case A --term "$deep"
result messages term-30000-deep "refused with an error under 2000 bytes" "$(test "$RC" != 0 -a "$(both | wc -c)" -lt 2000; echo $?)" "$(said | cut -c1-100); $(both | wc -c) bytes"
readonly_case() {  # readonly_case CMD: on hh.db in a read-only bind mount
    local cmd=$1
    mkdir -p ro
    cpdb hh.db ro/ro.db
    if ! unshare -m true 2>/dev/null; then result messages "$cmd-read-only-media" "a probe set-up: unshare -m (run as root)" 1 "unshare -m not permitted"; return; fi
    unshare -m bash -c 'mount --bind -o ro "$0/ro" "$0/ro" || exit 99; cd "$0"; exec timeout -k 5 20 "$@"' "$W" "$EMADIAG" "$cmd" --db ro/ro.db --tail N100 >"$OUT" 2>"$ERR"
    RC=$?
    result messages "$cmd-read-only-media" "$cmd reads a database on read-only media: exit 0" "$(test "$RC" = 0; echo $?)"
}
readonly_case report
readonly_case verify

echo "$PASSED passed, $FAILED failed"
if [ "${PROBE_KEEP:-1}" = 0 ]; then cd / && rm -rf "$W"; fi
[ "$FAILED" = 0 ]
