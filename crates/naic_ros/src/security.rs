//! DDS Security (SROS2 enclaves) for a node's participant, failing closed.
//!
//! The ROS 2 way (rcl's `rcl_get_security_options_from_environment`): security is on with
//! `ROS_SECURITY_ENABLE=true`; the keystore is `ROS_SECURITY_KEYSTORE`; the enclave is
//! `ROS_SECURITY_ENCLAVE_OVERRIDE`, else `--ros-args --enclave NAME`, else `/`; its files are
//! `<keystore>/enclaves/<enclave>/` ([`FILES`]: identity certificate and key, the two CA
//! certificates, the signed governance and permissions documents), the layout
//! `ros2 security create_keystore / create_enclave` and `naic security init` write.
//! An `--enclave` on the command line turns security on by itself (asking for an enclave
//! and running without one would be the silent fallback this module exists to prevent).
//!
//! **Fail closed.** rcl's `ROS_SECURITY_STRATEGY=Permissive` runs a node without security
//! when its enclave's files are missing; a naic node never does: an enclave it cannot load
//! (a missing or unreadable file, a file that is not what it should be, a certificate that
//! is expired or not yet valid, documents RustDDS refuses) stops it with a message naming
//! the file and the fix, whatever the strategy. A build without the `security` feature
//! refuses every enclave the same way.

use std::path::{Path, PathBuf};

use crate::RosError;

/// The files of an enclave directory, with what each must start with (PEM or S/MIME).
pub const FILES: [(&str, &str, &str); 6] = [
    ("identity_ca.cert.pem", "-----BEGIN CERTIFICATE-----", "the identity CA's certificate"),
    ("cert.pem", "-----BEGIN CERTIFICATE-----", "this enclave's identity certificate"),
    ("key.pem", "-----BEGIN", "this enclave's private key"),
    ("permissions_ca.cert.pem", "-----BEGIN CERTIFICATE-----", "the permissions CA's certificate"),
    ("governance.p7s", "MIME-Version", "the signed governance document (S/MIME)"),
    ("permissions.p7s", "MIME-Version", "this enclave's signed permissions document (S/MIME)"),
];

/// What to do about a broken keystore, for every message.
const FIX: &str = "create the keystore and the enclave with `naic security init KEYSTORE` (or `ros2 security create_keystore KEYSTORE` and `ros2 security create_enclave KEYSTORE /NAME`), or unset ROS_SECURITY_ENABLE and drop --enclave to run without DDS Security";

/// An enclave to run a participant in.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Enclave {
    /// The enclave's name, `/naic/chain`.
    pub name: String,
    /// `<keystore>/enclaves/<name>`.
    pub dir: PathBuf,
}

impl Enclave {
    /// From the environment and the command line's `--enclave`; `None`: security off.
    pub fn from_env(arg: Option<&str>) -> Result<Option<Enclave>, RosError> {
        Self::from_vars(arg, |k| std::env::var(k).ok())
    }

    /// [`Enclave::from_env`] with an explicit variable lookup (tests).
    pub fn from_vars(arg: Option<&str>, get: impl Fn(&str) -> Option<String>) -> Result<Option<Enclave>, RosError> {
        let enable = get("ROS_SECURITY_ENABLE").map(|s| s.trim().to_string()).unwrap_or_default();
        let on = match enable.as_str() {
            "true" => true,
            "" | "false" => arg.is_some(),
            other => {
                return Err(RosError::Env(format!(
                    "ROS_SECURITY_ENABLE='{other}': use true (DDS Security with the enclave of --enclave / ROS_SECURITY_ENCLAVE_OVERRIDE) or unset it"
                )))
            }
        };
        if !on {
            return Ok(None);
        }
        let keystore = get("ROS_SECURITY_KEYSTORE").map(|s| s.trim().to_string()).unwrap_or_default();
        if keystore.is_empty() {
            return Err(RosError::Env(format!(
                "DDS Security is on ({}) but ROS_SECURITY_KEYSTORE is not set: set it to the keystore directory (the one holding enclaves/); {FIX}",
                if enable == "true" { "ROS_SECURITY_ENABLE=true" } else { "--enclave" }
            )));
        }
        let name = get("ROS_SECURITY_ENCLAVE_OVERRIDE").filter(|s| !s.trim().is_empty()).or(arg.map(str::to_string)).unwrap_or_else(|| "/".into());
        let name = name.trim().to_string();
        if !name.starts_with('/') || name.split('/').any(|c| c == "..") {
            return Err(RosError::Args(format!("enclave '{name}': an enclave is an absolute name such as /naic/chain (a path under <keystore>/enclaves/)")));
        }
        let dir = Path::new(&keystore).join("enclaves").join(name.trim_start_matches('/'));
        Ok(Some(Enclave { name, dir }))
    }

