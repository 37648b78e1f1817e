//! The tuning page's HTTP endpoints: the page, JSON for the state, the frames' blobs, the
//! plots and the ranges, PNG for the frame with its overlay.
//!
//! - `GET /`: the page.
//! - `GET /api/state`: the frames held, the classes and their ranges.
//! - `GET /api/frame/N`: frame N's blobs (and signs, with `--signs`); `GET /frame/N.png`:
//!   frame N drawn.
//! - `GET /api/plots`: per class, blobs and largest area per frame over the recording.
//! - `POST /api/ranges` `{class, y, u, v}`: sets a class's ranges.
//! - `POST /api/mark` `{frame, class, rect: [x, y, w, h], outside}`: marks pixels and
//!   refits the class; answers the YUV values marked.
//! - `POST /api/save`: writes the colour file.
//! - `POST /api/box` `{frame, class, box: [left, top, right, bottom]}` (full-frame px):
//!   labels an object on frame N; `POST /api/box/remove` `{frame, index}`: removes one;
//!   both answer the frame's boxes and the labelled frames.
//! - `POST /api/labels/save`: writes the labels file.
//! - `GET /api/score`: precision and recall per labelled class with the ranges as they
//!   are now, over the labelled frames held.

use std::io::Read as _;
use std::sync::Mutex;

use lewis_perception::sweep;
use serde::Deserialize;
use serde_json::json;
use tiny_http::{Header, Method, Request, Response};

use super::render;
use super::state::{State, lock};

const PAGE: &str = include_str!("page.html");

/// The largest request body taken (a mark or ranges are a few dozen bytes).
const MAX_BODY: u64 = 64 * 1024;

type Body = std::io::Cursor<Vec<u8>>;

#[derive(Deserialize)]
struct Ranges {
    class: usize,
    y: [u8; 2],
    u: [u8; 2],
    v: [u8; 2],
}

#[derive(Deserialize)]
struct Mark {
    frame: usize,
    class: usize,
    rect: [u32; 4],
    #[serde(default)]
    outside: bool,
}

#[derive(Deserialize)]
struct NewBox {
    frame: usize,
    class: usize,
    #[serde(rename = "box")]
    bounds: [u32; 4],
}

#[derive(Deserialize)]
struct RemoveBox {
    frame: usize,
    index: usize,
}

/// Answers one request.
pub fn handle(mut request: Request, state: &Mutex<State>) {
    let url = request.url().to_owned();
    let path = url.split('?').next().unwrap_or_default().to_owned();
    let method = request.method().clone();
    let response = match (&method, path.as_str()) {
        (Method::Get, "/" | "/index.html") => {
            bytes(200, PAGE.as_bytes(), "text/html; charset=utf-8")
        }
        (Method::Get, "/api/state") => state_json(&lock(state)),
        (Method::Get, "/api/plots") => {
            let plots = lock(state).plots();
            json_response(200, &json!(plots))
        }
        (Method::Get, p) if p.starts_with("/api/frame/") => {
            frame_json(&lock(state), p.trim_start_matches("/api/frame/"))
        }
        (Method::Get, p) if p.starts_with("/frame/") && p.ends_with(".png") => frame_png(
            &lock(state),
            p.trim_start_matches("/frame/").trim_end_matches(".png"),
        ),
        (Method::Post, "/api/ranges") => match body::<Ranges>(&mut request) {
            Ok(r) => {
                let mut state = lock(state);
                match state.set_ranges(r.class, [r.y, r.u, r.v]) {
                    Ok(()) => state_json(&state),
                    Err(e) => text(400, &e),
                }
            }
            Err(e) => text(400, &e),
        },
        (Method::Post, "/api/mark") => match body::<Mark>(&mut request) {
            Ok(m) => {
                let mut state = lock(state);
                match state.mark(m.frame, m.class, m.rect, m.outside) {
                    Ok(marked) => json_response(
                        200,
                        &json!({ "marked": marked, "classes": state.classes() }),
                    ),
                    Err(e) => text(400, &e),
                }
            }
            Err(e) => text(400, &e),
        },
        (Method::Post, "/api/save") => save(&lock(state)),
        (Method::Post, "/api/box") => match body::<NewBox>(&mut request) {
            Ok(b) => {
                let mut state = lock(state);
                match state.add_box(b.frame, b.class, b.bounds) {
                    Ok(()) => boxes_json(&state, b.frame),
                    Err(e) => text(400, &e),
                }
            }
            Err(e) => text(400, &e),
        },
        (Method::Post, "/api/box/remove") => match body::<RemoveBox>(&mut request) {
            Ok(r) => {
                let mut state = lock(state);
                match state.remove_box(r.frame, r.index) {
                    Ok(()) => boxes_json(&state, r.frame),
                    Err(e) => text(400, &e),
                }
            }
            Err(e) => text(400, &e),
        },
        (Method::Post, "/api/labels/save") => save_labels(&mut lock(state)),
        (Method::Get, "/api/score") => match lock(state).score() {
            Ok(score) => json_response(200, &json!(score)),
            Err(e) => text(500, &format!("{e:#}")),
        },
        (Method::Get, _) => text(404, "no such page: try /"),
        _ => text(405, "method not allowed"),
    };
    if let Err(e) = request.respond(response) {
        tracing::debug!("the tuning page went away before its answer to {url}: {e}");
    }
}

fn body<T: serde::de::DeserializeOwned>(request: &mut Request) -> Result<T, String> {
    let mut text = String::new();
    request
        .as_reader()
        .take(MAX_BODY)
        .read_to_string(&mut text)
        .map_err(|e| format!("cannot read the request: {e}"))?;
    serde_json::from_str(&text).map_err(|e| format!("bad request body: {e}"))
}

