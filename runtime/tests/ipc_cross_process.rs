//! IPC between processes: each test starts the helper binary `lewis-ipc-peer`
//! (`runtime/src/bin/lewis-ipc-peer.rs`) in one role, in the test's namespace. A peer keeps
//! its endpoints until its standard input closes, so the test decides when it goes away.

#![allow(
    clippy::unwrap_used,
    reason = "helpers shared by the tests: a failure there is a test failure"
)]

use std::io::Write;
use std::process::{Child, ChildStdin, Command, Stdio};
use std::time::{Duration, Instant};

use lewis_runtime::ipc::{
    ChannelConfig, CommandConfig, Ipc, NAMESPACE_ENV, Namespace, NodeCleaner, NodeLiveness,
    Subscriber, WaitSet, WakeMode, Woken,
};

const WATCHDOG: Duration = Duration::from_secs(30);
const SIZES: [usize; 3] = [64, 64 << 10, 1 << 20];

/// The bytes the peer fills a payload of `len` bytes with (`lewis-ipc-peer`'s `pattern`).
fn pattern(len: usize) -> impl Fn(&mut [u8]) {
    move |buf: &mut [u8]| {
        for (i, b) in buf.iter_mut().enumerate() {
            *b = ((i * 31 + len) % 251) as u8;
        }
    }
}

fn config() -> ChannelConfig {
    ChannelConfig {
        buffer: 8,
        ..ChannelConfig::sensor(64)
    }
}

struct Peer {
    child: Child,
    stdin: Option<ChildStdin>,
}

impl Peer {
    fn start(namespace: &Namespace, role: &str) -> Self {
        let mut child = Command::new(env!("CARGO_BIN_EXE_lewis-ipc-peer"))
            .arg(role)
            .env(NAMESPACE_ENV, namespace.as_str())
            .stdin(Stdio::piped())
            .stdout(Stdio::null())
            .spawn()
            .unwrap();
        let stdin = child.stdin.take();
        Self { child, stdin }
    }

    fn pid(&self) -> i32 {
        self.child.id() as i32
    }

    fn say(&mut self, line: &str) {
        let stdin = self.stdin.as_mut().unwrap();
        writeln!(stdin, "{line}").unwrap();
        stdin.flush().unwrap();
    }

    /// Lets the peer finish and checks that it succeeded.
    fn finish(mut self) {
        drop(self.stdin.take());
        let status = self.child.wait().unwrap();
        assert!(status.success(), "peer failed: {status}");
    }
}

