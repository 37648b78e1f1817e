//! People who move (`lewis_sim::scene`) in the conference world: the same seed and robot
//! track give the same people bit for bit; the queue waits for the robot, then is served
//! one by one; nobody steps within 0.6 m of the robot; the world file's tables are checked
//! at their line; and `sim-base` publishes WorldState, which the laser draws the people
//! from.

#![allow(clippy::unwrap_used)]

use lewis_geometry::Vec2;
use lewis_interfaces::msg::{GroundTruth, InputRef, PersonState, Pose2D, RangeFinder, WorldState};
use lewis_runtime::names::data_channel;
use lewis_service::ServiceRegistry;
use lewis_sim::scene::PERSONAL_SPACE_M;
use lewis_sim::{Scene, World};
use lewis_testkit::{Harness, decoded, repository_path, robot};

const MS: i64 = 1_000_000;
const S: i64 = 1_000_000_000;

fn conference() -> World {
    World::load(&repository_path("robots/worlds/conference")).unwrap()
}

/// The robot's true centre at `t_ns` on a track that waits in the hall's east, then
/// drives west along y 23.2 (from the hall sign towards the desk) at 0.5 m/s, and stops
/// behind the queue's last place.
fn hall_track(t_ns: i64) -> Vec2 {
    let t = t_ns as f64 * 1e-9;
    let x = if t < 10.0 {
        34.0
    } else {
        (34.0 - 0.5 * (t - 10.0)).max(20.4)
    };
    Vec2::new(x, 23.2)
}

/// Steps a scene of `seed` every 20 ms for `seconds` along `track`; returns every
/// people snapshot.
fn run(seed: u64, seconds: i64, track: impl Fn(i64) -> Vec2) -> Vec<Vec<PersonState>> {
    let world = conference();
    let mut scene = Scene::new(&world, seed);
    (0..=seconds * 50)
        .map(|i| {
            let t = i * 20 * MS;
            scene.step(t, track(t));
            scene.people()
        })
        .collect()
}

fn bits(people: &[Vec<PersonState>]) -> Vec<(String, u64, u64, u64, bool)> {
    people
        .iter()
        .flatten()
        .map(|p| {
            (
                p.name.clone(),
                p.position.x.to_bits(),
                p.position.y.to_bits(),
                p.heading.to_bits(),
                p.present,
            )
        })
        .collect()
}

fn person<'a>(people: &'a [PersonState], name: &str) -> &'a PersonState {
    people.iter().find(|p| p.name == name).unwrap()
}

#[test]
fn the_same_seed_and_track_give_the_same_people_bit_for_bit() {
    let a = run(1, 60, hall_track);
    let b = run(1, 60, hall_track);
    assert_eq!(bits(&a), bits(&b));
    // Another seed serves for other times.
    let c = run(2, 60, hall_track);
    assert_ne!(bits(&a), bits(&c));
}

#[test]
fn the_queue_waits_for_the_robot_then_is_served_one_by_one() {
    let world = conference();
    let initial = Scene::new(&world, 1).people();
    // The robot stays in the lobby: nobody moves, however long.
    let still = run(1, 120, |_| Vec2::new(3.0, 12.5));
    for snapshot in &still {
        assert_eq!(
            bits(std::slice::from_ref(snapshot)),
            bits(std::slice::from_ref(&initial))
        );
    }
    // Coming down the hall, it starts the queue when 9 m from the last in line, at
    // x = 19.2 + sqrt(81 - 2.2^2) ~ 27.9, some 22 s in.
    let snapshots = run(1, 60, hall_track);
    let moved_at = snapshots
        .iter()
        .position(|s| bits(std::slice::from_ref(s)) != bits(std::slice::from_ref(&initial)))
        .unwrap();
    let moved_s = moved_at as f64 * 0.02;
    // Service (3 to 5 s) comes before the first step.
    assert!((25.0..=27.5).contains(&moved_s), "moved at {moved_s} s");
    let gone = |s: &[PersonState], name: &str| !person(s, name).present;
    let names = ["queue-1", "queue-2", "queue-3", "queue-4", "queue-5"];
    // They leave in order: the head first.
    let left_at: Vec<usize> = names
        .iter()
        .map(|n| {
            snapshots
                .iter()
                .position(|s| gone(s, n))
                .unwrap_or_else(|| panic!("{n} never left"))
        })
        .collect();
    assert!(left_at.windows(2).all(|w| w[0] < w[1]), "{left_at:?}");
    // All served within 30 s of the start.
    let last_s = left_at[4] as f64 * 0.02;
    assert!(
        last_s - moved_s < 32.0,
        "served from {moved_s} to {last_s} s"
    );
    // The robot arrives (x 20.4 at 37 s) with people still in line.
    let at_arrival = &snapshots[37 * 50];
    assert!(
        names.iter().any(|n| !gone(at_arrival, n)),
        "nobody left in line when the robot arrives"
    );
    // The clerk stays.
    let last = snapshots.last().unwrap();
    assert_eq!(person(last, "clerk"), person(&initial, "clerk"));
}

