//! Nothing crosses that nobody reads. A channel of another host crosses only while a
//! process of this host reads it: the bridge subscribes to it on Zenoh when its
//! shared-memory channel here gets a reader, and stops when the last reader goes. A channel
//! of this host is read by the bridge only while a subscriber on Zenoh wants it. The other
//! host is a plain Zenoh session: its publisher's matching status says whether anyone
//! subscribes, and the channel's subscriber count here whether the bridge reads.

#![allow(clippy::unwrap_used, clippy::expect_used)]

use std::time::{Duration, Instant};

use lewis_bridge::routes::{Route, Routes};
use lewis_bridge::{ForwardOptions, Forwarder, Heard, Schemas, keys};
use lewis_interfaces::cdr;
use lewis_interfaces::msg::RangeFinder;
use lewis_runtime::ipc::{Ipc, Namespace, WaitSet, WakeMode};
use lewis_runtime::names;
use zenoh::{Config, Session, Wait as _};

const CHANNEL: &str = "/laser/RangeFinder";
const EXPORTED: &str = "/laser/Distance";
const LIMIT: Duration = Duration::from_secs(10);

fn session(listen: Option<&str>, connect: Option<&str>) -> Session {
    let list = |e: Option<&str>| e.map_or_else(|| "[]".to_owned(), |e| format!("[\"{e}\"]"));
    let mut config = Config::default();
    for (key, value) in [
        ("mode", "\"peer\"".to_owned()),
        ("listen/endpoints", list(listen)),
        ("connect/endpoints", list(connect)),
        ("scouting/multicast/enabled", "false".to_owned()),
    ] {
        config.insert_json5(key, &value).unwrap();
    }
    zenoh::open(config).wait().unwrap()
}

/// A port of the loopback nobody listens on now.
fn free_port() -> u16 {
    let listener = std::net::TcpListener::bind("127.0.0.1:0").unwrap();
    listener.local_addr().unwrap().port()
}

#[test]
fn a_channel_of_another_host_crosses_only_while_it_is_read_here() {
    let endpoint = format!("tcp/127.0.0.1:{}", free_port());
    let here = session(Some(&endpoint), None);
    let namespace = Namespace::unique("crossing");
    let options = ForwardOptions {
        robot: "r".to_owned(),
        host: "workstation".to_owned(),
        routes: Routes {
            imports: vec![Route {
                channel: CHANNEL.to_owned(),
                host: "robot".to_owned(),
            }],
            exports: vec![EXPORTED.to_owned()],
            ..Routes::default()
        },
        namespace: namespace.clone(),
        beat_period: Duration::from_millis(10),
        schemas: Schemas::default(),
    };
    let _forwarder = Forwarder::start(&here, options, Heard::default()).unwrap();

    let there = session(None, Some(&endpoint));
    let beats = there
        .declare_subscriber(keys::beat("r", "workstation"))
        .wait()
        .unwrap();
    let publisher = there
        .declare_publisher(keys::channel("r", "robot", CHANNEL))
        .wait()
        .unwrap();
    let matching = publisher.matching_listener().wait().unwrap();
    // The link is up once this host's beat arrives; what the bridge declared before it has
    // arrived too, and it declared no subscription: nobody reads the channel here.
    beats.recv_timeout(LIMIT).unwrap().expect("a beat");
    assert!(!publisher.matching_status().wait().unwrap().matching());

    // A reader comes: the channel crosses, unchanged.
    let ipc = Ipc::open(&namespace, "reader").unwrap();
    let mut reader = ipc
        .subscriber(CHANNEL, &names::channel_config(CHANNEL))
        .unwrap();
    let status = matching.recv_timeout(LIMIT).unwrap().expect("a change");
    assert!(status.matching());
    let scan = cdr::to_vec(&RangeFinder {
        range_count: 3,
        ranges: vec![1.0, 2.0, 3.0],
        ..RangeFinder::default()
    });
    publisher.put(scan.clone()).wait().unwrap();
    WaitSet::new(WakeMode::Event)
        .wait(&[&reader], Some(Instant::now() + LIMIT))
        .unwrap();
    let received = reader.receive().unwrap().expect("the scan");
    assert_eq!(received.bytes(), &scan[..]);

    // The reader goes: the channel no longer crosses.
    drop(reader);
    let status = matching.recv_timeout(LIMIT).unwrap().expect("a change");
    assert!(!status.matching());

    // The other way: the bridge reads a channel of this host only while another host's
    // subscriber wants it.
    let mut exported = ipc
        .publisher(EXPORTED, &names::channel_config(EXPORTED))
        .unwrap();
    assert_eq!(exported.subscribers(), 0);
    let listener = there
        .declare_subscriber(keys::channel("r", "workstation", EXPORTED))
        .wait()
        .unwrap();
    wait_for_readers(&exported, 1);
    let distance = cdr::to_vec(&lewis_interfaces::msg::Distance {
        min_distance: 1.5,
        ..lewis_interfaces::msg::Distance::default()
    });
    exported
        .publish_with(distance.len(), |buf| buf.copy_from_slice(&distance))
        .unwrap();
    let sample = listener.recv_timeout(LIMIT).unwrap().expect("the distance");
    assert_eq!(sample.payload().to_bytes().as_ref(), &distance[..]);
    drop(listener);
    wait_for_readers(&exported, 0);
}

/// Waits (at most [`LIMIT`]) until `exported` has `count` subscribers here. iceoryx2 says
/// nothing when a port comes or goes, so it is looked at every millisecond.
fn wait_for_readers(exported: &lewis_runtime::ipc::Publisher, count: usize) {
    let start = Instant::now();
    while exported.subscribers() != count {
        assert!(
            start.elapsed() < LIMIT,
            "{EXPORTED} has {} readers here, not {count}",
            exported.subscribers()
        );
        std::thread::sleep(Duration::from_millis(1));
    }
}
