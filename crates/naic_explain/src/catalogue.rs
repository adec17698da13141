//! The catalogue of candidate model extensions and the regressor columns they add.
//!
//! Every candidate is linear in its amplitude parameters once its shape parameters
//! (Stribeck velocity `q_s`, ripple wave number `k`) are fixed; shape parameters are
//! found by a grid scan on the training part (see [`crate::analysis`]).
//!
//! Notation: `s = tanh(q̇/w)` (w per joint in 0–2 mrad/s, 0 = the exact sign, chosen on the nominal fit: [`crate::analysis::calibrate_coulomb_width`]) with 0 at rest (regime, see [`crate::prepare`]), `p = [q̇ > 0]`,
//! `n = [q̇ < 0]`. The residual explained is `y = τ_measured − τ_rigid_body(q, q̇, q̈)`.
//!
//! | effect | columns added (per joint) | parameters |
//! | --- | --- | --- |
//! | nominal (eq. 5 symmetric) | `s·σ₀(q̇)`, `q̇` | f_a, f_v (σ₀ = Stribeck shape of `--nominal`, flat by default) |
//! | `friction_asymmetry` | friction columns split by direction (`p·…`, `n·…`) | f_c⁺, f_c⁻, f_v⁺, f_v⁻ |
//! | `stribeck` | `s·e^{−(q̇/q_s)²}` (per direction if asymmetric) | f_s = f_b − f_a, q_s |
//! | `position_ripple` | `s·sin(k q)`, `s·cos(k q)` | amplitude, k [rad⁻¹], phase |
//! | `position_torque` | `sin(k' q)`, `cos(k' q)` (no `s`: the same torque in both directions — cogging, a gravity-model error) | amplitude, k' [rad⁻¹], phase |
//! | `payload` | `[J_tip,linᵀ (p̈_tip − g)]_j` | mass [kg] at the `tip` frame |
//! | `torque_offset` | `1` | offset [N·m] |
//! | `delay` | none: the model is evaluated at the motion of t − d (scanned with τ_rb(t − d) ≈ τ_rb − d·τ̇_rb + d²/2·τ̈_rb; once found, re-estimated and fixed with τ_rb(t − d) exact on a 1 ms lattice, every other column at q̇(t − d), q(t − d), q̈(t − d)); d scanned on ±30 ms, then refined; found on one joint, it is fixed at the joints' median on all | delay [s] (torque lags motion when > 0) |
//! | `drift` | `s·(t − t_mid)/T` | change of the Coulomb level over the session [N·m] |
//! | `rotor_inertia` | `q̈_j` (engineer's check: unmodelled motor/gear inertia) | I_a [kg·m²] |
//! | `viscous_nonlinearity` | `s·q̇²` (engineer's check: non-Newtonian lubricant; per direction on friction points with `friction_asymmetry`) | f_v2 [N·m·s²/rad²] |
//! | `torque_scale` | `τ_rb,j` (the rigid-body torque: measured = k·(τ_rb + friction), so y = (k − 1)·τ_rb + k·friction, the friction columns absorbing k) | k = 1 + coefficient |
//! | `inertial_parameters` | `Y_B,j(q, q̇, q̈) δβ`: the joint's share of a base-parameter correction δβ fitted on **all joints together** and cross-fitted per fold (see [`crate::inertial`]) | δβ (shared); per joint the column's scale (≈ 1) |
//!
//!
//! Contact data (wrench columns `fx..mz` in the `ft_sensor` frame, or `/wrench` in a bag)
//! is analysed per sensor axis `a` (targets `fx, fy, fz, mx, my, mz`, see [`crate::contact`]).
//! The residual is `y_a = w_measured,a − w_tool,a` (the nominal tool weight of the URDF's
//! `ft_sensor` link removed); `u_a` is the sensor-frame component of the unit contact
//! force (forces: `R_wsᵀ n`, moments: `R_wsᵀ (r_tip × n)`), `δ = h − z_tip` the
//! penetration of the tip into the horizontal surface at height `h`, `δ̇ = −ż_tip`,
//! `g_s = R_wsᵀ g` gravity in the sensor frame.
//!
//! | effect | columns added (per axis) | parameters |
//! | --- | --- | --- |
//! | nominal (linear spring, the simulator's environment) | `u_a·δ₊` | k [N/m], h [m] (scanned) |
//! | `contact_nonlinearity` | spring column becomes `u_a·δ₊ⁿ` (power law, Hunt–Crossley's elastic part) | k_n [N/mⁿ], n |
//! | `contact_damping` | `u_a·δ̇·[δ > 0]` (Kelvin–Voigt damping the nominal spring lacks) | c [N·s/m] |
//! | `ft_bias` | `1` | bias of the axis [N or N·m] |
//! | `tool_gravity` | forces: `g_s,a`; moments: the two components of `(Δ(m c)) × g_s` on that axis | Δm [kg]; Δ(m·c) [kg·m] |

