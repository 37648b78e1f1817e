//! Arbitrary bytes as every payload one host's bridge reads from another's over Zenoh: a
//! beat, an order of the broker, the answer to one, an exit report, and a key a schema
//! query names. An error or `None` is fine; a panic is not, and what is read back is what
//! was sent.
#![no_main]

use lewis_bridge::keys;
use lewis_bridge::wire::{self, Order};
use lewis_runtime::broker::remote::HostEvent;
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let text = wire::text(data);
    if let Err(said) = wire::beat_protocol(text) {
        assert!(said.chars().count() <= 32);
    }
    match wire::parse_order(text) {
        Ok(Order::Start(service) | Order::Stop(service)) => {
            assert_eq!(service, service.trim());
        }
        Err(why) => assert!(why.starts_with("unknown order")),
    }
    let _ = wire::parse_answer("nuc", text);
    if let Some(event) = wire::parse_exit(text) {
        let HostEvent::Exited { service, status } = &event else {
            panic!("an exit report read as {event:?}");
        };
        assert_eq!(
            wire::parse_exit(&wire::exit_text(service, *status)),
            Some(event.clone())
        );
    }
    if let Some(channel) = keys::channel_of_schema_query("robot", "nuc", text) {
        assert!(channel.starts_with('/'));
    }
    let _ = keys::host_of_token("robot", text);
});
