#!/usr/bin/env bash
# The station on separate hosts, as the README's "Running the processes by
# hand, on separate hosts" lays it out, with each host's link cut mid-soak.
#
# Four hosts are network namespaces this test makes (veth pairs on one
# bridge, 10.77.0.0/24, inside the test's own private network and mount
# namespaces: tests/netns_run): A runs the store (with --sync-to the plant),
# B two analyze shards, C acquire with 8 simulated units, P the plant's
# PostgreSQL (throwaway cluster on TCP). The bus is multicast with ttl=1,
# MACs and role signatures on.
#
# A reference soak of the same lot runs undisturbed first (same layout, no
# cut, as fast as acknowledged). Then the soak under test, paced, with B's,
# A's and C's link cut for 30 s each in turn, and P's from mid-soak until a
# minute after the soak ended (the plant unreachable for minutes while the
# store finalises and ships). Asserted: every run complete, judged, no gap;
# verdicts, measurements, curves and every raw sample equal to the reference
# soak's; after P is back the store's own shipping brings every run to the
# plant (nothing lost), `imuqual sync` then finds nothing to ship (nothing
# duplicated), `imuqual verify` passes at the plant, and the plant's lot
# table equals the station's.
#
# Usage: multihost_test.sh BIN_DIR SOURCE_DIR (run inside tests/netns_run)
set -euo pipefail
bin="${1:?usage: multihost_test.sh BIN_DIR SOURCE_DIR}"
src="${2:?usage: multihost_test.sh BIN_DIR SOURCE_DIR}"
say() { echo "multihost: $*"; }
fail() {
  echo "multihost: FAIL: $*" >&2
  exit 1
}

[ "${IMUQUAL_NETNS:-}" = "1" ] || {
  say "SKIPPED: needs private network namespaces (root); ran without them"
  exit 0
}
for tool in ip runuser; do command -v $tool >/dev/null || fail "$tool is not installed"; done

work="$(mktemp -d /tmp/imuqual-multihost.XXXXXX)"
chmod 755 "$work"
pids=()
cleanup() {
  for p in "${pids[@]}"; do kill "$p" 2>/dev/null || true; done
  ip netns exec P "$src/scripts/pg-throwaway" stop "$work/plant" >/dev/null 2>&1 || true
  # Whatever still runs on a host (each host's processes, whoever started them).
  for h in A B C P; do ip netns pids "$h" 2>/dev/null | xargs -r kill 2>/dev/null || true; done
  wait 2>/dev/null || true
  for h in A B C P; do ip netns del "$h" 2>/dev/null || true; done
  if [ "${KEEP:-}" != "1" ]; then rm -rf "$work"; else say "kept $work"; fi
}
trap cleanup EXIT
trap 'exit 1' INT TERM  # cleanup runs on those too (ctest's timeout)

# The hosts: named namespaces kept in this test's own mount namespace.
mkdir -p /run/netns
mount -t tmpfs imuqual-netns /run/netns
ip link add br0 type bridge mcast_snooping 0
ip link set br0 up
declare -A addr=([A]=10.77.0.1 [B]=10.77.0.2 [C]=10.77.0.3 [P]=10.77.0.4)
for h in A B C P; do
  ip netns add "$h"
  ip link add "to$h" type veth peer name eth0 netns "$h"
  ip link set "to$h" master br0 up
  ip netns exec "$h" ip addr add "${addr[$h]}/24" dev eth0
  ip netns exec "$h" ip link set lo up
  ip netns exec "$h" ip link set eth0 up multicast on
  ip netns exec "$h" ip route add 224.0.0.0/4 dev eth0
done
on() {
  local h="$1"
  shift
  ip netns exec "$h" "$@"
}
cut_link() { ip link set "to$1" down; }
mend_link() { ip link set "to$1" up; }

# The plant.
PG_LISTEN="${addr[P]}" on P "$src/scripts/pg-throwaway" start "$work/plant" >/dev/null
plant="postgresql://imuqual@${addr[P]}:5432/postgres"

# Keys, as the README makes them.
cd "$work"
"$bin/imuqual" keygen --out station.key >/dev/null
for role in acquire analyze store; do "$bin/imuqual" keygen --role $role --out $role.key >/dev/null; done
cat acquire.key.pub analyze.key.pub store.key.pub >station.trust
trust=(--key-file station.key --trust station.trust)

lot=MH-LOT
units=8
duration=7200
rate=20
port=7701