impl Drop for Peer {
    fn drop(&mut self) {
        // A failed test must not leave its peer behind.
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

fn receive_one(waits: &WaitSet, sub: &mut Subscriber) -> Vec<u8> {
    let deadline = Instant::now() + WATCHDOG;
    loop {
        if let Some(sample) = sub.receive().unwrap() {
            return sample.bytes().to_vec();
        }
        match waits.wait(&[&*sub], Some(deadline)).unwrap() {
            Woken::DeadlineReached => {
                panic!("watchdog: nothing on {} within {WATCHDOG:?}", sub.channel())
            }
            Woken::Ready(_) | Woken::Interrupted => {}
        }
    }
}

#[test]
fn payloads_of_64_bytes_64_kib_and_1_mib_cross_processes_intact() {
    let ns = Namespace::unique("xp-sizes");
    let ipc = Ipc::open(&ns, "parent").unwrap();
    let mut sub = ipc.subscriber("sizes", &config()).unwrap();
    let peer = Peer::start(&ns, "publish-sizes");
    let waits = WaitSet::new(WakeMode::Event);
    for len in SIZES {
        let got = receive_one(&waits, &mut sub);
        let mut expected = vec![0; len];
        pattern(len)(&mut expected);
        assert!(
            got == expected,
            "payload of {len} bytes arrived corrupted or with {} bytes",
            got.len()
        );
    }
    assert_eq!(sub.lost(), 0);
    peer.finish();
}

#[test]
fn a_blocked_wait_wakes_when_another_process_publishes() {
    let ns = Namespace::unique("xp-wake");
    let ipc = Ipc::open(&ns, "parent").unwrap();
    let mut sub = ipc.subscriber("wake", &config()).unwrap();
    let mut peer = Peer::start(&ns, "publish-on-line");
    peer.say("hello");
    let waits = WaitSet::new(WakeMode::Event);
    match waits
        .wait(&[&sub], Some(Instant::now() + WATCHDOG))
        .unwrap()
    {
        Woken::Ready(fired) => assert_eq!(fired.iter().collect::<Vec<_>>(), vec![0]),
        other => panic!("watchdog: the publication of the peer did not wake the wait: {other:?}"),
    }
    assert_eq!(sub.receive().unwrap().unwrap().bytes(), b"hello");
    peer.finish();
}

#[test]
fn a_command_is_answered_by_a_server_in_another_process() {
    let ns = Namespace::unique("xp-cmd");
    let ipc = Ipc::open(&ns, "parent").unwrap();
    let mut ready = ipc.subscriber("ready", &config()).unwrap();
    let peer = Peer::start(&ns, "serve-echo");
    assert_eq!(
        receive_one(&WaitSet::new(WakeMode::Event), &mut ready),
        b"serving"
    );
    let mut client = ipc
        .command_client("echo", &CommandConfig::default())
        .unwrap();
    let reply = client
        .call_blocking(3, WATCHDOG, |b| b.copy_from_slice(b"abc"), WakeMode::Event)
        .unwrap();
    let reply = reply.bytes().to_vec();
    assert_eq!(reply, b"cba");
    peer.finish();
}

#[test]
fn a_sigkilled_publisher_goes_unnoticed_by_subscribers_but_is_dead_in_the_node_list_and_cleaned_up()
{
    let ns = Namespace::unique("xp-kill");
    let ipc = Ipc::open(&ns, "parent").unwrap();
    let mut sub = ipc.subscriber("alive", &config()).unwrap();
    let mut peer = Peer::start(&ns, "publish-then-hang");
    let waits = WaitSet::new(WakeMode::Event);
    assert_eq!(receive_one(&waits, &mut sub), b"alive");

    let peer_pid = peer.pid();
    let liveness_of_peer = |ipc: &Ipc| -> Vec<NodeLiveness> {
        ipc.nodes()
            .unwrap()
            .into_iter()
            .filter(|n| n.pid == Some(peer_pid))
            .map(|n| n.liveness)
            .collect()
    };
    assert_eq!(liveness_of_peer(&ipc), vec![NodeLiveness::Alive]);

    peer.child.kill().unwrap(); // SIGKILL
    peer.child.wait().unwrap();

    // Subscribers see nothing: no error, no sample, no wake-up.
    assert!(sub.receive().unwrap().is_none());
    assert_eq!(
        waits
            .wait(&[&sub], Some(Instant::now() + Duration::from_millis(5)))
            .unwrap(),
        Woken::DeadlineReached
    );
    // The node list does.
    assert_eq!(liveness_of_peer(&ipc), vec![NodeLiveness::Dead]);
    let report = ipc.cleanup_dead_nodes();
    assert_eq!((report.cleaned, report.failed), (1, 0));
    assert_eq!(liveness_of_peer(&ipc), vec![]);
    assert_eq!(
        ipc.nodes()
            .unwrap()
            .iter()
            .map(|n| n.id)
            .collect::<Vec<_>>(),
        vec![ipc.node_id()]
    );
}

#[test]
fn the_background_cleaner_removes_a_sigkilled_node_and_says_when_it_is_done() {
    let ns = Namespace::unique("xp-cleaner");
    let ipc = Ipc::open(&ns, "parent").unwrap();
    let cleaner = NodeCleaner::start(&ns, "cleaner").unwrap();
    // Nothing asked: nothing to wait for.
    assert!(cleaner.wait_for(0, Duration::ZERO));

    let mut sub = ipc.subscriber("alive", &config()).unwrap();
    let mut peer = Peer::start(&ns, "publish-then-hang");
    let waits = WaitSet::new(WakeMode::Event);
    assert_eq!(receive_one(&waits, &mut sub), b"alive");
    let peer_pid = peer.pid();
    peer.child.kill().unwrap(); // SIGKILL
    peer.child.wait().unwrap();
    let dead = |ipc: &Ipc| {
        ipc.nodes()
            .unwrap()
            .into_iter()
            .filter(|n| n.pid == Some(peer_pid))
            .count()
    };
    assert_eq!(dead(&ipc), 1);

    let ticket = cleaner.request();
    assert!(
        cleaner.wait_for(ticket, WATCHDOG),
        "the cleanup never ended"
    );
    assert_eq!(dead(&ipc), 0);
    assert_eq!(cleaner.cleaned(), 1);
    // The parent and the cleaner's own node are all that is left.
    let left = ipc.nodes().unwrap();
    assert_eq!(left.len(), 2, "nodes left: {left:?}");
}
