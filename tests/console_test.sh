#!/usr/bin/env bash
# The operator's view: `imuqual run --station FILE` in a terminal (a tmux
# pane, 140 x 45; soaks read frame by frame at 100 x 30 and 80 x 24 and checked
# against the archive; the Ctrl-C soak at 80 x 24), read the way a person reads it. A soak of four units in
# named slots with two analyze shards: the live table (slots, units, axes,
# elapsed vs planned, live bias instability, provisional verdicts, progress
# bar); the store and an analyze shard killed mid-soak and restarted by the
# station, the soak still archived whole and analysed bit for bit; the final verdict table and report. Then a second
# soak stopped with Ctrl-C: runs archived as aborted, nothing measured lost.
# Usage: console_test.sh BIN_DIR SOURCE_DIR
set -euo pipefail
bin="$1"
src="$2"
work="$(mktemp -d)"
sock="imuqual-console-$$"
tm() { tmux -L "$sock" -f "$work/tmux.conf" "$@"; }
cleanup() {
  tm kill-server 2>/dev/null || true
  rm -rf "$work"
}
trap cleanup EXIT
echo "set -g remain-on-exit on" >"$work/tmux.conf"

fail() {
  echo "FAIL: $*" >&2
  echo "--- screen:" >&2
  tm capture-pane -p -t soak >&2 2>/dev/null || true
  echo "--- process log (tail):" >&2
  tail -n 30 "$work/lot.db.log" >&2 2>/dev/null || true
  exit 1
}
# A capture that fails (tmux once said "server exited unexpectedly" here on a
# host loaded by other work) is tried again; a server that is really gone
# fails the test with the process log. Read it as `x="$(screen)" || exit 1`
# (fail, in the command substitution's subshell, prints why), never in a
# pipeline, where its exit would end only the pipeline.
screen() {
  local try
  for try in 1 2 3 4 5; do
    tm capture-pane -p -t soak 2>"$work/tmux.err" && return 0
    sleep 0.5
  done
  fail "tmux capture-pane failed 5 times: $(cat "$work/tmux.err")"
}
# Waits until the screen matches the extended regular expression.
wait_screen() {
  local pattern="$1" timeout="$2" t=0 now
  while :; do
    now="$(screen)" || exit 1
    printf '%s\n' "$now" | grep -Eq -- "$pattern" && return 0
    sleep 0.5
    t=$((t + 1))
    [ "$t" -lt $((timeout * 2)) ] || fail "no '$pattern' on screen within $timeout s"
  done
}
# The pane runs `imuqual run` under a shell that reports its exit code (the
# shell keeps Ctrl-C for imuqual: its trap runs only once imuqual has ended).
start_soak() {  # [COLUMNS ROWS], default 140 x 45
  tm new-session -d -s soak -x "${1:-140}" -y "${2:-45}" \
    "trap : INT; '$bin/imuqual' run --station '$work/station.textproto'; echo \"imuqual run exited with \$?\""
}
wait_exit() {
  local now
  wait_screen "^imuqual run exited with [0-9]+$" "$1"
  now="$(screen)" || exit 1
  printf '%s\n' "$now" | sed -nE 's/^imuqual run exited with ([0-9]+)$/\1/p' | tail -n 1
}
sql() { sqlite3 "$work/lot.db" "$1"; }

# A short-soak variant of the VG700CA plan: 20 simulated minutes suffice.
sed 's/^min_duration_s: .*/min_duration_s: 600/; s/^name: .*/name: "vg700ca-short"/' \
  "$src/plans/vg700ca.textproto" >"$work/plan.textproto"
write_config() {  # PACE [LOT ARCHIVE]
  cat >"$work/station.textproto" <<EOF
# Bench C, four fixtures
station_id: "bench-C"
lot: "${2:-CONSOLE-LOT}"
operator_name: "ana"
plan: "plan.textproto"
duration_s: 1200
archive: "${3:-lot.db}"
analyze_shards: 2
pace: $1
rate_hz: 100
slot { name: "A1" unit_serial: "SN-101" source: "sim:vg700,index=0" }
slot { name: "A2" unit_serial: "SN-102" source: "sim:vg700,index=1" }
slot { name: "B1" unit_serial: "SN-103" source: "sim:vg700,index=2" }
slot { name: "B2" unit_serial: "SN-104" source: "sim:vg700,index=3" }
EOF
}

