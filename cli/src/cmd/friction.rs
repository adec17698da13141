//! `naic friction fit` and `naic friction eval`: identify equation 4/5 friction
//! parameters from steady-state data and check a parameter file against data.
use super::{CliError, CliResult};
use naic_core::friction::{FrictionError, FrictionParams, JointFriction};
use naic_ident::{fit, residual_stats, FitForm, FitOptions, FrictionData};
use std::path::PathBuf;
use std::time::Instant;

#[derive(clap::Subcommand)]
pub enum FrictionCmd {
    /// Fit a friction model to steady-state (velocity, torque) points and write a params YAML.
    Fit(FitArgs),
    /// RMSE per joint and direction of a params YAML on a data file (e.g. Table 1 on the JK5 data).
    Eval(EvalArgs),
}

#[derive(clap::Args)]
pub struct FitArgs {
    /// CSV with header `joint,velocity_rad_s,torque_nm`, one row per constant-velocity segment.
    #[arg(long)]
    data: PathBuf,
    /// `per-direction` (eq. 5 per direction, Table 1), `symmetric` (eq. 5) or `coulomb-viscous` (eq. 4).
    #[arg(long, default_value = "per-direction")]
    model: String,
    /// Output params YAML [default: runs/friction_fit_<model>.yaml].
    #[arg(long)]
    out: Option<PathBuf>,
    /// Comma-separated joint numbers (from 1) to fit [default: every joint in the data].
    #[arg(long)]
    joints: Option<String>,
    /// Leave out segments slower than this, rad/s (segments at exactly 0 are always left out).
    #[arg(long, default_value_t = 0.0)]
    min_speed: f64,
}

#[derive(clap::Args)]
pub struct EvalArgs {
    /// Params YAML (e.g. params/friction_jk5.yaml).
    #[arg(long)]
    params: PathBuf,
    /// CSV with header `joint,velocity_rad_s,torque_nm`.
    #[arg(long)]
    data: PathBuf,
    /// Leave out segments slower than this, rad/s (as `fit --min-speed`).
    #[arg(long, default_value_t = 0.0)]
    min_speed: f64,
}

pub fn run(c: FrictionCmd) -> CliResult {
    match c {
        FrictionCmd::Fit(a) => run_fit(a),
        FrictionCmd::Eval(a) => run_eval(a),
    }
}

fn input_err(e: FrictionError) -> CliError {
    CliError::usage(e.to_string())
}

fn parse_joints(s: &str) -> Result<Vec<usize>, CliError> {
    let mut out = Vec::new();
    for part in s.split(',').map(str::trim) {
        match part.parse::<usize>() {
            Ok(j) if j >= 1 => {
                if !out.contains(&j) {
                    out.push(j)
                }
            }
            _ => {
                return Err(CliError::usage(format!(
                    "--joints: `{part}` is not a joint number; give a comma-separated list of joints from 1, e.g. --joints 1,2,3"
                )))
            }
        }
    }
    Ok(out)
}