    /// Every file of the enclave is there, readable, and of its kind; the identity
    /// certificate is valid now. `Err` names the first bad file and the fix.
    pub fn check(&self) -> Result<(), RosError> {
        if !self.dir.is_dir() {
            return Err(RosError::Node(format!(
                "enclave {}: no directory {} (ROS_SECURITY_KEYSTORE/enclaves{}); refusing to start without DDS Security: {FIX}",
                self.name,
                self.dir.display(),
                self.name
            )));
        }
        for (file, head, what) in FILES {
            let path = self.dir.join(file);
            let text = std::fs::read(&path).map_err(|e| {
                RosError::Node(format!("enclave {}: cannot read {} ({what}): {e}; refusing to start without DDS Security: {FIX}", self.name, path.display()))
            })?;
            let text = String::from_utf8_lossy(&text);
            if !text.trim_start().starts_with(head) {
                return Err(RosError::Node(format!(
                    "enclave {}: {} is not {what} (it does not start with '{head}'); refusing to start without DDS Security: {FIX}",
                    self.name,
                    path.display()
                )));
            }
        }
        #[cfg(feature = "security")]
        for file in ["cert.pem", "identity_ca.cert.pem", "permissions_ca.cert.pem"] {
            check_certificate(&self.name, &self.dir.join(file))?;
        }
        Ok(())
    }
}

/// The certificate at `path` parses and is valid now.
#[cfg(feature = "security")]
fn check_certificate(enclave: &str, path: &Path) -> Result<(), RosError> {
    let pem = std::fs::read(path).map_err(|e| RosError::Node(format!("enclave {enclave}: cannot read {}: {e}", path.display())))?;
    let bad = |why: String| RosError::Node(format!("enclave {enclave}: {} {why}; refusing to start without DDS Security: {FIX}", path.display()));
    let cert = openssl::x509::X509::from_pem(&pem).map_err(|e| bad(format!("is not a PEM certificate ({e})")))?;
    let now = openssl::asn1::Asn1Time::days_from_now(0).map_err(|e| bad(format!("cannot be checked ({e})")))?;
    if cert.not_after() < now {
        return Err(bad(format!("expired on {}: issue a new one (naic security init KEYSTORE --enclave NAME re-creates the enclave)", cert.not_after())));
    }
    if cert.not_before() > now {
        return Err(bad(format!("is not valid before {} (check this machine's clock)", cert.not_before())));
    }
    Ok(())
}

/// DDS Security in `b` from `enclave`'s files (checked first, [`Enclave::check`]).
#[cfg(feature = "security")]
pub fn secure(b: ros2_client::dds::rustdds::DomainParticipantBuilder, enclave: &Enclave) -> Result<ros2_client::dds::rustdds::DomainParticipantBuilder, RosError> {
    enclave.check()?;
    // The key files `naic security init` and `ros2 security` write are not encrypted.
    let files = ros2_client::dds::rustdds::DomainParticipantSecurityConfigFiles::with_ros_default_names(&enclave.dir, String::new());
    Ok(b.builtin_security(files))
}

/// Without the `security` feature every enclave is refused.
#[cfg(not(feature = "security"))]
pub fn secure(_b: ros2_client::dds::rustdds::DomainParticipantBuilder, enclave: &Enclave) -> Result<ros2_client::dds::rustdds::DomainParticipantBuilder, RosError> {
    Err(RosError::Node(format!(
        "enclave {}: this build has no DDS Security (built without the `security` feature); refusing to start without it: rebuild with `cargo build --release --features naic_ros/security` (needs libssl-dev and pkg-config), or unset ROS_SECURITY_ENABLE and drop --enclave",
        enclave.name
    )))
}

/// Whether this build carries DDS Security.
pub const AVAILABLE: bool = cfg!(feature = "security");

#[cfg(test)]
mod tests {
    use super::*;

    fn with(arg: Option<&str>, vars: &[(&str, &str)]) -> Result<Option<Enclave>, RosError> {
        let v: Vec<(String, String)> = vars.iter().map(|(a, b)| (a.to_string(), b.to_string())).collect();
        Enclave::from_vars(arg, move |k| v.iter().find(|(a, _)| a == k).map(|(_, b)| b.clone()))
    }

    #[test]
    fn the_enclave_comes_from_the_ros_variables_and_the_command_line() {
        assert_eq!(with(None, &[]).unwrap(), None, "off by default");
        assert_eq!(with(None, &[("ROS_SECURITY_KEYSTORE", "/ks")]).unwrap(), None, "a keystore alone does not turn it on");
        let e = with(Some("/naic/chain"), &[("ROS_SECURITY_KEYSTORE", "/ks")]).unwrap().unwrap();
        assert_eq!(e.dir, Path::new("/ks/enclaves/naic/chain"));
        let e = with(None, &[("ROS_SECURITY_ENABLE", "true"), ("ROS_SECURITY_KEYSTORE", "/ks")]).unwrap().unwrap();
        assert_eq!((e.name.as_str(), e.dir.as_path()), ("/", Path::new("/ks/enclaves")));
        let e = with(Some("/a"), &[("ROS_SECURITY_ENABLE", "true"), ("ROS_SECURITY_KEYSTORE", "/ks"), ("ROS_SECURITY_ENCLAVE_OVERRIDE", "/b")]).unwrap().unwrap();
        assert_eq!(e.name, "/b", "the override wins, as in rcl");
    }