# --- A configuration error is one line naming the file and line.
printf 'station_id: "bench-C"\nlot: "L"\nplan: "builtin:vg700ca"\nduration_s: -5\n' >"$work/bad.textproto"
set +e
err="$("$bin/imuqual" run --station "$work/bad.textproto" 2>&1)"
code=$?
set -e
[ "$code" = 2 ] || fail "bad configuration: exit $code"
[ "$(printf '%s\n' "$err" | wc -l)" = 1 ] || fail "bad configuration: not one line: $err"
printf '%s' "$err" | grep -q "bad.textproto:4: duration_s: must be > 0" || fail "bad configuration: $err"

# --- Soak 1: live table, the store killed and restarted, the end.
write_config 40
start_soak
wait_screen "imuqual station bench-C +lot CONSOLE-LOT +plan vg700ca-short +operator ana" 20
wait_screen "^A1 +SN-101 .*running" 30
# The live bias instability of A1 itself, once past the warm-up (units reach
# it one after another; on a loaded host "deg/h" on another row came first).
# A live value with its marks: "≤ 9.8", "10.2†", "10.2‡", "10.2 ± 0.81" (n/m has no number).
v='(≤ )?[0-9.]+(†|‡)?( ± [0-9.e+-]+)?'
p='((pass|marginal|fail)\?|pending)'
wait_screen "^A1 .* x +($p +)?$v deg/h" 30
# Both analyze shards heard (on a loaded host a shard's status can lag its
# first results, and the line reads "analyze 1/1" or "1/2" for a moment).
wait_screen "analyze 2/2" 30
now="$(screen)" || exit 1
# Each row: slot, unit, the unit's verdict (and why, when not a pass), state,
# elapsed / planned, axis, the axis's verdict, its live value, samples, gaps.
for want in "^\[#*\.*\] +[0-9]+% +elapsed" "^B2 +SN-104 .*running +[0-9:]+ / 20:00" \
    "^A1 +SN-101 +$p .* x +$p +$v deg/h" "^ +y +$p +$v deg/h" "^ +z +$p +$v deg/h" \
    "Ctrl-C: stop the soak"; do
  printf '%s\n' "$now" | grep -Eq -- "$want" || fail "live table lacks '$want'"
done
pkill -9 -f "imuqual-store .*--db $work/lot.db" || fail "no store process to kill"
wait_screen "store up \(restarted 1x\)" 30
# (This station's shard only: another station on this host keeps its own.)
station_pid="$(pgrep -d, -f "imuqual run --station $work/station.textproto")" ||
  fail "no imuqual run process"
pkill -9 -P "$station_pid" -f "imuqual-analyze .*--shard 1/2" || fail "no analyze shard 1/2 to kill"
wait_screen "analyze 2/2 \(restarted 1x\)" 30
code="$(wait_exit 240)"
[ "$code" = 0 ] || fail "soak 1: imuqual run exit $code"
final="$(screen)" || exit 1
for want in "^4 units: [0-9]+ PASS, [0-9]+ MARGINAL, [0-9]+ FAIL$" "^A1 +SN-101 +x " "^B2 +SN-104 +z " \
    "^report: $work/lot-CONSOLE-LOT.html$" "restarted 2 time"; do
  printf '%s\n' "$final" | grep -Eq -- "$want" || fail "final screen lacks '$want'"
done
printf '%s\n' "$final" | grep -q "running" && fail "final screen still shows the live table"
[ -s "$work/lot-CONSOLE-LOT.html" ] || fail "no report file"
[ "$(sql "SELECT COUNT(*) FROM runs WHERE state = 'complete' AND verdict IS NOT NULL")" = 4 ] ||
  fail "soak 1: not 4 complete judged runs: $(sql 'SELECT run_id, state, verdict FROM runs')"
[ "$(sql "SELECT group_concat(slot, ' ') FROM (SELECT slot FROM runs ORDER BY slot)")" = "A1 A2 B1 B2" ] ||
  fail "soak 1: slots $(sql 'SELECT slot FROM runs')"
[ "$(sql "SELECT SUM(samples_archived) || ' ' || SUM(gap_samples) FROM run_archive")" = "480000 0" ] ||
  fail "soak 1: archive $(sql 'SELECT * FROM run_archive')"
# The restarted analysis caught up: each archived result is what the
# analysis of the archived samples gives, bit for bit.
for run in $(sql "SELECT run_id FROM runs"); do
  "$bin/imuqual" reanalyze "$run" --db "$work/lot.db" --check >/dev/null 2>&1 ||
    fail "soak 1: $run: archived result differs from re-analysis"
done
tm kill-session -t soak