# One soak of the lot across the hosts; "$@": extra store flags. Starts
# (with ip netns exec itself, not a shell function, so that $! is the
# process and killing it stops it)
# store (A), two analyze shards (B) and acquire (C, paced at $pace); leaves
# the pids in store_pid, analyze_pids, acquire_pid.
start_soak() {
  local db="$1" pace="$2"
  shift 2
  local bus="udpm://239.255.76.67:$port?ttl=1&recv_buf_size=4194304"
  port=$((port + 1))
  ip netns exec A "$bin/imuqual-store" --lcm-url "$bus" "${trust[@]}" --sign-key store.key --db "$db" \
    --accept-plan builtin:vg700ca "$@" >"$db.store.log" 2>&1 &
  store_pid=$!
  pids+=("$store_pid")
  analyze_pids=()
  for k in 0 1; do
    ip netns exec B "$bin/imuqual-analyze" --lcm-url "$bus" "${trust[@]}" --sign-key analyze.key \
      --accept-plan builtin:vg700ca --shard "$k/2" >"$db.analyze$k.log" 2>&1 &
    analyze_pids+=("$!")
    pids+=("$!")
  done
  ip netns exec C "$bin/imuqual-acquire" --lcm-url "$bus" "${trust[@]}" --sign-key acquire.key --lot "$lot" \
    --sim "$units" --duration "$duration" --rate "$rate" --plan builtin:vg700ca \
    --await store,analyze --pace "$pace" --station mh-station >"$db.acquire.log" 2>&1 &
  acquire_pid=$!
  pids+=("$acquire_pid")
}

stop_station() {
  kill "$store_pid" "${analyze_pids[@]}" 2>/dev/null || true
  wait "$store_pid" "${analyze_pids[@]}" 2>/dev/null || true
}

logs_of() {
  for f in "$1".*.log; do
    echo "---- $f (last lines)"
    tail -15 "$f"
  done
}

# Waits for acquire to end; fails (with the logs) if it fails.
await_acquire() {
  local db="$1"
  if ! wait "$acquire_pid"; then
    logs_of "$db" >&2
    fail "acquire ended with an error ($db)"
  fi
}

# Waits (bounded) until the store has archived every unit's verdict: acquire
# ends once the store and analyze acknowledged the data, but the last
# verdicts are still on their way from analyze to the store.
await_judged() {
  local db="$1" judged=0
  for _ in $(seq 1 120); do
    judged="$("$bin/imuqual" runs --db "$db" --lot "$lot" --format csv 2>/dev/null | tail -n +2 |
      awk -F, '$7 == "complete" && ($8 == "PASS" || $8 == "MARGINAL" || $8 == "FAIL")' | wc -l)"
    [ "$judged" = "$units" ] && return 0
    sleep 1
  done
  logs_of "$db" >&2
  fail "only $judged of $units units judged 120 s after the soak ($db)"
}

# What is compared between two archives of the lot: every run's state,
# verdict and reasons, every measurement, every curve point, every raw
# sample (run ids and arrival times aside: they name the soak, not the data).
digest_of() {
  local db="$1" out="$2"
  # serial, lot, station, slot, state, verdict, reasons, operator
  "$bin/imuqual" runs --db "$db" --lot "$lot" --format csv | cut -d, -f2-5,7- >"$out.verdicts" ||
    fail "runs --db $db"
  "$bin/imuqual" export --db "$db" --lot "$lot" --format measurements | cut -d, -f1,2,4- |
    sort >"$out.measurements"
  "$bin/imuqual" export --db "$db" --lot "$lot" --format curves | cut -d, -f1,2,4- |
    sort >"$out.curves"
  : >"$out.samples"
  local run serial
  while IFS=, read -r run serial; do
    echo "== $serial" >>"$out.samples"
    "$bin/imuqual" export --db "$db" --run "$run" --format samples | cut -d, -f1,2,4- \
      >>"$out.samples"
  done < <(sqlite3 "$db" "SELECT run_id || ',' || serial FROM runs ORDER BY serial")
}

# 1. The reference soak: same hosts, no cut, as fast as acknowledged.
say "reference soak ($units units, $duration s at $rate Hz, undisturbed)"
start_soak "$work/reference.db" 0
await_acquire "$work/reference.db"
await_judged "$work/reference.db"
stop_station
digest_of "$work/reference.db" "$work/reference"
say "reference: $(wc -l <"$work/reference.samples") sample lines"

