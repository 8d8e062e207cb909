//! Kinova Gen3 arms over Ethernet with Kinova's Kortex protocol (API 2.6): the messages
//! ([`proto`], compiled from `hw-adapter/proto`), their framing ([`header`], [`codec`]), one
//! link with its session ([`channel`]), and the arm as the executor drives it ([`KortexArm`]).
//!
//! `--arm NAME=kortex:HOST` reaches the arm at HOST on TCP 10000 and UDP 10001;
//! `kortex:HOST:TCP_PORT:UDP_PORT` names other ports (the tests' mocks).

pub mod arm;
pub mod channel;
pub mod codec;
pub mod header;
pub mod proto;

pub use arm::KortexArm;

use std::fmt;
use std::net::{SocketAddr, ToSocketAddrs};

/// The Gen3's TCP port (configuration rpcs).
pub const DEFAULT_TCP_PORT: u16 = 10000;
/// The Gen3's UDP port (the cyclic rpcs).
pub const DEFAULT_UDP_PORT: u16 = 10001;
/// Environment variable read for the user name when no option gives it.
pub const USER_ENV: &str = "OMCBSA_KORTEX_USER";
/// Environment variable read for the password when no option gives it.
pub const PASSWORD_ENV: &str = "OMCBSA_KORTEX_PASSWORD";

/// `kortex:HOST[:TCP_PORT:UDP_PORT]`, checked.
///
/// ```
/// use omcbsa_hw::kortex::{KortexSpec, SpecProblem};
///
/// let s = KortexSpec::parse("kortex:192.168.1.10")?;
/// assert_eq!((s.host.as_str(), s.tcp_port, s.udp_port), ("192.168.1.10", 10000, 10001));
/// let e = KortexSpec::parse("kortex:host:4000").unwrap_err();
/// assert_eq!(e.problem, SpecProblem::OnePort);
/// assert!(e.to_string().contains("give both ports or neither"));
/// # Ok::<(), omcbsa_hw::kortex::SpecError>(())
/// ```
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct KortexSpec {
    /// Host name or address (IPv6 in brackets in the spec).
    pub host: String,
    /// TCP port (configuration).
    pub tcp_port: u16,
    /// UDP port (cyclic).
    pub udp_port: u16,
}

/// A Kortex spec that cannot be read: the spec, and what is wrong with it.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
#[error(
    "cannot reach arm {spec}: {problem} (expected kortex:HOST or kortex:HOST:TCP_PORT:UDP_PORT)"
)]
pub struct SpecError {
    /// The spec as given.
    pub spec: String,
    /// What is wrong with it.
    pub problem: SpecProblem,
}

/// What is wrong with a Kortex spec.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
pub enum SpecProblem {
    /// It does not start with `kortex:`.
    #[error("not a kortex spec")]
    NotKortex,
    /// An IPv6 address opened with `[` and never closed.
    #[error("a '[' without ']'")]
    UnclosedBracket,
    /// No host, or one with white space or a NUL in it.
    #[error("the host is empty or contains spaces")]
    BadHost,
    /// A port that is not a number from 1 to 65535.
    #[error("the {which} port {text:?} is not a number from 1 to 65535")]
    BadPort {
        /// `TCP` or `UDP`.
        which: &'static str,
        /// The port as written.
        text: String,
    },
    /// One port given: both or neither.
    #[error("give both ports or neither")]
    OnePort,
}

/// Why an arm whose spec was read could not be reached.
#[derive(Debug, thiserror::Error)]
pub enum ReachError {
    /// Its host name did not resolve.
    #[error("cannot reach arm {spec}: cannot resolve {}: {source}", spec.host)]
    Resolve {
        /// The arm.
        spec: KortexSpec,
        /// Why.
        source: std::io::Error,
    },
    /// A link to it could not be opened.
    #[error("cannot reach arm {spec}: {source}")]
    Link {
        /// The arm.
        spec: KortexSpec,
        /// Which link and why.
        source: channel::OpenError,
    },
}

impl KortexSpec {
    /// Parses a spec; the error names the spec and what is wrong with it.
    pub fn parse(spec: &str) -> Result<Self, SpecError> {
        let bad = |problem: SpecProblem| SpecError {
            spec: spec.to_string(),
            problem,
        };
        let rest = spec
            .strip_prefix("kortex:")
            .ok_or_else(|| bad(SpecProblem::NotKortex))?;
        // An IPv6 address is written in brackets: kortex:[fe80::1]:10000:10001.
        let (host, ports) = match rest.strip_prefix('[') {
            Some(r) => {
                let (h, p) =
                    (r.split_once(']')).ok_or_else(|| bad(SpecProblem::UnclosedBracket))?;
                (h, p.strip_prefix(':'))
            }
            None => match rest.split_once(':') {
                Some((h, p)) => (h, Some(p)),
                None => (rest, None),
            },
        };
        if host.is_empty() || host.chars().any(|c| c.is_whitespace() || c == '\0') {
            return Err(bad(SpecProblem::BadHost));
        }
        let (tcp_port, udp_port) = match ports {
            None | Some("") if !rest.ends_with(':') => (DEFAULT_TCP_PORT, DEFAULT_UDP_PORT),
            Some(p) => {
                let port = |s: &str, which: &'static str| {
                    s.parse::<u16>().ok().filter(|&p| p != 0).ok_or_else(|| {
                        bad(SpecProblem::BadPort {
                            which,
                            text: s.to_string(),
                        })
                    })
                };
                match p.split_once(':') {
                    Some((t, u)) => (port(t, "TCP")?, port(u, "UDP")?),
                    None => return Err(bad(SpecProblem::OnePort)),
                }
            }
            None => return Err(bad(SpecProblem::OnePort)),
        };
        Ok(Self {
            host: host.to_string(),
            tcp_port,
            udp_port,
        })
    }

    fn resolve(&self, port: u16) -> Result<SocketAddr, ReachError> {
        let fail = |source| ReachError::Resolve {
            spec: self.clone(),
            source,
        };
        (self.host.as_str(), port)
            .to_socket_addrs()
            .map_err(fail)?
            .next()
            .ok_or_else(|| fail(std::io::Error::other("the name has no address")))
    }
}