#[test]
fn nobody_steps_within_personal_space_of_the_robot() {
    // The robot parks on the served people's way out, near the desk: they wait for it.
    let parked = Vec2::new(16.15, 19.5);
    let snapshots = run(1, 40, |_| parked);
    let world = conference();
    let initial = Scene::new(&world, 1).people();
    for s in &snapshots {
        for p in s.iter().filter(|p| p.present) {
            let at = Vec2::new(p.position.x, p.position.y);
            let before = person(&initial, &p.name);
            let started = Vec2::new(before.position.x, before.position.y);
            if at != started {
                assert!(
                    at.distance(parked) >= PERSONAL_SPACE_M - 1e-9,
                    "{} at {at:?}",
                    p.name
                );
            }
        }
    }
    // The head is stuck behind the robot: nobody else was served.
    let last = snapshots.last().unwrap();
    assert!(person(last, "queue-1").present);
    assert!(person(last, "queue-2").present);
    // Once the robot moves away, they go on.
    let world = conference();
    let mut scene = Scene::new(&world, 1);
    let mut t = 0;
    while t <= 40 * S {
        scene.step(t, parked);
        t += 20 * MS;
    }
    while t <= 80 * S {
        scene.step(t, Vec2::new(26.0, 23.0));
        t += 20 * MS;
    }
    assert!(!person(&scene.people(), "queue-1").present);
}

#[test]
fn the_guide_walks_away_when_the_robot_comes_near_and_leaves() {
    let world = conference();
    let start = world.object("red-cap").unwrap();
    let lewis_sim::world::ObjectKind::Person(cap) = &start.kind else {
        panic!("red-cap is a person")
    };
    let cap_at = cap.centre;
    // At 3.5 m, the guide stands; at 2.9 m, they set off and, some 12 s later, are gone.
    let far = run(1, 10, |_| cap_at + Vec2::new(3.5, 0.0));
    assert!(far.iter().all(|s| {
        let p = person(s, "red-cap");
        p.present && p.position.x == cap_at.x
    }));
    let near = run(1, 30, |_| cap_at + Vec2::new(2.9, 0.0));
    assert!(person(&near[50], "red-cap").position.x < cap_at.x);
    assert!(!person(near.last().unwrap(), "red-cap").present);
}

fn registry() -> ServiceRegistry {
    let mut registry = ServiceRegistry::new();
    lewis_sim::service::register(&mut registry);
    registry
}

