//! `naic security init KEYSTORE`: an SROS2-layout keystore made with the `openssl` command,
//! for machines without the ros2 CLI (`ros2 security create_keystore` / `create_enclave`
//! make the same layout).
//!
//! ```text
//! KEYSTORE/public/ca.cert.pem              one CA for identities and permissions (as sros2)
//! KEYSTORE/private/ca.key.pem              its key: keep it off the robot
//! KEYSTORE/enclaves/governance.xml, .p7s   the domain's rules, signed by the CA
//! KEYSTORE/enclaves/<enclave>/             per enclave (what a node's --enclave names):
//!     cert.pem key.pem                     identity (CN = the enclave name), signed by the CA
//!     identity_ca.cert.pem permissions_ca.cert.pem governance.p7s
//!     permissions.xml permissions.p7s      what it may publish and subscribe, signed
//! ```
//!
//! Governance: authentication required (no unauthenticated participant joins), access
//! control on every topic, discovery and liveliness encrypted, the command and state topics
//! (`/joint_effort_cmd`, `/naic/effort`, `/joint_states`, `/wrench`) encrypted, every other
//! topic signed. Permissions: the chain's enclave (`/naic/chain`, the default of
//! `naic launch --enclave`) may publish and subscribe everything; every other enclave
//! (default: `/naic/observer`, for tools and rclpy observers) may subscribe everything and
//! publish everything but `/joint_effort_cmd` and `/naic/effort`.

use std::{
    path::{Path, PathBuf},
    process::Command,
};

use super::{CliError, CliResult};

/// The enclave of the chain's three nodes.
pub const CHAIN_ENCLAVE: &str = "/naic/chain";
/// The command topics only the chain may publish (DDS names).
const COMMAND_TOPICS: [&str; 2] = ["rt/joint_effort_cmd", "rt/naic/effort"];
/// The topics whose data is encrypted (DDS names); the others are signed.
const ENCRYPTED_TOPICS: [&str; 4] = ["rt/joint_effort_cmd", "rt/naic/effort", "rt/joint_states", "rt/wrench"];

#[derive(clap::Subcommand)]
pub enum SecurityCmd {
    /// Create an SROS2-layout keystore with the `openssl` command (CA, governance, enclaves).
    Init(InitArgs),
}

#[derive(clap::Args)]
pub struct InitArgs {
    /// The keystore directory to create (must not hold a keystore already, unless --force).
    pub keystore: PathBuf,
    /// Enclaves to create (repeatable); the first is the chain's. Default: /naic/chain
    /// (publishes the commands) and /naic/observer (reads, sets parameters, never commands).
    #[arg(long = "enclave")]
    pub enclaves: Vec<String>,
    /// Validity of the CA and the identity certificates [days].
    #[arg(long, default_value_t = 3650)]
    pub days: u32,
    /// Add enclaves to an existing keystore (its CA is reused), or replace them.
    #[arg(long)]
    pub force: bool,
}

pub fn run(c: SecurityCmd) -> CliResult {
    match c {
        SecurityCmd::Init(a) => init(&a),
    }
}

fn openssl(args: &[&str], what: &str) -> CliResult {
    let out = Command::new("openssl").args(args).output().map_err(|e| {
        CliError::failure(format!("cannot run `openssl` ({e}): install it (Debian/Ubuntu: apt-get install openssl) to create a keystore, or use `ros2 security create_keystore`"))
    })?;
    if !out.status.success() {
        return Err(CliError::failure(format!("openssl failed to {what}: {}", String::from_utf8_lossy(&out.stderr).trim())));
    }
    Ok(())
}

fn write(path: &Path, text: &str) -> CliResult {
    std::fs::write(path, text).map_err(|e| CliError::failure(format!("cannot write {}: {e}", path.display())))
}

fn mkdir(path: &Path) -> CliResult {
    std::fs::create_dir_all(path).map_err(|e| CliError::failure(format!("cannot create {}: {e}", path.display())))
}

fn s(p: &Path) -> &str {
    p.to_str().unwrap_or_default()
}

/// Sign `xml` as S/MIME (multipart/signed, what DDS Security reads) with the CA into `p7s`.
fn sign(xml: &Path, p7s: &Path, ca_cert: &Path, ca_key: &Path) -> CliResult {
    openssl(&["smime", "-sign", "-text", "-in", s(xml), "-out", s(p7s), "-signer", s(ca_cert), "-inkey", s(ca_key)], &format!("sign {}", xml.display()))
}

fn utc_now_plus(days: u32) -> String {
    let now = std::time::SystemTime::now().duration_since(std::time::UNIX_EPOCH).map(|d| d.as_secs() as i64).unwrap_or(0);
    let t = |secs: i64| {
        let (y, mo, d, h, mi, se) = super::utc_civil(secs);
        format!("{y:04}-{mo:02}-{d:02}T{h:02}:{mi:02}:{se:02}Z")
    };
    t(now + i64::from(days) * 86_400)
}

