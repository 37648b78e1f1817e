//! The layout the viewer opens with: the world on the left with the plots under it; the
//! robot frame, the camera, the state lanes and the text logs on the right. For a replay's
//! output, the re-simulated lanes and logs get views of their own beside the recorded ones.
//!
//! Built from Rerun's blueprint archetypes with ids numbered from the layout (not random,
//! as the SDK's blueprint builder makes them), so that the .rrd file stays the same for
//! the same recording.

use rerun::external::re_log_types::{
    BlueprintActivationCommand, LogMsg, SetStoreInfo, StoreInfo, StoreSource,
};
use rerun::external::re_sdk_types::blueprint::archetypes::{
    ContainerBlueprint, ViewBlueprint, ViewContents, ViewportBlueprint,
};
use rerun::external::re_sdk_types::blueprint::components::{
    ColumnShare, ContainerKind, IncludedContent, QueryExpression, RootContainer, RowShare,
    ViewClass,
};
use rerun::external::re_sdk_types::datatypes::Uuid;
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
    name: "Events",
    origin: "/events",
    contents: &["+ $origin/**", "- $origin/replay/**"],
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
    contents: &["+ $origin/**"],
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
        #[allow(clippy::cast_possible_truncation)]
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
    } = *contents;
    let store = store_id(StoreKind::Blueprint, &format!("{recording_id}-layout"));
    let mut layout = Layout {
        next: 0,
        rows: Vec::new(),
    };
    let world = layout.view(&WORLD);
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
    let left = if plot_views.is_empty() {
        world
    } else {
        let plots = layout.container(ContainerKind::Tabs, &plot_views, &[]);
        layout.container(ContainerKind::Vertical, &[world, plots], &[0.65, 0.35])
    };
    let robot = layout.view(&ROBOT);
    let mut states = layout.view(&STATES);
    let events = layout.view(&EVENTS);
    let topics = layout.view(&TOPICS);
    let mut logs = layout.container(ContainerKind::Tabs, &[events, topics], &[]);
    if replay {
        let replay_states = layout.view(&REPLAY_STATES);
        let replay_events = layout.view(&REPLAY_EVENTS);
        states = layout.container(
            ContainerKind::Horizontal,
            &[states, replay_states],
            &[0.5, 0.5],
        );
        logs = layout.container(
            ContainerKind::Horizontal,
            &[logs, replay_events],
            &[0.5, 0.5],
        );
    }
    let right = if with_camera {
        let camera = layout.view(&CAMERA);
        let top = layout.container(ContainerKind::Horizontal, &[robot, camera], &[0.5, 0.5]);
        layout.container(
            ContainerKind::Vertical,
            &[top, states, logs],
            &[0.45, 0.25, 0.3],
        )
    } else {
        layout.container(
            ContainerKind::Vertical,
            &[robot, states, logs],
            &[0.45, 0.25, 0.3],
        )
    };
    let root = layout.container(ContainerKind::Horizontal, &[left, right], &[0.55, 0.45]);
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
