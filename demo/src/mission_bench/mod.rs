//! `lewis bench mission`: the Challenge mission again and again from random start poses in
//! the start room (any heading), with people walking the corridors and crossing the robot's
//! way, and the demo's live fault (the laser killed beyond its restart limit once the robot
//! is through the door): the success rate, and each failure's state and reason.
//!
//! Mission `i` draws everything from `seed + i`: its start pose, its people (each walks a
//! straight way between two points of the building outside the start room, once, at their
//! own pace, setting off within the mission's first minute, then leaves) and the noise of
//! its devices. Its world (the robot file's, its
//! people added) and robot file are written to its folder, so a failed mission is run again
//! by `lewis up` on them; a mission that succeeds leaves only its line. [`picture`] draws
//! the starts on the map.

pub mod picture;

use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::time::Duration;

use lewis_geometry::Vec2;
use lewis_launch::Launch;
use lewis_runtime::ipc::Namespace;
use lewis_sequencer::session::load_mission;
use lewis_service::{Rng, ServiceRegistry};
use lewis_sim::world::{ObjectKind, World};
use serde::Serialize;

use crate::fault::{FaultThread, LiveFault};
use crate::{
    DemoError, fresh_dir, load_robot, mission_lines, unattended_launch, with_seed, write_error,
};

/// Where the bench writes by default.
pub const OUT_DIR: &str = "logs/bench-mission";

/// The grid the start room is found on, in m.
const CELL_M: f64 = 0.1;
/// A start pose has this much room around the robot's centre, in m (the B21r's radius is
/// 0.26 m: room to turn, and for the laser, mounted in front, to see past the walls).
const START_CLEARANCE_M: f64 = 0.6;
/// Walkers' routes keep this far from walls and objects, in m.
const WALK_CLEARANCE_M: f64 = 0.5;
/// Walkers keep this far from the start room (and so out of its doorways), in m.
const ROOM_MARGIN_M: f64 = 1.0;
/// A walker's way is this long, in m.
const WALK_LENGTH_M: (f64, f64) = (4.0, 12.0);
/// Walkers set off within this of the mission's start, in s.
const WALK_START_S: f64 = 60.0;
/// Walkers stay this far from the people already in the world (the queue, the clerk, the
/// guide), in m: they walk past the queue, not through it.
const CROWD_M: f64 = 2.0;
/// How long one mission may last before it is stopped and counted as failed.
const MISSION_LIMIT: Duration = Duration::from_secs(600);

/// What to run.
#[derive(Debug, Clone)]
pub struct MissionBenchOptions {
    /// The robot file (`robots/sim.toml`): its base's `start` is the start room's seed
    /// point, its `world` the world.
    pub robot: PathBuf,
    /// The mission script.
    pub script: PathBuf,
    /// How many missions.
    pub seeds: u32,
    /// Mission `i` (from 0) draws from `seed + i`.
    pub seed: u64,
    /// Start anywhere in the start room, at any heading (else at the robot file's start).
    pub random_start: bool,
    /// People walking about in each mission.
    pub people: u32,
    /// The output folder.
    pub out: PathBuf,
    /// The `lewis` binary.
    pub lewis_exe: PathBuf,
    /// The live fault of every mission.
    pub fault: LiveFault,
}

/// A start pose.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct StartPose {
    /// In the world, m.
    pub x_m: f64,
    /// In the world, m.
    pub y_m: f64,
    /// In degrees, counter-clockwise from the world's x axis.
    pub heading_deg: f64,
}

/// A person who walks a straight way once, and leaves.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Walker {
    /// Their name in the world.
    pub name: String,
    /// One end of their way.
    pub from: [f64; 2],
    /// The other.
    pub to: [f64; 2],
    /// Their pace, m/s.
    pub speed_mps: f64,
    /// When they set off, s from the start.
    pub starts_at_s: f64,
}

/// One mission of the bench.
#[derive(Debug, Clone, Serialize)]
pub struct BenchMission {
    /// From 1.
    pub number: u32,
    /// What it drew from.
    pub seed: u64,
    /// Where the robot started.
    pub start: StartPose,
    /// Who walked about.
    pub walkers: Vec<Walker>,
    /// Whether the mission succeeded.
    pub succeeded: bool,
    /// The verdict's reason.
    pub reason: String,
    /// The states it went through.
    pub states: Vec<String>,
    /// The last state before it failed (`None` when it succeeded).
    pub failed_in: Option<String>,
    /// What the live fault did.
    pub fault: String,
    /// Its folder, kept when it failed.
    pub kept: Option<PathBuf>,
}

