//! The computers a robot runs on (`[[hosts]]`), and how they talk (`[network]`).
//!
//! A robot without `[[hosts]]` runs on one machine. With them, the first host is the robot's
//! own: its broker decides for the whole robot, and a service without `host = ...` runs
//! there. Every other host connects to the robot host's `listen` endpoints unless it names
//! its own `connect` ones. Endpoints are Zenoh's (`tcp/10.0.0.1:7447`); Lewis listens on
//! the ones the file names and nothing else.
//!
//! ```toml
//! [[hosts]]
//! name = "robot"
//! listen = ["tcp/10.77.0.1:7447"]
//!
//! [[hosts]]
//! name = "workstation"
//! listen = ["tcp/10.77.0.2:7447"]   # optional: where other hosts may reach it
//! # connect = ["tcp/10.77.0.1:7447"] # default: the robot host's listen endpoints
//!
//! [network]
//! key_file = "/etc/lewis/robot.key" # optional: hosts prove they share this key
//! link_deadline_ms = 200            # a host silent this long is lost (default: the
//!                                   # broker's heartbeat deadline)
//!
//! [network.tls]                     # needed by `quic/` endpoints: mutual TLS 1.3
//! ca = "/etc/lewis/ca.pem"          # the authority every host's certificate is signed by
//! certificate = "/etc/lewis/host.pem" # this host's certificate (each host its own file
//! private_key = "/etc/lewis/host.key" # at the same path), and its key
//! ```

use std::collections::BTreeMap;
use std::fmt;
use std::net::IpAddr;
use std::ops::Range;
use std::path::PathBuf;

use toml::Spanned;

use super::error::line_column;
use super::raw::{RawHost, RawNetwork, RawTls};
use super::validate::Checker;
use super::{BrokerSettings, ServiceSpec};

/// One computer of a multi-host robot.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct HostSpec {
    /// Its name, unique in the robot (an identifier); services name it with `host = ...`.
    pub name: String,
    /// What it is, for people.
    pub description: String,
    /// Where it accepts the other hosts' connections.
    pub listen: Vec<Endpoint>,
    /// Where it connects to: the robot host's `listen` endpoints unless the file says.
    pub connect: Vec<Endpoint>,
}

/// A network endpoint as the robot file writes it, `PROTOCOL/ADDRESS:PORT`
/// (`tcp/10.0.0.1:7447`, `quic/robot.local:7447`, `[::1]` in brackets): the form Zenoh
/// reads.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Endpoint {
    /// `tcp` or `quic`.
    pub protocol: String,
    /// The IP address or DNS name.
    pub address: String,
    /// The port.
    pub port: u16,
}

/// The protocols an endpoint may name: the ones the bridge's Zenoh is built with. `quic`
/// is TCP's encrypted alternative: TLS 1.3 inside QUIC, over UDP.
pub const PROTOCOLS: &[&str] = &["tcp", "quic"];

/// Zenoh's protocols Lewis does not offer, and why: what a robot file naming one is told.
const REFUSED: &[(&str, &str)] = &[
    (
        "tls",
        "Zenoh 1.10's TLS link reads and writes one TLS stream from two threads at once \
         (eclipse-zenoh/zenoh#2557), and with data crossing both ways the link broke and its \
         host was lost every few seconds; use `quic`, which encrypts with TLS 1.3 and the \
         same [network.tls]",
    ),
    (
        "udp",
        "Zenoh's UDP link drops what does not arrive, decisions and heartbeats included; use \
         `tcp`, or `quic` for an encrypted link",
    ),
];

impl Endpoint {
    /// Reads `PROTOCOL/ADDRESS:PORT`; the error says what is wrong.
    ///
    /// # Errors
    /// When the text is not of that form, names another protocol or a port out of range.
    pub fn parse(text: &str) -> Result<Self, String> {
        let Some((protocol, rest)) = text.split_once('/') else {
            return Err(format!(
                "endpoint `{}` has no protocol: write it as `tcp/ADDRESS:PORT`",
                text.escape_debug()
            ));
        };
        if let Some((_, why)) = REFUSED.iter().find(|(refused, _)| *refused == protocol) {
            return Err(format!(
                "endpoint `{}` names protocol `{protocol}`, which Lewis does not offer: {why}",
                text.escape_debug(),
            ));
        }
        if !PROTOCOLS.contains(&protocol) {
            let hint = lewis_stdx::closest(protocol, PROTOCOLS.iter().copied())
                .map_or_else(String::new, |near| format!("did you mean `{near}`? "));
            return Err(format!(
                "endpoint `{}` names protocol `{}`: {hint}Lewis speaks {}",
                text.escape_debug(),
                protocol.escape_debug(),
                PROTOCOLS.join(", ")
            ));
        }
        let Some((address, port)) = rest.rsplit_once(':') else {
            return Err(format!(
                "endpoint `{}` has no port: write it as `{protocol}/ADDRESS:PORT`",
                text.escape_debug()
            ));
        };
        let port: u16 = port.parse().ok().filter(|p| *p > 0).ok_or_else(|| {
            format!(
                "endpoint `{}` has port `{}`: a port is a number from 1 to 65535",
                text.escape_debug(),
                port.escape_debug()
            )
        })?;
        let bare = address
            .strip_prefix('[')
            .and_then(|a| a.strip_suffix(']'))
            .unwrap_or(address);
        let valid_name = !bare.is_empty()
            && bare
                .chars()
                .all(|c| c.is_ascii_alphanumeric() || c == '-' || c == '.');
        if bare.parse::<IpAddr>().is_err() && !valid_name {
            return Err(format!(
                "endpoint `{}` has address `{}`: give an IP address or a host name",
                text.escape_debug(),
                address.escape_debug()
            ));
        }
        Ok(Self {
            protocol: protocol.to_owned(),
            address: address.to_owned(),
            port,
        })
    }
}

