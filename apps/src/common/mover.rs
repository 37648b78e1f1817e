//! The Mover client every moving program uses: it sends the program's latest wish (a goal,
//! a rotation, a stop) to whichever provider serves Mover now, keeps the goal id it got,
//! and sends it again when the broker moved Mover to another provider or the provider no
//! longer pursues it before it was done (it restarted, or another client of the same
//! provider, such as a restarted obstacle avoider stopping it, took its place: a rotation
//! is then sent again whole, which beats waiting for it for ever). A motion once seen done
//! stays done. A goal the Mover has been blocked on for 3 s is sent
//! again as a new goal: the obstacle avoider holds a goal it made no progress on, and a
//! person who walked by and left the way free would otherwise hold the robot for good.
//! Time comes from the context only.

use lewis_geometry::Vec2;
use lewis_interfaces::msg::{Mover, MoverGoto, MoverRotate, MoverStatus, MoverStop};
use lewis_service::{CallId, Context, ReplyEvent};

/// How soon a command that could not be sent (no provider yet, refused) is tried again.
const RETRY_NS: i64 = 250_000_000;

/// Goals closer than this to the one asked for already are the same goal.
const SAME_GOAL_M: f64 = 0.05;

/// A goal blocked this long is sent again, in ns.
const BLOCKED_RETRY_NS: i64 = 3_000_000_000;

/// What the program wants of the Mover.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Motion {
    /// Go to this point of the odometry frame.
    Goto(Vec2),
    /// Turn by this angle, in rad, counter-clockwise.
    Rotate(f64),
    /// Stand still.
    Stop,
}

/// A motion sent: to whom, and the goal id it got.
#[derive(Debug, Clone, PartialEq)]
struct Sent {
    generation: u64,
    provider: String,
    goal_id: i32,
    replied_ns: i64,
    /// Whether the provider said it had arrived with it.
    arrived: bool,
}

/// The program's side of the Mover (see the module documentation).
#[derive(Debug, Clone, Default)]
pub struct MoverClient {
    wanted: Option<Motion>,
    generation: u64,
    in_flight: Option<(CallId, u64)>,
    sent: Option<Sent>,
    status: Option<Mover>,
    retry_at_ns: Option<i64>,
    /// Since when the goal asked for has been blocked.
    blocked_since_ns: Option<i64>,
}

impl MoverClient {
    /// Go to `point` (odometry frame); the same goal again is not sent again.
    pub fn goto(&mut self, ctx: &mut Context<'_>, point: Vec2) {
        if let Some(Motion::Goto(current)) = self.wanted
            && current.distance(point) < SAME_GOAL_M
        {
            return;
        }
        self.want(ctx, Motion::Goto(point));
    }

    /// Turn by `angle_rad` from the current heading.
    pub fn rotate(&mut self, ctx: &mut Context<'_>, angle_rad: f64) {
        self.want(ctx, Motion::Rotate(angle_rad));
    }

    /// Stop (sent again only if another motion was asked since).
    pub fn stop(&mut self, ctx: &mut Context<'_>) {
        if self.wanted != Some(Motion::Stop) {
            self.want(ctx, Motion::Stop);
        }
    }

    /// Stop now, whatever was sent: the last word of a program (`on_stop`), sent even while
    /// another call is waiting for its reply.
    pub fn stop_now(&mut self, ctx: &mut Context<'_>) {
        self.wanted = Some(Motion::Stop);
        self.generation += 1;
        let _ = ctx.call(&mut MoverStop::default());
    }

    /// The motion asked for last.
    #[must_use]
    pub fn wanted(&self) -> Option<Motion> {
        self.wanted
    }

    fn want(&mut self, ctx: &mut Context<'_>, motion: Motion) {
        self.wanted = Some(motion);
        self.generation += 1;
        self.send(ctx);
    }

    fn send(&mut self, ctx: &mut Context<'_>) {
        if self.in_flight.is_some() {
            // Sent when the reply comes.
            return;
        }
        let Some(motion) = self.wanted else { return };
        let sent = match motion {
            Motion::Goto(p) => ctx.call(&mut MoverGoto {
                x: p.x,
                y: p.y,
                ..MoverGoto::default()
            }),
            Motion::Rotate(angle) => ctx.call(&mut MoverRotate {
                angle,
                ..MoverRotate::default()
            }),
            Motion::Stop => ctx.call(&mut MoverStop::default()),
        };
        match sent {
            Ok(id) => {
                self.in_flight = Some((id, self.generation));
                self.retry_at_ns = None;
            }
            Err(_) => self.retry_at_ns = Some(ctx.now() + RETRY_NS),
        }
    }

