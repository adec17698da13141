//! Helpers shared by the DDS-level tests of the vendored rustdds patches
//! (crates/vendor/rustdds/PATCHED.md).

use std::fs::File;
use std::net::UdpSocket;
use std::os::fd::AsRawFd;

use ros2_client::dds::rustdds::{DomainParticipant, DomainParticipantBuilder};

/// A domain no one else on this machine uses now, claimed the way the Python suite claims
/// them (tests/ros/rostest_util.py `fresh_domain`): a lock file per id in
/// $TMPDIR/naic-ros-domains, and the id's first discovery port (7410 + 250 d) free.
/// The claim lasts as long as the returned file.
pub fn claim_domain() -> (u16, File) {
    let dir = std::env::temp_dir().join("naic-ros-domains");
    std::fs::create_dir_all(&dir).expect("create the domain lock directory");
    let base = (std::process::id() as usize * 7919) % 131;
    for k in 0..131 {
        let d = 101 + ((base + k) % 131) as u16;
        let f = File::create(dir.join(format!("{d}.lock"))).expect("create a domain lock file");
        // SAFETY: flock on a file descriptor this function owns.
        if unsafe { libc::flock(f.as_raw_fd(), libc::LOCK_EX | libc::LOCK_NB) } != 0 {
            continue;
        }
        if UdpSocket::bind(("127.0.0.1", 7410 + 250 * d)).is_ok() {
            return (d, f);
        }
    }
    panic!("no free ROS domain id in 101..=231 on this machine");
}

pub fn participant(domain: u16) -> DomainParticipant {
    DomainParticipantBuilder::new(domain)
        .with_only_networks([std::net::IpAddr::V4(std::net::Ipv4Addr::LOCALHOST)])
        .build()
        .unwrap_or_else(|e| panic!("cannot create a participant on domain {domain}: {e:?}"))
}
