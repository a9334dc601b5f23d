//! DDS Security the ROS 2 way (SROS2): which enclave of which keystore a participant uses,
//! resolved like rcl from `ROS_SECURITY_ENABLE`, `ROS_SECURITY_KEYSTORE`,
//! `ROS_SECURITY_ENCLAVE_OVERRIDE` and `ROS_SECURITY_STRATEGY`. The participant then runs
//! RustDDS's builtin plugins (authentication PKI-DH, access control with signed governance and
//! permissions, AES-GCM cryptography) on the enclave's files
//! (`<keystore>/enclaves/<enclave>/{identity_ca.cert.pem, cert.pem, key.pem,
//! permissions_ca.cert.pem, governance.p7s, permissions.p7s}`, as made by
//! `launch-scripts/keystore.sh` or `ros2 security create_enclave`).

use std::path::{Path, PathBuf};

/// The enclave of the node (`rockwatch node`).
pub const NODE_ENCLAVE: &str = "/rockwatch/node";
/// The enclave of the senders of `/pbr/accel` (`rockwatch replay`, `rockwatch acquire`).
pub const STATION_ENCLAVE: &str = "/rockwatch/station";
/// The enclave of the operator's reset client (`rockwatch reset --node`).
pub const OPERATOR_ENCLAVE: &str = "/rockwatch/operator";
/// The enclave of read-only subscribers of `/pbr/alerts`, `/pbr/state`, `/pbr/ims`.
pub const READER_ENCLAVE: &str = "/rockwatch/reader";

/// The files of an enclave, in the SROS2 names (those RustDDS's
/// `DomainParticipantSecurityConfigFiles::with_ros_default_names` reads).
pub const ENCLAVE_FILES: [&str; 6] = [
    "identity_ca.cert.pem",
    "cert.pem",
    "key.pem",
    "permissions_ca.cert.pem",
    "governance.p7s",
    "permissions.p7s",
];

/// The security of one participant: the enclave and the directory holding its files.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct DdsSecurity {
    /// The enclave's name, e.g. `/rockwatch/node`.
    pub enclave: String,
    /// `<keystore>/enclaves/<enclave>`.
    pub dir: PathBuf,
}

/// What the SROS2 variables ask for.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum SecurityPlan {
    /// `ROS_SECURITY_ENABLE` is not `true`: no DDS Security.
    Off,
    /// Secured with these files.
    On(DdsSecurity),
    /// `ROS_SECURITY_STRATEGY` is `Permissive` (or unset) and the enclave cannot be used:
    /// the participant runs without security; the reason is said at start.
    PermissiveFallback(String),
}

/// Why the SROS2 variables cannot be followed (`ROS_SECURITY_STRATEGY=Enforce`, or a
/// malformed value).
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum SecurityError {
    #[error("ROS_SECURITY_STRATEGY must be Enforce or Permissive, got {0:?}")]
    Strategy(String),
    #[error("ROS_SECURITY_ENABLE=true but ROS_SECURITY_KEYSTORE is not set (ROS_SECURITY_STRATEGY=Enforce)")]
    NoKeystore,
    #[error(
        "enclave {0:?} must be an absolute path of names (e.g. /rockwatch/node), without . or .."
    )]
    BadEnclave(String),
    #[error(
        "{0} (ROS_SECURITY_STRATEGY=Enforce; create the keystore with launch-scripts/keystore.sh)"
    )]
    Missing(String),
}

/// The SROS2 environment of a process (the four variables' values).
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct SecurityEnv {
    pub enable: Option<String>,
    pub keystore: Option<String>,
    pub enclave_override: Option<String>,
    pub strategy: Option<String>,
}

impl SecurityEnv {
    /// This process's `ROS_SECURITY_*` variables.
    #[must_use]
    pub fn from_process() -> SecurityEnv {
        let var = |k| std::env::var(k).ok();
        SecurityEnv {
            enable: var("ROS_SECURITY_ENABLE"),
            keystore: var("ROS_SECURITY_KEYSTORE"),
            enclave_override: var("ROS_SECURITY_ENCLAVE_OVERRIDE"),
            strategy: var("ROS_SECURITY_STRATEGY"),
        }
    }
}