fn utc_now() -> String {
    let now = std::time::SystemTime::now().duration_since(std::time::UNIX_EPOCH).map(|d| d.as_secs() as i64).unwrap_or(0);
    let (y, mo, d, h, mi, se) = super::utc_civil(now - 86_400);
    format!("{y:04}-{mo:02}-{d:02}T{h:02}:{mi:02}:{se:02}Z")
}

/// The governance document (DDS Security 1.1, as sros2's template, with per-topic rules).
pub fn governance_xml() -> String {
    let rule = |expr: &str, kind: &str| {
        format!(
            "        <topic_rule>\n          <topic_expression>{expr}</topic_expression>\n          <enable_discovery_protection>true</enable_discovery_protection>\n          <enable_liveliness_protection>true</enable_liveliness_protection>\n          <enable_read_access_control>true</enable_read_access_control>\n          <enable_write_access_control>true</enable_write_access_control>\n          <metadata_protection_kind>{kind}</metadata_protection_kind>\n          <data_protection_kind>{kind}</data_protection_kind>\n        </topic_rule>\n"
        )
    };
    let mut rules: String = ENCRYPTED_TOPICS.iter().map(|t| rule(t, "ENCRYPT")).collect();
    rules.push_str(&rule("*", "SIGN"));
    format!(
        r#"<?xml version="1.0" encoding="UTF-8"?>
<dds xmlns:xsi="http://www.w3.org/2001/XMLSchema-instance" xsi:noNamespaceSchemaLocation="http://www.omg.org/spec/DDS-Security/20170801/omg_shared_ca_domain_governance.xsd">
  <domain_access_rules>
    <domain_rule>
      <domains>
        <id_range>
          <min>0</min>
          <max>232</max>
        </id_range>
      </domains>
      <allow_unauthenticated_participants>false</allow_unauthenticated_participants>
      <enable_join_access_control>true</enable_join_access_control>
      <discovery_protection_kind>ENCRYPT</discovery_protection_kind>
      <liveliness_protection_kind>ENCRYPT</liveliness_protection_kind>
      <rtps_protection_kind>SIGN</rtps_protection_kind>
      <topic_access_rules>
{rules}      </topic_access_rules>
    </domain_rule>
  </domain_access_rules>
</dds>
"#
    )
}

/// The permissions of `enclave` (subject `CN=<enclave>`), valid for `days`.
pub fn permissions_xml(enclave: &str, chain: bool, days: u32) -> String {
    let topics = |ts: &[&str]| ts.iter().map(|t| format!("            <topic>{t}</topic>\n")).collect::<String>();
    let deny = if chain {
        String::new()
      } else {
        format!(
            "      <deny_rule>\n        <domains>\n          <id_range>\n            <min>0</min>\n            <max>232</max>\n          </id_range>\n        </domains>\n        <publish>\n          <topics>\n{}          </topics>\n        </publish>\n      </deny_rule>\n",
            topics(&COMMAND_TOPICS)
        )
    };
    format!(
        r#"<?xml version="1.0" encoding="UTF-8"?>
<dds xmlns:xsi="http://www.w3.org/2001/XMLSchema-instance" xsi:noNamespaceSchemaLocation="http://www.omg.org/spec/DDS-Security/20170801/omg_shared_ca_permissions.xsd">
  <permissions>
    <grant name="{enclave}">
      <subject_name>CN={enclave}</subject_name>
      <validity>
        <not_before>{}</not_before>
        <not_after>{}</not_after>
      </validity>
{deny}      <allow_rule>
        <domains>
          <id_range>
            <min>0</min>
            <max>232</max>
          </id_range>
        </domains>
        <publish>
          <topics>
            <topic>*</topic>
          </topics>
        </publish>
        <subscribe>
          <topics>
            <topic>*</topic>
          </topics>
        </subscribe>
      </allow_rule>
      <default>DENY</default>
    </grant>
  </permissions>
</dds>
"#,
        utc_now(),
        utc_now_plus(days)
    )
}

fn check_enclave_name(e: &str) -> CliResult {
    let ok = e.starts_with('/') && e.len() > 1 && e[1..].split('/').all(|c| !c.is_empty() && c != ".." && c.chars().all(|ch| ch.is_ascii_alphanumeric() || ch == '_'));
    if ok {
        Ok(())
    } else {
        Err(CliError::usage(format!("--enclave '{e}': an enclave is an absolute name of letters, digits and _ such as /naic/chain")))
    }
}

