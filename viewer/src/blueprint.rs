//! The layout the viewer opens with: the world on the left with the state lanes under it
//! (bindings, services, health, the sequencer's state: a failover is a lane changing
//! colour); the robot frame and the camera, the text logs (decisions first, then the
//! commands and the services' output) and the plots on the right. For a replay's
//! output, the re-simulated lanes and logs get views of their own beside the recorded ones.
//!
//! The viewer opens at the end of the run on the `log_time` timeline (the whole path, and
//! the scans of the end; scrub back to see the failover), the world view framed on where
//! the robot went, the robot frame on the sensors' reach, and the side panels collapsed so
//! the views get the room.
//!
//! Built from Rerun's blueprint archetypes with ids numbered from the layout (not random,
//! as the SDK's blueprint builder makes them), so that the .rrd file stays the same for
//! the same recording.

use rerun::external::re_log_types::{
    BlueprintActivationCommand, LogMsg, SetStoreInfo, StoreInfo, StoreSource,
};
use rerun::external::re_sdk_types::blueprint::archetypes::{
    ContainerBlueprint, PanelBlueprint, TimePanelBlueprint, ViewBlueprint, ViewContents,
    ViewportBlueprint, VisualBounds2D,
};
use rerun::external::re_sdk_types::blueprint::components::{
    ColumnShare, ContainerKind, IncludedContent, PanelState, PlayState, QueryExpression,
    RootContainer, RowShare, ViewClass,
};
use rerun::external::re_sdk_types::datatypes::{Range1D, Range2D, Uuid};
use rerun::external::re_tuid::Tuid;
use rerun::log::{Chunk, ChunkId, RowId};
use rerun::{AsComponents, Transform3D};
use rerun::{EntityPath, StoreKind, TimeCell, TimePoint, TimelineName};

use crate::ViewError;
use crate::output::store_id;
use crate::rows::{ChunkSink, Rows};

/// One view of the layout.
struct View<'a> {
    class: &'a str,
    name: &'a str,
    origin: &'a str,
    contents: &'a [&'a str],
}

/// A rectangle of a frame, metres, x then y (y up, as the robot's frames are).
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Bounds {
    /// Least and greatest x.
    pub x_m: [f64; 2],
    /// Least and greatest y.
    pub y_m: [f64; 2],
}

impl Bounds {
    /// The bounds as the 2D view sees them: its origin is above the frame's y mirror.
    fn in_view(self) -> Range2D {
        Range2D {
            x_range: Range1D(self.x_m),
            y_range: Range1D([-self.y_m[1], -self.y_m[0]]),
        }
    }
}

/// What the robot frame view shows: the outline and the sensors' reach around it (the
/// laser's 8 m ahead, the sonar's 5 m all round).
const ROBOT_FRAME_BOUNDS: Bounds = Bounds {
    x_m: [-5.5, 8.5],
    y_m: [-6.0, 6.0],
};

const WORLD: View<'static> = View {
    class: "2D",
    name: "World",
    origin: "/",
    contents: &["+ /world/**"],
};
const ROBOT: View<'static> = View {
    class: "2D",
    name: "Robot frame",
    origin: "/",
    contents: &["+ /robot/**"],
};
const CAMERA: View<'static> = View {
    class: "2D",
    name: "Camera",
    origin: "/camera",
    contents: &["+ $origin/**"],
};
const STATES: View<'static> = View {
    class: "StateTimeline",
    name: "Bindings, services, health, sequencer",
    origin: "/status",
    contents: &["+ $origin/**", "- $origin/replay/**"],
};
const EVENTS: View<'static> = View {
    class: "TextLog",
    name: "Broker, health, sequencer",
    origin: "/events",
    contents: &[
        "+ $origin/**",
        "- $origin/commands/**",
        "- $origin/log/**",
        "- $origin/mover/**",
        "- $origin/replay/**",
    ],
};
const MOTION: View<'static> = View {
    class: "TextLog",
    name: "Motion",
    origin: "/events/mover",
    contents: &["+ $origin/**"],
};
const COMMANDS: View<'static> = View {
    class: "TextLog",
    name: "Commands",
    origin: "/events/commands",
    contents: &["+ $origin/**"],
};
const OUTPUT: View<'static> = View {
    class: "TextLog",
    name: "Services' output",
    origin: "/events/log",
    contents: &["+ $origin/**"],
};
const REPLAY_STATES: View<'static> = View {
    class: "StateTimeline",
    name: "Re-simulated: bindings, services, health, faults",
    origin: "/status/replay",
    contents: &["+ $origin/**"],
};
const REPLAY_EVENTS: View<'static> = View {
    class: "TextLog",
    name: "Re-simulated events and injected faults",
    origin: "/events/replay",
    contents: &["+ $origin/**", "- $origin/commands/**"],
};
const TOPICS: View<'static> = View {
    class: "TextLog",
    name: "Other topics",
    origin: "/topics",
    contents: &["+ $origin/**"],
};

