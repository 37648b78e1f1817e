//! A channel of another host crosses only while a process of this host reads it: the
//! bridge subscribes to it on Zenoh when its shared-memory channel here gets a reader, and
//! stops when the last reader goes. The other host is a plain Zenoh publisher of the
//! channel's key, whose matching status says whether anyone subscribes.

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
}
