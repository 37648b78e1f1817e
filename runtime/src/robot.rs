//! The robot description (`robots/*.toml`): services, providers, policies.