/// The whole bench.
#[derive(Debug, Clone, Serialize)]
pub struct MissionBenchReport {
    /// The first seed.
    pub seed: u64,
    /// Whether the starts were random.
    pub random_start: bool,
    /// People walking about in each mission.
    pub people: u32,
    /// Each mission.
    pub missions: Vec<BenchMission>,
}

impl MissionBenchReport {
    /// How many succeeded.
    #[must_use]
    pub fn succeeded(&self) -> usize {
        self.missions.iter().filter(|m| m.succeeded).count()
    }

    /// The bench in a few lines: the rate, then each failure.
    #[must_use]
    pub fn summary(&self) -> String {
        let n = self.missions.len();
        let ok = self.succeeded();
        let mut s = format!(
            "{ok} of {n} missions succeeded ({:.0}%), {}, {} people walking about\n",
            100.0 * ok as f64 / n.max(1) as f64,
            if self.random_start {
                "from random starts in the start room"
            } else {
                "from the robot file's start"
            },
            self.people
        );
        for m in self.missions.iter().filter(|m| !m.succeeded) {
            let _ = writeln!(s, "  {}", mission_line(m));
        }
        s
    }
}

/// One mission in one line.
#[must_use]
pub fn mission_line(m: &BenchMission) -> String {
    let start = m.start;
    let mut line = format!(
        "mission {:>2} (seed {}) from {:.1},{:.1} at {:.0} deg: ",
        m.number, m.seed, start.x_m, start.y_m, start.heading_deg
    );
    if m.succeeded {
        line.push_str("succeeded");
    } else {
        let _ = write!(
            line,
            "FAILED in {}: {}",
            m.failed_in.as_deref().unwrap_or("no state"),
            m.reason
        );
    }
    let _ = write!(line, " ({})", m.states.join(" -> "));
    if let Some(kept) = &m.kept {
        let _ = write!(line, "; kept in {}", kept.display());
    }
    line
}

/// Runs the bench; `on_mission` hears each mission as it ends. `bench.json` and `bench.png`
/// in the output folder are rewritten after every mission.
///
/// # Errors
/// When the robot, its world or the mission cannot be read, or a mission cannot start.
pub fn run_mission_bench(
    options: &MissionBenchOptions,
    registry: &ServiceRegistry,
    on_mission: &mut dyn FnMut(&BenchMission),
) -> Result<MissionBenchReport, DemoError> {
    let robot_text = std::fs::read_to_string(&options.robot)
        .map_err(|e| DemoError::Robot(format!("cannot read {}: {e}", options.robot.display())))?;
    let table: toml::Table = robot_text
        .parse()
        .map_err(|e| DemoError::Robot(format!("{}: {e}", options.robot.display())))?;
    let (world_dir, start) = base_world(&table, &options.robot)?;
    let world = World::load(&world_dir)
        .map_err(|e| DemoError::Robot(format!("{}: {e}", world_dir.display())))?;
    let room = start_room(&world, Vec2::new(start.x_m, start.y_m));
    if room.starts.is_empty() {
        return Err(DemoError::Robot(format!(
            "the start ({:.2}, {:.2}) of {} has no room around it in {}",
            start.x_m,
            start.y_m,
            options.robot.display(),
            world_dir.display()
        )));
    }
    let ways = walkable(&world, &room);
    let mission = load_mission(&options.script)?;
    std::fs::create_dir_all(&options.out).map_err(|source| DemoError::Write {
        path: options.out.clone(),
        source,
    })?;
    let mut report = MissionBenchReport {
        seed: options.seed,
        random_start: options.random_start,
        people: options.people,
        missions: Vec::new(),
    };
    for i in 0..options.seeds {
        let seed = options.seed.wrapping_add(u64::from(i));
        let mut rng = Rng::new(seed);
        let start = if options.random_start {
            let starts = &room.starts;
            let p = starts[(rng.uniform(0.0, starts.len() as f64) as usize).min(starts.len() - 1)];
            StartPose {
                x_m: round2(p.x),
                y_m: round2(p.y),
                heading_deg: round2(rng.uniform(-180.0, 180.0)),
            }
        } else {
            start
        };
        let walkers = draw_walkers(&mut rng, &ways, options.people);
        let dir = options.out.join(format!("mission-{:03}", i + 1));
        let result = run_one(
            options,
            registry,
            (&robot_text, &mission, &world_dir),
            (i + 1, seed, start, walkers),
            &dir,
        )?;
        on_mission(&result);
        report.missions.push(result);
        let path = options.out.join("bench.json");
        let text =
            serde_json::to_string_pretty(&report).map_err(|e| DemoError::Report(e.to_string()))?;
        std::fs::write(&path, text + "\n").map_err(|source| DemoError::Write { path, source })?;
        picture::write_png(&report, &world, &options.out.join("bench.png"))
            .map_err(DemoError::Report)?;
    }
    Ok(report)
}

