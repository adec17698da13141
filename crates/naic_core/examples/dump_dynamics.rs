//! Dump the dynamics of a URDF at given states as JSON, for the cross-checks
//! against Pinocchio and MuJoCo (`tests/python/test_dynamics_vs_pinocchio.py`).
//!
//! ```text
//! cargo run --release -p naic_core --example dump_dynamics -- URDF STATES.json > out.json
//! ```
//! `STATES.json`: `{"frames": ["tip", ...], "states": [{"q": [..], "v": [..], "a": [..], "tau": [..]}, ..]}`.
//! Output: `{"nv", "joint_names", "frame_names", "results": [{"rnea", "bias", "gravity", "M", "aba",
//! "frames": {name: {"pos", "rot", "J", "jdot_qdot"}}, "cartesian": {"D", "h", "damped", "sigma_min"} | null}]}`
//! (`cartesian` for the first requested frame of a 6-joint model).
//!
//! `dump_dynamics --test-urdf arm6|planar3` prints one of the URDFs of the Rust
//! dynamics tests, so the Python cross-check can run Pinocchio on it too.

#[path = "../tests/dynamics_common/mod.rs"]
mod dynamics_common;

use naic_core::dynamics::{self, Damping};
use naic_core::model::{Data, Model};
use nalgebra::DVector;
use serde_json::{json, Value};

fn rows<R: nalgebra::Dim, C: nalgebra::Dim, S: nalgebra::storage::Storage<f64, R, C>>(
    m: &nalgebra::Matrix<f64, R, C, S>,
) -> Value {
    Value::Array((0..m.nrows()).map(|r| json!((0..m.ncols()).map(|c| m[(r, c)]).collect::<Vec<_>>())).collect())
}

fn vecj<R: nalgebra::Dim, S: nalgebra::storage::Storage<f64, R>>(v: &nalgebra::Vector<f64, R, S>) -> Value {
    json!(v.iter().copied().collect::<Vec<f64>>())
}