impl fmt::Display for Endpoint {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}/{}:{}", self.protocol, self.address, self.port)
    }
}

/// How the hosts of a robot talk (`[network]`).
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub struct NetworkSettings {
    /// A file of the user's whose content every host must hold to join (Zenoh's
    /// user-password authentication, the robot's name as the user), when the file asks for
    /// one. It must be readable by its owner only, as an ssh key.
    pub key_file: Option<PathBuf>,
    /// A host silent this long (no heartbeat of its own or of its services) is lost, in
    /// milliseconds: its providers are failed and their clients move.
    pub link_deadline_ms: u64,
    /// The files of mutual TLS, for `quic/` endpoints.
    pub tls: Option<TlsFiles>,
}

/// The files of TLS between the hosts (`[network.tls]`): every host proves itself with a
/// certificate signed by the same authority, and checks the others' the same way.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct TlsFiles {
    /// The authority's certificate (PEM).
    pub ca: PathBuf,
    /// This host's certificate (PEM), for the address the others reach it at.
    pub certificate: PathBuf,
    /// This host's private key (PEM); readable by its owner only.
    pub private_key: PathBuf,
}

/// The span of the first `quic/` endpoint of the hosts, if any: such an endpoint needs
/// `[network.tls]`.
pub(super) fn first_encrypted_endpoint(hosts: &[Spanned<RawHost>]) -> Option<Range<usize>> {
    hosts
        .iter()
        .flat_map(|h| {
            let h = h.get_ref();
            h.listen.iter().chain(h.connect.iter().flatten())
        })
        .find(|e| e.get_ref().starts_with("quic/"))
        .map(Spanned::span)
}