/// The base's world folder and start pose, from the robot file.
fn base_world(table: &toml::Table, robot: &Path) -> Result<(PathBuf, StartPose), DemoError> {
    let base = table
        .get("services")
        .and_then(toml::Value::as_array)
        .into_iter()
        .flatten()
        .filter_map(toml::Value::as_table)
        .find(|s| s.get("kind").and_then(toml::Value::as_str) == Some("sim-base"))
        .ok_or_else(|| {
            DemoError::Robot(format!(
                "{} has no simulated base (kind `sim-base`): the mission bench needs a simulated world",
                robot.display()
            ))
        })?;
    let parameters = base.get("parameters").and_then(toml::Value::as_table);
    let world = parameters
        .and_then(|p| p.get("world"))
        .and_then(toml::Value::as_str)
        .ok_or_else(|| DemoError::Robot(format!("{}: the base has no `world`", robot.display())))?;
    let start = parameters
        .and_then(|p| p.get("start"))
        .and_then(toml::Value::as_table);
    let number = |key: &str| {
        start
            .and_then(|s| s.get(key))
            .and_then(|v| v.as_float().or_else(|| v.as_integer().map(|i| i as f64)))
            .unwrap_or(0.0)
    };
    Ok((
        PathBuf::from(world),
        StartPose {
            x_m: number("x_m"),
            y_m: number("y_m"),
            heading_deg: number("heading_deg"),
        },
    ))
}

/// The start room: the points reached from `start` with every door closed.
#[derive(Debug, Clone)]
pub struct StartRoom {
    /// Every point of it (10 cm apart).
    pub points: Vec<Vec2>,
    /// Those where a robot has room to start: `START_CLEARANCE_M` around them.
    pub starts: Vec<Vec2>,
}

/// The start room of `world` around `start`.
#[must_use]
pub fn start_room(world: &World, start: Vec2) -> StartRoom {
    let mut closed = world.clone();
    let doors: Vec<String> = world
        .objects()
        .iter()
        .filter(|o| matches!(o.kind, ObjectKind::Door { .. }))
        .map(|o| o.name.clone())
        .collect();
    for door in &doors {
        let _ = closed.set_door_open(door, false);
    }
    let points = flood(&closed, start);
    let starts = points
        .iter()
        .copied()
        .filter(|p| !closed.circle_collides(*p, START_CLEARANCE_M, 1.0))
        .collect();
    StartRoom { points, starts }
}

/// The points reachable from `from` (a robot's centre, 10 cm cells, 0.25 m of room).
fn flood(world: &World, from: Vec2) -> Vec<Vec2> {
    let grid = world.grid();
    let origin = grid.origin();
    let far = grid.far_corner();
    let columns = ((far.x - origin.x) / CELL_M).ceil() as i64;
    let rows = ((far.y - origin.y) / CELL_M).ceil() as i64;
    let centre = |c: i64, r: i64| {
        Vec2::new(
            origin.x + (c as f64 + 0.5) * CELL_M,
            origin.y + (r as f64 + 0.5) * CELL_M,
        )
    };
    let cell = |p: Vec2| {
        (
            ((p.x - origin.x) / CELL_M).floor() as i64,
            ((p.y - origin.y) / CELL_M).floor() as i64,
        )
    };
    let inside = |(c, r): (i64, i64)| (0..columns).contains(&c) && (0..rows).contains(&r);
    let index = |(c, r): (i64, i64)| (r * columns + c) as usize;
    let mut seen = vec![false; (columns * rows).max(0) as usize];
    let first = cell(from);
    if !inside(first) || world.circle_collides(centre(first.0, first.1), 0.25, 1.0) {
        return Vec::new();
    }
    let mut queue = std::collections::VecDeque::from([first]);
    seen[index(first)] = true;
    let mut out = Vec::new();
    while let Some((c, r)) = queue.pop_front() {
        out.push(centre(c, r));
        for next in [(c + 1, r), (c - 1, r), (c, r + 1), (c, r - 1)] {
            if inside(next)
                && !seen[index(next)]
                && !world.circle_collides(centre(next.0, next.1), 0.25, 1.0)
            {
                seen[index(next)] = true;
                queue.push_back(next);
            }
        }
    }
    out
}

