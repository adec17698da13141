//! Every way a URDF can be wrong gives the right `ModelError`, naming the
//! link/joint and the fix, and never a panic.

mod dynamics_common;

use dynamics_common::*;
use naic_core::model::{Data, Data6, Model, ModelError};

const LINK_OK: &str = r#"<inertial><mass value="1"/><inertia ixx="0.01" ixy="0" ixz="0" iyy="0.01" iyz="0" izz="0.01"/></inertial>"#;

/// base → a (joint j1, about z) → b (joint j2, about y); `extra` is added inside <robot>.
fn two_link(link_b_inertial: &str, j2: &str, extra: &str) -> String {
    format!(
        r#"<robot name="t">
  <link name="base"/>
  <link name="a">{LINK_OK}</link>
  <link name="b">{link_b_inertial}</link>
  <joint name="j1" type="revolute"><parent link="base"/><child link="a"/><axis xyz="0 0 1"/><limit lower="-1" upper="1" effort="1" velocity="1"/></joint>
  {j2}
  {extra}
</robot>"#
    )
}

fn j2(kind: &str, axis: &str, parent: &str, child: &str) -> String {
    format!(
        r#"<joint name="j2" type="{kind}"><parent link="{parent}"/><child link="{child}"/><origin xyz="0 0 0.3"/><axis xyz="{axis}"/><limit lower="-1" upper="1" effort="1" velocity="1"/></joint>"#
    )
}

