#!/usr/bin/env python3
"""Attribute the driver's missed cycles in a scheduler trace of the chain's CPU.

    python3 bench/chain/trace_misses.py TRACE TIDS [--skip SECONDS]

TRACE: the text of an ftrace instance with sched_switch / sched_wakeup on the chain's CPU
and the driver's `naic missed N` markers (bench/chain/trace_chain.sh records both); TIDS:
the thread ids of the chain's three node processes. Misses within 2.5 ms of each other form
one episode. For each episode, everything that ran on the CPU while some chain thread was
runnable but not running, in the 2.5 ms before the episode and during it, is summed by kind,
and the largest names the cause:
  chain               the chain's own threads (one of them ran while another waited)
  foreign RT          a SCHED_FIFO/RR thread of another process
  kernel thread (CFS) a normal-priority kernel thread (kworker, ...): with preempt=none a
                      kernel thread is not preempted by a woken SCHED_FIFO thread
  CFS task            a normal-priority process, which could only keep the CPU from a woken
                      SCHED_FIFO thread while in the kernel (preempt=none)
  no trace event      no event at all on the CPU for > 1.5 ms (the vCPU did not run)
Then per thread of the chain: run segments (work per wake-up) and wake-up -> run waits.
"""
import argparse
import bisect
import collections
import re

LINE = re.compile(r'^\s*(.+?)-(\d+)\s+\[(\d+)\]\s+\S+\s+([\d.]+):\s+(\w+):\s?(.*)$')
SW = re.compile(r'prev_comm=(.*) prev_pid=(\d+) prev_prio=(\d+) prev_state=(\S+) ==> next_comm=(.*) next_pid=(\d+) next_prio=(\d+)')
WK = re.compile(r'comm=(.*) pid=(\d+) prio=(\d+)')
KTHREADS = ('kworker', 'ksoftirqd', 'rcu', 'kcompact', 'kswapd', 'migration', 'kdamond', 'khugepaged', 'ksmd')