# --- Soaks on a 100 x 30 and an 80 x 24 terminal, to the end, read frame by frame: no
# line wider than the screen, "final:" only once no unit is provisional, and
# every number against the archive: each final value a frame shows (a unit
# judged, still on the live table) and the final table's, equal to the
# archived value to the digits shown.
soak_frames() {  # COLUMNS ROWS
  local frames="$work/frames-$1x$2" db="soak-$1x$2.db"
  write_config 120 "CONSOLE-$1x$2" "$db"
  start_soak "$1" "$2"
  mkdir -p "$frames"
  ( n=0; while tm has-session -t soak 2>/dev/null; do
      tm capture-pane -p -t soak >"$frames/$(printf %05d $n)" 2>/dev/null || true
      n=$((n + 1)); sleep 0.25
    done ) &
  local frames_pid=$!
  code="$(wait_exit 240)"
  [ "$code" = 0 ] || fail "soak at $1 x $2: imuqual run exit $code"
  tm capture-pane -p -S - -t soak >"$frames/99999"  # with what scrolled off
  tm kill-session -t soak
  wait "$frames_pid" 2>/dev/null || true
  python3 - "$frames" "$work/$db" "$1" "$2" <<'PY' || fail "soak at $1 x $2: frames against the archive"
import os, re, sqlite3, sys
frames_dir, db, width, height = sys.argv[1], sys.argv[2], int(sys.argv[3]), sys.argv[4]
archived = {}
for slot, axis, value in sqlite3.connect(db).execute(
        "SELECT r.slot, m.axis, m.value FROM measurements m JOIN runs r USING (run_key) "
        "WHERE m.name = 'bias_instability'"):
    archived[(slot, axis)] = value
if len(archived) != 12:
    sys.exit(f"{len(archived)} archived bias_instability values, 12 expected")
problems, checked, final_frames = [], 0, 0
def agrees(text, value, where):
    # The value to the digits shown: within half a unit of its last place.
    decimals = len(text.split(".")[1]) if "." in text else 0
    if abs(float(text) - value) > 0.5 * 10 ** -decimals + 1e-9 * abs(value):
        problems.append(f"{where}: shown {text}, archived {value}")
num = r"([0-9]+(?:\.[0-9]+)?)"
for name in sorted(os.listdir(frames_dir)):
    lines = open(os.path.join(frames_dir, name), encoding="utf-8").read().split("\n")
    for line in lines:
        if len(line) > width:
            problems.append(f"frame {name}: a line of {len(line)} columns")
    text = "\n".join(lines)
    live = "Ctrl-C: stop the soak" in text
    if live and re.search(r"^final:", text, re.M):
        final_frames += 1
        for line in lines:
            if re.match(r"^(A1|A2|B1|B2) ", line) and re.search(r"(pass|fail|marginal)\?|pending|running|waiting", line):
                problems.append(f"frame {name}: 'final:' while a unit is provisional: {line}")
    slot = None
    for line in lines:
        m = re.match(r"^(A1|A2|B1|B2) +SN-10[1-4] ", line)
        if m: slot = m.group(1)
        elif not line.startswith(" "): slot = None
        if slot is None:
            continue
        # A live row of a judged unit: "... x  PASS  10.2 ± 0.81 deg/h".
        row = re.search(r" ([xyz]) +(PASS|FAIL|MARGINAL|INCONCLUSIVE) +" + num + r"(?: ± [0-9.e+-]+)? deg/h", line)
        if live and row and re.match(r"^(A1|A2|B1|B2) +SN-10[1-4] +(PASS|FAIL|MARGINAL|INCONCLUSIVE) ", 
                                    [l for l in lines if l.startswith(slot + " ")][0]):
            agrees(row.group(3), archived[(slot, row.group(1))], f"frame {name} {slot} {row.group(1)}")
            checked += 1
# The final table: slot, serial, axis, ARW, BI (value ± u), ...
last = open(os.path.join(frames_dir, "99999"), encoding="utf-8").read().split("\n")
starts = [i for i, l in enumerate(last) if l.startswith("slot ")]
if not starts:
    sys.exit("no final table on the last screen:\n" + "\n".join(last))
cols = re.split(r"  +", last[starts[-1]].strip())
if "BI deg/h" not in cols:
    sys.exit("the final table has no BI column: " + last[starts[-1]])
bi = cols.index("BI deg/h")
rows = 0
for line in last[starts[-1]:]:
    if re.match(r"^(A1|A2|B1|B2) +SN-10[1-4] ", line):
        cells = re.split(r"  +", line.strip())
        value = cells[bi].split(" ± ")[0].lstrip("≤ ").rstrip("†‡")
        agrees(value, archived[(cells[0], cells[2])], f"final table {cells[0]} {cells[2]}")
        rows += 1
        checked += 1
if rows != 12:
    problems.append(f"final table: {rows} axis rows, 12 expected")
print(f"{width} x {height}: {len(os.listdir(frames_dir))} frames, {final_frames} live frames saying "
      f"final, {checked} numbers checked against the archive")
if problems:
    sys.exit("\n".join(problems[:20]))
PY
}
soak_frames 100 30
soak_frames 80 24

