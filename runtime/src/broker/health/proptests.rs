//! No payload bytes panic the data checks, whatever the interface.

use proptest::prelude::*;

use super::DataMonitor;
use lewis_robot::DataChecks;

proptest! {
    #[test]
    fn no_payload_panics_the_checks(
        interface in prop::sample::select(lewis_interfaces::interface_names()),
        payloads in prop::collection::vec(prop::collection::vec(any::<u8>(), 0..256), 1..8),
        publish_ns in any::<i64>(),
        now_ns in any::<i64>(),
    ) {
        let checks = DataChecks {
            frozen_count: Some(2),
            ..DataChecks::default_for(interface)
        };
        let mut monitor = DataMonitor::new(interface, checks, Some(10.0), now_ns);
        for bytes in &payloads {
            let _ = monitor.sample(now_ns, publish_ns, bytes);
        }
        let _ = monitor.poll(now_ns.saturating_add(i64::MAX / 2));
    }

    #[test]
    fn a_cdr_prefix_with_random_tail_never_panics(
        interface in prop::sample::select(lewis_interfaces::interface_names()),
        tail in prop::collection::vec(any::<u8>(), 0..512),
    ) {
        let mut bytes = vec![0x00, 0x01, 0x00, 0x00];
        bytes.extend_from_slice(&tail);
        let mut monitor = DataMonitor::new(interface, DataChecks::default_for(interface), None, 0);
        let _ = monitor.sample(0, 0, &bytes);
    }
}