fn state_json(state: &State) -> Response<Body> {
    let frames: Vec<_> = state
        .store
        .frames()
        .iter()
        .map(|f| {
            json!({
                "name": f.name,
                "width": f.width_px,
                "height": f.height_px,
                "full": state.full_size(f),
            })
        })
        .collect();
    json_response(
        200,
        &json!({
            "source": state.source,
            "colors": state.colors_path.display().to_string(),
            "save": state.save_path.display().to_string(),
            "loading": state.loading,
            "load_error": state.load_error,
            "stride": state.store.stride(),
            "offered": state.store.offered(),
            "frames": frames,
            "classes": state.classes(),
            "labels": labels_json(state),
        }),
    )
}

/// The labels file and which held frames are labelled.
fn labels_json(state: &State) -> serde_json::Value {
    let (labelled, not_held) = state.labelled_frames();
    json!({
        "path": state.labels_path.display().to_string(),
        "changed": state.labels_changed,
        "labelled": labelled,
        "not_held": not_held,
    })
}

fn boxes_json(state: &State, frame: usize) -> Response<Body> {
    json_response(
        200,
        &json!({ "boxes": state.boxes(frame), "labels": labels_json(state) }),
    )
}

fn save_labels(state: &mut State) -> Response<Body> {
    match state.save_labels() {
        Ok(objects) => json_response(
            200,
            &json!({
                "path": state.labels_path.display().to_string(),
                "frames": state.labels.frames.len(),
                "objects": objects,
                "labels": labels_json(state),
            }),
        ),
        Err(e) => text(500, &format!("{e:#}")),
    }
}

fn frame_index(state: &State, index: &str) -> Result<usize, Response<Body>> {
    let index: usize = index
        .parse()
        .map_err(|_| text(400, "a frame is named by its number"))?;
    if index >= state.store.frames().len() {
        return Err(text(404, &format!("no frame {index} (yet)")));
    }
    Ok(index)
}

fn frame_json(state: &State, index: &str) -> Response<Body> {
    let index = match frame_index(state, index) {
        Ok(i) => i,
        Err(response) => return response,
    };
    let Some(frame) = state.store.frames().get(index) else {
        return text(404, "no such frame");
    };
    match sweep::regions(&state.config, frame) {
        Ok(regions) => {
            let blobs: Vec<_> = regions
                .iter()
                .map(|r| {
                    json!({
                        "class": r.color,
                        "area_px": r.area_px.saturating_mul(sweep::PIXELS_PER_HELD_PIXEL),
                        "box": [r.left_px, r.top_px, r.right_px, r.bottom_px],
                        "centroid": [r.centroid_x_px, r.centroid_y_px],
                    })
                })
                .collect();
            let signs =
                state
                    .signs
                    .then(|| match render::signs(&state.config, frame) {
                        Ok(signs) => json!(signs
                    .signs
                    .iter()
                    .map(|s| json!({
                        "arrow": s.arrow,
                        "confidence": s.confidence,
                        "box": [s.board.left, s.board.top, s.board.right, s.board.bottom],
                    }))
                    .collect::<Vec<_>>()),
                        Err(e) => json!({ "error": format!("{e:#}") }),
                    });
            json_response(
                200,
                &json!({
                    "name": frame.name,
                    "blobs": blobs,
                    "signs": signs,
                    "boxes": state.boxes(index),
                }),
            )
        }
        Err(e) => text(500, &e.to_string()),
    }
}

fn frame_png(state: &State, index: &str) -> Response<Body> {
    let index = match frame_index(state, index) {
        Ok(i) => i,
        Err(response) => return response,
    };
    let Some(frame) = state.store.frames().get(index) else {
        return text(404, "no such frame");
    };
    let drawn = sweep::regions(&state.config, frame)
        .map_err(anyhow::Error::from)
        .and_then(|regions| {
            // A sign the detector cannot look for (no White or Black class) is said in
            // the frame's JSON; the picture is drawn without boards.
            let boards = if state.signs {
                render::signs(&state.config, frame)
                    .map(|s| render::sign_boards(&s))
                    .unwrap_or_default()
            } else {
                Vec::new()
            };
            render::overlay_png(&state.config, frame, &regions, &boards)
        });
    match drawn {
        Ok(png) => bytes(200, &png, "image/png"),
        Err(e) => text(500, &format!("{e:#}")),
    }
}

fn save(state: &State) -> Response<Body> {
    let text_out = state.colour_file();
    match std::fs::write(&state.save_path, &text_out) {
        Ok(()) => json_response(
            200,
            &json!({ "path": state.save_path.display().to_string(), "text": text_out }),
        ),
        Err(e) => text(
            500,
            &format!("cannot write {}: {e}", state.save_path.display()),
        ),
    }
}

/// Adds a header; `from_bytes` refuses only non-ASCII, and ours are ASCII constants.
fn with_header(response: Response<Body>, field: &str, value: &str) -> Response<Body> {
    match Header::from_bytes(field.as_bytes(), value.as_bytes()) {
        Ok(header) => response.with_header(header),
        Err(()) => response,
    }
}

fn bytes(status: u16, body: &[u8], content_type: &str) -> Response<Body> {
    let response = Response::from_data(body.to_vec()).with_status_code(status);
    with_header(
        with_header(response, "Content-Type", content_type),
        "Cache-Control",
        "no-store",
    )
}

fn text(status: u16, message: &str) -> Response<Body> {
    bytes(status, message.as_bytes(), "text/plain; charset=utf-8")
}

fn json_response(status: u16, value: &serde_json::Value) -> Response<Body> {
    bytes(status, value.to_string().as_bytes(), "application/json")
}
