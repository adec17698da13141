#!/usr/bin/env bash
# Alternating pairs of tests/python/test_safety_process.py: A with reliable observers (rclpy
# and `naic record`, the suite's setting), B with best-effort ones; each run's recording
# goes to OUT/A<i> or OUT/B<i> (NAIC_TAKEOVER_DUMP), the pytest line to OUT/summary.txt.
# Start a load beside it (docs/nodes.md, "Reliable observers"), then read the driver's own
# wake-up report with observer_qos.py OUT.
#   bash docs/figures/nodes/observer_qos_pairs.sh OUT [FIRST LAST]
set -u
out=${1:?usage: observer_qos_pairs.sh OUT [FIRST LAST]}
mkdir -p "$out"; out=$(cd "$out" && pwd)
cd "$(dirname "$0")/../../.."
py=${NAIC_VENV:-.venv}/bin/python
for i in $(seq "${2:-1}" "${3:-10}"); do
  for v in A B; do
    obs=reliable; [ $v = B ] && obs=best_effort
    rm -rf "$out/$v$i"
    NAIC_TAKEOVER_OBSERVERS=$obs NAIC_TAKEOVER_DUMP="$out/$v$i" ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST \
      timeout 600 "$py" -m pytest -q -rfEx --timeout=420 tests/python/test_safety_process.py > "$out/$v$i.out" 2>&1
    echo "$v$i rc=$? load=$(cut -d' ' -f1 /proc/loadavg) $(tail -1 "$out/$v$i.out")" >> "$out/summary.txt"
  done
done
