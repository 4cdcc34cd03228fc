#!/usr/bin/env bash
# The test suite as this machine runs it: started from a background shell (SIGINT ignored,
# stdin not a terminal, as a CI runner or `make test &` in a script starts it) while
# `python -m bench ros_cycle --quick` runs beside it, again and again until the suite ends.
# Prints both results; exits with the suite's exit code.
#
#   tools/test_busy.sh [PYTEST ARGS...]      (or: make test-busy ARGS='...')
#   TEST_BUSY_DIR=dir   where the logs go (default: a new /tmp/test-busy-* directory)
#   TEST_BUSY_BENCH=0   no benchmark beside it (only the background-shell start)
set -uo pipefail
cd "$(dirname "$0")/.."
VENV=${DRIVE_BRIDGE_VENV:-.venv}
OUT=${TEST_BUSY_DIR:-$(mktemp -d /tmp/test-busy-XXXXXX)}
mkdir -p "$OUT"
tools/bootstrap.sh >/dev/null || exit 2
export ROS_AUTOMATIC_DISCOVERY_RANGE=${ROS_AUTOMATIC_DISCOVERY_RANGE:-LOCALHOST}
suite_domain=$((RANDOM % 45 + 1))  # the suite and the benchmark on DDS domains of their own
bench_domain=$((suite_domain + 50))

started=$(date +%s)
# A non-interactive shell starts an asynchronous command with SIGINT and SIGQUIT ignored and
# its stdin on /dev/null: exactly what the suite inherits from a background launcher.
LOG="$OUT/suite.log" PIDFILE="$OUT/suite.pid" ROS_DOMAIN_ID=$suite_domain \
    bash -c '"$0" -m pytest "$@" > "$LOG" 2>&1 & echo $! > "$PIDFILE"; wait $!' "$VENV/bin/python" "$@" &
runner=$!
while [ ! -s "$OUT/suite.pid" ]; do sleep 0.1; done
suite_pid=$(cat "$OUT/suite.pid")
ignored=$(awk '/^SigIgn:/ {print $2}' "/proc/$suite_pid/status" 2>/dev/null || echo 0)
if (( 16#${ignored:-0} & 2 )); then sigint=ignored; else sigint='NOT ignored'; fi
echo "test-busy: the suite started (pid $suite_pid, SIGINT $sigint, stdin $(readlink "/proc/$suite_pid/fd/0")) -> $OUT/suite.log"

runs=0
failed_runs=0
if [ "${TEST_BUSY_BENCH:-1}" != 0 ]; then
    while kill -0 "$suite_pid" 2>/dev/null; do
        runs=$((runs + 1))
        ROS_DOMAIN_ID=$bench_domain "$VENV/bin/python" -m bench ros_cycle --quick > "$OUT/bench-$runs.log" 2>&1 < /dev/null
        code=$?
        [ "$code" = 0 ] || failed_runs=$((failed_runs + 1))
        echo "test-busy: bench ros_cycle --quick run $runs exited $code -> $OUT/bench-$runs.log"
    done
fi
wait "$runner"
suite_code=$?
ended=$(date +%s)

echo
echo "test-busy: the suite: exit code $suite_code, $(( (ended - started) / 60 )) min $(( (ended - started) % 60 )) s wall"
grep -E '^(FAILED|ERROR) ' "$OUT/suite.log" | sed 's/^/  /'
tail -n 1 "$OUT/suite.log" | sed 's/^/  /'
if [ "$runs" -gt 0 ]; then
    echo "test-busy: bench ros_cycle --quick beside it: $runs run(s), $failed_runs failed; the last one's table:"
    grep -E '^ *[0-9]+ +[0-9.]+ |^ *axes|^ +ratio' "$OUT/bench-$runs.log" | sed 's/^/  /'
    grep -c 'could not run' "$OUT"/bench-*.log | awk -F: '$2 > 0 {print "  " $1 ": " $2 " case(s) could not run"}'
fi
exit "$suite_code"