/// One candidate extension.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Effect {
    FrictionAsymmetry,
    Stribeck,
    PositionRipple,
    Payload,
    TorqueOffset,
    Delay,
    Drift,
    RotorInertia,
    ViscousNonlinearity,
    InertialParameters,
    TorqueScale,
    PositionTorque,
    ContactNonlinearity,
    ContactDamping,
    FtBias,
    ToolGravity,
}

pub const ALL_EFFECTS: [Effect; 16] = [
    Effect::FrictionAsymmetry,
    Effect::Stribeck,
    Effect::PositionRipple,
    Effect::Payload,
    Effect::TorqueOffset,
    Effect::Delay,
    Effect::Drift,
    Effect::RotorInertia,
    Effect::ViscousNonlinearity,
    Effect::InertialParameters,
    Effect::TorqueScale,
    Effect::PositionTorque,
    Effect::ContactNonlinearity,
    Effect::ContactDamping,
    Effect::FtBias,
    Effect::ToolGravity,
];

impl Effect {
    pub fn name(self) -> &'static str {
        match self {
            Effect::FrictionAsymmetry => "friction_asymmetry",
            Effect::Stribeck => "stribeck",
            Effect::PositionRipple => "position_ripple",
            Effect::Payload => "payload",
            Effect::TorqueOffset => "torque_offset",
            Effect::Delay => "delay",
            Effect::Drift => "drift",
            Effect::RotorInertia => "rotor_inertia",
            Effect::ViscousNonlinearity => "viscous_nonlinearity",
            Effect::InertialParameters => "inertial_parameters",
            Effect::TorqueScale => "torque_scale",
            Effect::PositionTorque => "position_torque",
            Effect::ContactNonlinearity => "contact_nonlinearity",
            Effect::ContactDamping => "contact_damping",
            Effect::FtBias => "ft_bias",
            Effect::ToolGravity => "tool_gravity",
        }
    }

    pub fn parse(s: &str) -> Option<Effect> {
        ALL_EFFECTS.iter().copied().find(|e| e.name() == s)
    }

    /// Whether the effect can be seen in steady-state friction points (no time, position, acceleration).
    pub fn applies_to_points(self) -> bool {
        matches!(self, Effect::FrictionAsymmetry | Effect::Stribeck | Effect::ViscousNonlinearity)
    }

    /// Whether the effect belongs to the contact (wrench) catalogue rather than the joint one.
    pub fn is_contact(self) -> bool {
        matches!(self, Effect::ContactNonlinearity | Effect::ContactDamping | Effect::FtBias | Effect::ToolGravity)
    }

    /// Extra parameters it adds (amplitudes + scanned shape parameters), for the information criterion.
    pub fn n_params(self, asymmetric: bool, stribeck: bool) -> usize {
        match self {
            // splitting every friction column by direction
            Effect::FrictionAsymmetry => 2 + if stribeck { 2 } else { 0 },
            Effect::Stribeck => {
                if asymmetric {
                    4
                } else {
                    2
                }
            }
            Effect::PositionRipple | Effect::PositionTorque => 3,
            _ => 1,
        }
    }

    /// What a finding of this effect means, for the report.
    pub fn meaning(self) -> &'static str {
        match self {
            Effect::FrictionAsymmetry => "friction differs between the positive and negative direction (eq. 5 per direction, Table 1)",
            Effect::Stribeck => "a low-speed (Stribeck) friction shape that the nominal friction law lacks or gets wrong (f_b, q_s)",
            Effect::PositionRipple => "friction that varies periodically with joint position (gear/bearing ripple)",
            Effect::Payload => "an unmodelled mass at the tool",
            Effect::TorqueOffset => "a constant bias of the torque sensor",
            Effect::Delay => "a time shift between the torque and the motion channels",
            Effect::Drift => "friction that changes over the session (warm-up, wear)",
            Effect::RotorInertia => "unmodelled motor/gear inertia (torque proportional to joint acceleration)",
            Effect::ViscousNonlinearity => "viscous friction that grows faster than linearly with speed",
            Effect::InertialParameters => "the link inertials (masses, centres of mass, inertias) differ from the URDF: the rigid body's base parameters, refitted on all joints together, explain the residual",
            Effect::TorqueScale => "the measured torque is the model torque times a gain k ≠ 1 (a drive's current-to-torque constant or a torque sensor's calibration)",
            Effect::PositionTorque => "a torque that varies periodically with joint position and does not flip with the direction of motion (cogging, or a gravity-model error)",
            Effect::ContactNonlinearity => "a contact force that is not linear in the penetration (power law k·δⁿ, the elastic part of Hunt–Crossley)",
            Effect::ContactDamping => "a contact damping force c·δ̇ that the nominal linear spring lacks",
            Effect::FtBias => "a constant bias of the F/T sensor axis (not tared, or drifted since the tare)",
            Effect::ToolGravity => "the tool's weight differs from the nominal tool (mass or centre of mass wrong), seen rotating with the sensor",
        }
    }
}

