//! `lewis tune label-sim RUN.mcap -o LABELS.json`: labels for the camera frames of a
//! simulator recording, from the simulator's ground truth.
//!
//! Each frame of a `sim-camera` names in its provenance the GroundTruth and WorldState
//! samples it was rendered from. Those give the robot's true pose and where the people
//! stood; the camera's parameters come from the robot description stored in the recording,
//! its pan, tilt and zoom from the latest CameraControl. The frame is rendered again with
//! the simulator's own camera model, naming the surface each pixel shows
//! (`SimCamera::render_sources`), so an object behind another is hidden exactly as in the
//! picture. Every person's cap, every sign's white board and every sign's black arrow that
//! shows gets a box around its visible pixels; one with fewer visible pixels than
//! `--min-pixels` is labelled optional (too small to require, not wrong to find).

use std::collections::{BTreeMap, VecDeque};
use std::fmt;
use std::path::PathBuf;

use anyhow::Context as _;
use clap::Args;
use lewis_geometry::{Pose2, Vec2};
use lewis_interfaces::Struct as _;
use lewis_interfaces::msg::{CameraControl, GroundTruth, ImageSource, PersonState, WorldState};
use lewis_perception::labels::{LABELS_VERSION, LabelledFrame, LabelledObject, Labels, PixelBox};
use lewis_recording::{RecordedMessage, Recording};
use lewis_sim::service::CameraParams;
use lewis_sim::world::{Material, ObjectKind};
use lewis_sim::{PixelSource, PrimitivePart, SimCamera, World};

use crate::frames::frame_name;

/// Objects with fewer visible pixels are optional, and smaller blobs are not scored: the
/// default of `--min-pixels`, and the `min_area_px` of a labels file `lewis tune open`
/// starts.
pub const DEFAULT_MIN_PIXELS: u32 = 40;

/// The kind of the simulator's camera service in robot files.
const SIM_CAMERA_KIND: &str = "sim-camera";

/// GroundTruth and WorldState samples kept per topic while looking for the ones a frame
/// names: a frame names samples published shortly before it (at 50 Hz, a 5 Hz camera
/// names one of the last few), so a few hundred is far more than enough.
const KEPT_SAMPLES: usize = 512;

/// Arguments of `lewis tune label-sim`.
#[derive(Debug, Args)]
pub struct LabelSimArgs {
    /// A recording of the simulated robot (its camera, GroundTruth and WorldState).
    pub input: PathBuf,
    /// The labels file to write (JSON).
    #[arg(short, long, value_name = "LABELS.json")]
    pub output: PathBuf,
    /// Label every Nth frame only.
    #[arg(long, default_value_t = 1, value_parser = clap::value_parser!(u64).range(1..))]
    pub every: u64,
    /// Objects with fewer visible pixels are optional, and smaller blobs are not scored.
    #[arg(long, default_value_t = DEFAULT_MIN_PIXELS)]
    pub min_pixels: u32,
    /// The colour class of the people's caps.
    #[arg(long, default_value = "Red")]
    pub cap_class: String,
    /// The colour class of the signs' white boards.
    #[arg(long, default_value = "White")]
    pub board_class: String,
    /// The colour class of the signs' black arrows.
    #[arg(long, default_value = "Black")]
    pub arrow_class: String,
}

/// The class names of what is labelled.
struct Classes<'a> {
    cap: &'a str,
    board: &'a str,
    arrow: &'a str,
}

/// What `lewis tune label-sim` wrote: its `Display` is the line it prints.
#[derive(Debug, Clone)]
pub struct LabelSimReport {
    /// The recording, as given.
    pub input: String,
    /// Frames labelled.
    pub frames: usize,
    /// Objects labelled that are not optional.
    pub objects: usize,
    /// Frames of a simulator's camera skipped: without the ground truth they were rendered
    /// from.
    pub unlabelled: u64,
    /// The labels file written.
    pub output: PathBuf,
}

impl fmt::Display for LabelSimReport {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        writeln!(
            f,
            "{} frames of {} labelled ({} objects{}): wrote {}",
            self.frames,
            self.input,
            self.objects,
            if self.unlabelled > 0 {
                format!(", {} frames without ground truth skipped", self.unlabelled)
            } else {
                String::new()
            },
            self.output.display()
        )
    }
}