/// Resolves the SROS2 variables for a participant whose own enclave is `default_enclave`
/// (one of [`NODE_ENCLAVE`], [`STATION_ENCLAVE`], …), as rcl does: security only when
/// `ROS_SECURITY_ENABLE` is exactly `true`; the enclave is `ROS_SECURITY_ENCLAVE_OVERRIDE` when
/// set, else `default_enclave`; its files are `<ROS_SECURITY_KEYSTORE>/enclaves<enclave>/`.
/// When they cannot be used, `ROS_SECURITY_STRATEGY=Enforce` is an error and `Permissive` (the
/// default, as in ROS 2) runs without security.
pub fn security_plan(
    env: &SecurityEnv,
    default_enclave: &str,
) -> Result<SecurityPlan, SecurityError> {
    if env.enable.as_deref().map(str::trim) != Some("true") {
        return Ok(SecurityPlan::Off);
    }
    let enforce = match env.strategy.as_deref().map(str::trim) {
        None | Some("") | Some("Permissive") => false,
        Some("Enforce") => true,
        Some(other) => return Err(SecurityError::Strategy(other.to_owned())),
    };
    let fallback = |e: SecurityError| {
        if enforce {
            Err(e)
        } else {
            Ok(SecurityPlan::PermissiveFallback(e.to_string()))
        }
    };
    let enclave = match env.enclave_override.as_deref().map(str::trim) {
        Some(e) if !e.is_empty() => e,
        _ => default_enclave,
    };
    // A malformed name is a mistake, whatever the strategy.
    check_enclave(enclave)?;
    let keystore = match env.keystore.as_deref().map(str::trim) {
        Some(k) if !k.is_empty() => Path::new(k),
        _ => return fallback(SecurityError::NoKeystore),
    };
    let dir = keystore.join("enclaves").join(&enclave[1..]);
    let missing: Vec<&str> = ENCLAVE_FILES
        .iter()
        .copied()
        .filter(|f| !dir.join(f).is_file())
        .collect();
    if !missing.is_empty() {
        return fallback(SecurityError::Missing(format!(
            "enclave {enclave}: {} lacks {}",
            dir.display(),
            missing.join(", ")
        )));
    }
    Ok(SecurityPlan::On(DdsSecurity {
        enclave: enclave.to_owned(),
        dir,
    }))
}

/// Checks that `enclave` is an absolute path of names (`/rockwatch/node`), without `.`/`..`.
pub fn check_enclave(enclave: &str) -> Result<(), SecurityError> {
    let valid = enclave.starts_with('/')
        && enclave.len() > 1
        && enclave[1..]
            .split('/')
            .all(|p| !p.is_empty() && p != "." && p != "..");
    if valid {
        Ok(())
    } else {
        Err(SecurityError::BadEnclave(enclave.to_owned()))
    }
}

/// [`security_plan`] for this process's environment; a permissive fallback is said on stderr
/// (never silently unsecured) and gives `None`.
pub fn security_from_env(default_enclave: &str) -> Result<Option<DdsSecurity>, SecurityError> {
    match security_plan(&SecurityEnv::from_process(), default_enclave)? {
        SecurityPlan::Off => Ok(None),
        SecurityPlan::On(s) => Ok(Some(s)),
        SecurityPlan::PermissiveFallback(why) => {
            eprintln!(
                "rockwatch: warning: DDS Security requested (ROS_SECURITY_ENABLE=true) but not \
                 used: {why}; running WITHOUT security because ROS_SECURITY_STRATEGY is not \
                 Enforce"
            );
            Ok(None)
        }
    }
}

/// Pads `text` with `fill` so that its CDR encoding (a 4-byte length, the bytes and a NUL)
/// ends on a 4-byte boundary, i.e. `text.len() + 1` is a multiple of 4.
///
/// Why: RustDDS 0.15.1 cannot decode a protected payload whose length is not a multiple of 4.
/// Its `decode_serialized_payload` finds the CryptoFooter by counting back from the end of the
/// received payload, but the sender pads every DATA submessage to 4 bytes (RTPS), so the padding
/// is taken for the end of the footer and the MAC check fails ("ring … 'Unspecified' error",
/// or "Could not find decode key materials"). The messages of a secured rockwatch end on a
/// 4-byte field (`PbrAlert.episode`, `AccelPacket.up`, …); the reset request and response end
/// on a string, padded by this function when security is on (the server ignores trailing NULs
/// of an id; a response message may end in spaces).
#[must_use]
pub fn pad_for_protection(mut text: String, fill: char) -> String {
    debug_assert!(fill.is_ascii());
    while !(text.len() + 1).is_multiple_of(4) {
        text.push(fill);
    }
    text
}