/// Effects considered unless `--effects` says otherwise: the whole time-series catalogue.
/// `position_torque` competes with `inertial_parameters` on the forward selection's one
/// criterion, the held-out BIC, where the inertial column counts the joint's share of the
/// shared base parameters ([`crate::analysis::Candidate::heldout_bic`]), and the all-joint
/// stage fits δβ beside the nominal friction only, so a first-pass `position_torque` cannot
/// take the rigid-body error away from it. (It was opt-in while the stage fitted δβ beside the
/// first-pass models: there it came first on five Panda joints and pre-empted
/// `inertial_parameters`; with the stage as it is the Panda's `inertial_parameters` stays
/// first on all seven joints and `position_torque` is named after it on joints 3, 4 and 6,
/// docs/explain.md.)
pub fn default_effects() -> Vec<Effect> {
    ALL_EFFECTS.to_vec()
}

/// Log-spaced grid from `lo` to `hi` with `n` points.
pub fn log_grid(lo: f64, hi: f64, n: usize) -> Vec<f64> {
    (0..n).map(|i| lo * (hi / lo).powf(i as f64 / (n - 1).max(1) as f64)).collect()
}

/// Grid of Stribeck velocities q_s [rad/s].
pub fn q_s_grid() -> Vec<f64> {
    log_grid(1.5e-3, 0.5, 18)
}

/// Grid of torque-channel delays [s] (`delay`; refined by halving around the best): ±30 ms.
pub fn delay_grid() -> Vec<f64> {
    lin_grid(-0.03, 0.03, 61)
}

/// Linear grid from `lo` to `hi` with `n` points.
pub fn lin_grid(lo: f64, hi: f64, n: usize) -> Vec<f64> {
    (0..n).map(|i| lo + (hi - lo) * i as f64 / (n - 1).max(1) as f64).collect()
}

/// Grid of contact exponents n (`contact_nonlinearity`).
pub fn n_exp_grid() -> Vec<f64> {
    lin_grid(0.5, 3.0, 26)
}

/// Grid of `position_torque` wave numbers k' [rad⁻¹]: from 0.5 (a gravity-model error,
/// ∝ sin q or cos q of the joint, seen over a joint's range) up to the ripple grid's 120.
pub fn k_pos_grid() -> Vec<f64> {
    log_grid(0.5, 120.0, 84)
}

/// Grid of ripple wave numbers k [rad⁻¹] (cycles per radian × 2π).
pub fn k_grid() -> Vec<f64> {
    log_grid(2.0, 120.0, 72)
}
