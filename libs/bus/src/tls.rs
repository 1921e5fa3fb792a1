//! Per-session certificates for Zenoh's `quic/` links (mutual TLS).
//!
//! Beside the passwords (see [`crate::auth`]), each session gets its own certificate authority
//! and one certificate per process (common name: the process's user name, e.g. `camera-O1`) plus
//! one for the router. The CA's private key is never written: once the session's certificates are
//! issued nobody can mint another, and a certificate of another session (another CA) is refused
//! by every link. Certificates expire with the session (`valid_for`; Zenoh closes a link whose
//! certificate expires). Files, all private (0600) in the secrets directory: `ca.pem`,
//! `<user>.cert.pem`, `<user>.key.pem`.
//!
//! Only `quic/` endpoints use them: Zenoh 1.10.2's `tls/` link is unsound
//! (eclipse-zenoh/zenoh#2557), and loopback TCP needs no encryption.

use std::path::{Path, PathBuf};
use std::time::Duration;

use rcgen::{
    BasicConstraints, CertificateParams, DnType, ExtendedKeyUsagePurpose, IsCa, Issuer, KeyPair,
    KeyUsagePurpose, SanType,
};

use crate::error::BusError;

/// The router's certificate name (the router has no password: it checks the others').
pub const ROUTER_CERT_NAME: &str = "router";

/// The session CA's certificate file in a secrets directory.
pub const CA_FILE: &str = "ca.pem";

/// The certificate and key files of `name` in a secrets directory.
pub fn cert_files(dir: &Path, name: &str) -> TlsFiles {
    TlsFiles {
        ca: dir.join(CA_FILE),
        cert: dir.join(format!("{name}.cert.pem")),
        key: dir.join(format!("{name}.key.pem")),
    }
}

/// One process's TLS files: the session CA, its certificate and its private key.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct TlsFiles {
    pub ca: PathBuf,
    pub cert: PathBuf,
    pub key: PathBuf,
}

impl TlsFiles {
    /// True when all three files exist.
    pub fn exist(&self) -> bool {
        [&self.ca, &self.cert, &self.key]
            .iter()
            .all(|p| p.is_file())
    }
}

fn tls_err(what: &str, e: impl std::fmt::Display) -> BusError {
    BusError::Credentials(format!("certificates: {what}: {e}"))
}

/// Issues a session CA and a certificate for each of `names` into `dir` through `write`
/// (which writes one private file), valid from a minute ago for `valid_for`.
pub(crate) fn issue(
    session_label: &str,
    names: &[String],
    valid_for: Duration,
    mut write: impl FnMut(&Path, &str) -> Result<(), BusError>,
    dir: &Path,
) -> Result<(), BusError> {
    let now = time::OffsetDateTime::now_utc();
    let not_before = now - time::Duration::minutes(1);
    let not_after =
        now + time::Duration::try_from(valid_for).map_err(|e| tls_err("validity", e))?;

    let ca_key = KeyPair::generate().map_err(|e| tls_err("CA key", e))?;
    let mut ca = CertificateParams::new(Vec::<String>::new()).map_err(|e| tls_err("CA", e))?;
    ca.is_ca = IsCa::Ca(BasicConstraints::Constrained(0));
    ca.distinguished_name.push(
        DnType::CommonName,
        format!("waggle session {session_label} CA"),
    );
    ca.key_usages = vec![
        KeyUsagePurpose::KeyCertSign,
        KeyUsagePurpose::CrlSign,
        KeyUsagePurpose::DigitalSignature,
    ];
    ca.not_before = not_before;
    ca.not_after = not_after;
    let ca_cert = ca.self_signed(&ca_key).map_err(|e| tls_err("CA", e))?;
    write(&dir.join(CA_FILE), &ca_cert.pem())?;
    let issuer = Issuer::new(ca, ca_key);

    for name in names {
        let key = KeyPair::generate().map_err(|e| tls_err(name, e))?;
        let mut p = CertificateParams::new(vec!["localhost".to_string(), name.clone()])
            .map_err(|e| tls_err(name, e))?;
        p.subject_alt_names
            .push(SanType::IpAddress(std::net::Ipv4Addr::LOCALHOST.into()));
        p.distinguished_name.push(DnType::CommonName, name.clone());
        p.key_usages = vec![
            KeyUsagePurpose::DigitalSignature,
            KeyUsagePurpose::KeyEncipherment,
        ];
        p.extended_key_usages = vec![
            ExtendedKeyUsagePurpose::ServerAuth,
            ExtendedKeyUsagePurpose::ClientAuth,
        ];
        p.not_before = not_before;
        p.not_after = not_after;
        let cert = p.signed_by(&key, &issuer).map_err(|e| tls_err(name, e))?;
        let files = cert_files(dir, name);
        write(&files.cert, &cert.pem())?;
        write(&files.key, &key.serialize_pem())?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::collections::BTreeMap;

    #[test]
    fn a_session_gets_a_ca_and_one_certificate_and_key_per_name() {
        let mut files: BTreeMap<PathBuf, String> = BTreeMap::new();
        let dir = Path::new("/nowhere");
        issue(
            "s1",
            &["camera-O1".to_string(), ROUTER_CERT_NAME.to_string()],
            Duration::from_secs(3600),
            |p, text| {
                files.insert(p.to_path_buf(), text.to_string());
                Ok(())
            },
            dir,
        )
        .unwrap();
        let names: Vec<String> = files
            .keys()
            .map(|p| p.file_name().unwrap().to_string_lossy().into_owned())
            .collect();
        assert_eq!(
            names,
            [
                "ca.pem",
                "camera-O1.cert.pem",
                "camera-O1.key.pem",
                "router.cert.pem",
                "router.key.pem"
            ]
        );
        assert!(files[&dir.join("ca.pem")].starts_with("-----BEGIN CERTIFICATE-----"));
        assert!(files[&dir.join("router.key.pem")].contains("PRIVATE KEY"));
        // Two sessions never share a CA.
        let mut other = String::new();
        issue(
            "s2",
            &[],
            Duration::from_secs(60),
            |p, t| {
                if p.ends_with(CA_FILE) {
                    other = t.to_string();
                }
                Ok(())
            },
            dir,
        )
        .unwrap();
        assert_ne!(other, files[&dir.join("ca.pem")]);
    }
}
