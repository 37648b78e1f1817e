//! The Zenoh session of one host, configured from the robot file alone: it listens on the
//! endpoints the file names and nowhere else, connects to the robot host (or where the file
//! says), scouts nothing, and proves the robot's key where the file asks for one.

use std::fs;
use std::io::Write as _;
use std::os::unix::fs::{MetadataExt as _, OpenOptionsExt as _};
use std::path::{Path, PathBuf};

use lewis_robot::{Endpoint, HostSpec, Robot, TlsFiles};
use zenoh::{Config, Session, Wait as _};

use crate::BridgeError;

/// The version of what the bridge says on Zenoh (its keys, beats and orders): hosts that
/// differ refuse each other with a clear error instead of misreading each other.
pub const PROTOCOL: u32 = 1;

/// What a host's beat says ([`crate::wire::beat_protocol`] of its text).
pub(crate) fn beat_protocol(payload: &zenoh::bytes::ZBytes) -> Result<(), String> {
    crate::wire::beat_protocol(&payload.try_to_string().unwrap_or_default())
}

/// Why `host`, whose beat says `said`, is not one this host works with.
pub(crate) fn other_protocol(host: &str, said: &str) -> String {
    format!(
        "{host} speaks bridge protocol `{said}`, this one {PROTOCOL}: run the same lewis on every host"
    )
}

/// Opens `host`'s session of `robot`. `scratch` is a folder of this run's own where the
/// key's dictionary is written (readable by its owner only).
///
/// # Errors
/// When the key file is missing, readable by others or empty, or Zenoh refuses the
/// configuration or cannot listen where the file says.
pub fn open(robot: &Robot, host: &HostSpec, scratch: &Path) -> Result<Session, BridgeError> {
    let config = config(robot, host, scratch)?;
    zenoh::open(config)
        .wait()
        .map_err(|e| BridgeError::Session {
            host: host.name.clone(),
            reason: e.to_string(),
        })
}

fn config(robot: &Robot, host: &HostSpec, scratch: &Path) -> Result<Config, BridgeError> {
    let mut config = Config::default();
    let list = |endpoints: &[Endpoint]| {
        let quoted: Vec<String> = endpoints.iter().map(|e| format!("\"{e}\"")).collect();
        format!("[{}]", quoted.join(","))
    };
    let mut settings: Vec<(&str, String)> = vec![
        ("mode", "\"peer\"".to_owned()),
        ("listen/endpoints", list(&host.listen)),
        ("connect/endpoints", list(&host.connect)),
        // A host started before the robot host waits for it: retried, never given up.
        ("connect/exit_on_failure", "false".to_owned()),
        (
            "connect/retry",
            "{period_init_ms: 100, period_max_ms: 1000, period_increase_factor: 2}".to_owned(),
        ),
        ("scouting/multicast/enabled", "false".to_owned()),
        // A link cut for a second closes the session, and the host connects afresh when the
        // link is back, rather than waiting out TCP's retransmission backoff on the old one.
        ("transport/link/tx/lease", "1000".to_owned()),
        ("transport/link/tx/keep_alive", "4".to_owned()),
    ];
    if let Some(key_file) = &robot.network.key_file {
        let key = read_key(key_file)?;
        let dictionary = scratch.join("zenoh-users");
        write_private(&dictionary, &format!("{}:{key}\n", robot.name)).map_err(|source| {
            BridgeError::Scratch {
                path: dictionary.clone(),
                source,
            }
        })?;
        settings.push(("transport/auth/usrpwd/user", json(&robot.name)));
        settings.push(("transport/auth/usrpwd/password", json(&key)));
        settings.push((
            "transport/auth/usrpwd/dictionary_file",
            json(&dictionary.to_string_lossy()),
        ));
    }
    if let Some(tls) = &robot.network.tls {
        settings.extend(tls_settings(tls)?);
    }
    for (key, value) in settings {
        config
            .insert_json5(key, &value)
            .map_err(|e| BridgeError::Config {
                key: key.to_owned(),
                reason: e.to_string(),
            })?;
    }
    Ok(config)
}

fn json(text: &str) -> String {
    serde_json::Value::String(text.to_owned()).to_string()
}

/// The shared key: the file's first line, from a file only its owner may read.
fn read_key(path: &Path) -> Result<String, BridgeError> {
    let error = |reason: String| BridgeError::Key {
        path: path.to_path_buf(),
        reason,
    };
    check_private(path).map_err(error)?;
    let text = fs::read_to_string(path).map_err(|e| error(e.to_string()))?;
    let key = text.lines().next().unwrap_or("").trim().to_owned();
    if key.is_empty() || key.contains(':') {
        return Err(error(
            "its first line must be the key: not empty, without `:`".to_owned(),
        ));
    }
    Ok(key)
}

/// A secret's file must be the user's, readable by them only, as an ssh key; else why not.
fn check_private(path: &Path) -> Result<(), String> {
    let meta = fs::metadata(path).map_err(|e| e.to_string())?;
    if meta.mode() & 0o077 != 0 {
        return Err(format!(
            "others may read it (mode {:o}): `chmod 600 {}`",
            meta.mode() & 0o777,
            path.display()
        ));
    }
    // The owner of this process's own /proc entry is the user running it.
    let uid = fs::metadata("/proc/self").map_or(meta.uid(), |m| m.uid());
    if meta.uid() != uid {
        return Err(format!(
            "it belongs to user {}, not to the user running lewis ({uid})",
            meta.uid()
        ));
    }
    Ok(())
}

/// Zenoh's settings of mutual TLS from `[network.tls]`: the files must be there, the
/// private key readable by its owner only.
fn tls_settings(tls: &TlsFiles) -> Result<Vec<(&'static str, String)>, BridgeError> {
    let error = |path: &Path, reason: String| BridgeError::Tls {
        path: path.to_path_buf(),
        reason,
    };
    for path in [&tls.ca, &tls.certificate] {
        fs::metadata(path).map_err(|e| error(path, e.to_string()))?;
    }
    check_private(&tls.private_key).map_err(|reason| error(&tls.private_key, reason))?;
    let path = |p: &Path| json(&p.to_string_lossy());
    Ok(vec![
        ("transport/link/tls/root_ca_certificate", path(&tls.ca)),
        (
            "transport/link/tls/listen_certificate",
            path(&tls.certificate),
        ),
        (
            "transport/link/tls/listen_private_key",
            path(&tls.private_key),
        ),
        (
            "transport/link/tls/connect_certificate",
            path(&tls.certificate),
        ),
        (
            "transport/link/tls/connect_private_key",
            path(&tls.private_key),
        ),
        ("transport/link/tls/enable_mtls", "true".to_owned()),
    ])
}

fn write_private(path: &PathBuf, text: &str) -> std::io::Result<()> {
    let mut file = fs::OpenOptions::new()
        .write(true)
        .create(true)
        .truncate(true)
        .mode(0o600)
        .open(path)?;
    file.write_all(text.as_bytes())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_beat_of_another_version_or_of_no_lewis_says_what_it_said() {
        let beat = |text: &str| beat_protocol(&zenoh::bytes::ZBytes::from(text));
        assert_eq!(beat(&PROTOCOL.to_string()), Ok(()));
        assert_eq!(beat("99"), Err("99".to_owned()));
        assert_eq!(beat(""), Err("unknown".to_owned()));
        assert_eq!(
            other_protocol("workstation", "99"),
            "workstation speaks bridge protocol `99`, this one 1: run the same lewis on every host"
        );
    }
}
