//! Properties of the simulator over random inputs: the grid traversal finds the first wall
//! cell a ray enters, and no sequence of commands drives the base into an obstacle.
#![allow(
    clippy::unwrap_used,
    clippy::expect_used,
    reason = "test helpers fail loudly on broken fixtures"
)]

use std::path::Path;
use std::sync::OnceLock;

use lewis_geometry::{Pose2, Vec2};
use lewis_sim::world::OccupancyGrid;
use lewis_sim::{BaseConfig, SimBase, World};
use proptest::prelude::*;

fn conference() -> &'static World {
    static WORLD: OnceLock<World> = OnceLock::new();
    WORLD.get_or_init(|| {
        let dir = Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("../..")
            .join("robots/worlds/conference");
        World::load(&dir).unwrap()
    })
}

proptest! {
    #[test]
    fn a_ray_stops_in_the_first_wall_cell_on_its_way(
        cells in proptest::collection::vec(prop::bool::weighted(0.15), 30 * 30),
        start in (0.05f64..2.95, 0.05f64..2.95),
        angle in -3.2f64..3.2,
    ) {
        let grid = OccupancyGrid::from_fn(30, 30, 0.1, Vec2::new(0.0, 0.0), |c, r| cells[r * 30 + c]);
        let origin = Vec2::new(start.0, start.1);
        let (c, r) = grid.cell_of(origin);
        prop_assume!(!grid.is_occupied(c, r));
        let dir = Vec2::from_angle(angle);
        // Outside the grid counts as wall: every ray ends within the grid's diagonal.
        let hit = grid.cast_ray(origin, dir, 10.0).unwrap();
        // Just past the hit is a wall cell...
        let past = origin + dir * (hit.range_m + 1e-7);
        let (c, r) = grid.cell_of(past);
        prop_assert!(grid.is_occupied(c, r), "hit at {} is not in a wall", hit.range_m);
        // ...and nothing before it is.
        let mut t = 0.0;
        while t < hit.range_m - 1e-7 {
            let (c, r) = grid.cell_of(origin + dir * t);
            prop_assert!(!grid.is_occupied(c, r), "wall at {t} before the hit at {}", hit.range_m);
            t += 0.001;
        }
    }

    #[test]
    fn no_commands_drive_the_base_into_an_obstacle(
        commands in proptest::collection::vec((-1.0f64..1.0, -1.5f64..1.5, 1i64..40), 1..25),
        seed in any::<u64>(),
    ) {
        let world = conference();
        let config = BaseConfig::default();
        let mut base = SimBase::new(config, Pose2::new(6.5, 12.5, 0.0), seed).unwrap();
        for (v, w, steps) in commands {
            base.set_velocity(v, w);
            for _ in 0..steps {
                base.step(world, 20_000_000);
                let p = base.true_pose().position();
                prop_assert!(!world.circle_collides(p, config.radius_m, config.height_m), "inside an obstacle at {p:?}");
            }
        }
    }
}