/// Draws the world and the robot frame with y up (x forward, y left, as the robot's
/// frames are), where Rerun's 2D views have y down like images: a mirror on the two roots,
/// which the views see because their origin is above them.
pub(crate) fn log_frames(rows: &mut Rows, sink: &mut dyn ChunkSink) -> Result<(), ViewError> {
    for root in ["world", "robot"] {
        rows.log_static(
            sink,
            &EntityPath::from_single_string(root),
            &Transform3D::from_scale([1.0, -1.0, 1.0]),
        )?;
    }
    Ok(())
}

/// A UUID numbered `n` (version 4 layout, so the viewer takes it as any other id).
fn uuid(n: u64) -> Uuid {
    let text = format!("1e715000-0000-4000-8000-{n:012x}");
    let mut bytes = [0_u8; 16];
    let hex: Vec<u8> = text.bytes().filter(u8::is_ascii_hexdigit).collect();
    for (byte, pair) in bytes.iter_mut().zip(hex.chunks(2)) {
        let digit = |c: u8| char::from(c).to_digit(16).unwrap_or(0);
        {
            *byte = (digit(pair[0]) * 16 + digit(pair[1])) as u8;
        }
    }
    Uuid { bytes }
}

fn uuid_text(n: u64) -> String {
    format!("1e715000-0000-4000-8000-{n:012x}")
}

/// What the recording holds that changes the layout.
pub(crate) struct Contents<'a> {
    /// Camera images: a camera view.
    pub camera: bool,
    /// A replay's outputs: views of the re-simulated lanes and logs beside the recorded.
    pub replay: bool,
    /// Topics with plots: one plot each (one scale per interface: volts and metres per
    /// second do not share an axis well).
    pub plotted_topics: &'a [String],
    /// What the world view frames (where the robot went), or the data's own bounds.
    pub world_bounds: Option<Bounds>,
}

/// The blueprint's messages, and the command that makes it the default and active layout.
pub(crate) fn blueprint(
    recording_id: &str,
    contents: &Contents<'_>,
) -> Result<(Vec<LogMsg>, BlueprintActivationCommand), ViewError> {
    let Contents {
        camera: with_camera,
        replay,
        plotted_topics,
        world_bounds,
    } = *contents;
    let store = store_id(StoreKind::Blueprint, &format!("{recording_id}-layout"));
    let mut layout = Layout {
        next: 0,
        rows: Vec::new(),
    };
    let world = layout.view(&WORLD);
    if let Some(bounds) = world_bounds {
        layout.bounds(&world, bounds);
    }
    let mut states = layout.view(&STATES);
    if replay {
        let replay_states = layout.view(&REPLAY_STATES);
        states = layout.container(
            ContainerKind::Horizontal,
            &[states, replay_states],
            &[0.5, 0.5],
        );
    }
    // The lanes under the world, wide: a failover is a lane changing colour.
    let left = layout.container(ContainerKind::Vertical, &[world, states], &[0.6, 0.4]);

    let robot = layout.view(&ROBOT);
    layout.bounds(&robot, ROBOT_FRAME_BOUNDS);
    let top = if with_camera {
        let camera = layout.view(&CAMERA);
        layout.container(ContainerKind::Horizontal, &[robot, camera], &[0.5, 0.5])
    } else {
        robot
    };
    let decisions = layout.view(&EVENTS);
    let motion = layout.view(&MOTION);
    let commands = layout.view(&COMMANDS);
    let output = layout.view(&OUTPUT);
    let topics = layout.view(&TOPICS);
    let mut logs = layout.container(
        ContainerKind::Tabs,
        &[decisions, motion, commands, output, topics],
        &[],
    );
    if replay {
        let replay_events = layout.view(&REPLAY_EVENTS);
        logs = layout.container(
            ContainerKind::Horizontal,
            &[logs, replay_events],
            &[0.5, 0.5],
        );
    }
    let plot_views: Vec<Part> = plotted_topics
        .iter()
        .map(|topic| {
            let origin = crate::draw::topic_entity(&["plots"], topic, &[]).to_string();
            layout.view(&View {
                class: "TimeSeries",
                name: topic,
                origin: &origin,
                contents: &["+ $origin/**"],
            })
        })
        .collect();
    let right = if plot_views.is_empty() {
        layout.container(ContainerKind::Vertical, &[top, logs], &[0.55, 0.45])
    } else {
        let plots = layout.container(ContainerKind::Tabs, &plot_views, &[]);
        layout.container(
            ContainerKind::Vertical,
            &[top, logs, plots],
            &[0.4, 0.32, 0.28],
        )
    };
    let root = layout.container(ContainerKind::Horizontal, &[left, right], &[0.55, 0.45]);
    for panel in ["blueprint_panel", "selection_panel"] {
        layout.rows.push((
            EntityPath::from_single_string(panel),
            Box::new(PanelBlueprint::new().with_state(PanelState::Collapsed)),
        ));
    }
    layout.rows.push((
        EntityPath::from_single_string("time_panel"),
        Box::new(
            TimePanelBlueprint::new()
                .with_state(PanelState::Collapsed)
                .with_timeline(crate::LOG_TIME)
                .with_play_state(PlayState::Following),
        ),
    ));
    layout.rows.push((
        EntityPath::from_single_string("viewport"),
        Box::new(
            ViewportBlueprint::new()
                .with_root_container(RootContainer(uuid(root.1)))
                .with_auto_layout(false)
                .with_auto_views(false),
        ),
    ));

    let mut messages = vec![LogMsg::SetStoreInfo(SetStoreInfo {
        row_id: Tuid::from_u128(2),
        info: StoreInfo::new(store.clone(), StoreSource::Other("lewis view".to_owned())),
    })];
    let time = TimePoint::from([(TimelineName::from("blueprint"), TimeCell::from_sequence(0))]);
    for (index, (path, data)) in (1_u128..).zip(layout.rows) {
        let chunk = Chunk::builder_with_id(ChunkId::from_u128(index << 1), path.clone())
            .with_archetype(
                RowId::from_u128((index << 1) | 1),
                time.clone(),
                data.as_ref(),
            )
            .build()
            .map_err(|e| build_error(&path, &e))?;
        let message = chunk.to_arrow_msg().map_err(|e| build_error(&path, &e))?;
        messages.push(LogMsg::ArrowMsg(store.clone(), message));
    }
    let activation = BlueprintActivationCommand {
        blueprint_id: store,
        make_active: true,
        make_default: true,
    };
    Ok((messages, activation))
}