impl fmt::Display for KortexSpec {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "kortex:{}:{}:{}",
            self.host, self.tcp_port, self.udp_port
        )
    }
}

/// The user and password of a Kortex session. Never printed: `Debug` withholds the password.
#[derive(Clone, PartialEq, Eq)]
pub struct Credentials {
    /// The user name.
    pub username: String,
    /// The password (never logged).
    pub password: String,
}

impl fmt::Debug for Credentials {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "Credentials {{ username: {:?}, password: <withheld> }}",
            self.username
        )
    }
}

impl Credentials {
    /// The credentials from the options given (`None`: not given), else from
    /// [`USER_ENV`] / [`PASSWORD_ENV`]; `lookup` reads the environment.
    pub fn resolve(
        username: Option<String>,
        password: Option<String>,
        lookup: impl Fn(&str) -> Option<String>,
    ) -> Result<Self, CredentialsError> {
        let username = username
            .or_else(|| lookup(USER_ENV))
            .filter(|u| !u.is_empty());
        let password = password.or_else(|| lookup(PASSWORD_ENV));
        match (username, password) {
            (Some(username), Some(password)) => Ok(Self { username, password }),
            (None, _) => Err(CredentialsError::NoUser),
            (_, None) => Err(CredentialsError::NoPassword),
        }
    }
}

/// Credentials that were not given.
#[derive(Clone, Copy, Debug, PartialEq, Eq, thiserror::Error)]
pub enum CredentialsError {
    /// No user name, by option or environment.
    #[error("no Kortex user name: give --kortex-user or set {USER_ENV}")]
    NoUser,
    /// No password, by option or environment.
    #[error("no Kortex password: give --kortex-password-file or set {PASSWORD_ENV}")]
    NoPassword,
}

/// An arm's two links, open but without sessions yet ([`KortexArm`] creates them at start-up).
pub struct Connection {
    /// Where the arm is.
    pub spec: KortexSpec,
    /// The TCP link (configuration rpcs).
    pub tcp: channel::Channel,
    /// The UDP link (the cyclic rpcs).
    pub udp: channel::Channel,
    /// Who the sessions log in as.
    pub credentials: Credentials,
}

impl Connection {
    /// Connects TCP and opens the UDP socket (no frame is sent); the error names the arm.
    pub fn open(spec: &KortexSpec, credentials: &Credentials) -> Result<Self, ReachError> {
        let link = |source| ReachError::Link {
            spec: spec.clone(),
            source,
        };
        let tcp = channel::Channel::tcp(spec.resolve(spec.tcp_port)?).map_err(link)?;
        let udp = channel::Channel::udp(spec.resolve(spec.udp_port)?).map_err(link)?;
        Ok(Self {
            spec: spec.clone(),
            tcp,
            udp,
            credentials: credentials.clone(),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn specs_default_to_ports_10000_and_10001_and_bad_ones_are_refused() {
        let s = KortexSpec::parse("kortex:192.168.1.10").unwrap();
        assert_eq!(
            (s.host.as_str(), s.tcp_port, s.udp_port),
            ("192.168.1.10", 10000, 10001)
        );
        let s = KortexSpec::parse("kortex:127.0.0.1:4000:4001").unwrap();
        assert_eq!((s.tcp_port, s.udp_port), (4000, 4001));
        let s = KortexSpec::parse("kortex:[::1]:4000:4001").unwrap();
        assert_eq!((s.host.as_str(), s.tcp_port), ("::1", 4000));
        for bad in [
            "kortex:",
            "kortex:host:4000",
            "kortex:host:0:1",
            "kortex:host:x:1",
            "kortex:host:",
            "kortex:ho st",
            "kortex:[::1",
        ] {
            let e = KortexSpec::parse(bad).unwrap_err();
            assert_eq!(e.spec, bad);
            assert!(
                e.to_string()
                    .starts_with(&format!("cannot reach arm {bad}:")),
                "{e}"
            );
        }
    }

    #[test]
    fn credentials_come_from_options_else_the_environment_and_the_password_is_never_shown() {
        let env = |k: &str| match k {
            USER_ENV => Some("operator".to_string()),
            PASSWORD_ENV => Some("s3cret".to_string()),
            _ => None,
        };
        let c = Credentials::resolve(None, None, env).unwrap();
        assert_eq!(
            (c.username.as_str(), c.password.as_str()),
            ("operator", "s3cret")
        );
        let c = Credentials::resolve(Some("admin".into()), Some("pw".into()), env).unwrap();
        assert_eq!((c.username.as_str(), c.password.as_str()), ("admin", "pw"));
        assert!(!format!("{c:?}").contains("pw\""));
        let none = |_: &str| None;
        let e = Credentials::resolve(None, Some("x".into()), none).unwrap_err();
        assert_eq!(e, CredentialsError::NoUser);
        assert!(e.to_string().contains(USER_ENV), "{e}");
        let e = Credentials::resolve(Some("a".into()), None, none).unwrap_err();
        assert_eq!(e, CredentialsError::NoPassword);
        assert!(e.to_string().contains(PASSWORD_ENV), "{e}");
    }
}
