//! People who move: the queue at the registration desk, served one by one, and people who
//! walk a route. A [`Scene`] is a pure function of its seed and of the times and true robot
//! positions it is stepped with: the same seed and the same robot track give the same
//! people, bit for bit. `sim-base` owns the only scene of a running robot and publishes it
//! as WorldState; the sensors draw the people where it says.
//!
//! The world file says what moves (every person it does not name stands still):
//!
//! ```toml
//! [queue]
//! desk = "registration"                 # the desk they queue at
//! people = ["queue-1", "queue-2"]       # head of the line first
//! serve_s = [3.0, 5.0]                  # each is served for a time drawn in this range
//! starts_when_robot_within_m = 10.0     # of the last one in line: serving starts then
//! leave_by = [[16.0, 18.5], [12.8, 17.8]]  # the way the served walk away, then vanish
//! walk_speed_mps = 1.0
//!
//! [[walks]]
//! person = "red-cap"
//! route = [[22.0, 19.5], [18.0, 18.5]]  # waypoints after where the person stands
//! speed_mps = 0.6
//! starts_when_robot_within_m = 3.0      # or starts_at_s = 20.0 (after the scene's start)
//! leaves = true                         # vanishes at the route's end; or back_and_forth = true
//! ```
//!
//! People yield to the robot: a person never steps to within [`PERSONAL_SPACE_M`] of the
//! robot's true centre; they wait until it has moved.

use lewis_geometry::Vec2;
use lewis_interfaces::msg::{PersonState, Point2D, WorldState};
use lewis_service::Rng;

use crate::world::{ObjectKind, World};

/// No person steps closer than this to the robot's centre, in m (a B21r's radius, a
/// person's, and a little room).
pub const PERSONAL_SPACE_M: f64 = 0.6;

/// The longest step of the motion, in ns: a late call is integrated in steps no longer.
const STEP_NS: i64 = 50_000_000;

/// Longest time integrated at once, in ns (as the base's).
const MAX_CATCH_UP_NS: i64 = 1_000_000_000;

/// How the people of a world move.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct ScenePlan {
    /// The queue at the desk, if any.
    pub queue: Option<QueuePlan>,
    /// People walking a route.
    pub walks: Vec<WalkPlan>,
}

impl ScenePlan {
    /// Whether nobody moves.
    #[must_use]
    pub fn is_empty(&self) -> bool {
        self.queue.is_none() && self.walks.is_empty()
    }
}

/// The queue at a desk.
#[derive(Debug, Clone, PartialEq)]
pub struct QueuePlan {
    /// The desk's name.
    pub desk: String,
    /// The people in line, head first (names of person objects).
    pub people: Vec<String>,
    /// Each is served for a time drawn uniformly in this range, in s.
    pub serve_s: (f64, f64),
    /// Serving starts when the robot comes this near the last person in line, in m.
    pub starts_when_robot_within_m: f64,
    /// The way a served person walks away before vanishing.
    pub leave_by: Vec<Vec2>,
    /// Walking speed, in m/s.
    pub walk_speed_mps: f64,
}

/// When a walk starts.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum WalkStart {
    /// When the robot comes this near the person, in m.
    RobotWithin(f64),
    /// This long after the scene's first step, in s.
    At(f64),
}

/// What a person does at the end of their route.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum WalkEnd {
    /// Stays there.
    Stays,
    /// Leaves the world.
    Leaves,
    /// Walks the route back, and again, for ever.
    BackAndForth,
}

/// A person walking a route.
#[derive(Debug, Clone, PartialEq)]
pub struct WalkPlan {
    /// The person's name.
    pub person: String,
    /// The waypoints after where they stand.
    pub route: Vec<Vec2>,
    /// Walking speed, in m/s.
    pub speed_mps: f64,
    /// When they set off.
    pub start: WalkStart,
    /// What they do at the end.
    pub end: WalkEnd,
}

/// One person of the world, as the scene has them.
#[derive(Debug, Clone, PartialEq)]
struct Mover {
    /// Index of the person's object in the world.
    object: usize,
    name: String,
    position: Vec2,
    heading_rad: f64,
    present: bool,
    /// The waypoints still to walk to, next first.
    path: Vec<Vec2>,
    speed_mps: f64,
}

impl Mover {
    fn arrived(&self) -> bool {
        self.path.is_empty()
    }

    /// Walks `dt_s` along the path, unless that would bring them within
    /// [`PERSONAL_SPACE_M`] of the robot at `robot` (then they wait).
    fn walk(&mut self, dt_s: f64, robot: Vec2) {
        let Some(&target) = self.path.first() else {
            return;
        };
        let to_target = target - self.position;
        let left = to_target.norm();
        let reach = self.speed_mps * dt_s;
        let next = if left <= reach {
            target
        } else {
            self.position + to_target * (reach / left)
        };
        let (now_d, next_d) = (self.position.distance(robot), next.distance(robot));
        if next_d < PERSONAL_SPACE_M && next_d < now_d {
            return;
        }
        if left > 0.0 {
            self.heading_rad = to_target.angle();
        }
        self.position = next;
        if next == target {
            self.path.remove(0);
        }
    }
}