/// Runs `lewis tune label-sim`: labels the recording's frames and writes the labels file.
///
/// # Errors
/// When the recording cannot be read, is not of the simulator's camera, or the labels
/// cannot be written.
pub fn label_sim(args: &LabelSimArgs) -> anyhow::Result<LabelSimReport> {
    let input = args.input.display().to_string();
    let recording = Recording::open(std::slice::from_ref(&args.input))?;
    let mut cameras = sim_cameras(&recording, &input)?;
    let topics_of = |schema: &str| -> Vec<String> {
        recording
            .topics()
            .values()
            .filter(|t| t.schema_name == schema)
            .map(|t| t.name.to_string())
            .collect()
    };
    let images = topics_of(ImageSource::SCHEMA_NAME);
    anyhow::ensure!(
        !images.is_empty(),
        "{input} has no ImageSource topic: check its topics with `lewis info {input}`"
    );
    let truths = topics_of(GroundTruth::SCHEMA_NAME);
    anyhow::ensure!(
        !truths.is_empty(),
        "{input} has no GroundTruth topic: only a recording of the simulator (robots/sim.toml) can be labelled from its ground truth"
    );
    let mut topics = images.clone();
    topics.extend(truths);
    topics.extend(topics_of(WorldState::SCHEMA_NAME));
    topics.extend(topics_of(CameraControl::SCHEMA_NAME));
    let names: Vec<&str> = topics.iter().map(String::as_str).collect();

    let classes = Classes {
        cap: &args.cap_class,
        board: &args.board_class,
        arrow: &args.arrow_class,
    };
    let mut poses: BTreeMap<String, VecDeque<(u64, Pose2)>> = BTreeMap::new();
    let mut people: BTreeMap<String, VecDeque<(u64, Vec<PersonState>)>> = BTreeMap::new();
    let mut controls: BTreeMap<String, CameraControl> = BTreeMap::new();
    let mut frames = Vec::new();
    let (mut seen, mut unlabelled) = (0u64, 0u64);
    for message in recording.messages_on(&names)? {
        let message = message?;
        let decode_error = |what: &str| {
            format!(
                "{input}: message {} on {} does not decode as {what}",
                message.seq, message.topic
            )
        };
        let schema = &recording.topics()[&message.topic].schema_name;
        if *schema == GroundTruth::SCHEMA_NAME {
            let truth: GroundTruth = lewis_interfaces::cdr::from_bytes(&message.data)
                .with_context(|| decode_error("GroundTruth"))?;
            keep(
                &mut poses,
                &message.topic,
                truth.header.seq,
                Pose2::from_msg(&truth.pose),
            );
        } else if *schema == WorldState::SCHEMA_NAME {
            let state: WorldState = lewis_interfaces::cdr::from_bytes(&message.data)
                .with_context(|| decode_error("WorldState"))?;
            keep(&mut people, &message.topic, state.header.seq, state.people);
        } else if *schema == CameraControl::SCHEMA_NAME {
            let control: CameraControl = lewis_interfaces::cdr::from_bytes(&message.data)
                .with_context(|| decode_error("CameraControl"))?;
            controls.insert(control.header.provider.clone(), control);
        } else {
            seen += 1;
            if (seen - 1) % args.every != 0 {
                continue;
            }
            let image: ImageSource = lewis_interfaces::cdr::from_bytes(&message.data)
                .with_context(|| decode_error("ImageSource"))?;
            let Some(camera) = cameras.get_mut(&image.header.provider) else {
                unlabelled += 1;
                continue;
            };
            let truth = image.header.inputs.iter().find_map(|i| {
                poses
                    .get(&i.channel)
                    .and_then(|q| q.iter().find(|(seq, _)| *seq == i.seq))
            });
            let Some(&(_, pose)) = truth else {
                unlabelled += 1;
                continue;
            };
            let crowd = image.header.inputs.iter().find_map(|i| {
                people
                    .get(&i.channel)
                    .and_then(|q| q.iter().find(|(seq, _)| *seq == i.seq))
            });
            camera.look(controls.get(&image.header.provider), crowd.map(|(_, p)| p));
            frames.push(camera.label(&message, pose, &classes, args.min_pixels));
        }
    }
    anyhow::ensure!(
        !frames.is_empty(),
        "{input}: no frame of a {SIM_CAMERA_KIND} names the GroundTruth sample it was rendered from ({unlabelled} frames without)"
    );
    let labels = Labels {
        version: LABELS_VERSION,
        source: format!(
            "{input}, labelled from the simulator's ground truth by `lewis tune label-sim`"
        ),
        min_area_px: args.min_pixels,
        frames,
    };
    labels.save(&args.output)?;
    let objects: usize = labels
        .frames
        .iter()
        .map(|f| f.objects.iter().filter(|o| !o.optional).count())
        .sum();
    Ok(LabelSimReport {
        input,
        frames: labels.frames.len(),
        objects,
        unlabelled,
        output: args.output.clone(),
    })
}

/// Keeps the latest [`KEPT_SAMPLES`] samples of a topic.
fn keep<T>(store: &mut BTreeMap<String, VecDeque<(u64, T)>>, topic: &str, seq: u64, value: T) {
    let queue = store.entry(topic.to_owned()).or_default();
    if queue.len() == KEPT_SAMPLES {
        queue.pop_front();
    }
    queue.push_back((seq, value));
}

/// A simulated camera of the recording, rendering its frames again.
struct LabelCamera {
    camera: SimCamera,
    /// The world as loaded, and as the latest frame saw it (people moved).
    world: World,
}