fn inertial(mass: &str, ixx: &str, ixy: &str, iyy: &str, izz: &str) -> String {
    format!(r#"<inertial><origin xyz="0.1 0 0"/><mass value="{mass}"/><inertia ixx="{ixx}" ixy="{ixy}" ixz="0" iyy="{iyy}" iyz="0" izz="{izz}"/></inertial>"#)
}

fn err(xml: &str) -> ModelError {
    match Model::from_urdf_str(xml) {
        Ok(_) => panic!("expected an error for:\n{xml}"),
        Err(e) => e,
    }
}

/// The message names `what` and tells a fix.
fn says(e: &ModelError, what: &[&str]) {
    let msg = e.to_string();
    for w in what {
        assert!(msg.contains(w), "message {msg:?} should mention {w:?}");
    }
}

#[test]
fn good_two_link_loads() {
    let m = Model::from_urdf_str(&two_link(LINK_OK, &j2("revolute", "0 1 0", "a", "b"), "")).unwrap();
    assert_eq!(m.nv(), 2);
}

#[test]
fn missing_file() {
    let e = Model::from_urdf_file("/nonexistent/robot.urdf").unwrap_err();
    assert!(matches!(e, ModelError::FileNotFound { .. }));
    says(&e, &["/nonexistent/robot.urdf", "not found"]);
}

#[test]
fn unreadable_xml() {
    let e = err("<robot name='x'><link name='a'></robot>");
    assert!(matches!(e, ModelError::Parse { .. }), "{e:?}");
    says(&e, &["parse"]);
    let dir = std::env::temp_dir().join("naic_dyn_test_bad.urdf");
    std::fs::write(&dir, "not xml at all <<<").unwrap();
    let e = Model::from_urdf_file(&dir).unwrap_err();
    assert!(matches!(e, ModelError::Parse { .. }), "{e:?}");
    says(&e, &["naic_dyn_test_bad.urdf"]);
}

#[test]
fn unknown_joint_type() {
    let e = err(&two_link(LINK_OK, &j2("hinge", "0 1 0", "a", "b"), ""));
    assert_eq!(e, ModelError::UnknownJointType { joint: "j2".into(), kind: "hinge".into() });
    says(&e, &["j2", "hinge", "revolute, continuous, prismatic or fixed"]);
}

#[test]
fn unsupported_joint_types() {
    for kind in ["floating", "planar", "spherical"] {
        let e = err(&two_link(LINK_OK, &j2(kind, "0 1 0", "a", "b"), ""));
        assert_eq!(e, ModelError::UnsupportedJointType { joint: "j2".into(), kind: kind.into() });
        says(&e, &["j2", kind]);
    }
}

#[test]
fn missing_parent_or_child_link() {
    let e = err(&two_link(LINK_OK, &j2("revolute", "0 1 0", "nowhere", "b"), ""));
    assert_eq!(e, ModelError::MissingLink { joint: "j2".into(), role: "parent", link: "nowhere".into() });
    says(&e, &["j2", "nowhere", "add the link"]);
    let e = err(&two_link(LINK_OK, &j2("revolute", "0 1 0", "a", "ghost"), ""));
    assert!(matches!(e, ModelError::MissingLink { role: "child", .. }));
}

#[test]
fn duplicate_names() {
    let e = err(&two_link(LINK_OK, &j2("revolute", "0 1 0", "a", "b"), r#"<link name="b"/>"#));
    assert_eq!(e, ModelError::DuplicateName { what: "link", name: "b".into() });
    let dup = j2("revolute", "0 1 0", "b", "c").replace("\"j2\"", "\"j1\"");
    let e = err(&two_link(LINK_OK, &j2("revolute", "0 1 0", "a", "b"), &format!(r#"<link name="c">{LINK_OK}</link>{dup}"#)));
    assert_eq!(e, ModelError::DuplicateName { what: "joint", name: "j1".into() });
}

#[test]
fn branching_tree_is_not_a_chain() {
    let extra = format!(
        r#"<link name="c">{LINK_OK}</link><joint name="j3" type="revolute"><parent link="a"/><child link="c"/><axis xyz="1 0 0"/><limit lower="-1" upper="1" effort="1" velocity="1"/></joint>"#
    );
    let e = err(&two_link(LINK_OK, &j2("revolute", "0 1 0", "a", "b"), &extra));
    assert!(matches!(&e, ModelError::Branching { link, .. } if link == "a"), "{e:?}");
    says(&e, &["'a'", "j2", "j3", "serial chains"]);
    // A side branch made only of fixed joints is fine.
    let extra = format!(r#"<link name="c">{LINK_OK}</link><joint name="j3" type="fixed"><parent link="a"/><child link="c"/></joint>"#);
    assert_eq!(Model::from_urdf_str(&two_link(LINK_OK, &j2("revolute", "0 1 0", "a", "b"), &extra)).unwrap().nv(), 2);
}

#[test]
fn multiple_roots_and_loops_and_two_parents() {
    let e = err(&two_link(LINK_OK, &j2("revolute", "0 1 0", "a", "b"), r#"<link name="floating_thing"/>"#));
    assert!(matches!(&e, ModelError::MultipleRoots { links } if links.contains(&"floating_thing".to_string())));
    says(&e, &["floating_thing", "exactly one"]);
    // b is the child of j2 and of j3: not a tree.
    let extra = r#"<joint name="j3" type="fixed"><parent link="base"/><child link="b"/></joint>"#;
    let e = err(&two_link(LINK_OK, &j2("revolute", "0 1 0", "a", "b"), extra));
    assert_eq!(e, ModelError::MultipleParents { link: "b".into(), first: "j2".into(), second: "j3".into() });
    // c and d are each other's parent: a loop not connected to the root.
    let extra = format!(
        r#"<link name="c">{LINK_OK}</link><link name="d">{LINK_OK}</link>
        <joint name="x1" type="fixed"><parent link="c"/><child link="d"/></joint>
        <joint name="x2" type="fixed"><parent link="d"/><child link="c"/></joint>"#
    );
    let e = err(&two_link(LINK_OK, &j2("revolute", "0 1 0", "a", "b"), &extra));
    assert!(matches!(&e, ModelError::Loop { .. }), "{e:?}");
    says(&e, &["c", "d", "loop"]);
}

#[test]
fn bad_masses_and_inertias() {
    let j = j2("revolute", "0 1 0", "a", "b");
    let e = err(&two_link(&inertial("-1", "0.01", "0", "0.01", "0.01"), &j, ""));
    assert_eq!(e, ModelError::NegativeMass { link: "b".into(), mass: -1.0 });
    says(&e, &["'b'", "-1"]);
    let e = err(&two_link(&inertial("0", "0.01", "0", "0.01", "0.01"), &j, ""));
    assert_eq!(e, ModelError::MassZeroWithInertia { link: "b".into() });
    says(&e, &["'b'", "zero mass", "inertia"]);
    // ixy larger than the diagonal: indefinite.
    let e = err(&two_link(&inertial("1", "0.01", "0.05", "0.01", "0.01"), &j, ""));
    assert!(matches!(&e, ModelError::InertiaNotPositive { link, .. } if link == "b"), "{e:?}");
    says(&e, &["'b'", "positive"]);
    let e = err(&two_link(&inertial("1", "0.01", "0", "0.01", "0.05"), &j, ""));
    assert!(matches!(&e, ModelError::InertiaTriangle { link, .. } if link == "b"), "{e:?}");
    says(&e, &["'b'", "triangle"]);
    // a point mass (zero inertia, positive mass) is fine
    assert!(Model::from_urdf_str(&two_link(&inertial("1", "0", "0", "0", "0"), &j, "")).is_ok());
}

#[test]
fn nan_numbers() {
    let j = j2("revolute", "0 1 0", "a", "b");
    let e = err(&two_link(&inertial("NaN", "0.01", "0", "0.01", "0.01"), &j, ""));
    assert!(matches!(&e, ModelError::NonFinite { what, .. } if what.contains("'b'") && what.contains("mass")), "{e:?}");
    let e = err(&two_link(&inertial("1", "nan", "0", "0.01", "0.01"), &j, ""));
    assert!(matches!(&e, ModelError::NonFinite { what, .. } if what.contains("ixx")), "{e:?}");
    let e = err(&two_link(LINK_OK, &j.replace("0 0 0.3", "0 nan 0.3"), ""));
    assert!(matches!(&e, ModelError::NonFinite { what, .. } if what.contains("j2") && what.contains("origin")), "{e:?}");
    let e = err(&two_link(LINK_OK, &j2("revolute", "0 NaN 1", "a", "b"), ""));
    assert!(matches!(&e, ModelError::NonFinite { what, .. } if what.contains("j2") && what.contains("axis")), "{e:?}");
    let e = err(&two_link(LINK_OK, &j.replace("upper=\"1\"", "upper=\"nan\""), ""));
    assert!(matches!(&e, ModelError::NonFinite { what, .. } if what.contains("j2") && what.contains("upper")), "{e:?}");
    says(&e, &["not a finite number"]);
}

#[test]
fn bad_axes_and_limits() {
    let e = err(&two_link(LINK_OK, &j2("revolute", "0 0 0", "a", "b"), ""));
    assert_eq!(e, ModelError::ZeroAxis { joint: "j2".into() });
    let j = j2("revolute", "0 1 0", "a", "b").replace("lower=\"-1\" upper=\"1\"", "lower=\"1\" upper=\"-1\"");
    let e = err(&two_link(LINK_OK, &j, ""));
    assert_eq!(e, ModelError::BadLimits { joint: "j2".into(), lower: 1.0, upper: -1.0 });
}

#[test]
fn massless_tail_makes_mass_matrix_singular() {
    // j2 moves link b only, and b is massless.
    let e = err(&two_link("", &j2("revolute", "0 1 0", "a", "b"), ""));
    assert_eq!(e, ModelError::SingularJoint { joint: "j2".into() });
    says(&e, &["j2", "singular", "<inertial>"]);
    // a point mass on the axis of a revolute joint moves no inertia either
    let on_axis = r#"<inertial><mass value="1"/><inertia ixx="0" ixy="0" ixz="0" iyy="0" iyz="0" izz="0"/></inertial>"#;
    let e = err(&two_link(on_axis, &j2("revolute", "0 1 0", "a", "b"), ""));
    assert_eq!(e, ModelError::SingularJoint { joint: "j2".into() });
    // but it is fine for a prismatic joint
    assert!(Model::from_urdf_str(&two_link(on_axis, &j2("prismatic", "0 1 0", "a", "b"), "")).is_ok());
}

#[test]
fn no_moving_joint() {
    let xml = r#"<robot name="t"><link name="a"/><link name="b"/><joint name="f" type="fixed"><parent link="a"/><child link="b"/></joint></robot>"#;
    assert_eq!(err(xml), ModelError::NoMovingJoints);
}

#[test]
fn static_workspace_needs_matching_dof() {
    let planar = Model::from_urdf_str(&planar3_urdf()).unwrap();
    let e = Data6::try_new(&planar).unwrap_err();
    assert_eq!(e, ModelError::WrongDof { expected: 6, found: 3 });
    says(&e, &["Data::new"]);
    // the dynamic one always works, and a static one with the right size too
    assert_eq!(Data::new(&planar).nv(), 3);
    assert_eq!(Data::<nalgebra::U3>::try_new(&planar).unwrap().nv(), 3);
}

#[test]
fn truncated_or_mangled_urdfs_never_panic() {
    let text = std::fs::read_to_string(jk5_path()).unwrap();
    let mut cases: Vec<String> = Vec::new();
    let cuts: Vec<usize> = (0..text.len()).step_by(13).filter(|&i| text.is_char_boundary(i)).collect();
    for &i in &cuts {
        cases.push(text[..i].to_string());
        cases.push(format!("{}{}", &text[..i], &text[(i + 7).min(text.len())..]));
    }
    let mut rng = Rng::seed(12);
    for _ in 0..300 {
        let mut bytes = text.clone().into_bytes();
        for _ in 0..3 {
            let k = rng.uniform(0.0, bytes.len() as f64) as usize;
            bytes[k] = b"<>/\"= -.0e9xNaN"[rng.uniform(0.0, 15.0) as usize];
        }
        if let Ok(s) = String::from_utf8(bytes) {
            cases.push(s);
        }
    }
    let mut errors = 0;
    for c in &cases {
        let r = std::panic::catch_unwind(|| Model::from_urdf_str(c));
        match r {
            Err(_) => panic!("Model::from_urdf_str panicked on:\n{c}"),
            Ok(Err(e)) => {
                errors += 1;
                assert!(!e.to_string().is_empty());
            }
            Ok(Ok(_)) => {}
        }
    }
    assert!(errors > cases.len() / 2, "most mangled files should be rejected ({errors} of {})", cases.len());
}

/// A non-ASCII character where a joint type's opening quote belongs (found by the fuzzer:
/// `type=�fixed"` panicked slicing inside the character): an error naming the joint, no panic.
#[test]
fn a_multibyte_character_for_the_quote_is_an_error_not_a_panic() {
    for quote in ["\u{FFFD}", "é", "€"] {
        let xml = two_link(&inertial("1", "0.1", "0", "0.1", "0.1"), &format!(r#"<joint name="j2" type={quote}fixed{quote}><parent link="a"/><child link="b"/></joint>"#), "");
        let r = std::panic::catch_unwind(|| Model::from_urdf_str(&xml));
        assert!(matches!(r, Ok(Err(_))), "{quote}: {r:?}");
    }
}
