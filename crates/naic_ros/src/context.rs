//! DDS participant creation from the standard ROS 2 environment variables.
//!
//! ros2-client's `Context::new()` always uses domain 0 and every network interface;
//! here the domain comes from `ROS_DOMAIN_ID`, and `ROS_LOCALHOST_ONLY=1` or
//! `ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST` (or `OFF`) restrict RustDDS to the loopback
//! interface (`with_only_networks([127.0.0.1])`): multicast joins/sends and advertised
//! locators use 127.0.0.1 only, so no DDS traffic leaves the machine.

use std::net::{IpAddr, Ipv4Addr};

use ros2_client::{dds::rustdds::DomainParticipantBuilder, Context};

use crate::RosError;

/// Settings read from the environment.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct DdsSettings {
    pub domain_id: u16,
    pub localhost_only: bool,
}

impl DdsSettings {
    pub fn from_env() -> Result<DdsSettings, RosError> {
        Self::from_vars(|k| std::env::var(k).ok())
    }

    /// Same as [`Self::from_env`] with an explicit variable lookup (for tests).
    pub fn from_vars(get: impl Fn(&str) -> Option<String>) -> Result<DdsSettings, RosError> {
        let domain_id = match get("ROS_DOMAIN_ID").map(|s| s.trim().to_string()) {
            None => 0,
            Some(s) if s.is_empty() => 0,
            Some(s) => match s.parse::<u16>() {
                // 232 is the largest domain id whose RTPS ports fit in 16 bits with
                // the default port mapping (as in the ROS 2 documentation).
                Ok(d) if d <= 232 => d,
                _ => {
                    return Err(RosError::Env(format!(
                        "ROS_DOMAIN_ID='{s}' is not a domain id; use an integer 0..=232 (0 when unset)"
                    )))
                }
            },
        };
        let localhost_only_var = get("ROS_LOCALHOST_ONLY").map(|s| s.trim().to_string());
        let range = get("ROS_AUTOMATIC_DISCOVERY_RANGE").map(|s| s.trim().to_ascii_uppercase());
        let localhost_only = match range.as_deref() {
            Some("LOCALHOST") | Some("OFF") => true,
            Some("SUBNET") | Some("SYSTEM_DEFAULT") | Some("") | None => {
                localhost_only_var.as_deref() == Some("1")
            }
            Some(other) => {
                return Err(RosError::Env(format!(
                    "ROS_AUTOMATIC_DISCOVERY_RANGE='{other}' is not one of LOCALHOST, SUBNET, OFF, SYSTEM_DEFAULT"
                )))
            }
        };
        Ok(DdsSettings { domain_id, localhost_only })
    }
}

/// Create this process's DDS participant (one per node process), in the SROS2 enclave the
/// environment names, if any ([`crate::security`]).
pub fn create_context(s: &DdsSettings) -> Result<Context, RosError> {
    create_context_in(s, crate::security::Enclave::from_env(None)?.as_ref())
}

/// [`create_context`] in `enclave` (DDS Security), or without security when `None`. An
/// enclave that cannot be loaded is an error: never an unsecured participant instead.
pub fn create_context_in(s: &DdsSettings, enclave: Option<&crate::security::Enclave>) -> Result<Context, RosError> {
    crate::msgs::register_type_hashes();
    let mut b = DomainParticipantBuilder::new(s.domain_id);
    if s.localhost_only {
        b = b.with_only_networks([IpAddr::V4(Ipv4Addr::LOCALHOST)]);
    }
    if let Some(e) = enclave {
        b = crate::security::secure(b, e)?;
    }
    let dp = b.build().map_err(|e| match enclave {
        Some(enc) => RosError::Node(format!(
            "enclave {}: DDS Security refused the files in {} ({e:?}); refusing to start without it: check that cert.pem was issued by identity_ca.cert.pem and that governance.p7s and permissions.p7s are signed by permissions_ca.cert.pem (naic security init KEYSTORE writes a consistent set)",
            enc.name,
            enc.dir.display()
        )),
        None => RosError::Dds(format!("cannot create DDS participant on domain {}: {e:?}", s.domain_id)),
    })?;
    if let Some(e) = enclave {
        log::info!("DDS Security on: enclave {} ({})", e.name, e.dir.display());
    }
    Context::from_domain_participant(dp)
        .map_err(|e| RosError::Dds(format!("cannot create ROS context: {e:?}")))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn with(vars: &[(&str, &str)]) -> Result<DdsSettings, RosError> {
        let v: Vec<(String, String)> = vars.iter().map(|(a, b)| (a.to_string(), b.to_string())).collect();
        DdsSettings::from_vars(move |k| v.iter().find(|(a, _)| a == k).map(|(_, b)| b.clone()))
    }

    #[test]
    fn reads_domain_and_localhost() {
        assert_eq!(with(&[]).unwrap(), DdsSettings { domain_id: 0, localhost_only: false });
        assert_eq!(with(&[("ROS_DOMAIN_ID", "42")]).unwrap().domain_id, 42);
        assert!(with(&[("ROS_LOCALHOST_ONLY", "1")]).unwrap().localhost_only);
        assert!(!with(&[("ROS_LOCALHOST_ONLY", "0")]).unwrap().localhost_only);
        assert!(with(&[("ROS_AUTOMATIC_DISCOVERY_RANGE", "localhost")]).unwrap().localhost_only);
        assert!(!with(&[("ROS_AUTOMATIC_DISCOVERY_RANGE", "SUBNET")]).unwrap().localhost_only);
    }

    #[test]
    fn bad_values_are_named() {
        let e = with(&[("ROS_DOMAIN_ID", "abc")]).unwrap_err().to_string();
        assert!(e.contains("ROS_DOMAIN_ID='abc'"), "{e}");
        assert!(with(&[("ROS_DOMAIN_ID", "300")]).is_err());
        let e = with(&[("ROS_AUTOMATIC_DISCOVERY_RANGE", "MOON")]).unwrap_err().to_string();
        assert!(e.contains("MOON"), "{e}");
    }
}