impl Checker<'_> {
    /// The `[[hosts]]`: unique names, endpoints that parse, a way for every other host to
    /// reach the robot host.
    pub(super) fn hosts(&mut self, raw: Vec<Spanned<RawHost>>) -> Vec<HostSpec> {
        let mut hosts: Vec<HostSpec> = Vec::with_capacity(raw.len());
        let mut seen: BTreeMap<String, usize> = BTreeMap::new();
        let mut connect_given = Vec::with_capacity(raw.len());
        for (index, host) in raw.into_iter().enumerate() {
            let table_span = host.span();
            let host = host.into_inner();
            self.identifier(&host.name, "host name");
            if let Some(first_line) = seen.get(host.name.get_ref()) {
                let message = format!(
                    "duplicate host name `{}` (first declared on line {first_line}): give each host its own name",
                    host.name.get_ref()
                );
                self.report(&host.name.span(), message);
            } else {
                let (line, _) = line_column(self.text, host.name.span().start);
                seen.insert(host.name.get_ref().clone(), line);
            }
            let listen = self.endpoints(&host.listen);
            // An endpoint that does not parse is reported as such, not as none.
            if index == 0 && host.listen.is_empty() {
                self.report(
                    &table_span,
                    format!(
                        "host `{}` is the robot host (the first of [[hosts]]) and listens nowhere: give it `listen = [\"tcp/ADDRESS:7447\"]` so that the other hosts can reach its broker",
                        host.name.get_ref()
                    ),
                );
            }
            connect_given.push(host.connect.is_some());
            let connect = host
                .connect
                .as_deref()
                .map(|c| self.endpoints(c))
                .unwrap_or_default();
            hosts.push(HostSpec {
                name: host.name.into_inner(),
                description: host.description,
                listen,
                connect,
            });
        }
        // Every other host reaches the robot host where the file does not say otherwise.
        let robot_listen = hosts.first().map(|h| h.listen.clone()).unwrap_or_default();
        for (host, given) in hosts.iter_mut().zip(connect_given).skip(1) {
            if !given {
                host.connect.clone_from(&robot_listen);
            }
        }
        hosts
    }

    /// A path the file gives, relative to the file's folder.
    fn beside_file(&self, path: &Spanned<String>) -> PathBuf {
        let given = PathBuf::from(path.get_ref());
        if given.is_relative() {
            self.origin
                .parent()
                .map_or(given.clone(), |dir| dir.join(&given))
        } else {
            given
        }
    }

    fn endpoints(&mut self, raw: &[Spanned<String>]) -> Vec<Endpoint> {
        raw.iter()
            .filter_map(|text| match Endpoint::parse(text.get_ref()) {
                Ok(endpoint) => Some(endpoint),
                Err(message) => {
                    self.report(&text.span(), message);
                    None
                }
            })
            .collect()
    }

    /// A service's `host` must be one of `[[hosts]]`.
    pub(super) fn service_hosts(
        &mut self,
        services: &[ServiceSpec],
        hosts: &[HostSpec],
        spans: &[Option<Range<usize>>],
    ) {
        for (service, span) in services.iter().zip(spans) {
            let (Some(host), Some(span)) = (&service.host, span) else {
                continue;
            };
            if hosts.iter().any(|h| &h.name == host) {
                continue;
            }
            let message = if hosts.is_empty() {
                format!(
                    "service `{}` runs on host `{host}`, but the robot has no [[hosts]]: declare the hosts, or remove `host`",
                    service.name
                )
            } else {
                let names: Vec<&str> = hosts.iter().map(|h| h.name.as_str()).collect();
                let hint = lewis_stdx::closest(host, names.iter().copied())
                    .map_or_else(String::new, |near| format!("did you mean `{near}`? "));
                format!(
                    "service `{}` runs on host `{host}`, which the robot does not have: {hint}its hosts are {}",
                    service.name,
                    names.join(", ")
                )
            };
            self.report(span, message);
        }
    }

    /// `[network]`: the key file's path, relative to the robot file's folder, and the
    /// link deadline.
    pub(super) fn network(
        &mut self,
        raw: Option<Spanned<RawNetwork>>,
        broker: &BrokerSettings,
        hosts: &[HostSpec],
        first_encrypted: Option<&Range<usize>>,
    ) -> NetworkSettings {
        let mut network = NetworkSettings {
            key_file: None,
            link_deadline_ms: broker.heartbeat_deadline_ms,
            tls: None,
        };
        let needs_tls = |checker: &mut Self, network: &NetworkSettings| {
            if let (Some(span), None) = (first_encrypted, &network.tls) {
                checker.report(
                    span,
                    "a `quic/` endpoint needs the certificates of [network.tls]: `ca`, `certificate` and `private_key` files",
                );
            }
        };
        let Some(raw) = raw else {
            needs_tls(self, &network);
            return network;
        };
        if hosts.is_empty() {
            self.report(
                &raw.span(),
                "[network] is for a robot on more than one host, and this one has no [[hosts]]",
            );
        }
        let raw = raw.into_inner();
        network.key_file = raw.key_file.map(|path| self.beside_file(&path));
        network.tls = raw.tls.map(|tls: RawTls| TlsFiles {
            ca: self.beside_file(&tls.ca),
            certificate: self.beside_file(&tls.certificate),
            private_key: self.beside_file(&tls.private_key),
        });
        needs_tls(self, &network);
        if let Some(ms) = raw.link_deadline_ms
            && let Some(ms) = self.positive_ms(&ms, "[network] link_deadline_ms")
        {
            network.link_deadline_ms = ms;
        }
        network
    }
}

#[cfg(test)]
mod tests {
    use super::Endpoint;

    #[test]
    fn endpoints_are_read_and_written_back() {
        for text in [
            "tcp/10.77.0.1:7447",
            "quic/robot.local:7448",
            "tcp/[::1]:7447",
        ] {
            assert_eq!(
                Endpoint::parse(text).map(|e| e.to_string()),
                Ok(text.to_owned())
            );
        }
    }

    #[test]
    fn a_bad_endpoint_says_what_is_wrong() {
        let cases = [
            ("10.0.0.1:7447", "has no protocol"),
            ("tpc/10.0.0.1:7447", "did you mean `tcp`?"),
            ("tcp/10.0.0.1", "has no port"),
            ("tcp/10.0.0.1:99999", "a port is a number from 1 to 65535"),
            ("tcp/10.0.0.1:0", "a port is a number"),
            ("tcp/:7447", "give an IP address or a host name"),
            ("tcp/a b:7447", "give an IP address or a host name"),
        ];
        for (text, expected) in cases {
            let error = Endpoint::parse(text).expect_err(text);
            assert!(error.contains(expected), "{text}: {error}");
        }
    }
}