/// Why the dump cannot be made: each variant names the argument, file or key and the rule.
#[derive(Debug, thiserror::Error)]
enum DumpError {
    #[error("--test-urdf takes arm6 or planar3, not {given:?}")]
    TestUrdf { given: Option<String> },
    #[error("usage: dump_dynamics URDF STATES.json")]
    Usage,
    #[error(transparent)]
    Model(#[from] naic_core::model::ModelError),
    #[error("cannot read {path}: {problem}")]
    Read { path: String, problem: String },
    #[error("{path}: bad JSON: {problem}")]
    Json { path: String, problem: String },
    #[error("states JSON needs a \"{key}\" list")]
    MissingList { key: &'static str },
    #[error("frame names must be strings, got {got}")]
    FrameName { got: Value },
    #[error("no frame '{frame}' in {urdf}")]
    NoFrame { frame: String, urdf: String },
    #[error("state needs \"{key}\"")]
    MissingKey { key: String },
    #[error("\"{key}\" has {got} entries, the model has {nv} joints")]
    Length { key: String, got: usize, nv: usize },
}

fn run() -> Result<(), DumpError> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    if args.first().map(String::as_str) == Some("--test-urdf") {
        match args.get(1).map(String::as_str) {
            Some("arm6") => print!("{}", dynamics_common::arm6_urdf()),
            Some("planar3") => print!("{}", dynamics_common::planar3_urdf()),
            other => return Err(DumpError::TestUrdf { given: other.map(str::to_string) }),
        }
        return Ok(());
    }
    let [urdf, states] = args.as_slice() else {
        return Err(DumpError::Usage);
    };
    let model = Model::from_urdf_file(urdf)?;
    let text = std::fs::read_to_string(states).map_err(|e| DumpError::Read { path: states.clone(), problem: e.to_string() })?;
    let input: Value = serde_json::from_str(&text).map_err(|e| DumpError::Json { path: states.clone(), problem: e.to_string() })?;
    let frames: Vec<String> = input["frames"]
        .as_array()
        .ok_or(DumpError::MissingList { key: "frames" })?
        .iter()
        .map(|f| f.as_str().map(str::to_string).ok_or_else(|| DumpError::FrameName { got: f.clone() }))
        .collect::<Result<_, _>>()?;
    let frame_ids = frames
        .iter()
        .map(|f| model.frame_id(f).ok_or_else(|| DumpError::NoFrame { frame: f.clone(), urdf: urdf.clone() }))
        .collect::<Result<Vec<_>, _>>()?;
    let n = model.nv();
    let get = |s: &Value, k: &str| -> Result<DVector<f64>, DumpError> {
        let a = s[k].as_array().ok_or_else(|| DumpError::MissingKey { key: k.to_string() })?;
        if a.len() != n {
            return Err(DumpError::Length { key: k.to_string(), got: a.len(), nv: n });
        }
        Ok(DVector::from_iterator(n, a.iter().map(|x| x.as_f64().unwrap_or(f64::NAN))))
    };
    let mut data = Data::new(&model);
    let mut results = Vec::new();
    for s in input["states"].as_array().ok_or(DumpError::MissingList { key: "states" })? {
        let (q, v, a, tau) = (get(s, "q")?, get(s, "v")?, get(s, "a")?, get(s, "tau")?);
        let rnea = vecj(dynamics::rnea(&model, &mut data, &q, &v, &a));
        let bias = vecj(dynamics::bias_torques(&model, &mut data, &q, &v));
        let gravity = vecj(dynamics::gravity_torques(&model, &mut data, &q));
        let m = rows(dynamics::crba(&model, &mut data, &q));
        let aba = vecj(dynamics::aba(&model, &mut data, &q, &v, &tau));
        dynamics::forward_kinematics(&model, &mut data, &q);
        let mut fr = serde_json::Map::new();
        for (name, &id) in frames.iter().zip(&frame_ids) {
            let se3 = *data.frame_se3(id);
            let j = rows(dynamics::frame_jacobian(&model, &mut data, &q, id));
            let jdq = vecj(&dynamics::frame_jdot_qdot(&model, &mut data, &q, &v, id));
            fr.insert(name.clone(), json!({"pos": vecj(&se3.trans), "rot": rows(&se3.rot), "J": j, "jdot_qdot": jdq}));
        }
        let cartesian = match frame_ids.first() {
            Some(&id) if n == 6 => {
                match dynamics::cartesian_terms(&model, &mut data, &q, &v, id, &Damping::default()) {
                    Ok(c) => json!({"D": rows(&c.d), "h": vecj(&c.h), "damped": c.damped, "sigma_min": c.sigma_min}),
                    Err(e) => json!({"error": e.to_string()}),
                }
            }
            _ => Value::Null,
        };
        results.push(json!({"rnea": rnea, "bias": bias, "gravity": gravity, "M": m, "aba": aba, "frames": fr, "cartesian": cartesian}));
    }
    let out = json!({
        "nv": n,
        "joint_names": model.joint_names().collect::<Vec<_>>(),
        "frame_names": model.frames().iter().map(|f| f.name.as_str()).collect::<Vec<_>>(),
        "results": results,
    });
    println!("{out}");
    Ok(())
}

fn main() {
    if let Err(e) = run() {
        eprintln!("dump_dynamics: error: {e}");
        std::process::exit(2);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn dump_errors_name_the_key_the_values_and_the_rule() {
        let m = DumpError::Length { key: "q".into(), got: 5, nv: 6 }.to_string();
        assert_eq!(m, "\"q\" has 5 entries, the model has 6 joints");
        let m = DumpError::MissingList { key: "frames" }.to_string();
        assert_eq!(m, "states JSON needs a \"frames\" list");
        let m = DumpError::TestUrdf { given: Some("arm7".into()) }.to_string();
        assert!(m.contains("arm6 or planar3") && m.contains("\"arm7\""), "{m}");
        let m = DumpError::FrameName { got: json!(3) }.to_string();
        assert!(m.contains("must be strings, got 3"), "{m}");
    }
}