fn run_fit(a: FitArgs) -> CliResult {
    let form = FitForm::parse(&a.model).ok_or_else(|| {
        CliError::usage(format!(
            "--model `{}` is not a friction model; use per-direction (Table 1), symmetric (eq. 5) or coulomb-viscous (eq. 4)",
            a.model
        ))
    })?;
    if !(a.min_speed >= 0.0 && a.min_speed.is_finite()) {
        return Err(CliError::usage(format!("--min-speed {} is invalid; give a speed ≥ 0 in rad/s", a.min_speed)));
    }
    let joints = a.joints.as_deref().map(parse_joints).transpose()?;
    let t0 = Instant::now();
    let data = FrictionData::from_csv_file(&a.data).map_err(input_err)?;
    let t_read = t0.elapsed();
    let opts = FitOptions { form, joints, min_speed: a.min_speed, ..FitOptions::default() };
    let report = fit(&data, &opts).map_err(input_err)?;

    println!(
        "friction fit: {} model on {} ({} points{})",
        form.name(),
        data.name,
        report.joints.iter().map(|j| j.n_positive + j.n_negative).sum::<usize>(),
        {
            let dropped: usize = report.joints.iter().map(|j| j.n_dropped).sum();
            if dropped > 0 { format!(", {dropped} left out for |q̇| = 0 or < --min-speed") } else { String::new() }
        }
    );
    println!(
        "bounds: f ≥ 0, q_s in [{}, {}] rad/s; {} q_s starts per branch; 95% CI = ±t(0.975, n−p)·σ·√diag((JᵀJ)⁻¹)",
        opts.q_s_min, opts.q_s_max, opts.n_starts
    );
    println!("RMSE = √(SSR/n); RMSE_dfe = √(SSR/(n−p)) (MATLAB gof.rmse, Table 1's column)\n");
    print!("{}", report.table());
    for j in &report.joints {
        for b in &j.branches {
            if !b.converged {
                println!("warning: joint {} {}: the best start hit the iteration limit", j.joint, b.direction.label());
            }
        }
    }

    let out = a.out.unwrap_or_else(|| PathBuf::from(format!("runs/friction_fit_{}.yaml", form.name())));
    let source = format!(
        "naic friction fit --model {} --data {}{} (bounded LM, {} q_s starts)",
        form.name(),
        a.data.display(),
        if a.min_speed > 0.0 { format!(" --min-speed {}", a.min_speed) } else { String::new() },
        opts.n_starts
    );
    let params = report.to_params(&source);
    params.save(&out).map_err(|e| CliError::failure(format!("could not write the fitted parameters: {e}")))?;
    // Read back through the loader so a written file is always loadable and unchanged.
    match FrictionParams::from_yaml_file(&out) {
        Ok(back) if back == params => {}
        Ok(_) => return Err(CliError::failure(format!("internal error: {} does not read back unchanged", out.display()))),
        Err(e) => return Err(CliError::failure(format!("internal error: the written file does not load back: {e}"))),
    }
    println!("\nwrote {}", out.display());
    println!(
        "time: read {:.2} ms, fit {:.2} ms ({} joints)",
        t_read.as_secs_f64() * 1e3,
        report.elapsed.as_secs_f64() * 1e3,
        report.joints.len()
    );
    Ok(())
}

fn run_eval(a: EvalArgs) -> CliResult {
    if !(a.min_speed >= 0.0 && a.min_speed.is_finite()) {
        return Err(CliError::usage(format!("--min-speed {} is invalid; give a speed ≥ 0 in rad/s", a.min_speed)));
    }
    let params = FrictionParams::from_yaml_file(&a.params).map_err(input_err)?;
    let data = FrictionData::from_csv_file(&a.data).map_err(input_err)?;
    println!(
        "{} on {}{}",
        a.params.display(),
        data.name,
        if a.min_speed > 0.0 { format!(" (segments with |q̇| < {} rad/s left out)", a.min_speed) } else { String::new() }
    );
    println!("source: {}", params.source);
    println!("RMSE = √(SSR/n); RMSE_dfe = √(SSR/(n−p)), p = parameters per branch; 'file' = the RMSE recorded in the params file\n");
    println!(
        "{:<5} {:<3} {:>4} {:>10} {:>10} {:>10} {:>10}",
        "joint", "dir", "n", "RMSE", "RMSE_dfe", "file rmse", "file dfe"
    );
    let present = data.joints();
    let f = |x: Option<f64>| x.map(|v| format!("{v:.4}")).unwrap_or_else(|| "-".into());
    for j in &params.joints {
        if !present.contains(&j.joint) {
            println!("{:<5} (no data)", j.joint);
            continue;
        }
        let s = residual_stats(&j.friction, &data, j.joint, a.min_speed);
        let p = match j.friction {
            JointFriction::CoulombViscous { .. } => 2,
            _ => 4,
        };
        for (dir, n, rmse, dfe, st) in [
            ("+", s.n_positive, s.rmse_positive(), s.rmse_dfe_positive(p), &j.stats.positive),
            ("−", s.n_negative, s.rmse_negative(), s.rmse_dfe_negative(p), &j.stats.negative),
        ] {
            println!(
                "{:<5} {:<3} {:>4} {:>10} {:>10} {:>10} {:>10}",
                j.joint,
                dir,
                n,
                f(rmse),
                f(dfe),
                f(st.rmse),
                f(st.rmse_dfe)
            );
        }
    }
    Ok(())
}