# 2. The soak under test: paced, each host's link cut in turn.
pace=40
say "soak under test (pace $pace): B, A and C cut for 30 s each, P from mid-soak"
start_soak "$work/station.db" "$pace" --sync-to "$plant" --sync-period 5
t0=$SECONDS
at() { while [ $((SECONDS - t0)) -lt "$1" ]; do sleep 1; done; }
at 20
say "t=$((SECONDS - t0)) s: cut B (analysis) for 30 s"
cut_link B
at 50
mend_link B
at 70
say "t=$((SECONDS - t0)) s: B is back; cut A (store) for 30 s"
cut_link A
at 90
p_cut_at=$((SECONDS - t0))
say "t=$p_cut_at s: cut P (plant) until a minute after the soak"
cut_link P
at 100
mend_link A
at 120
say "t=$((SECONDS - t0)) s: A is back; cut C (acquire) for 30 s"
cut_link C
at 150
mend_link C
say "t=$((SECONDS - t0)) s: C is back"
await_acquire "$work/station.db"
say "t=$((SECONDS - t0)) s: the soak ended"
await_judged "$work/station.db"
sleep 60
mend_link P
say "t=$((SECONDS - t0)) s: P is back after $((SECONDS - t0 - p_cut_at)) s"

# The store's own shipping catches the plant up (bounded wait: its backoff
# is at most 60 s): the plant's run table becomes the station's.
"$bin/imuqual" runs --db "$work/station.db" --lot "$lot" --format csv >"$work/runs.station.csv"
for _ in $(seq 1 150); do
  on A "$bin/imuqual" runs --db "$plant" --lot "$lot" --format csv >"$work/runs.plant.csv" \
    2>/dev/null || true
  cmp -s "$work/runs.station.csv" "$work/runs.plant.csv" && break
  sleep 1
done
cmp -s "$work/runs.station.csv" "$work/runs.plant.csv" || {
  logs_of "$work/station.db" >&2
  diff "$work/runs.station.csv" "$work/runs.plant.csv" >&2 || true
  fail "the store did not bring the plant up to the station within 150 s of its return"
}
# Each cut really happened (by the processes' own words).
grep -q "shipping is tried again" "$work/station.db.store.log" ||
  fail "the store never met the plant unreachable: the fault did not happen"
grep -q "acquire is back" "$work/station.db.store.log" ||
  fail "the store never missed acquire: the cuts of A and C did not happen"
say "t=$((SECONDS - t0)) s: the store shipped every run to the plant"
stop_station

# Every run complete, judged, without a gap.
bad="$("$bin/imuqual" runs --db "$work/station.db" --lot "$lot" --format csv | tail -n +2 |
  awk -F, '$7 != "complete" || ($8 != "PASS" && $8 != "MARGINAL" && $8 != "FAIL")')"
[ -z "$bad" ] || fail "runs not complete or not judged: $bad"
gaps="$(sqlite3 "$work/station.db" "SELECT count(*) FROM gaps")"
[ "$gaps" = 0 ] || fail "$gaps gap(s) archived"
[ "$(sqlite3 "$work/station.db" "SELECT count(*) FROM runs")" = "$units" ] ||
  fail "the station holds $(sqlite3 "$work/station.db" "SELECT count(*) FROM runs") runs, not $units"

# Equal to the undisturbed soak.
digest_of "$work/station.db" "$work/station"
for part in verdicts measurements curves samples; do
  if ! cmp -s "$work/reference.$part" "$work/station.$part"; then
    diff "$work/reference.$part" "$work/station.$part" | head -20 >&2
    fail "$part differ from the undisturbed soak's"
  fi
  say "$part: equal to the undisturbed soak's ($(wc -l <"$work/station.$part") lines)"
done

# Nothing duplicated at the plant; the plant verifies; the same lot table
# (the plant is reached from the station's host).
again="$(on A "$bin/imuqual" sync --db "$work/station.db" --to "$plant" 2>&1)" ||
  fail "sync again: $again"
echo "$again" | grep -q " 0 runs shipped (0 replaced: judged again), 0 rows inserted, 0 raw chunks" ||
  fail "sync again shipped something: $again"
on A "$bin/imuqual" verify --db "$plant" >"$work/verify.txt" 2>&1 ||
  fail "verify at the plant: $(tail -5 "$work/verify.txt")"
"$bin/imuqual" lot "$lot" --db "$work/station.db" --format csv >"$work/lot.station.csv"
on A "$bin/imuqual" lot "$lot" --db "$plant" --format csv >"$work/lot.plant.csv"
cmp -s "$work/lot.station.csv" "$work/lot.plant.csv" || {
  diff "$work/lot.station.csv" "$work/lot.plant.csv" | head >&2
  fail "the plant's lot table differs from the station's"
}
say "PASS: $units runs equal to the undisturbed soak; shipped once, verified at the plant"