#[derive(Debug, Clone, PartialEq)]
enum QueuePhase {
    /// Before the robot comes near.
    Waiting,
    /// The head of the line is being served until then.
    Serving { until_ns: i64 },
    /// The others step up; the new head is served once at the desk.
    SteppingUp,
    /// Everyone was served.
    Done,
}

#[derive(Debug, Clone, PartialEq)]
struct Queue {
    plan: QueuePlan,
    /// Where each place of the line is, head first (where the file puts the people).
    places: Vec<Vec2>,
    /// The movers still in line, head first (indices into the scene's people).
    line: Vec<usize>,
    /// Each person's service time, in ns, in the order of the plan's people.
    serve_ns: Vec<i64>,
    served: usize,
    /// The served, on their way out (indices into the scene's people).
    leaving: Vec<usize>,
    phase: QueuePhase,
}

#[derive(Debug, Clone, PartialEq)]
enum WalkPhase {
    Waiting,
    Walking,
    Done,
}

#[derive(Debug, Clone, PartialEq)]
struct Walk {
    plan: WalkPlan,
    person: usize,
    /// Where the route starts (where the person stood).
    origin: Vec2,
    forward: bool,
    phase: WalkPhase,
}

/// The people of a world and how they move.
#[derive(Debug, Clone, PartialEq)]
pub struct Scene {
    people: Vec<Mover>,
    queue: Option<Queue>,
    walks: Vec<Walk>,
    started_ns: Option<i64>,
    last_ns: Option<i64>,
}

impl Scene {
    /// The people of `world`, where its file puts them, moving as its plan says; service
    /// times are drawn from `seed`. Names of the plan that are no person of the world are
    /// ignored (the world file's reader reports them).
    #[must_use]
    pub fn new(world: &World, seed: u64) -> Self {
        let mut people: Vec<Mover> = world
            .objects()
            .iter()
            .enumerate()
            .filter_map(|(object, o)| match &o.kind {
                ObjectKind::Person(p) => Some(Mover {
                    object,
                    name: o.name.clone(),
                    position: p.centre,
                    heading_rad: 0.0,
                    present: world.is_here(object),
                    path: Vec::new(),
                    speed_mps: 1.0,
                }),
                _ => None,
            })
            .collect();
        let find = |people: &[Mover], name: &str| people.iter().position(|m| m.name == name);
        let plan = world.plan();
        let mut rng = Rng::for_device(seed, "scene");
        let queue = plan.queue.as_ref().map(|q| {
            let line: Vec<usize> = q.people.iter().filter_map(|n| find(&people, n)).collect();
            let desk = world.object(&q.desk).and_then(|d| match &d.kind {
                ObjectKind::Desk { shape, .. } => {
                    let (lo, hi) = shape.bounds();
                    Some((lo + hi) * 0.5)
                }
                _ => None,
            });
            for &i in &line {
                people[i].speed_mps = q.walk_speed_mps;
                if let Some(desk) = desk {
                    people[i].heading_rad = (desk - people[i].position).angle();
                }
            }
            let serve_ns = line
                .iter()
                .map(|_| {
                    let s = rng.uniform(q.serve_s.0, q.serve_s.1);
                    // seconds of service: far from i64's limits
                    (s * 1e9).round() as i64
                })
                .collect();
            Queue {
                plan: q.clone(),
                places: line.iter().map(|&i| people[i].position).collect(),
                line,
                serve_ns,
                served: 0,
                leaving: Vec::new(),
                phase: QueuePhase::Waiting,
            }
        });
        let walks = plan
            .walks
            .iter()
            .filter_map(|w| {
                let person = find(&people, &w.person)?;
                people[person].speed_mps = w.speed_mps;
                Some(Walk {
                    plan: w.clone(),
                    person,
                    origin: people[person].position,
                    forward: true,
                    phase: WalkPhase::Waiting,
                })
            })
            .collect();
        Self {
            people,
            queue,
            walks,
            started_ns: None,
            last_ns: None,
        }
    }

    /// Moves the people up to `now_ns`, with the robot's true centre at `robot`.
    pub fn step(&mut self, now_ns: i64, robot: Vec2) {
        let started = *self.started_ns.get_or_insert(now_ns);
        let last = *self.last_ns.get_or_insert(now_ns);
        let mut t = last;
        let end = now_ns.min(last.saturating_add(MAX_CATCH_UP_NS)).max(last);
        loop {
            self.decide(t, started, robot);
            if t >= end {
                break;
            }
            let dt = (end - t).min(STEP_NS);
            t += dt;
            // nanoseconds of a step: exact in f64
            let dt_s = dt as f64 * 1e-9;
            for mover in &mut self.people {
                if mover.present {
                    mover.walk(dt_s, robot);
                }
            }
        }
        self.last_ns = Some(now_ns.max(last));
    }

