//! Shared fixtures of the dynamics tests: test URDFs and deterministic random states.
#![allow(dead_code)]

use std::path::PathBuf;

/// Repository root (two levels above the crate).
pub fn repo_root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../..")
}

/// The shared reference material: `$NAIC_SHARED`, else `shared/` beside the repository.
pub fn shared_dir() -> PathBuf {
    if let Ok(p) = std::env::var("NAIC_SHARED") {
        return PathBuf::from(p);
    }
    let p = repo_root().join("../shared");
    assert!(
        p.is_dir(),
        "shared reference material not found at {} (set NAIC_SHARED to its path)",
        p.display()
    );
    p
}

/// JAKA's Zu 5 URDF (fixed `world` joint, joints `joint_1`..`joint_6`).
pub fn zu5_path() -> PathBuf {
    shared_dir().join("reference/jk5/jaka_zu5.urdf")
}

/// The project's JK5 (+ F/T sensor + rod tool) URDF, `urdf/jk5.urdf`.
pub fn jk5_path() -> PathBuf {
    repo_root().join("urdf/jk5.urdf")
}

/// The project's random numbers (`naic_core::rng`), with the draws these tests need.
pub struct Rng(naic_core::rng::Rng);
impl Rng {
    pub fn seed(seed: u64) -> Rng {
        Rng(naic_core::rng::Rng::seed(seed))
    }
    pub fn uniform(&mut self, lo: f64, hi: f64) -> f64 {
        self.0.range(lo, hi)
    }
    pub fn vec(&mut self, n: usize, lo: f64, hi: f64) -> nalgebra::DVector<f64> {
        nalgebra::DVector::from_fn(n, |_, _| self.uniform(lo, hi))
    }
}

/// Planar 3R arm in the x–z plane (axes along y), point masses `M[i]` at the
/// ends of links of lengths `L[i]`, and a `tip` frame at the end of link 3.
pub const PLANAR_L: [f64; 3] = [0.5, 0.4, 0.3];
pub const PLANAR_M: [f64; 3] = [2.0, 1.5, 1.0];
pub fn planar3_urdf() -> String {
    let [l1, l2, l3] = PLANAR_L;
    let [m1, m2, m3] = PLANAR_M;
    format!(
        r#"<robot name="planar3">
  <link name="base"/>
  <link name="l1"><inertial><origin xyz="{l1} 0 0"/><mass value="{m1}"/><inertia ixx="0" ixy="0" ixz="0" iyy="0" iyz="0" izz="0"/></inertial></link>
  <link name="l2"><inertial><origin xyz="{l2} 0 0"/><mass value="{m2}"/><inertia ixx="0" ixy="0" ixz="0" iyy="0" iyz="0" izz="0"/></inertial></link>
  <link name="l3"><inertial><origin xyz="{l3} 0 0"/><mass value="{m3}"/><inertia ixx="0" ixy="0" ixz="0" iyy="0" iyz="0" izz="0"/></inertial></link>
  <link name="tip"/>
  <joint name="q1" type="revolute"><parent link="base"/><child link="l1"/><axis xyz="0 1 0"/><limit lower="-3" upper="3" effort="50" velocity="2"/></joint>
  <joint name="q2" type="revolute"><parent link="l1"/><child link="l2"/><origin xyz="{l1} 0 0"/><axis xyz="0 1 0"/><limit lower="-3" upper="3" effort="40" velocity="2"/></joint>
  <joint name="q3" type="continuous"><parent link="l2"/><child link="l3"/><origin xyz="{l2} 0 0"/><axis xyz="0 1 0"/><limit effort="30" velocity="3"/></joint>
  <joint name="tip_joint" type="fixed"><parent link="l3"/><child link="tip"/><origin xyz="{l3} 0 0"/></joint>
</robot>"#
    )
}