# --- Soak 2, on an 80 x 24 terminal: every unit's row still starts with its
# slot, unit and provisional verdict (the numbers are what a narrow screen
# cuts); then Ctrl-C mid-soak.
write_config 10
start_soak 80 24
wait_screen "^A1 +SN-101 .*running" 30
wait_screen "^A1 +SN-101 +((pass|marginal|fail)\?|pending) " 60
now="$(screen)" || exit 1
for unit in "A2 +SN-102" "B1 +SN-103" "B2 +SN-104"; do
  printf '%s\n' "$now" | grep -Eq -- "^$unit +(((pass|marginal|fail)\?|pending) +)?.*(running|waiting|no data)" ||
    fail "80 x 24: no row '$unit ... running'"
done
# (A line the renderer let run past 80 columns would wrap onto the next
# unit's row and break the patterns above.)
tm send-keys -t soak C-c
code="$(wait_exit 120)"
[ "$code" = 130 ] || fail "soak 2: imuqual run exit $code after Ctrl-C"
final="$(screen)" || exit 1
for want in "^4 units: 0 PASS, 0 MARGINAL, 0 FAIL, 4 ABORTED \(interrupted: runs aborted\)$" \
    "^yield not measurable: no judged unit$" "slot B2 SN-104: run aborted before completion" "^report: "; do
  printf '%s\n' "$final" | grep -Eq -- "$want" || fail "final screen after Ctrl-C lacks '$want'"
done
# Stopped by the operator: ABORTED, not a FAIL of the units.
runs="$(sql "SELECT COUNT(*) FROM runs WHERE lot = 'CONSOLE-LOT' AND state = 'aborted' AND verdict = 'ABORTED'")"
[ "$runs" = 4 ] || fail "soak 2: $runs aborted runs judged; $(sql 'SELECT run_id, state, verdict FROM runs')"
# Everything published before the stop is archived: no gap, every sample.
bad="$(sql "SELECT COUNT(*) FROM runs r JOIN run_archive a USING (run_id)
            WHERE r.state = 'aborted' AND (a.gap_samples != 0 OR a.samples_archived != r.end_sample - r.first_sample
                                           OR a.samples_archived < 6000)")"
[ "$bad" = 0 ] || fail "soak 2: aborted runs lost data: $(sql 'SELECT * FROM run_archive')"
tm kill-session -t soak

# --- Soak 3: the terminal hangs up (a dropped SSH session): killing the tmux
# session sends SIGHUP to the pane's processes. The station stops as for
# Ctrl-C: every run aborted, archived and judged, nothing left running.
before="$(sql "SELECT COUNT(*) FROM runs")"
start_soak
wait_screen "^A1 +SN-101 .*running" 30
wait_screen "deg/h" 40
tm kill-session -t soak
t=0
while pgrep -f "$work/station.textproto" >/dev/null || pgrep -f "$work/lot.db" >/dev/null; do
  sleep 0.5
  t=$((t + 1))
  [ "$t" -lt 240 ] || fail "soak 3: station processes still running 120 s after the hang-up"
done
hung="$(sql "SELECT COUNT(*) FROM runs WHERE run_key > (SELECT MAX(run_key) - 4 FROM runs)
             AND state = 'aborted' AND verdict = 'ABORTED' AND finalized_utime IS NOT NULL")"
[ "$(sql "SELECT COUNT(*) FROM runs")" = $((before + 4)) ] || fail "soak 3: not 4 new runs"
[ "$hung" = 4 ] || fail "soak 3: after a hang-up $hung of 4 runs aborted and judged: $(sql 'SELECT run_id, state, verdict, finalized_utime FROM runs')"
left="$(sql "SELECT COUNT(*) FROM runs WHERE state = 'running' OR finalized_utime IS NULL")"
[ "$left" = 0 ] || fail "soak 3: $left runs left running or unfinished after a hang-up"
# The lot's yield is over judged units only: the two aborted retests of each
# unit neither lower it nor replace soak 1's judgement.
judged="$(sql "SELECT COUNT(*) || ' ' || SUM(verdict IN ('PASS', 'MARGINAL')) FROM runs
               WHERE lot = 'CONSOLE-LOT' AND verdict IN ('PASS', 'MARGINAL', 'FAIL')")"