/// Where people may walk: the points reachable from the start room (doors as they are),
/// outside it, with room around them, away from the people already there.
fn walkable(world: &World, room: &StartRoom) -> Vec<Vec2> {
    let room = &room.points;
    let Some(&inside) = room.first() else {
        return Vec::new();
    };
    // The room and a metre round it: its doorways too.
    let reach = (ROOM_MARGIN_M / CELL_M).round() as i64;
    let mut in_room = std::collections::HashSet::new();
    for p in room {
        let (c, r) = key(*p);
        for dc in -reach..=reach {
            for dr in -reach..=reach {
                in_room.insert((c + dc, r + dr));
            }
        }
    }
    let people: Vec<Vec2> = world
        .objects()
        .iter()
        .filter_map(|o| match &o.kind {
            ObjectKind::Person(person) => Some(person.centre),
            _ => None,
        })
        .collect();
    flood(world, inside)
        .into_iter()
        .filter(|p| {
            !in_room.contains(&key(*p))
                && !world.circle_collides(*p, WALK_CLEARANCE_M, 1.0)
                && people.iter().all(|q| q.distance(*p) > CROWD_M)
        })
        .collect()
}

fn key(p: Vec2) -> (i64, i64) {
    ((p.x / CELL_M).floor() as i64, (p.y / CELL_M).floor() as i64)
}

/// `n` people, each walking a straight way between two points of `ways`, once.
fn draw_walkers(rng: &mut Rng, ways: &[Vec2], n: u32) -> Vec<Walker> {
    let mut walkers = Vec::new();
    if ways.is_empty() {
        return walkers;
    }
    let pick =
        |rng: &mut Rng| ways[(rng.uniform(0.0, ways.len() as f64) as usize).min(ways.len() - 1)];
    let set: std::collections::HashSet<(i64, i64)> = ways.iter().map(|p| key(*p)).collect();
    for k in 0..n {
        // A few draws for a straight way of the right length in the walkable space.
        for _ in 0..200 {
            let from = pick(rng);
            let to = pick(rng);
            let length = from.distance(to);
            if !(WALK_LENGTH_M.0..=WALK_LENGTH_M.1).contains(&length) {
                continue;
            }
            let steps = (length / (CELL_M * 2.0)).ceil() as usize;
            let clear = (0..=steps).all(|s| {
                let t = s as f64 / steps as f64;
                set.contains(&key(from + (to - from) * t))
            });
            if clear {
                walkers.push(Walker {
                    name: format!("walker-{}", k + 1),
                    from: [round2(from.x), round2(from.y)],
                    to: [round2(to.x), round2(to.y)],
                    speed_mps: round2(rng.uniform(0.4, 1.1)),
                    starts_at_s: round2(rng.uniform(0.0, WALK_START_S)),
                });
                break;
            }
        }
    }
    walkers
}

fn round2(x: f64) -> f64 {
    (x * 100.0).round() / 100.0
}

/// The world of `world_dir` with `walkers` added, written to `out`.
fn write_world(world_dir: &Path, walkers: &[Walker], out: &Path) -> Result<(), DemoError> {
    std::fs::create_dir_all(out).map_err(write_error(out))?;
    let entries = std::fs::read_dir(world_dir).map_err(write_error(world_dir))?;
    for entry in entries {
        let entry = entry.map_err(write_error(world_dir))?;
        if entry.path().is_file() {
            let to = out.join(entry.file_name());
            std::fs::copy(entry.path(), &to).map_err(write_error(&to))?;
        }
    }
    let path = out.join("world.toml");
    let mut text = std::fs::read_to_string(&path).map_err(write_error(&path))?;
    text.push_str("\n# People walking about, drawn by `lewis bench mission`.\n");
    const SHIRTS: [&str; 5] = ["#b03030", "#3070b0", "#a0a040", "#8040a0", "#309070"];
    for (k, w) in walkers.iter().enumerate() {
        let _ = write!(
            text,
            "\n[[objects]]\nkind = \"person\"\nname = \"{}\"\ncentre = [{}, {}]\nshirt_colour = \"{}\"\n\n[[walks]]\nperson = \"{}\"\nroute = [[{}, {}]]\nspeed_mps = {}\nstarts_at_s = {}\nleaves = true\n",
            w.name,
            w.from[0],
            w.from[1],
            SHIRTS[k % SHIRTS.len()],
            w.name,
            w.to[0],
            w.to[1],
            w.speed_mps,
            w.starts_at_s
        );
    }
    std::fs::write(&path, text).map_err(write_error(&path))?;
    World::load(out).map_err(|e| DemoError::Robot(format!("{}: {e}", out.display())))?;
    Ok(())
}