def parse(path):
    segs, marks, waits, gaps = [], [], [], []
    cur, runnable, prio, name = None, {}, {}, {}
    first = last = lastev = None
    for line in open(path, errors='replace'):
        m = LINE.match(line)
        if not m:
            continue
        t, ev, rest = float(m.group(4)), m.group(5), m.group(6)
        first = t if first is None else first
        if lastev is not None and t - lastev > 0.0015:
            gaps.append((lastev, t))
        lastev = last = t
        if ev == 'sched_switch':
            s = SW.match(rest)
            if not s:
                continue
            pp, np_ = int(s.group(2)), int(s.group(6))
            name[pp], name[np_] = s.group(1), s.group(5)
            prio[pp], prio[np_] = int(s.group(3)), int(s.group(7))
            if cur:
                segs.append((cur[0], t, cur[1]))
            cur = (t, np_)
            if s.group(4).startswith('R') and pp:
                runnable.setdefault(pp, t)  # preempted: still runnable
            if np_ in runnable:
                waits.append((np_, runnable.pop(np_), t))
        elif ev == 'sched_wakeup':
            w = WK.match(rest)
            if w:
                p = int(w.group(2))
                name[p], prio[p] = w.group(1), int(w.group(3))
                runnable.setdefault(p, t)
        elif ev == 'tracing_mark_write':
            marks.append((t, rest.strip()))
    if cur:
        segs.append((cur[0], last, cur[1]))
    return segs, marks, waits, gaps, prio, name, first


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument('trace')
    ap.add_argument('tids')
    ap.add_argument('--skip', type=float, default=3.0, help='seconds at the start left out (start-up, warm-up)')
    a = ap.parse_args()
    chain = set(int(x) for x in open(a.tids).read().split())
    segs, marks, waits, gaps, prio, name, first = parse(a.trace)
    t0 = first + a.skip

    def kind(p):
        if p == 0:
            return 'idle'
        if p in chain:
            return 'chain'
        if prio.get(p, 120) < 100:
            return f'foreign RT ({name.get(p)})'
        n = name.get(p, '')
        if n.startswith(KTHREADS):
            return 'kernel thread (CFS): ' + n.split('/')[0]
        return 'CFS task (in the kernel)'

    iv = sorted((w0, w1) for p, w0, w1 in waits if p in chain and w1 > w0)
    merged = []
    for w0, w1 in iv:
        if merged and w0 <= merged[-1][1]:
            merged[-1][1] = max(merged[-1][1], w1)
        else:
            merged.append([w0, w1])
    starts = [s[0] for s in segs]
    mstarts = [m[0] for m in merged]

    def ran(x0, x1):
        acc = collections.Counter()
        i = max(0, bisect.bisect_right(starts, x0) - 1)
        while i < len(segs) and segs[i][0] < x1:
            s0, s1, p = segs[i]
            d = min(s1, x1) - max(s0, x0)
            if d > 0:
                acc[kind(p)] += d
            i += 1
        for g0, g1 in gaps:
            d = min(g1, x1) - max(g0, x0)
            if d > 0:
                acc['no trace event > 1.5 ms'] += d
        return acc

    def while_waiting(x0, x1):
        acc = collections.Counter()
        j = max(0, bisect.bisect_right(mstarts, x0) - 1)
        while j < len(merged) and merged[j][0] < x1:
            acc.update(ran(max(x0, merged[j][0]), min(x1, merged[j][1])))
            j += 1
        return acc

    miss = [t for t, r in marks if r.startswith('naic missed') and t >= t0]
    episodes = []
    for t in miss:
        if episodes and t - episodes[-1][1] < 0.0025:
            episodes[-1][1] = t
            episodes[-1][2] += 1
        else:
            episodes.append([t, t, 1])
    by_misses, by_episodes = collections.Counter(), collections.Counter()
    print('episode start      misses  cause: what ran while a chain thread waited [ms]')
    for e0, e1, n in episodes:
        acc = while_waiting(e0 - 0.0025 - (n - 1) * 0.001, e1)
        cause = acc.most_common(1)[0][0] if acc else 'chain'
        cause = 'kernel thread (CFS)' if cause.startswith('kernel thread') else cause
        by_misses[cause] += n
        by_episodes[cause] += 1
        print(f'{e0 - first:10.3f} s {n:7d}  {cause:24s} ' + ', '.join(f'{k} {v * 1e3:.2f}' for k, v in acc.most_common(4)))
    print(f'\n{len(miss)} missed cycles after the first {a.skip} s, {len(episodes)} episodes; by cause:')
    for k, v in by_misses.most_common():
        print(f'  {v:6d} missed in {by_episodes[k]:5d} episodes  {k}')
    span = max((s1 for s0, s1, p in segs if p in chain), default=t0) - t0
    print(f'\nCPU time while a chain thread was runnable but waited ({span:.1f} s) [ms]:')
    acc = collections.Counter()
    for w0, w1 in merged:
        if w0 >= t0:
            acc.update(ran(w0, w1))
    for k, v in acc.most_common():
        print(f'  {v * 1e3:9.1f}  {k}')
    print('\nchain threads: run segments [µs] (n, median, p99, p99.9, max) | wake-up -> run [µs] (median, p99.9, max)')
    runs, lat = collections.defaultdict(list), collections.defaultdict(list)
    for s0, s1, p in segs:
        if p in chain and s0 >= t0:
            runs[(p, name.get(p))].append(s1 - s0)
    for p, w0, w1 in waits:
        if p in chain and w0 >= t0:
            lat[(p, name.get(p))].append(w1 - w0)
    q = lambda v, f: v[min(len(v) - 1, int(f * len(v)))] * 1e6
    for k in sorted(runs):
        v, w = sorted(runs[k]), sorted(lat.get(k, [0]))
        print(f'  {k[1]:18s} {k[0]:7d} {len(v):7d} {q(v, .5):7.0f} {q(v, .99):7.0f} {q(v, .999):7.0f} {v[-1] * 1e6:8.0f} |'
              f' {q(w, .5):6.0f} {q(w, .999):7.0f} {w[-1] * 1e6:8.0f}')
    print('\nchain run segments over 0.3 ms (start [s], length [µs], thread):')
    for s0, s1, p in segs:
        if p in chain and s0 >= t0 and s1 - s0 > 0.0003:
            print(f'  {s0 - first:9.3f} {(s1 - s0) * 1e6:7.0f}  {p} {name.get(p)}')


if __name__ == '__main__':
    main()