pub fn init(a: &InitArgs) -> CliResult {
    let enclaves: Vec<String> = if a.enclaves.is_empty() { vec![CHAIN_ENCLAVE.into(), "/naic/observer".into()] } else { a.enclaves.clone() };
    for e in &enclaves {
        check_enclave_name(e)?;
    }
    let ks = &a.keystore;
    let (public, private, encl) = (ks.join("public"), ks.join("private"), ks.join("enclaves"));
    let (ca_cert, ca_key) = (public.join("ca.cert.pem"), private.join("ca.key.pem"));
    if ca_cert.exists() && !a.force {
        return Err(CliError::usage(format!(
            "{} already holds a keystore (public/ca.cert.pem); add --force to add or replace enclaves with its CA",
            ks.display()
        )));
    }
    for d in [&public, &private, &encl] {
        mkdir(d)?;
    }
    let days = a.days.to_string();
    if !ca_cert.exists() {
        openssl(&["ecparam", "-name", "prime256v1", "-genkey", "-noout", "-out", s(&ca_key)], "create the CA key")?;
        openssl(
            &["req", "-new", "-x509", "-sha256", "-key", s(&ca_key), "-out", s(&ca_cert), "-days", &days, "-subj", "/CN=naic keystore CA"],
            "create the CA certificate",
        )?;
        // sros2's layout: the identity and permissions CAs are the one CA.
        for n in ["identity_ca", "permissions_ca"] {
            let _ = std::fs::copy(&ca_cert, public.join(format!("{n}.cert.pem")));
            let _ = std::fs::copy(&ca_key, private.join(format!("{n}.key.pem")));
        }
    }
    let gov_xml = encl.join("governance.xml");
    let gov_p7s = encl.join("governance.p7s");
    write(&gov_xml, &governance_xml())?;
    sign(&gov_xml, &gov_p7s, &ca_cert, &ca_key)?;
    for (i, e) in enclaves.iter().enumerate() {
        let dir = encl.join(e.trim_start_matches('/'));
        mkdir(&dir)?;
        let (key, cert, csr) = (dir.join("key.pem"), dir.join("cert.pem"), dir.join("req.csr"));
        openssl(&["genpkey", "-algorithm", "EC", "-pkeyopt", "ec_paramgen_curve:prime256v1", "-out", s(&key)], &format!("create the key of {e}"))?;
        openssl(&["req", "-new", "-sha256", "-key", s(&key), "-out", s(&csr), "-subj", &format!("/CN={}", e.replace('/', "\\/"))], &format!("request the certificate of {e}"))?;
        openssl(
            &["x509", "-req", "-sha256", "-in", s(&csr), "-CA", s(&ca_cert), "-CAkey", s(&ca_key), "-CAcreateserial", "-out", s(&cert), "-days", &days],
            &format!("issue the certificate of {e}"),
        )?;
        let _ = std::fs::remove_file(&csr);
        for n in ["identity_ca", "permissions_ca"] {
            std::fs::copy(&ca_cert, dir.join(format!("{n}.cert.pem"))).map_err(|x| CliError::failure(format!("cannot copy the CA into {}: {x}", dir.display())))?;
        }
        std::fs::copy(&gov_p7s, dir.join("governance.p7s")).map_err(|x| CliError::failure(format!("cannot copy governance.p7s into {}: {x}", dir.display())))?;
        let perm_xml = dir.join("permissions.xml");
        write(&perm_xml, &permissions_xml(e, i == 0, a.days))?;
        sign(&perm_xml, &dir.join("permissions.p7s"), &ca_cert, &ca_key)?;
        println!("enclave {e}: {}{}", dir.display(), if i == 0 { " (may publish the commands)" } else { " (may not publish /joint_effort_cmd, /naic/effort)" });
    }
    let _ = std::fs::remove_file(ks.join("public/ca.cert.srl"));
    println!(
        "keystore {}: run the chain with `naic launch --enclave {}` (needs a build with --features naic_ros/security); keep private/ off the robot",
        ks.display(),
        encl.join(enclaves[0].trim_start_matches('/')).display()
    );
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn only_the_chain_may_publish_the_commands() {
        let chain = permissions_xml("/naic/chain", true, 10);
        let obs = permissions_xml("/naic/observer", false, 10);
        assert!(!chain.contains("deny_rule") && chain.contains("<subject_name>CN=/naic/chain</subject_name>"));
        let deny = &obs[obs.find("<deny_rule>").unwrap()..obs.find("</deny_rule>").unwrap()];
        assert!(deny.contains("rt/joint_effort_cmd") && deny.contains("rt/naic/effort"), "{deny}");
        assert!(obs.find("<deny_rule>") < obs.find("<allow_rule>"), "the deny rule must come first (first match wins)");
    }

    #[test]
    fn governance_encrypts_the_command_and_state_topics() {
        let g = governance_xml();
        for t in ENCRYPTED_TOPICS {
            let at = g.find(&format!("<topic_expression>{t}</topic_expression>")).unwrap();
            assert!(g[at..].find("ENCRYPT") < g[at..].find("</topic_rule>"), "{t}");
        }
        assert!(g.contains("<allow_unauthenticated_participants>false</allow_unauthenticated_participants>"));
        assert!(g.contains("<enable_join_access_control>true</enable_join_access_control>"));
    }

    #[test]
    fn bad_enclave_names_are_refused() {
        for bad in ["naic", "/", "/a/../b", "/a b", "/a//b"] {
            assert!(check_enclave_name(bad).is_err(), "{bad}");
        }
        assert!(check_enclave_name("/naic/chain").is_ok());
    }
}