/// The robot file `text` seeded with `seed`, its simulated devices in the world at
/// `world`, its base starting at `start`.
fn robot_for(text: &str, seed: u64, world: &Path, start: StartPose) -> Result<String, DemoError> {
    let seeded = with_seed(text, seed).map_err(DemoError::Robot)?;
    let mut table: toml::Table = seeded
        .parse()
        .map_err(|e| DemoError::Robot(format!("{e}")))?;
    let world = world.to_string_lossy().into_owned();
    if let Some(toml::Value::Array(services)) = table.get_mut("services") {
        for service in services.iter_mut().filter_map(toml::Value::as_table_mut) {
            let is_base = service.get("kind").and_then(toml::Value::as_str) == Some("sim-base");
            let Some(parameters) = service
                .get_mut("parameters")
                .and_then(toml::Value::as_table_mut)
            else {
                continue;
            };
            if parameters.contains_key("world") {
                parameters.insert("world".into(), toml::Value::String(world.clone()));
            }
            if is_base {
                let mut pose = toml::Table::new();
                pose.insert("x_m".into(), start.x_m.into());
                pose.insert("y_m".into(), start.y_m.into());
                pose.insert("heading_deg".into(), start.heading_deg.into());
                parameters.insert("start".into(), pose.into());
            }
        }
    }
    toml::to_string(&table).map_err(|e| DemoError::Robot(format!("{e}")))
}

