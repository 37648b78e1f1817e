//! The programs' Mover client: a goal the obstacle avoider is blocked on is sent again.

use lewis_apps::common::mover::MoverClient;
use lewis_geometry::Vec2;
use lewis_interfaces::msg::{Mover, MoverGoto};
use lewis_service::{Context, Input, ReplyEvent, Service};
use lewis_testkit::scene::calls_of;

use crate::support::{S, scene, sim_robot};

/// Asks once for a point 3 m ahead (odometry), and keeps its client ticking.
struct IntoTheWall {
    mover: MoverClient,
}

impl Service for IntoTheWall {
    fn tick_period_ns(&self) -> Option<i64> {
        Some(100_000_000)
    }

    fn on_start(&mut self, ctx: &mut Context<'_>) -> Result<(), String> {
        self.mover.goto(ctx, Vec2::new(3.0, 0.0));
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
    let program = Box::new(IntoTheWall {
        mover: MoverClient::default(),
    });
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
