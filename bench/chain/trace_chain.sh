#!/bin/bash
# Trace the scheduler on one CPU while a command runs (root, debugfs/tracefs), with the
# driver's missed cycles as trace markers; then attribute the misses with trace_misses.py.
#
#   bench/chain/trace_chain.sh OUT.trace [CPU] -- target/release/naic bench chain --duration 30 --realtime-priority 50 --skip-rclpy
#   python3 bench/chain/trace_misses.py OUT.trace OUT.trace.tids
#
# Uses its own trace instance (instances/naic_chain), so it does not disturb other tracers.
# OUT.trace.tids gets the thread ids of the chain's node processes (taken 4 s after start).
set -e
out=$1; shift
cpu=1
if [ "$1" != "--" ]; then cpu=$1; shift; fi
shift
base=/sys/kernel/tracing
[ -d $base/instances ] || base=/sys/kernel/debug/tracing
T=$base/instances/naic_chain
[ -d $T ] || mkdir $T
echo 0 > $T/tracing_on
echo > $T/trace
printf '%x\n' $((1 << cpu)) > $T/tracing_cpumask
echo 300000 > $T/buffer_size_kb
echo > $T/set_event
for e in sched:sched_switch sched:sched_wakeup irq:softirq_entry irq:irq_handler_entry \
         irq_vectors:local_timer_entry timer:hrtimer_expire_entry; do
  echo $e >> $T/set_event
done
echo mono > $T/trace_clock
echo 1 > $T/tracing_on
bins=$(dirname "$(readlink -f "$1")")   # the node binaries sit beside naic
( sleep 4; for p in $(pgrep -f "$bins/(jk5_sim_driver|naic_controller|friction_compensation) "); do ls /proc/$p/task; done > "$out.tids" ) &
rc=0
NAIC_TRACE_MARKER=$T/trace_marker "$@" || rc=$?
echo 0 > $T/tracing_on
cat $T/trace > "$out"
echo > $T/trace
echo "trace: $(wc -l < "$out") lines; $(grep overrun $T/per_cpu/cpu$cpu/stats)" >&2
rmdir $T 2>/dev/null || true
exit $rc