/// One mission, live.
fn run_one(
    options: &MissionBenchOptions,
    registry: &ServiceRegistry,
    (robot_text, mission, world_dir): (&str, &lewis_sequencer::Mission, &Path),
    (number, seed, start, walkers): (u32, u64, StartPose, Vec<Walker>),
    dir: &Path,
) -> Result<BenchMission, DemoError> {
    fresh_dir(dir)?;
    let dir = std::path::absolute(dir).map_err(write_error(dir))?;
    let world = dir.join("world");
    write_world(world_dir, &walkers, &world)?;
    let robot_path = dir.join("robot.toml");
    let text = robot_for(robot_text, seed, &world, start)?;
    std::fs::write(&robot_path, text).map_err(write_error(&robot_path))?;
    let robot = load_robot(&robot_path, registry)?;

    let namespace = Namespace::unique("bench");
    let _ = lewis_runtime::ipc::wipe_stale(&namespace);
    let fault = FaultThread::start(&namespace, options.fault.clone()).map_err(DemoError::Fault)?;
    let launch_options = unattended_launch(
        (robot_path, &namespace, &options.lewis_exe),
        (&options.script, mission),
        (dir.join("run.mcap"), dir.join("events.jsonl")),
        MISSION_LIMIT,
    );
    let launched = Launch::new(robot, launch_options).and_then(Launch::run);
    let fault = fault.finish();
    let _ = lewis_runtime::ipc::wipe_ended(&namespace);
    let report = launched?.mission.ok_or(DemoError::NoMission)?;
    let verdict = &report.verdict;
    let fault_text = mission_lines(&report, &fault)
        .lines()
        .find_map(|l| l.strip_prefix("live fault: ").map(str::to_owned))
        .unwrap_or_default();
    let succeeded = report.succeeded();
    let states: Vec<String> = verdict
        .states_visited
        .iter()
        .map(|v| v.state.clone())
        .collect();
    let failed_in = (!succeeded)
        .then(|| {
            verdict
                .states_visited
                .iter()
                .rev()
                .find(|v| mission.recovery().is_none_or(|r| r.name != v.state))
                .map(|v| v.state.clone())
        })
        .flatten();
    let kept = if succeeded {
        let _ = std::fs::remove_dir_all(&dir);
        None
    } else {
        Some(dir.clone())
    };
    Ok(BenchMission {
        number,
        seed,
        start,
        walkers,
        succeeded,
        reason: verdict.reason.clone(),
        states,
        failed_in,
        fault: fault_text,
        kept,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn conference() -> World {
        let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../robots/worlds/conference");
        World::load(&dir).unwrap()
    }

    #[test]
    fn the_start_room_is_the_lobby_and_people_walk_outside_it() {
        let world = conference();
        let room = start_room(&world, Vec2::new(3.0, 12.5));
        assert!(room.starts.len() > 1000, "{} starts", room.starts.len());
        // The lobby: x 0.5..7.9, y 7.5..17.5, with room around every start.
        for p in &room.starts {
            assert!(
                (1.0..7.5).contains(&p.x) && (8.0..17.0).contains(&p.y),
                "{p:?}"
            );
        }
        let ways = walkable(&world, &room);
        assert!(!ways.is_empty());
        let lobby: Vec<&Vec2> = ways.iter().filter(|p| p.x <= 8.0).collect();
        assert!(lobby.is_empty(), "nobody walks in the lobby: {lobby:?}");
        let mut rng = Rng::new(3);
        let walkers = draw_walkers(&mut rng, &ways, 4);
        assert_eq!(walkers.len(), 4);
        for w in &walkers {
            let length = Vec2::new(w.from[0], w.from[1]).distance(Vec2::new(w.to[0], w.to[1]));
            assert!((3.9..12.1).contains(&length), "{w:?}");
        }
        // The same seed, the same people.
        assert_eq!(walkers, draw_walkers(&mut Rng::new(3), &ways, 4));
    }

    #[test]
    fn the_picture_shows_each_start_coloured_by_its_outcome() {
        let world = conference();
        let mission = |number, succeeded, x_m, y_m| BenchMission {
            number,
            seed: u64::from(number),
            start: StartPose {
                x_m,
                y_m,
                heading_deg: 45.0,
            },
            walkers: vec![Walker {
                name: "walker-1".into(),
                from: [12.0, 12.5],
                to: [20.0, 12.5],
                speed_mps: 0.5,
                starts_at_s: 1.0,
            }],
            succeeded,
            reason: String::new(),
            states: Vec::new(),
            failed_in: None,
            fault: String::new(),
            kept: None,
        };
        let report = MissionBenchReport {
            seed: 1,
            random_start: true,
            people: 1,
            missions: vec![mission(1, true, 3.0, 12.5), mission(2, false, 5.0, 15.0)],
        };
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("bench.png");
        picture::write_png(&report, &world, &path).unwrap();
        let image = image::open(&path).unwrap().to_rgb8();
        // 40 m across in 1080 px: 27 px/m; the failed start at (5, 15) is red, the other
        // green.
        let at = |x: f64, y: f64| {
            let px = 10.0 + x * 27.0;
            let py = f64::from(image.height()) - 10.0 - y * 27.0;
            image.get_pixel(px.round() as u32, py.round() as u32).0
        };
        assert_eq!(at(5.0, 15.0), [0xd7, 0x19, 0x1c]);
        assert_eq!(at(3.0, 12.5), [0x1a, 0x96, 0x41]);
    }

    #[test]
    fn a_drawn_world_and_robot_file_load_with_the_people_and_the_start() {
        let dir = tempfile::tempdir().unwrap();
        let world_dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../robots/worlds/conference");
        let walkers = vec![Walker {
            name: "walker-1".into(),
            from: [12.0, 12.5],
            to: [12.0, 14.0],
            speed_mps: 0.5,
            starts_at_s: 1.0,
        }];
        write_world(&world_dir, &walkers, dir.path()).unwrap();
        let world = World::load(dir.path()).unwrap();
        assert!(world.object("walker-1").is_some());
        assert_eq!(
            world.plan().walks.len(),
            2,
            "the guide's walk and the walker's"
        );
        let robot = Path::new(env!("CARGO_MANIFEST_DIR")).join("../robots/sim.toml");
        let text = std::fs::read_to_string(robot).unwrap();
        let start = StartPose {
            x_m: 2.0,
            y_m: 9.0,
            heading_deg: 135.0,
        };
        let out = robot_for(&text, 7, dir.path(), start).unwrap();
        let table: toml::Table = out.parse().unwrap();
        let (world, read) = base_world(&table, Path::new("robot.toml")).unwrap();
        assert_eq!(world, dir.path());
        assert_eq!(read, start);
    }
}