    #[test]
    fn a_security_setting_that_cannot_work_is_an_error_not_a_fallback() {
        let e = with(Some("/naic/chain"), &[]).unwrap_err().to_string();
        assert!(e.contains("ROS_SECURITY_KEYSTORE is not set") && e.contains("naic security init"), "{e}");
        let e = with(None, &[("ROS_SECURITY_ENABLE", "yes")]).unwrap_err().to_string();
        assert!(e.contains("ROS_SECURITY_ENABLE='yes'"), "{e}");
        let e = with(Some("naic/chain"), &[("ROS_SECURITY_KEYSTORE", "/ks")]).unwrap_err().to_string();
        assert!(e.contains("absolute name"), "{e}");
        let e = with(Some("/../etc"), &[("ROS_SECURITY_KEYSTORE", "/ks")]).unwrap_err().to_string();
        assert!(e.contains("absolute name"), "{e}");
    }

    /// A self-signed certificate valid from `from_days` to `to_days` days from now (PEM).
    #[cfg(feature = "security")]
    fn certificate(from_days: i64, to_days: i64) -> Vec<u8> {
        use openssl::{asn1::Asn1Time, ec, hash::MessageDigest, nid::Nid, pkey::PKey, x509};
        let key = PKey::from_ec_key(ec::EcKey::generate(&ec::EcGroup::from_curve_name(Nid::X9_62_PRIME256V1).unwrap()).unwrap()).unwrap();
        let mut name = x509::X509NameBuilder::new().unwrap();
        name.append_entry_by_text("CN", "/naic/chain").unwrap();
        let name = name.build();
        let now = std::time::SystemTime::now().duration_since(std::time::UNIX_EPOCH).unwrap().as_secs() as i64;
        let mut b = x509::X509Builder::new().unwrap();
        b.set_subject_name(&name).unwrap();
        b.set_issuer_name(&name).unwrap();
        b.set_pubkey(&key).unwrap();
        b.set_not_before(&Asn1Time::from_unix(now + from_days * 86_400).unwrap()).unwrap();
        b.set_not_after(&Asn1Time::from_unix(now + to_days * 86_400).unwrap()).unwrap();
        b.sign(&key, MessageDigest::sha256()).unwrap();
        b.build().to_pem().unwrap()
    }

    #[cfg(feature = "security")]
    #[test]
    fn an_expired_or_future_certificate_is_named() {
        let dir = std::env::temp_dir().join(format!("naic-cert-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let p = dir.join("cert.pem");
        std::fs::write(&p, certificate(-10, 10)).unwrap();
        assert!(check_certificate("/naic/chain", &p).is_ok());
        std::fs::write(&p, certificate(-10, -1)).unwrap();
        let e = check_certificate("/naic/chain", &p).unwrap_err().to_string();
        assert!(e.contains("cert.pem expired on") && e.contains("naic security init"), "{e}");
        std::fs::write(&p, certificate(2, 10)).unwrap();
        let e = check_certificate("/naic/chain", &p).unwrap_err().to_string();
        assert!(e.contains("is not valid before"), "{e}");
        std::fs::write(&p, "-----BEGIN CERTIFICATE-----\nAAAA\n-----END CERTIFICATE-----\n").unwrap();
        let e = check_certificate("/naic/chain", &p).unwrap_err().to_string();
        assert!(e.contains("is not a PEM certificate"), "{e}");
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[cfg(not(feature = "security"))]
    #[test]
    fn a_build_without_security_refuses_every_enclave() {
        let e = Enclave { name: "/naic/chain".into(), dir: "/nonexistent".into() };
        let b = ros2_client::dds::rustdds::DomainParticipantBuilder::new(0);
        let msg = secure(b, &e).err().unwrap().to_string();
        assert!(msg.contains("no DDS Security") && msg.contains("naic_ros/security"), "{msg}");
    }

    #[test]
    fn a_missing_or_wrong_file_is_named() {
        let dir = std::env::temp_dir().join(format!("naic-enclave-{}", std::process::id()));
        let enc = dir.join("enclaves/naic/chain");
        std::fs::create_dir_all(&enc).unwrap();
        let e = Enclave { name: "/naic/chain".into(), dir: enc.clone() };
        let msg = e.check().unwrap_err().to_string();
        assert!(msg.contains("identity_ca.cert.pem") && msg.contains("refusing to start"), "{msg}");
        for (f, head, _) in FILES {
            std::fs::write(enc.join(f), format!("{head}\n")).unwrap();
        }
        std::fs::write(enc.join("governance.p7s"), "<dds>not signed</dds>").unwrap();
        let msg = e.check().unwrap_err().to_string();
        assert!(msg.contains("governance.p7s is not the signed governance document"), "{msg}");
        let gone = Enclave { name: "/nope".into(), dir: dir.join("enclaves/nope") };
        let msg = gone.check().unwrap_err().to_string();
        assert!(msg.contains("no directory") && msg.contains("enclaves/nope"), "{msg}");
        let _ = std::fs::remove_dir_all(&dir);
    }
}
