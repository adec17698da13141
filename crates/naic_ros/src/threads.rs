//! Which threads of this process kept a CPU busy: read at exit, so that a thread that
//! stopped blocking (docs/notes/2026-12-dds-test-forensics.md, "A start-up freeze") is named in the node's log.
//!
//! Every thread of a node blocks in each cycle; at 1 kHz the busiest (the driver's loop)
//! uses 10–20 % of a CPU. A thread whose CPU time is most of the process's run time did not
//! block. Under SCHED_RR (`node::set_realtime`) such a thread no longer freezes the chain, so
//! the chain can stop normally and this report can say which thread it was.

use std::time::Duration;

/// One thread's CPU time, from `/proc/self/task/<tid>/stat`.
#[derive(Debug, Clone, PartialEq)]
pub struct ThreadCpu {
    pub tid: u32,
    /// The thread's name (`comm`, at most 15 bytes).
    pub name: String,
    /// User plus system time, seconds.
    pub cpu_s: f64,
}

/// CPU time of every thread of this process (threads that end while being read are skipped).
pub fn thread_cpu_times() -> Vec<ThreadCpu> {
    // SAFETY: sysconf has no preconditions.
    let tick = unsafe { libc::sysconf(libc::_SC_CLK_TCK) }.max(1) as f64;
    let Ok(dir) = std::fs::read_dir("/proc/self/task") else { return Vec::new() };
    let mut out: Vec<ThreadCpu> = dir
        .filter_map(|e| {
            let e = e.ok()?;
            let tid: u32 = e.file_name().to_str()?.parse().ok()?;
            let stat = std::fs::read_to_string(e.path().join("stat")).ok()?;
            parse_stat(tid, &stat, tick)
        })
        .collect();
    out.sort_by_key(|t| t.tid);
    out
}

/// A `stat` line: `tid (comm) state ppid …`, utime and stime the 14th and 15th fields. The
/// name may hold spaces and parentheses, so the fields are counted after the last `)`.
fn parse_stat(tid: u32, stat: &str, tick: f64) -> Option<ThreadCpu> {
    let open = stat.find('(')?;
    let close = stat.rfind(')')?;
    let name = stat.get(open + 1..close)?.to_string();
    let mut rest = stat.get(close + 1..)?.split_whitespace(); // field 3 (state) first
    let utime: f64 = rest.nth(11)?.parse().ok()?;
    let stime: f64 = rest.next()?.parse().ok()?;
    Some(ThreadCpu { tid, name, cpu_s: (utime + stime) / tick })
}

/// Those of `threads` whose CPU time exceeds `fraction` of `elapsed`.
pub fn busy_threads(threads: Vec<ThreadCpu>, elapsed: Duration, fraction: f64) -> Vec<ThreadCpu> {
    let limit = elapsed.as_secs_f64() * fraction;
    threads.into_iter().filter(|t| t.cpu_s > limit).collect()
}

/// Log a warning naming each thread that was busy for more than half of `elapsed` (runs of
/// 2 s or more; shorter ones are mostly start-up work).
pub fn warn_busy_threads(process: &str, elapsed: Duration) {
    if elapsed < Duration::from_secs(2) {
        return;
    }
    for t in busy_threads(thread_cpu_times(), elapsed, 0.5) {
        log::warn!(
            "{process}: thread {:?} (tid {}) used {:.1} s of CPU in {:.1} s: it did not block as a node's threads do; \
             please report it with this line (docs/notes/2026-12-dds-test-forensics.md, \"A start-up freeze\")",
            t.name,
            t.tid,
            t.cpu_s,
            elapsed.as_secs_f64()
        );
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_stat_line_with_spaces_and_parentheses_in_the_name_parses() {
        let line = "4242 (RustDDS (x) y) S 1 2 3 4 5 6 7 8 9 10 250 50 0 0 20 0 9 0 100 0 0";
        let t = parse_stat(4242, line, 100.0).expect("parses");
        assert_eq!(t.name, "RustDDS (x) y");
        assert!((t.cpu_s - 3.0).abs() < 1e-12, "{t:?}"); // (250 + 50) ticks at 100 Hz
        assert_eq!(parse_stat(1, "garbage", 100.0), None);
    }

    #[test]
    fn a_spinning_thread_is_named_and_a_sleeping_one_is_not() {
        // The spinner spins until its own CPU clock reads 0.3 s (however long a busy machine
        // takes to give it that), then waits, still alive, until it is read.
        let thread_cpu_s = || {
            let mut ts = libc::timespec { tv_sec: 0, tv_nsec: 0 };
            // SAFETY: valid pointer to a timespec.
            unsafe { libc::clock_gettime(libc::CLOCK_THREAD_CPUTIME_ID, &mut ts) };
            ts.tv_sec as f64 + ts.tv_nsec as f64 * 1e-9
        };
        let (spun_tx, spun_rx) = std::sync::mpsc::channel::<()>();
        let (done_tx, done_rx) = std::sync::mpsc::channel::<()>();
        let spinner = std::thread::Builder::new()
            .name("naic-spin-test".into())
            .spawn(move || {
                while thread_cpu_s() < 0.3 {
                    std::hint::spin_loop();
                }
                let _ = spun_tx.send(());
                let _ = done_rx.recv();
            })
            .expect("spawn");
        let (nap_tx, nap_rx) = std::sync::mpsc::channel::<()>();
        let sleeper = std::thread::Builder::new()
            .name("naic-nap-test".into())
            .spawn(move || {
                let _ = nap_rx.recv();
            })
            .expect("spawn");
        spun_rx.recv_timeout(Duration::from_secs(120)).expect("the spinner got 0.3 s of CPU within 120 s");
        let all = thread_cpu_times();
        let _ = (done_tx.send(()), nap_tx.send(()));
        spinner.join().expect("spinner");
        sleeper.join().expect("sleeper");
        let spin = all.iter().find(|t| t.name == "naic-spin-test").expect("the spinner is listed");
        let nap = all.iter().find(|t| t.name == "naic-nap-test").expect("the sleeper is listed");
        assert!(spin.cpu_s >= 0.25, "the spinner's CPU time {spin:?} (0.3 s by its own clock; /proc counts 10 ms ticks)");
        assert!(nap.cpu_s < 0.05, "the sleeper's CPU time {nap:?}");
        // Over a 1 s run at 0.2 of it: the spinner is busy, the sleeper (and this thread) not.
        let busy = busy_threads(all.clone(), Duration::from_secs(1), 0.2);
        assert!(busy.iter().any(|t| t.name == "naic-spin-test"), "{busy:?}");
        assert!(!busy.iter().any(|t| t.name == "naic-nap-test"), "{busy:?}");
    }
}