/// The `sim-camera` services of the recording's robot description, by name, each with its
/// world loaded.
fn sim_cameras(
    recording: &Recording,
    input: &str,
) -> anyhow::Result<BTreeMap<String, LabelCamera>> {
    let (robot_name, robot_toml) = recording.robot_toml();
    let robot: toml::Table = robot_toml
        .parse()
        .with_context(|| format!("{input}: the robot description {robot_name} is not TOML"))?;
    let services = robot
        .get("services")
        .and_then(toml::Value::as_array)
        .cloned()
        .unwrap_or_default();
    let mut cameras = BTreeMap::new();
    for service in services {
        if service.get("kind").and_then(toml::Value::as_str) != Some(SIM_CAMERA_KIND) {
            continue;
        }
        let name = service
            .get("name")
            .and_then(toml::Value::as_str)
            .unwrap_or_default()
            .to_owned();
        let params: CameraParams = service
            .get("parameters")
            .cloned()
            .unwrap_or(toml::Value::Table(toml::Table::new()))
            .try_into()
            .with_context(|| {
                format!("{input}: the parameters of {SIM_CAMERA_KIND} `{name}` in {robot_name}")
            })?;
        let world = World::load(&params.world).with_context(|| {
            format!("{input}: the world of camera `{name}` (run from the folder the robot ran in)")
        })?;
        let camera = SimCamera::new(params.camera_config(), 0)
            .with_context(|| format!("{input}: camera `{name}`"))?;
        cameras.insert(name, LabelCamera { camera, world });
    }
    anyhow::ensure!(
        !cameras.is_empty(),
        "{input}: the robot description {robot_name} has no {SIM_CAMERA_KIND}: only the simulator's camera can be labelled from its ground truth"
    );
    Ok(cameras)
}

impl LabelCamera {
    /// Points the camera as `control` says and puts the people where `people` says.
    fn look(&mut self, control: Option<&CameraControl>, people: Option<&Vec<PersonState>>) {
        if let Some(control) = control {
            self.camera.set_zoom(control.zoom);
            self.camera.set_pan_tilt(control.pan, control.tilt);
        }
        for person in people.into_iter().flatten() {
            if let Some(index) = self.world.object_index(&person.name) {
                let at = Vec2::new(person.position.x, person.position.y);
                self.world.place_person(index, person.present.then_some(at));
            }
        }
    }

    /// The labels of the frame `message`, seen from `pose`.
    fn label(
        &mut self,
        message: &RecordedMessage,
        pose: Pose2,
        classes: &Classes<'_>,
        min_pixels: u32,
    ) -> LabelledFrame {
        let sources = self.camera.render_sources(&self.world, pose);
        let width = self.camera.config().width_px as usize;
        // (primitive, class) -> (box, visible pixels), in a stable order.
        let mut seen: BTreeMap<(usize, &str), (PixelBox, u32)> = BTreeMap::new();
        for (i, source) in sources.iter().enumerate() {
            let PixelSource::Primitive { index, part } = *source else {
                continue;
            };
            let Some(class) = self.class_of(index, part, classes) else {
                continue;
            };
            // within a frame of at most 8192 px a side
            let (x, y) = ((i % width) as u32, (i / width) as u32);
            let entry = seen.entry((index, class)).or_insert((
                PixelBox {
                    left: x,
                    top: y,
                    right: x,
                    bottom: y,
                },
                0,
            ));
            entry.0.left = entry.0.left.min(x);
            entry.0.top = entry.0.top.min(y);
            entry.0.right = entry.0.right.max(x);
            entry.0.bottom = entry.0.bottom.max(y);
            entry.1 += 1;
        }
        LabelledFrame {
            frame: frame_name(&message.topic, message.seq),
            objects: seen
                .into_iter()
                .map(|((_, class), (bounds, pixels))| LabelledObject {
                    class: class.to_owned(),
                    bounds,
                    optional: pixels < min_pixels,
                })
                .collect(),
        }
    }

    /// The class a part of a primitive is labelled with, if any.
    fn class_of<'a>(
        &self,
        primitive: usize,
        part: PrimitivePart,
        classes: &Classes<'a>,
    ) -> Option<&'a str> {
        match part {
            PrimitivePart::SignBoard => Some(classes.board),
            PrimitivePart::SignArrow => Some(classes.arrow),
            PrimitivePart::SignBack => None,
            PrimitivePart::Solid => {
                let p = self.world.primitives().get(primitive)?;
                let ObjectKind::Person(person) = &self.world.objects().get(p.object)?.kind else {
                    return None;
                };
                // The cap is the person's only primitive above their head's top.
                let is_cap = person
                    .cap
                    .is_some_and(|cap| p.material == Material::Solid(cap))
                    && p.top_m > person.height_m;
                is_cap.then_some(classes.cap)
            }
        }
    }
}