/// A general 6-DOF chain that exercises everything the loader supports:
/// non-unit and negative axes, a prismatic and a continuous joint, rotated
/// joint origins and inertial frames, off-diagonal inertias, a massive link
/// fixed to a moving one (merged), a fixed side branch (camera), a fixed
/// tool with a `tip` frame, and a fixed `world` root.
pub fn arm6_urdf() -> String {
    let inertial = |xyz: &str, rpy: &str, m: f64, d: [f64; 3], off: [f64; 3]| {
        format!(
            r#"<inertial><origin xyz="{xyz}" rpy="{rpy}"/><mass value="{m}"/><inertia ixx="{}" ixy="{}" ixz="{}" iyy="{}" iyz="{}" izz="{}"/></inertial>"#,
            d[0], off[0], off[1], d[1], off[2], d[2]
        )
    };
    format!(
        r#"<robot name="arm6">
  <link name="world"/>
  <link name="base_link">{b}</link>
  <link name="s1">{l1}</link>
  <link name="s2">{l2}</link>
  <link name="camera">{cam}</link>
  <link name="s3">{l3}</link>
  <link name="s4">{l4}</link>
  <link name="s5">{l5}</link>
  <link name="s6">{l6}</link>
  <link name="tool">{tool}</link>
  <link name="tip"/>
  <joint name="world_joint" type="fixed"><parent link="world"/><child link="base_link"/><origin xyz="0.1 -0.2 0.05" rpy="0 0 0.3"/></joint>
  <joint name="j1" type="revolute"><parent link="base_link"/><child link="s1"/><origin xyz="0 0 0.15"/><axis xyz="0 0 1"/><limit lower="-3" upper="3" effort="100" velocity="2"/></joint>
  <joint name="j2" type="revolute"><parent link="s1"/><child link="s2"/><origin xyz="0 0.05 0.1" rpy="1.5707963 0 0"/><axis xyz="0 2 0"/><limit lower="-2" upper="2" effort="100" velocity="2"/></joint>
  <joint name="cam_mount" type="fixed"><parent link="s2"/><child link="camera"/><origin xyz="0.1 0.05 0" rpy="0.2 0.1 -0.4"/></joint>
  <joint name="j3" type="revolute"><parent link="s2"/><child link="s3"/><origin xyz="0.4 0 0.02" rpy="0 0.3 0"/><axis xyz="1 1 0"/><limit lower="-2.5" upper="2.5" effort="60" velocity="2"/></joint>
  <joint name="j4" type="prismatic"><parent link="s3"/><child link="s4"/><origin xyz="0.3 0 0"/><axis xyz="0 0 1"/><limit lower="-0.1" upper="0.2" effort="200" velocity="0.5"/></joint>
  <joint name="j5" type="continuous"><parent link="s4"/><child link="s5"/><origin xyz="0 0.02 0.1" rpy="0 -1.2 0.4"/><axis xyz="-1 0 0"/><limit effort="20" velocity="3"/></joint>
  <joint name="j6" type="revolute"><parent link="s5"/><child link="s6"/><origin xyz="0.08 0 0"/><axis xyz="0.2 -0.3 0.9"/><limit lower="-3" upper="3" effort="10" velocity="3"/></joint>
  <joint name="tool_joint" type="fixed"><parent link="s6"/><child link="tool"/><origin xyz="0 0 0.05" rpy="0 0 0.7"/></joint>
  <joint name="tip_joint" type="fixed"><parent link="tool"/><child link="tip"/><origin xyz="0.01 0 0.12"/></joint>
</robot>"#,
        b = inertial("0 0 0.05", "0 0 0", 5.0, [0.05, 0.05, 0.03], [0.0, 0.0, 0.0]),
        l1 = inertial("0.01 0.02 0.05", "0.1 0.2 0.3", 4.0, [0.03, 0.025, 0.02], [0.001, -0.002, 0.0015]),
        l2 = inertial("0.2 0.01 -0.02", "0 0.4 0", 6.0, [0.02, 0.12, 0.11], [0.003, 0.001, -0.002]),
        cam = inertial("0 0 0.02", "0 0 0", 0.3, [0.0004, 0.0005, 0.0003], [0.0, 0.0, 0.0]),
        l3 = inertial("0.15 0 0.01", "0.3 0 0.1", 3.0, [0.01, 0.05, 0.045], [0.0005, 0.0, 0.0004]),
        l4 = inertial("0 0 0.05", "0 0 0", 1.5, [0.008, 0.008, 0.002], [0.0, 0.0001, 0.0]),
        l5 = inertial("0.03 0 0", "0 0 0.5", 1.0, [0.002, 0.003, 0.0025], [0.0001, 0.0, -0.0001]),
        l6 = inertial("0 0 0.02", "0 0 0", 0.4, [0.0006, 0.0006, 0.0004], [0.0, 0.0, 0.0]),
        tool = inertial("0 0 0.06", "0 0 0", 0.5, [0.0015, 0.0015, 0.0002], [0.0, 0.0, 0.0]),
    )
}