    /// Starts and ends what is due at `now_ns`.
    fn decide(&mut self, now_ns: i64, started_ns: i64, robot: Vec2) {
        let people = &mut self.people;
        if let Some(q) = &mut self.queue {
            q.decide(people, now_ns, robot);
        }
        for walk in &mut self.walks {
            let mover = &mut people[walk.person];
            match walk.phase {
                WalkPhase::Waiting => {
                    let due = match walk.plan.start {
                        WalkStart::RobotWithin(d) => mover.position.distance(robot) <= d,
                        WalkStart::At(s) => {
                            // seconds since the start: far from overflow
                            (now_ns - started_ns) as f64 * 1e-9 >= s
                        }
                    };
                    if due && mover.present {
                        mover.path.clone_from(&walk.plan.route);
                        walk.phase = WalkPhase::Walking;
                    }
                }
                WalkPhase::Walking if mover.arrived() => match walk.plan.end {
                    WalkEnd::Stays => walk.phase = WalkPhase::Done,
                    WalkEnd::Leaves => {
                        mover.present = false;
                        walk.phase = WalkPhase::Done;
                    }
                    WalkEnd::BackAndForth => {
                        walk.forward = !walk.forward;
                        let mut path: Vec<Vec2> = std::iter::once(walk.origin)
                            .chain(walk.plan.route.iter().copied())
                            .collect();
                        if walk.forward {
                            path.remove(0);
                        } else {
                            path.pop();
                            path.reverse();
                        }
                        mover.path = path;
                    }
                },
                WalkPhase::Walking | WalkPhase::Done => {}
            }
        }
    }

    /// Everyone, where they are now, in the order of the world's objects.
    #[must_use]
    pub fn people(&self) -> Vec<PersonState> {
        self.people
            .iter()
            .map(|m| PersonState {
                name: m.name.clone(),
                position: Point2D {
                    x: m.position.x,
                    y: m.position.y,
                },
                heading: m.heading_rad,
                present: m.present,
            })
            .collect()
    }

    /// The WorldState publication (header left to the context).
    #[must_use]
    pub fn world_state(&self) -> WorldState {
        let people = self.people();
        WorldState {
            person_count: i32::try_from(people.len()).unwrap_or(i32::MAX),
            people,
            ..WorldState::default()
        }
    }

    /// Puts the people in `world` where the scene has them.
    pub fn apply_to(&self, world: &mut World) {
        for m in &self.people {
            world.place_person(m.object, m.present.then_some(m.position));
        }
    }

    /// How many of the queue have been served and left the line.
    #[must_use]
    pub fn served_count(&self) -> usize {
        self.queue.as_ref().map_or(0, |q| q.served)
    }

    /// Whether the queue has started moving (the robot came near).
    #[must_use]
    pub fn queue_started(&self) -> bool {
        self.queue
            .as_ref()
            .is_some_and(|q| q.phase != QueuePhase::Waiting)
    }
}

impl Queue {
    fn decide(&mut self, people: &mut [Mover], now_ns: i64, robot: Vec2) {
        match self.phase {
            QueuePhase::Waiting => {
                let Some(&tail) = self.line.last() else {
                    self.phase = QueuePhase::Done;
                    return;
                };
                if people[tail].position.distance(robot) <= self.plan.starts_when_robot_within_m {
                    self.serve_head(now_ns);
                }
            }
            QueuePhase::Serving { until_ns } if now_ns >= until_ns => {
                let head = self.line.remove(0);
                people[head].path.clone_from(&self.plan.leave_by);
                self.leaving.push(head);
                self.served += 1;
                for (place, &i) in self.places.iter().zip(&self.line) {
                    people[i].path = vec![*place];
                }
                self.phase = QueuePhase::SteppingUp;
            }
            QueuePhase::SteppingUp => match self.line.first() {
                None => self.phase = QueuePhase::Done,
                Some(&head) if people[head].arrived() => self.serve_head(now_ns),
                Some(_) => {}
            },
            QueuePhase::Serving { .. } | QueuePhase::Done => {}
        }
        // The served vanish at the end of their way out.
        for &i in &self.leaving {
            if people[i].present && people[i].arrived() {
                people[i].present = false;
            }
        }
    }

    fn serve_head(&mut self, now_ns: i64) {
        let time = self.serve_ns.get(self.served).copied().unwrap_or(0);
        self.phase = QueuePhase::Serving {
            until_ns: now_ns.saturating_add(time),
        };
    }
}
