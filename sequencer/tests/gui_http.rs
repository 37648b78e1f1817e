//! The supervisor page's server over plain HTTP: the page, the view, the event stream, and
//! the commands with their refusals. The FSM is fed directly (no processes) so every
//! state of the page is reached on purpose.

#![allow(clippy::unwrap_used, clippy::expect_used)]

use std::net::{Ipv4Addr, SocketAddr};
use std::path::Path;

use crate::common::http::{EventStream, Reply, command, request};
use lewis_sequencer::live::{Command, control_channel};
use lewis_sequencer::record::{Entry, Record, RecordSink};
use lewis_sequencer::{Event, GuiServer, MemorySources, Sequencer, TrustingResolver, check_with};

const SCRIPT: &str = "\
start a
restart 1
recovery r
use gui
state a /bin/a
  action 0 trans b
state b /bin/b
  action 0 trans stop
  action 1 trans b
state r /bin/r
  action 0 trans stop
";

fn mission() -> lewis_sequencer::Mission {
    let sources = MemorySources::new().with("m.seq", SCRIPT);
    check_with(Path::new("m.seq"), &sources, &TrustingResolver)
        .unwrap_or_else(|d| panic!("{d}"))
        .mission
}

/// Feeds the FSM and the page's sink the same events, as the driver would.
struct Feeder {
    sequencer: Sequencer,
    sink: lewis_sequencer::GuiSink,
    seq: u64,
}

impl Feeder {
    fn emit(&mut self, entry: Entry) {
        let record = Record {
            seq: self.seq,
            time_ns: 1_700_000_000_000_000_000 + i64::try_from(self.seq).unwrap() * 1_000_000_000,
            entry,
        };
        self.seq += 1;
        self.sink.record(&record);
    }

    fn start(gui: &GuiServer) -> Self {
        let (sequencer, decisions) =
            Sequencer::start(mission(), lewis_sequencer::Supervision::Page);
        let mut feeder = Self {
            sequencer,
            sink: gui.sink(),
            seq: 0,
        };
        feeder.emit(Entry::MissionStarted {
            script: "m.seq".into(),
            states: vec!["a".into(), "b".into(), "r".into()],
            use_gui: true,
            supervision: Some(lewis_sequencer::Supervision::Page),
        });
        for decision in decisions {
            feeder.emit(Entry::Decided { decision });
        }
        feeder
    }

    fn feed(&mut self, event: Event) {
        let decisions = self.sequencer.handle(&event).unwrap();
        self.emit(Entry::Observed { event });
        for decision in decisions {
            self.emit(Entry::Decided { decision });
        }
    }
}

fn choose(addr: SocketAddr, state: &str) -> Reply {
    command(addr, "/choose", &format!("{{\"state\":\"{state}\"}}"))
}

fn view(addr: SocketAddr) -> serde_json::Value {
    serde_json::from_slice(&request(addr, "GET", "/view", "", "").body).unwrap()
}

#[test]
fn the_page_is_compiled_in_and_loads_nothing_from_the_network() {
    let (controller, _control) = control_channel().unwrap();
    let gui = GuiServer::start(
        SocketAddr::from((Ipv4Addr::LOCALHOST, 0)),
        &mission(),
        controller,
    )
    .unwrap();
    let page = request(gui.addr(), "GET", "/", "", "");
    let text = page.text();
    assert_eq!(page.status, 200);
    assert!(text.contains("<svg id=\"diagram\""));
    assert!(text.contains("new EventSource(\"events\")"));
    for remote in ["http://", "https://", "//cdn"] {
        let outside = text
            .match_indices(remote)
            .any(|(at, _)| !text[at..].starts_with("http://www.w3.org/2000/svg"));
        assert!(!outside, "the page refers to {remote}");
    }
    assert_eq!(request(gui.addr(), "GET", "/nowhere", "", "").status, 404);
}

#[test]
fn the_view_follows_the_mission_and_choices_are_taken_only_when_asked() {
    let (controller, control) = control_channel().unwrap();
    let gui = GuiServer::start(
        SocketAddr::from((Ipv4Addr::LOCALHOST, 0)),
        &mission(),
        controller,
    )
    .unwrap();
    let addr = gui.addr();
    let mut feeder = Feeder::start(&gui);

    let running = view(addr);
    assert_eq!(running["phase"], "running");
    assert_eq!(running["current"]["state"], "a");
    assert_eq!(running["diagram"]["states"][1]["actions"][1]["to"], "b");
    assert_eq!(choose(addr, "b").status, 409, "nothing is asked yet");

    let unsigned = request(addr, "POST", "/choose", "", "{\"state\":\"b\"}");
    assert_eq!(unsigned.status, 403);
    assert!(unsigned.text().contains("X-Lewis-Supervisor"));

    feeder.feed(Event::Signalled { signal: 11 });
    feeder.feed(Event::Signalled { signal: 11 });
    feeder.feed(Event::Exited { code: 0 });
    let asking = view(addr);
    assert_eq!(asking["phase"], "asking");
    assert_eq!(asking["question"]["suggested"], "stop");
    let kinds: Vec<&str> = asking["history"]
        .as_array()
        .unwrap()
        .iter()
        .map(|h| h["kind"].as_str().unwrap())
        .collect();
    assert_eq!(kinds, ["start", "restart", "recovery", "ask"]);
    assert_eq!(asking["history"][0]["text"], "start at a");

    let unknown = choose(addr, "nowhere");
    assert_eq!(unknown.status, 400);
    assert!(unknown.text().contains("`nowhere` is not a state"));
    assert_eq!(
        request(addr, "POST", "/choose", "X-Lewis-Supervisor: 1\r\n", "b").status,
        400
    );
    assert_eq!(choose(addr, "b").status, 202);
    assert_eq!(control.drain(), [Command::Choose("b".into())]);
    assert_eq!(
        request(addr, "POST", "/stop", "X-Lewis-Supervisor: 1\r\n", "").status,
        202
    );
    assert_eq!(control.drain(), [Command::Stop]);
}

#[test]
fn the_event_stream_sends_the_view_at_once_and_again_on_every_change() {
    let (controller, _control) = control_channel().unwrap();
    let gui = GuiServer::start(
        SocketAddr::from((Ipv4Addr::LOCALHOST, 0)),
        &mission(),
        controller,
    )
    .unwrap();
    let mut events = EventStream::open(gui.addr());
    let mut next_view = || events.next("message");
    assert_eq!(next_view()["phase"], "starting");
    let mut feeder = Feeder::start(&gui);
    // Views may be skipped for a slow reader, never reordered: wait for the running one.
    while next_view()["phase"] != "running" {}
    feeder.feed(Event::Exited { code: 0 });
    feeder.feed(Event::Exited { code: 0 });
    let finished = loop {
        let view = next_view();
        if view["phase"] == "finished" {
            break view;
        }
    };
    assert_eq!(finished["outcome"], "`b` led to `stop`");
    assert_eq!(finished["visited"], serde_json::json!(["a", "b"]));
    // The end of the mission closes the stream after the last view.
    gui.shutdown();
}