overview="$(sql "SELECT units || ' ' || aborted || ' ' || retests || ' ' || (pass + marginal + fail) || ' ' ||
                 printf('%.6f', yield) FROM lot_overview WHERE lot = 'CONSOLE-LOT'")"
n_judged="${judged%% *}"
n_passed="${judged##* }"
want="4 0 8 $n_judged $(awk -v p="$n_passed" -v n="$n_judged" 'BEGIN { printf "%.6f", p / n }')"
[ "$n_judged" = 4 ] || fail "soak 3: $n_judged judged runs in the lot (soak 1's 4 expected)"
[ "$overview" = "$want" ] || fail "soak 3: lot_overview '$overview', expected '$want' (units aborted retests judged yield)"
lots="$("$bin/imuqual" lot CONSOLE-LOT --db "$work/lot.db" 2>&1)" || fail "soak 3: imuqual lot failed: $lots"
printf '%s\n' "$lots" | grep -Eq "by their final run: .*[1-9][0-9]* ABORTED" && fail "soak 3: imuqual lot counts aborted retests as final: $lots"
printf '%s\n' "$lots" | grep -Eq "final yield" || fail "soak 3: imuqual lot shows no final yield: $lots"
# --- Soak 4: a unit on a serial line (a text-line device on a pseudo-
# terminal) goes silent (SIGSTOP), then its cable is pulled and plugged in
# again: the console says "no data M:SS", then "reconnecting M:SS", then
# "running" again, and the run ends complete with the unplugged time as a gap.
cat >"$work/serial_plan.textproto" <<EOF
name: "serial-console"
axes { name: "x" kind: GYRO }
axes { name: "y" kind: GYRO }
axes { name: "z" kind: GYRO }
nominal_rate_hz: 100
min_duration_s: 0
warmup_s: 0
limits { measurement: "bias_instability" axis_kind: GYRO high: 1000 unit: "deg/h" }
EOF
cat >"$work/serial.textproto" <<EOF
station_id: "bench-S"
lot: "SERIAL-LOT"
plan: "serial_plan.textproto"
duration_s: 45
archive: "serial.db"
slot { name: "S1" unit_serial: "SN-201" source: "serial:$work/ttyS,protocol=text,baud=115200,rate=100,columns=n/x/y/z,counter=n,counter_bits=32" }
EOF
t0="$(date +%s.%N)"
python3 "$src/tests/serial_feeder.py" "$work/ttyS" 100 "$t0" &
feeder=$!
for _ in $(seq 50); do [ -e "$work/ttyS" ] && break; sleep 0.1; done
[ -e "$work/ttyS" ] || fail "soak 4: the serial feeder made no device"
tm new-session -d -s soak -x 120 -y 30 \
  "trap : INT; '$bin/imuqual' run --station '$work/serial.textproto'; echo \"imuqual run exited with \$?\""
wait_screen "^S1 +SN-201 .*running" 30
sleep 2
kill -STOP "$feeder"
wait_screen "^S1 +SN-201 .*no data 0:0[5-9]" 20
kill -CONT "$feeder"
wait_screen "^S1 +SN-201 .*running" 20
kill "$feeder"  # the cable is pulled
wait "$feeder" 2>/dev/null || true
wait_screen "^S1 +SN-201 .*reconnecting 0:0[0-9]" 20
python3 "$src/tests/serial_feeder.py" "$work/ttyS" 100 "$t0" &
feeder=$!
wait_screen "^S1 +SN-201 .*running" 30
code="$(wait_exit 120)"
kill "$feeder" 2>/dev/null || true
[ "$code" = 0 ] || fail "soak 4: imuqual run exit $code"
serial="$(sqlite3 "$work/serial.db" "SELECT r.state || ' ' || (a.gap_samples > 0) || ' ' || (r.verdict IS NOT NULL)
                                      FROM runs r JOIN run_archive a USING (run_id)")"
[ "$serial" = "complete 1 1" ] || fail "soak 4: run '$serial' (want complete, a gap from the unplug, judged)"
tm kill-session -t soak

echo "console test: ok"