#[cfg(test)]
mod tests {
    use super::*;

    fn keystore_with(enclave: &str, files: &[&str]) -> tempfile::TempDir {
        let k = tempfile::tempdir().unwrap();
        let d = k.path().join("enclaves").join(&enclave[1..]);
        std::fs::create_dir_all(&d).unwrap();
        for f in files {
            std::fs::write(d.join(f), "x").unwrap();
        }
        k
    }

    fn env(enable: &str, keystore: &Path, over: Option<&str>, strategy: &str) -> SecurityEnv {
        SecurityEnv {
            enable: Some(enable.into()),
            keystore: Some(keystore.display().to_string()),
            enclave_override: over.map(Into::into),
            strategy: Some(strategy.into()),
        }
    }

    #[test]
    fn the_enclave_is_the_override_or_the_commands_own() {
        let k = keystore_with(OPERATOR_ENCLAVE, &ENCLAVE_FILES);
        let e = env("true", k.path(), None, "Enforce");
        assert_eq!(
            security_plan(&e, STATION_ENCLAVE).unwrap_err(),
            SecurityError::Missing(format!(
                "enclave /rockwatch/station: {} lacks {}",
                k.path().join("enclaves/rockwatch/station").display(),
                ENCLAVE_FILES.join(", ")
            ))
        );
        let e = env("true", k.path(), Some("/rockwatch/operator"), "Enforce");
        assert_eq!(
            security_plan(&e, STATION_ENCLAVE).unwrap(),
            SecurityPlan::On(DdsSecurity {
                enclave: OPERATOR_ENCLAVE.into(),
                dir: k.path().join("enclaves/rockwatch/operator"),
            })
        );
    }

    #[test]
    fn only_true_enables_and_permissive_falls_back_loudly() {
        let k = keystore_with(NODE_ENCLAVE, &["cert.pem"]);
        for off in ["false", "1", "TRUE", ""] {
            let e = env(off, k.path(), None, "Enforce");
            assert_eq!(security_plan(&e, NODE_ENCLAVE).unwrap(), SecurityPlan::Off);
        }
        assert_eq!(
            security_plan(&SecurityEnv::default(), NODE_ENCLAVE).unwrap(),
            SecurityPlan::Off
        );
        let e = env("true", k.path(), None, "Permissive");
        match security_plan(&e, NODE_ENCLAVE).unwrap() {
            SecurityPlan::PermissiveFallback(why) => assert!(why.contains("key.pem"), "{why}"),
            other => panic!("{other:?}"),
        }
        let e = env("true", k.path(), None, "Enforce");
        assert!(matches!(
            security_plan(&e, NODE_ENCLAVE),
            Err(SecurityError::Missing(_))
        ));
        let mut e = env("true", k.path(), None, "Enforce");
        e.keystore = None;
        assert_eq!(
            security_plan(&e, NODE_ENCLAVE).unwrap_err(),
            SecurityError::NoKeystore
        );
        let e = env("true", k.path(), None, "enforce");
        assert!(matches!(
            security_plan(&e, NODE_ENCLAVE),
            Err(SecurityError::Strategy(_))
        ));
    }

    #[test]
    fn padded_strings_end_their_cdr_encoding_on_four_bytes() {
        for n in 0..12 {
            let s = pad_for_protection("é".repeat(n), '\0');
            assert_eq!((s.len() + 1) % 4, 0, "{n}");
            assert_eq!(s.trim_end_matches('\0'), "é".repeat(n));
            assert!(s.len() < 2 * n + 4);
        }
    }

    #[test]
    fn enclave_names_cannot_leave_the_keystore() {
        let k = keystore_with(NODE_ENCLAVE, &ENCLAVE_FILES);
        for bad in [
            "rockwatch/node",
            "/",
            "/rockwatch/../../etc",
            "/a//b",
            "/a/./b",
        ] {
            let e = env("true", k.path(), Some(bad), "Permissive");
            assert_eq!(
                security_plan(&e, NODE_ENCLAVE).unwrap_err(),
                SecurityError::BadEnclave(bad.into()),
                "{bad}"
            );
        }
    }
}
