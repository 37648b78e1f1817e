//! The programs' Mover client: a goal the obstacle avoider is blocked on is sent again; a
//! rotation another client displaced is sent again, and one done is never turned again.

use lewis_apps::common::mover::MoverClient;
use lewis_geometry::Vec2;
use lewis_interfaces::cdr;
use lewis_interfaces::msg::{Mover, MoverGoto, MoverRotateReply};
use lewis_service::{Context, Input, ReplyEvent, Service};
use lewis_testkit::Harness;
use lewis_testkit::scene::calls_of;

use crate::support::{S, scene, sim_robot};

/// A program that asks its Mover client for one motion at its start, then keeps the client
/// fed (statuses, replies) and ticking.
struct Asking {
    mover: MoverClient,
    ask: fn(&mut MoverClient, &mut Context<'_>),
}

impl Asking {
    fn new(ask: fn(&mut MoverClient, &mut Context<'_>)) -> Self {
        Self {
            mover: MoverClient::default(),
            ask,
        }
    }
}

impl Service for Asking {
    fn tick_period_ns(&self) -> Option<i64> {
        Some(100_000_000)
    }

    fn on_start(&mut self, ctx: &mut Context<'_>) -> Result<(), String> {
        (self.ask)(&mut self.mover, ctx);
        Ok(())
    }

    fn on_input(&mut self, ctx: &mut Context<'_>, input: &Input<'_>) {
        if let Ok(status) = input.decode::<Mover>() {
            self.mover.on_status(ctx, input.provider, status);
        }
    }

    fn on_reply(&mut self, ctx: &mut Context<'_>, reply: &ReplyEvent<'_>) {
        self.mover.on_reply(ctx, reply);
    }

    fn on_tick(&mut self, ctx: &mut Context<'_>) {
        self.mover.tick(ctx);
    }
}

#[test]
fn a_goal_the_avoider_is_blocked_on_is_sent_again_after_3_s() {
    // 2.5 m east of the lobby's west wall, facing it: the goal 3 m ahead is inside it.
    let robot = sim_robot((3.0, 12.5, 180.0), (320, 240));
    let services = ["base", "laser", "vector_mover", "obstacle_avoider"];
    // A point 3 m ahead (odometry).
    let program = Box::new(Asking::new(|mover, ctx| {
        mover.goto(ctx, Vec2::new(3.0, 0.0));
    }));
    let mut scene = scene(&robot, &services, "wall", program, &["Mover"]);
    scene.tap("Mover");
    scene.run_until(60 * S, |_| false);
    let gotos: Vec<i64> = calls_of::<MoverGoto>(&scene)
        .into_iter()
        .filter(|(_, client, _)| client == "wall")
        .map(|(at, _, _)| at)
        .collect();
    let blocked: Vec<i64> = scene
        .tapped_as::<Mover>()
        .into_iter()
        .filter(|(_, m)| m.header.provider == "obstacle_avoider" && m.status == "blocked")
        .map(|(at, _)| at)
        .collect();
    let first_blocked = *blocked.first().expect("the avoider is blocked by the wall");
    assert!(gotos.len() >= 2, "sent once only: {gotos:?}");
    let again = gotos[1];
    assert!(
        (first_blocked + 3 * S..first_blocked + 4 * S).contains(&again),
        "blocked at {first_blocked}, sent again at {again}"
    );
}

/// The vector mover's status at `at_ns`: goal `goal_id`, `status`.
fn status(at_ns: i64, goal_id: i32, status: &str) -> Mover {
    let mut mover = Mover {
        goal_id,
        status: status.to_owned(),
        ..Mover::default()
    };
    mover.header.provider = "vector_mover".into();
    mover.header.publish_time_ns = at_ns;
    mover
}

/// A turner whose rotation the vector mover took as goal 8 at 1 s.
fn turning() -> Harness {
    // 45 degrees.
    let turn = Asking::new(|mover, ctx| mover.rotate(ctx, std::f64::consts::FRAC_PI_4));
    let mut turner = Harness::from_service("turner", Box::new(turn), 1);
    if let Err(e) = turner.start(0) {
        panic!("the turner starts: {e}");
    }
    let calls = turner.take_calls();
    assert_eq!(calls.len(), 1);
    assert_eq!(calls[0].command, "rotate");
    let mut reply = MoverRotateReply {
        goal_id: 8,
        ..MoverRotateReply::default()
    };
    reply.header.provider = "vector_mover".into();
    reply.header.publish_time_ns = S;
    turner.reply(S, calls[0].id, "Mover", "rotate", Ok(&cdr::to_vec(&reply)));
    turner.send(S + S / 10, "vector_mover", &status(S + S / 10, 8, "moving"));
    assert!(turner.take_calls().is_empty(), "pursued: not sent again");
    turner
}

#[test]
fn a_rotation_another_client_took_the_place_of_is_sent_again() {
    // Chaos's mission 4: Recovery's rotation on the vector mover, and a restarted obstacle
    // avoider stopping that mover: Recovery waited for the rotation for good.
    let mut turner = turning();
    turner.send(2 * S, "vector_mover", &status(2 * S, 0, "idle"));
    let calls = turner.take_calls();
    assert_eq!(calls.len(), 1, "the rotation is sent again");
    assert_eq!(calls[0].command, "rotate");
}

#[test]
fn a_rotation_done_stays_done_when_another_goal_follows() {
    let mut turner = turning();
    turner.send(2 * S, "vector_mover", &status(2 * S, 8, "arrived"));
    turner.send(3 * S, "vector_mover", &status(3 * S, 0, "idle"));
    assert!(turner.take_calls().is_empty(), "done: not turned again");
    // Nor by the next provider after a rebind.
    let mut other = status(4 * S, 0, "idle");
    other.header.provider = "obstacle_avoider".into();
    turner.send(4 * S, "obstacle_avoider", &other);
    assert!(turner.take_calls().is_empty(), "done: not turned again");
}