#[test]
fn the_base_publishes_world_state_and_the_laser_draws_people_there() {
    let world = repository_path("robots/worlds/conference")
        .to_string_lossy()
        .into_owned();
    let text = format!(
        "[robot]\nname = \"t\"\n\n\
         [[services]]\nname = \"base\"\nkind = \"sim-base\"\n\
         provides = [{{ interface = \"GroundTruth\", quality = 5, cost = 1 }}, {{ interface = \"WorldState\", quality = 5, cost = 1 }}]\n\n\
         [services.parameters]\nworld = {world:?}\nstart = {{ x_m = 22.0, y_m = 21.0, heading_deg = 180.0 }}\nseed = 1\n\n\
         [[services]]\nname = \"laser\"\nkind = \"sim-laser\"\nrequires = [\"GroundTruth\", \"WorldState\"]\n\
         provides = [{{ interface = \"RangeFinder\", quality = 5, cost = 1 }}]\n\n\
         [services.parameters]\nworld = {world:?}\nrange_noise_std_m = 0.0\n"
    );
    let robot = robot(&text);
    let mut base = Harness::build(&robot, "base", &registry()).unwrap();
    let mut laser = Harness::build(&robot, "laser", &registry()).unwrap();
    base.start(0).unwrap();
    laser.start(0).unwrap();
    // The robot, 2.8 m east of the last in line and facing them, starts the queue; the
    // laser follows the base's publications.
    let mut t = 0;
    let mut state = None;
    let mut truth = None;
    while t < 12 * S {
        t += 20 * MS;
        base.tick(t);
        for p in base.take_published() {
            let channel = data_channel("base", &p.interface);
            laser.input(t, "base", &channel, &p);
            match p.interface.as_str() {
                "WorldState" => state = Some(p.decode::<WorldState>()),
                "GroundTruth" => truth = Some(p.decode::<GroundTruth>()),
                _ => {}
            }
        }
    }
    let state = state.unwrap();
    let truth = truth.unwrap();
    assert_eq!(state.person_count as usize, state.people.len());
    // Some have been served by now: the first left the line.
    assert!(!person(&state.people, "queue-1").present, "{state:#?}");
    laser.tick(t + 30 * MS);
    let scan = decoded::<RangeFinder>(&laser.take_published())
        .pop()
        .unwrap();
    assert_eq!(
        scan.header.inputs,
        vec![
            InputRef {
                channel: data_channel("base", "GroundTruth"),
                seq: truth.header.seq,
            },
            InputRef {
                channel: data_channel("base", "WorldState"),
                seq: state.header.seq,
            },
        ]
    );
    // Every beam agrees with a world whose people stand where WorldState says, and the
    // beam straight ahead meets the nearest in line (trousers at the laser's height).
    let mut expected_world = conference();
    for p in &state.people {
        let i = expected_world.object_index(&p.name).unwrap();
        expected_world.place_person(
            i,
            p.present.then_some(Vec2::new(p.position.x, p.position.y)),
        );
    }
    let Pose2D { x, y, theta } = truth.pose;
    let origin = Vec2::new(x, y) + Vec2::from_angle(theta) * 0.12;
    for (i, &range) in scan.ranges.iter().enumerate() {
        let bearing = theta + scan.theta_offset + scan.theta_separation * i as f64;
        let expected = expected_world
            .cast_ray(origin, Vec2::from_angle(bearing), 8.191, 0.38)
            .map_or(8.191, |h| h.range_m);
        assert!(
            (range - expected).abs() < 1e-9,
            "beam {i}: {range} vs {expected}"
        );
    }
    let nearest_in_line = state
        .people
        .iter()
        .filter(|p| p.present && p.name.starts_with("queue-"))
        .map(|p| p.position.x)
        .fold(f64::NEG_INFINITY, f64::max);
    let ahead = scan.ranges[scan.ranges.len() / 2];
    let trousers_radius = 0.8 * 0.22;
    assert!(
        (ahead - (origin.x - nearest_in_line - trousers_radius)).abs() < 0.05,
        "ahead {ahead}, last in line at x {nearest_in_line}, laser at {origin:?}"
    );
    // The file's world would have had the last in line at x 19.2.
    assert!(nearest_in_line < 19.2 - 0.5, "{nearest_in_line}");
    let static_ahead = conference()
        .cast_ray(origin, Vec2::from_angle(theta), 8.191, 0.38)
        .map_or(8.191, |h| h.range_m);
    assert!(ahead > static_ahead + 0.5, "{static_ahead} {ahead}");
}