    /// A Mover sample from `provider`: sends the motion again when it is no longer pursued.
    pub fn on_status(&mut self, ctx: &mut Context<'_>, provider: &str, status: Mover) {
        let generation = self.generation;
        let resend = match (&mut self.sent, self.wanted) {
            (Some(sent), Some(motion)) if sent.generation == generation => {
                let newer = status.header.publish_time_ns >= sent.replied_ns;
                if sent.provider != provider {
                    // A motion done is not done again by the next provider (a rotation
                    // would turn again); a stop is said to it all the same.
                    !sent.arrived || matches!(motion, Motion::Stop)
                } else if newer && status.goal_id == sent.goal_id {
                    sent.arrived |= status.status.parse() == Ok(MoverStatus::Arrived);
                    false
                } else {
                    !matches!(motion, Motion::Stop)
                        && !sent.arrived
                        && status.header.publish_time_ns > sent.replied_ns
                        && status.goal_id != sent.goal_id
                }
            }
            _ => false,
        };
        self.status = Some(status);
        if resend {
            self.sent = None;
            self.send(ctx);
        }
    }

    /// Takes a reply; false when it answers a call that is not the Mover's.
    pub fn on_reply(&mut self, ctx: &mut Context<'_>, reply: &ReplyEvent<'_>) -> bool {
        let Some((id, generation)) = self.in_flight else {
            return false;
        };
        if reply.call != id {
            return false;
        }
        self.in_flight = None;
        let answered = match reply.command {
            "goto" => reply
                .decode::<MoverGoto>()
                .map(|r| (r.header.provider, r.goal_id, r.header.publish_time_ns)),
            "rotate" => reply
                .decode::<MoverRotate>()
                .map(|r| (r.header.provider, r.goal_id, r.header.publish_time_ns)),
            _ => reply
                .decode::<MoverStop>()
                .map(|r| (r.header.provider, 0, r.header.publish_time_ns)),
        };
        match answered {
            Ok((provider, goal_id, replied_ns)) => {
                self.sent = Some(Sent {
                    generation,
                    provider,
                    goal_id,
                    replied_ns,
                    arrived: false,
                });
                if generation != self.generation {
                    self.send(ctx);
                }
            }
            Err(_) => self.retry_at_ns = Some(ctx.now() + RETRY_NS),
        }
        true
    }

    /// The periodic look: retries a command that could not be sent, and a goal blocked for
    /// `BLOCKED_RETRY_NS`.
    pub fn tick(&mut self, ctx: &mut Context<'_>) {
        let now = ctx.now();
        match (self.wanted, self.state()) {
            (Some(Motion::Goto(goal)), Some(MoverStatus::Blocked)) => {
                let since = *self.blocked_since_ns.get_or_insert(now);
                if now - since >= BLOCKED_RETRY_NS {
                    self.blocked_since_ns = None;
                    self.want(ctx, Motion::Goto(goal));
                }
            }
            _ => self.blocked_since_ns = None,
        }
        if self.retry_at_ns.is_some_and(|at| ctx.now() >= at) {
            self.retry_at_ns = None;
            self.send(ctx);
        }
    }

    /// Where the Mover is with the motion asked for last: `None` until it took it.
    #[must_use]
    pub fn state(&self) -> Option<MoverStatus> {
        let sent = self.sent.as_ref()?;
        let status = self.status.as_ref()?;
        if sent.generation != self.generation
            || status.header.provider != sent.provider
            || status.goal_id != sent.goal_id
            || status.header.publish_time_ns < sent.replied_ns
        {
            return None;
        }
        status.status.parse().ok()
    }

    /// Whether the motion asked for last is done.
    #[must_use]
    pub fn arrived(&self) -> bool {
        self.sent
            .as_ref()
            .is_some_and(|sent| sent.generation == self.generation && sent.arrived)
            || self.state() == Some(MoverStatus::Arrived)
    }

    /// The latest Mover sample.
    #[must_use]
    pub fn status(&self) -> Option<&Mover> {
        self.status.as_ref()
    }
}
