//! Fuzzing the parsers with proptest (issue 7, item 5): each takes the real file it is
//! meant for, damaged at random (bytes replaced, inserted, deleted, truncated, lines
//! shuffled) or plain random text, and must return `Ok` or an `Err` with a message —
//! never panic, never hang. Budgets are bounded (`CASES`, override with
//! PROPTEST_CASES) so the suite stays fast; failures print the shrunk input.

use naic_core::friction::FrictionParams;
use naic_core::model::Model;
use naic_ident::FrictionData;
use proptest::prelude::*;

const ROOT: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../..");

fn cases() -> u32 {
    std::env::var("PROPTEST_CASES").ok().and_then(|v| v.parse().ok()).unwrap_or(300)
}

fn config() -> ProptestConfig {
    ProptestConfig { cases: cases(), failure_persistence: None, max_shrink_iters: 2000, ..ProptestConfig::default() }
}

fn read(rel: &str) -> Vec<u8> {
    std::fs::read(format!("{ROOT}/{rel}")).unwrap_or_else(|e| panic!("{rel}: {e}"))
}

/// One damage to a byte string.
#[derive(Clone, Debug)]
enum Edit {
    Replace(usize, u8),
    Insert(usize, Vec<u8>),
    Delete(usize, usize),
    Truncate(usize),
    SwapLines(usize, usize),
}

/// Bytes that matter to the formats: digits, signs, separators, quotes, brackets, XML/YAML syntax.
fn nasty_byte() -> impl Strategy<Value = u8> {
    prop_oneof![
        3 => prop::sample::select(b"0123456789-+.eE,:;\n\t \"'<>/=[]{}#&!*|-nNaAiIfF\\\x00\xff".to_vec()),
        1 => any::<u8>(),
    ]
}

fn edit() -> impl Strategy<Value = Edit> {
    prop_oneof![
        4 => (any::<usize>(), nasty_byte()).prop_map(|(i, b)| Edit::Replace(i, b)),
        2 => (any::<usize>(), prop::collection::vec(nasty_byte(), 1..8)).prop_map(|(i, b)| Edit::Insert(i, b)),
        2 => (any::<usize>(), 1usize..40).prop_map(|(i, n)| Edit::Delete(i, n)),
        1 => any::<usize>().prop_map(Edit::Truncate),
        1 => (any::<usize>(), any::<usize>()).prop_map(|(a, b)| Edit::SwapLines(a, b)),
    ]
}

fn apply(src: &[u8], edits: &[Edit]) -> Vec<u8> {
    let mut v = src.to_vec();
    for e in edits {
        let n = v.len().max(1);
        match e {
            Edit::Replace(i, b) => {
                if !v.is_empty() {
                    let i = i % v.len();
                    v[i] = *b;
                }
            }
            Edit::Insert(i, b) => {
                let i = i % (v.len() + 1);
                v.splice(i..i, b.iter().copied());
            }
            Edit::Delete(i, k) => {
                let i = i % n;
                let j = (i + k).min(v.len());
                if i < j {
                    v.drain(i..j);
                }
            }
            Edit::Truncate(i) => v.truncate(i % n),
            Edit::SwapLines(a, b) => {
                let mut lines: Vec<Vec<u8>> = v.split(|c| *c == b'\n').map(|l| l.to_vec()).collect();
                let len = lines.len();
                lines.swap(a % len, b % len);
                v = lines.join(&b'\n');
            }
        }
    }
    v
}

fn damaged(rel: &'static str) -> impl Strategy<Value = String> {
    let src = read(rel);
    prop::collection::vec(edit(), 1..6).prop_map(move |e| String::from_utf8_lossy(&apply(&src, &e)).into_owned())
}

fn damaged_bytes(src: Vec<u8>) -> impl Strategy<Value = Vec<u8>> {
    prop::collection::vec(edit(), 1..6).prop_map(move |e| apply(&src, &e))
}

/// Errors must say something.
fn check_err<T, E: std::fmt::Display>(r: Result<T, E>) -> Result<(), TestCaseError> {
    if let Err(e) = r {
        prop_assert!(!e.to_string().trim().is_empty(), "empty error message");
    }
    Ok(())
}

