#!/usr/bin/env bash
# Run the default test suite N times in a row on a deliberately loaded machine, stopping at
# the first failure; one line per run: exit code, seconds, load average, pytest's summary.
#
#   bash experiments/soak_suite.sh [N=5] [busy loops=1]
#
# The load is whatever else runs on the machine plus the given number of busy-loop
# processes at nice 19 (always runnable, so the load average stays above the core count on
# a 2-core machine, while the suite still gets its share).  Each run uses its own pytest
# base temp directory and no cache, as a fresh CI checkout would.
set -u
runs=${1:-5}
loops=${2:-1}
cd "$(dirname "$0")/.."
python=${PYTHON:-python}
hogs=()
for _ in $(seq 1 "$loops"); do
  nice -n 19 "$python" -c 'while True: pass' &
  hogs+=($!)
done
trap 'kill "${hogs[@]}" 2>/dev/null' EXIT
echo "commit $(git rev-parse --short HEAD 2>/dev/null || echo '?'), $(nproc) cores, $loops busy loop(s)"
status=0
for i in $(seq 1 "$runs"); do
  start=$(date +%s)
  base=$(mktemp -d)
  log="$base/pytest.log"
  "$python" -m pytest -q -p no:cacheprovider --basetemp="$base/tmp" > "$log" 2>&1
  status=$?
  echo "run $i: exit $status, $(( $(date +%s) - start )) s, load $(cut -d' ' -f1-3 /proc/loadavg), $(tail -1 "$log")"
  if [ "$status" -ne 0 ]; then
    echo "failed; the log is kept at $log"
    break
  fi
  rm -rf "$base"
done
exit "$status"
