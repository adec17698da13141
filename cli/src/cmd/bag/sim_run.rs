//! A simulated run as a bag with the node suite's topics (`naic sim --bag`).
use super::bag_err;
use crate::cmd::CliError;
use naic_msgs::*;
use std::path::Path;

/// Writes one simulated run as a bag with the topics the node suite publishes, so that
/// `naic plot`, `naic replay` and rosbag2 tools treat simulations and recordings alike.
/// Stamps, log and publish times are the simulation time (like a `use_sim_time` run; `/clock`
/// is included). Per control period: `/joint_states` (q, q̇, applied τ), `/wrench` (raw F/T,
/// `ft_sensor`), `/joint_effort_cmd` (applied τ), `/naic/params` (mode = `controller`,
/// measured force = the controller's estimate) and `/clock`. Fields a simulation record does
/// not carry are NaN (`k_d`, `phi`); `gamma_clipped` is derived as γ ≥ its eq-15 bound.
/// `force_axis` is the axis index 0..2 (x, y, z) of the scenario's force direction; `names`
/// are the arm's joints (`/joint_states`, and the size of `/joint_effort_cmd`).
pub fn write_sim_run<const N: usize>(
    path: &Path,
    controller: &str,
    records: &[naic_sim::runner::Record<N>],
    force_axis: u8,
    names: &[String],
) -> Result<u64, CliError> {
    let mut w = naic_bag::BagWriter::create(path).map_err(bag_err)?;
    let q = naic_bag::Qos::default();
    let js = w.add_topic::<JointState>("/joint_states", q).map_err(bag_err)?;
    let wr = w.add_topic::<WrenchStamped>("/wrench", q).map_err(bag_err)?;
    let ef = w.add_topic::<Float64MultiArray>("/joint_effort_cmd", q).map_err(bag_err)?;
    let pa = w.add_topic::<NaicParams>("/naic/params", q).map_err(bag_err)?;
    let ck = w.add_topic::<Clock>("/clock", q).map_err(bag_err)?;
    let names: Vec<String> = names.to_vec();
    let dim = vec![MultiArrayDimension { label: "joints".into(), size: N as u32, stride: N as u32 }];
    for r in records {
        let ns = (r.t * 1e9).round().max(0.0) as u64;
        let stamp = Time::from_nanos(ns as i64);
        let header = |frame: &str| Header { stamp: stamp.clone(), frame_id: frame.into() };
        let wrench = Wrench {
            force: Vector3 { x: r.wrench[0], y: r.wrench[1], z: r.wrench[2] },
            torque: Vector3 { x: r.wrench[3], y: r.wrench[4], z: r.wrench[5] },
        };
        w.write(ck, &Clock { clock: stamp.clone() }, ns, ns).map_err(bag_err)?;
        w.write(
            js,
            &JointState {
                header: header(""),
                name: names.clone(),
                position: r.q.to_vec(),
                velocity: r.dq.to_vec(),
                effort: r.tau.to_vec(),
            },
            ns,
            ns,
        )
        .map_err(bag_err)?;
        w.write(wr, &WrenchStamped { header: header("ft_sensor"), wrench }, ns, ns).map_err(bag_err)?;
        w.write(
            ef,
            &Float64MultiArray { layout: MultiArrayLayout { dim: dim.clone(), data_offset: 0 }, data: r.tau.to_vec() },
            ns,
            ns,
        )
        .map_err(bag_err)?;
        let params = NaicParams {
            header: header("base_link"),
            mode: controller.to_string(),
            phase: r.phase as u8,
            force_axis,
            desired_force: r.f_d,
            measured_force: r.f_ext_est,
            e_f: r.f_ext_est - r.f_d,
            m_d: r.m_d,
            b_d: r.b_d,
            k_d: f64::NAN,
            sigma: r.sigma,
            phi: f64::NAN,
            gamma: r.gamma,
            gamma_bound: r.gamma_bound,
            gamma_clipped: r.gamma_bound.is_finite() && r.gamma >= r.gamma_bound,
            fault: String::new(),
            fault_count: 0,
            k_e_hat: r.k_e_hat,
            k_e_confidence: r.k_e_confidence,
            model_gain: r.model_gain,
            gravity_scale: r.gravity_scale,
            ..Default::default()
        };
        w.write(pa, &params, ns, ns).map_err(bag_err)?;
    }
    let n = w.message_count();
    w.finish().map_err(bag_err)?;
    Ok(n)
}

#[cfg(test)]
mod tests {
    use super::*;
    use naic_bag::Bag;

    #[test]
    fn sim_run_bag_reads_back_every_value() {
        let recs: Vec<naic_sim::runner::Record> = (0..500)
            .map(|k| {
                let mut r = naic_sim::runner::Record { t: k as f64 * 1e-3, ..Default::default() };
                r.q = [0.1 * k as f64, 1.0, -1.0, 0.5, 0.25, 0.0];
                r.tau = [k as f64, 2.0, 3.0, 4.0, 5.0, 6.0];
                r.wrench = [1.0, 2.0, -(k as f64), 0.0, 0.1, 0.2];
                r.f_d = 10.0;
                r.f_ext_est = 9.0 + k as f64 * 1e-3;
                r.b_d = 50.0 + k as f64;
                r.gamma = 1e-3;
                r.gamma_bound = if k % 2 == 0 { f64::INFINITY } else { 5e-4 };
                r.phase = naic_core::pipeline::control::Phase::Contact;
                r
            })
            .collect();
        let p = std::env::temp_dir().join(format!("naic_sim_bag_{}.mcap", std::process::id()));
        let names: Vec<String> = (1..=6).map(|j| format!("joint{j}")).collect();
        let n = write_sim_run(&p, "naic", &recs, 2, &names).unwrap();
        assert_eq!(n, 5 * 500);
        let bag = Bag::open(&p).unwrap();
        let run = naic_bag::RunData::load(&bag, ..);
        assert_eq!(run.params.len(), 500);
        assert_eq!(run.clock.len(), 500);
        for (k, r) in recs.iter().enumerate() {
            assert_eq!(run.joint_states[k].msg.position, r.q.to_vec());
            assert_eq!(run.effort_cmd[k].msg.data, r.tau.to_vec());
            assert_eq!(run.wrench[k].msg.wrench.force.z, r.wrench[2]);
            let p = &run.params[k].msg;
            assert_eq!((p.measured_force, p.b_d, p.mode.as_str()), (r.f_ext_est, r.b_d, "naic"));
            assert_eq!(p.gamma_clipped, k % 2 == 1);
            assert_eq!(run.params[k].log_time, (r.t * 1e9).round() as u64);
        }
        let _ = std::fs::remove_file(&p);
    }
}