proptest! {
    #![proptest_config(config())]

    #[test]
    fn urdf_parser_never_panics_on_a_damaged_jk5_urdf(text in damaged("urdf/jk5.urdf")) {
        match Model::from_urdf_str(&text) {
            Ok(m) => {
                // Whatever loads must be usable: limits are numbers, not garbage.
                prop_assert!(m.nv() <= 64);
            }
            Err(e) => prop_assert!(!e.to_string().is_empty()),
        }
    }

    #[test]
    fn urdf_parser_never_panics_on_random_text(text in "\\PC{0,300}") {
        check_err(Model::from_urdf_str(&text))?;
    }

    #[test]
    fn friction_yaml_never_panics_and_what_loads_is_valid(text in damaged("params/friction_jk5.yaml")) {
        if let Ok(p) = FrictionParams::from_yaml_str("fuzz.yaml", &text) {
            // What loads converts to a model that never produces NaN at finite speeds.
            if let Ok(m) = p.to_model() {
                for j in 0..m.n_joints() {
                    for v in [-3.0, -0.01, 0.0, 0.01, 3.0] {
                        prop_assert!(m.tau_f(j, v).is_finite(), "joint {} at {} rad/s", j, v);
                    }
                }
            }
        } else if let Err(e) = FrictionParams::from_yaml_str("fuzz.yaml", &text) {
            prop_assert!(e.to_string().contains("fuzz.yaml"), "error does not name the file: {}", e);
        }
    }

    #[test]
    fn friction_yaml_never_panics_on_random_yaml(text in "(joints|source|model|f_a|f_b|q_s|f_v|positive|negative|joint|[-:{}\\[\\], \n0-9.eE]|nan|inf|stribeck_per_direction|coulomb_viscous){0,60}") {
        check_err(FrictionParams::from_yaml_str("fuzz.yaml", &text))?;
    }

    #[test]
    fn friction_csv_never_panics_and_what_loads_is_finite(text in damaged("tests/fuzz_data/friction_sample.csv")) {
        match FrictionData::from_csv_str("fuzz.csv", &text) {
            Ok(d) => {
                for j in d.joints() {
                    for s in d.joint_samples(j) {
                        prop_assert!(s.qdot.is_finite() && s.tau.is_finite());
                    }
                }
            }
            Err(e) => prop_assert!(e.to_string().contains("fuzz.csv"), "error does not name the file: {}", e),
        }
    }

    #[test]
    fn ros2_params_file_never_panics(text in damaged("params/naic_controller.yaml")) {
        check_err(naic_ros::params_file::parse_for_node(&text, "/naic_controller"))?;
    }

    #[test]
    fn ros_args_never_panic(args in prop::collection::vec(
        prop_oneof![
            Just("--ros-args".to_string()), Just("-p".to_string()), Just("-r".to_string()),
            Just("--params-file".to_string()), Just("--".to_string()), Just("-e".to_string()),
            "[a-z_.:=/~0-9-]{0,12}", "\\PC{0,12}",
        ], 0..8)) {
        check_err(naic_ros::RosArgs::parse(args.iter().cloned()))?;
        if let Ok(a) = naic_ros::RosArgs::parse(args.iter().cloned()) {
            let _ = a.fqn("n");
            check_err(a.overrides("n"))?;
        }
    }
}

/// A small valid bag of the four naic topics, written once.
fn sample_bag() -> Vec<u8> {
    use naic_bag::{BagWriter, Qos};
    use naic_msgs::*;
    let path = std::env::temp_dir().join(format!("naic_fuzz_{}.mcap", std::process::id()));
    let mut w = BagWriter::create(&path).unwrap();
    w.set_flush_interval(std::time::Duration::from_secs(3600));
    let js = w.add_topic::<JointState>("/joint_states", Qos::default()).unwrap();
    let pa = w.add_topic::<NaicParams>("/naic/params", Qos::default()).unwrap();
    for i in 0..60 {
        let c = naic_bag::sample::cycle(i, 1000.0);
        w.write(js, &c.joint_states, c.stamp_ns + 100, c.stamp_ns).unwrap();
        w.write(pa, &c.params, c.stamp_ns + 200, c.stamp_ns).unwrap();
        if i % 20 == 19 {
            w.flush().unwrap();
        }
    }
    w.finish().unwrap();
    let b = std::fs::read(&path).unwrap();
    let _ = std::fs::remove_file(&path);
    b
}

proptest! {
    #![proptest_config(config())]

    #[test]
    fn mcap_reader_never_panics_on_a_damaged_bag(bytes in damaged_bytes(sample_bag())) {
        use naic_msgs::*;
        if let Ok(bag) = naic_bag::Bag::from_bytes("fuzz.mcap", bytes) {
            let _ = bag.topics();
            let _ = bag.damage();
            check_err(bag.messages::<JointState>("/joint_states", ..))?;
            check_err(bag.messages::<NaicParams>("/naic/params", ..))?;
            let mut n = 0u64;
            bag.for_each_message(None, naic_bag::TimeRange::from_bounds(..), |_| n += 1);
            prop_assert!(n <= 10_000);
        }
    }

    #[test]
    fn mcap_reader_never_panics_on_random_bytes(bytes in prop::collection::vec(any::<u8>(), 0..2000)) {
        let mut b = b"\x89MCAP0\r\n".to_vec();
        b.extend(bytes);
        check_err(naic_bag::Bag::from_bytes("fuzz.mcap", b))?;
    }
}