fn build_error(path: &EntityPath, error: &dyn std::fmt::Display) -> ViewError {
    ViewError::Build {
        entity: format!("blueprint {path}"),
        detail: error.to_string(),
    }
}

/// A view or container: its blueprint path and id number.
#[derive(Clone)]
struct Part(String, u64);

struct Layout {
    next: u64,
    rows: Vec<(EntityPath, Box<dyn AsComponents>)>,
}

impl Layout {
    fn id(&mut self) -> u64 {
        self.next += 1;
        self.next
    }

    fn view(&mut self, view: &View) -> Part {
        let n = self.id();
        let path = format!("view/{}", uuid_text(n));
        let queries: Vec<QueryExpression> = view
            .contents
            .iter()
            .map(|q| QueryExpression((*q).into()))
            .collect();
        self.rows.push((
            EntityPath::parse_forgiving(&format!("{path}/ViewContents")),
            Box::new(ViewContents::new(queries)),
        ));
        self.rows.push((
            EntityPath::parse_forgiving(&path),
            Box::new(
                ViewBlueprint::new(ViewClass(view.class.into()))
                    .with_display_name(view.name)
                    .with_space_origin(view.origin),
            ),
        ));
        Part(path, n)
    }

    /// Frames the 2D view `view` on `bounds`.
    fn bounds(&mut self, view: &Part, bounds: Bounds) {
        self.rows.push((
            EntityPath::parse_forgiving(&format!("{}/VisualBounds2D", view.0)),
            Box::new(VisualBounds2D::new(bounds.in_view())),
        ));
    }

    fn container(&mut self, kind: ContainerKind, children: &[Part], shares: &[f32]) -> Part {
        let n = self.id();
        let path = format!("container/{}", uuid_text(n));
        let mut container = ContainerBlueprint::new(kind).with_contents(
            children
                .iter()
                .map(|c| IncludedContent(c.0.as_str().into())),
        );
        if !shares.is_empty() {
            container = if kind == ContainerKind::Horizontal {
                container.with_col_shares(shares.iter().map(|&s| ColumnShare(s.into())))
            } else {
                container.with_row_shares(shares.iter().map(|&s| RowShare(s.into())))
            };
        }
        self.rows
            .push((EntityPath::parse_forgiving(&path), Box::new(container)));
        Part(path, n)
    }
}
